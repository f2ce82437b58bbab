"""Measure the detector on a frame dataset's held-out parts (``biovln-ms perception evaluate``).

Per frame, the detector's instances (connected regions of a category, at least
:func:`~biovln_ms.perception.segmenter.min_pixels`) are matched to the annotated instances of the same
category, highest score first, each to the unmatched annotation it overlaps most if their mask IoU is at
least :data:`IOU_MATCH` (COCO's AP50 rule). Annotated instances smaller than the same minimum are
*ignored*, as COCO ignores crowd regions: not counted as misses, and a detection matching one is not a
false positive (VLFM's GT detector drops them too). Per category:

| figure | what |
|---|---|
| precision | matched detections / detections, Wilson 95 % interval |
| recall | matched instances / annotated instances, Wilson 95 % interval |
| mask IoU | mean IoU of the matched pairs |
| pixel IoU | the category's pixels, detected vs annotated, over all frames |
| misses | each unmatched instance by cause (:data:`~.matching.MISS_CAUSES`), and what the net took it for |

The means are over categories: recall over those with annotated instances, precision over those with
detections. Frames are filtered by their lighting and noise presets. ``results`` match by mask IoU;
``results_box`` by the IoU of the masks' bounding boxes (COCO's detection rule; box IoU of the matched
pairs, no miss causes): an object annotated as its outline (the pipette stand's rails) is found as a
filled region, a miss by mask and a match by box.
"""

from __future__ import annotations

import datetime
import hashlib
import time
from collections import Counter
from pathlib import Path

import numpy as np

from biovln_ms.io_utils import atomic_write_text
from biovln_ms.measured import check_table, dumps, machine
from biovln_ms.perception import segmenter as S
from biovln_ms.perception.frames import LIGHTING_SHARES, NOISE_SHARES, FramesError
from biovln_ms.perception.matching import IOU_MATCH, MISS_CAUSES, Tally, annotated, match_frame
from biovln_ms.perception.train_detector import read_frame, read_manifest, read_part

HELD_OUT = ("test_scenes", "test_looks")
LIGHTINGS = tuple(LIGHTING_SHARES)
NOISES = tuple(NOISE_SHARES)


def file_sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def evaluate_detector(
    frames: str | Path,
    weights: str | Path | None = None,
    lighting: str | None = None,
    noise: str | None = None,
    threads: int = 2,
    limit: int | None = None,
    timing_frames: int = 20,
) -> dict:
    """Per held-out part and per (lighting, noise) condition (``lighting``/``noise`` None: every preset and
    all together), the :class:`Tally` summary; the detection time at 640x480."""
    for name, v, allowed in (("lighting", lighting, LIGHTINGS), ("noise", noise, NOISES)):
        if v is not None and v not in allowed:
            raise FramesError(f"unknown {name} '{v}'", field=name, fix=f"use one of: {', '.join(allowed)}")
    frames = Path(frames)
    manifest = read_manifest(frames)
    seg = S.Segmenter(weights, threads=threads)
    cats = seg.categories
    lights = [lighting] if lighting else [*LIGHTINGS, "all"]
    noises = [noise] if noise else [*NOISES, "all"]
    keys_all = [(p, li, no) for p in HELD_OUT for li in lights for no in noises]
    tallies = {k: Tally(cats, causes=True) for k in keys_all}
    by_box = {k: Tally(cats, rule="box") for k in keys_all}
    sample = None
    for part in HELD_OUT:
        images, anns = read_part(frames, part, limit)
        for im in images:
            keys = [
                (part, li, no)
                for li in lights
                for no in noises
                if li in (im["lighting"], "all") and no in (im["noise"], "all")
            ]
            if not keys:
                continue
            rgb, lab = read_frame(frames, im, anns[im["id"]])
            sample = rgb if sample is None else sample
            net, conf = seg.labels(rgb)  # checks the frame
            preds = seg.regions(net, conf, rgb.shape[:2])
            net = S.nearest(net, rgb.shape[1::-1])
            gts = annotated(anns[im["id"]], cats, lab.shape)
            for key in keys:
                match_frame(tallies[key], preds, gts, cats, lab, net)
                match_frame(by_box[key], preds, gts, cats, lab)

    def summaries(t: dict) -> dict:
        return {
            f"{li}/{no}": {part: t[(part, li, no)].summary() for part in HELD_OUT}
            for li in lights
            for no in noises
        }

    return {
        "weights": str(seg.path.name),
        "weights_sha256": file_sha256(seg.path),
        "frames": {
            "source": manifest.get("source", ""),
            "seed": manifest.get("seed"),
            "size": [manifest.get("width"), manifest.get("height")],
            "annotations_sha256": {k: v for k, v in manifest.get("files", {}).items() if "test" in k},
        },
        "iou_match": IOU_MATCH,
        "min_pixels_at_640x480": S.MIN_PIXELS,
        "threads": threads,
        "input_size": list(seg.input_size),
        "detect_ms_640x480": detect_time(seg, sample, timing_frames) if sample is not None else None,
        "results": summaries(tallies),
        "results_box": summaries(by_box),
    }


def head_frame(rgb: np.ndarray) -> np.ndarray:
    """``rgb`` resized to the head camera's 640x480, the size detection is timed at."""
    from PIL import Image

    return np.asarray(Image.fromarray(rgb).resize((640, 480), Image.BILINEAR))


def target_mask_ms(seg: S.Segmenter, big: np.ndarray, n: int, first: int = 0) -> list[float]:
    """Milliseconds of ``n`` target masks on ``big``, the targets the categories in turn from ``first``."""
    times = []
    for k in range(first, first + max(1, n)):
        t = time.perf_counter()
        seg.target_mask(big, seg.categories[k % len(seg.categories)])
        times.append(1000 * (time.perf_counter() - t))
    return times


def detect_time(seg: S.Segmenter, rgb: np.ndarray, n: int) -> dict:
    """Median and 90th percentile milliseconds of one target mask on ``rgb`` resized to 640x480."""
    big = head_frame(rgb)
    seg.target_mask(big, seg.categories[0])  # warm-up
    times = target_mask_ms(seg, big, n)
    return {
        "median": round(float(np.median(times)), 1),
        "p90": round(float(np.percentile(times, 90)), 1),
        "n": len(times),
    }


def summary_table(result: dict, condition: str = "fast/ideal") -> tuple[list[str], list[list]]:
    """Columns and rows for the docs: per category, precision and recall with intervals on each held-out
    part under ``condition``, then the means."""
    cols = ["category"]
    for part in HELD_OUT:
        cols += [f"{part}: n", "precision", "recall", "mask IoU"]
    cols.append(f"{HELD_OUT[0]}: misses by cause")
    res = result["results"][condition]

    def fmt(v, ci=None):
        if v is None:
            return None
        return f"{v:.2f}" + (f" [{ci[0]:.2f}, {ci[1]:.2f}]" if ci else "")

    rows = []
    for c in res[HELD_OUT[0]]["categories"]:
        row = [c]
        for part in HELD_OUT:
            r = res[part]["categories"][c]
            row += [
                r["instances"],
                fmt(r["precision"], r["precision_ci"]),
                fmt(r["recall"], r["recall_ci"]),
                fmt(r["mask_iou"]),
            ]
        rows.append([*row, misses(res[HELD_OUT[0]]["categories"][c])])
    mean = ["mean over categories"]
    for part in HELD_OUT:
        s = res[part]
        mean += [
            sum(r["instances"] for r in s["categories"].values()),
            fmt(s["mean_precision"]),
            fmt(s["mean_recall"]),
            None,
        ]
    total = sum((Counter(r.get("misses", {})) for r in res[HELD_OUT[0]]["categories"].values()), Counter())
    return cols, [*rows, [*mean, "total: " + (misses({"misses": dict(total)}) or "none")]]


def misses(row: dict) -> str | None:
    """A category's misses by cause, e.g. ``merged 37, other category 6 (lab_table 6)``."""
    if not row.get("misses"):
        return None
    out = []
    for cause in MISS_CAUSES:
        n = row["misses"].get(cause)
        if n:
            taken = row.get("confused_with") if cause == "other category" else None
            named = f" ({', '.join(f'{c} {k}' for c, k in taken.items())})" if taken else ""
            out.append(f"{cause} {n}{named}")
    return ", ".join(out)


def write_table(path: str | Path, result: dict, command: str, condition: str = "fast/ideal") -> Path:
    """The docs' measured table (:mod:`biovln_ms.measured`'s format) of ``result`` under ``condition``."""

    cols, rows = summary_table(result, condition)
    lighting, noise = condition.split("/")
    box = result.get("results_box", {}).get(condition)
    ms = result.get("detect_ms_640x480") or {}
    others = {
        cond: {p: (r[p]["mean_precision"], r[p]["mean_recall"]) for p in HELD_OUT}
        for cond, r in result["results"].items()
        if cond != condition
    }
    notes = [
        f"Lighting `{lighting}`, noise `{noise}`; n: annotated instances of at least {S.MIN_PIXELS} "
        f"pixels at 640x480 (smaller ones are ignored); precision and recall at mask IoU >= {IOU_MATCH}, "
        "Wilson 95 % intervals; mask IoU: mean over matched pairs; – : no instance or no detection.",
        *(
            f"`{cond}`: " + "; ".join(f"{p} precision {v[0]}, recall {v[1]}" for p, v in parts.items())
            for cond, parts in others.items()
        ),
        f"Detection time at 640x480 ({result['threads']} threads): median {ms.get('median')} ms, "
        f"90th percentile {ms.get('p90')} ms.",
    ]
    if box:  # before the detection time
        pairs = "; ".join(
            f"{p} precision {r['mean_precision']}, recall {r['mean_recall']}" for p, r in box.items()
        )
        notes.insert(-1, f"Matched by box IoU >= {IOU_MATCH} (`results_box`), `{condition}`: {pairs}")
    data = {
        "title": "Trained detector on held-out frames",
        "command": command,
        "machine": machine(),
        "written": datetime.date.today().isoformat(),
        "columns": cols,
        "rows": rows,
        "notes": notes,
    }
    check_table(data, str(path))
    return atomic_write_text(path, dumps(data))
