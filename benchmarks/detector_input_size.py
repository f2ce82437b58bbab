"""The detector's recall, precision and cost against the size of the net's input, on the same frames.

    python benchmarks/detector_input_size.py --frame-data data/frames --run RUN_DIR [--run RUN_DIR ...]

Each ``RUN_DIR`` is a ``perception train`` output folder (``train.json``, ``detector.safetensors``) in which
``perception evaluate --frame-data data/frames --weights RUN_DIR/detector.safetensors -o RUN_DIR/eval.json``
has been run. One column per run: the input size, training time, the operating point and its validation
figures, mean precision and recall on the held-out scenes and looks per condition (matched by mask IoU;
under ``fast`` lighting and ideal noise also by box IoU), each category's recall on the held-out scenes
under that condition by mask and by box, and the detection time at 640x480, timed here for every run in
interleaved blocks (one target mask, 2 threads). The table goes to
``docs/data/perception/detector_input_size.json``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.perception import segmenter as S
from biovln_ms.perception.evaluate_detector import file_sha256, head_frame, target_mask_ms
from biovln_ms.perception.train_detector import read_frame, read_part

CONDITIONS = ("fast/ideal", "fast/realistic", "quality/ideal", "quality/realistic")
PARTS = ("test_scenes", "test_looks")
#: the condition the detector's precision and recall goal is stated for
GOAL = "fast/ideal"


def _pr(s: dict) -> str:
    p, r = s["mean_precision"], s["mean_recall"]
    return "-" if p is None or r is None else f"{p:.2f} / {r:.2f}"


def read_run(folder: Path) -> tuple[dict, dict]:
    """(``train.json``, ``eval.json``) of a run, the evaluation checked to be of the run's weights."""
    train = json.loads((folder / "train.json").read_text())
    ev = json.loads((folder / "eval.json").read_text())
    if ev["weights_sha256"] != file_sha256(folder / "detector.safetensors"):
        raise SystemExit(f"error: {folder}/eval.json is of other weights; evaluate this run's weights again")
    return train, ev


def detection_ms(weights: list[Path], frame: np.ndarray, blocks: int, per_block: int) -> list[list[float]]:
    """Milliseconds of one target mask at 640x480 for each weights file, in interleaved blocks."""
    big = head_frame(frame)
    segs = [S.Segmenter(w, threads=2) for w in weights]
    for seg in segs:
        seg.target_mask(big, seg.categories[0])  # warm-up
    times: list[list[float]] = [[] for _ in segs]
    for b in range(blocks):
        for seg, out in zip(segs, times):
            out += target_mask_ms(seg, big, per_block, b * per_block)
    return times


def column(train: dict, ev: dict, ms: list[float]) -> list:
    """One run's values, in the order of :func:`row_names`."""
    chosen = next(p for p in train["operating_points"] if p["min_score"] == train["min_score"])
    epochs = np.diff([0.0] + [h["seconds"] for h in train["history"]])
    out = [
        "x".join(map(str, train["input_size"])),
        f"{train['train_frames']:,} / {train['validation_frames']:,}",
        train["epochs_run"],
        round(train["seconds"] / 60, 1),
        f"{epochs.min():.0f}-{epochs.max():.0f}",
        train["min_score"],
        f"{chosen['mean_precision']:.3f} / {chosen['mean_recall']:.3f} / {chosen['f1']:.3f}",
        f"{np.median(ms):.1f}",
        f"{np.percentile(ms, 90):.1f}",
    ]
    for cond in CONDITIONS:
        for part in PARTS:
            s = ev["results"][cond][part]
            out.append(f"{_pr(s)} (frames {s['frames']})")
    for part in PARTS:
        out.append(_pr(ev["results_box"][GOAL][part]))
    cats, boxes = (ev[k][GOAL]["test_scenes"]["categories"] for k in ("results", "results_box"))
    for c in S.goal_categories():
        m, b = cats[c], boxes[c]
        out.append(f"{m['recall']:.2f} / {b['recall']:.2f} (n {m['instances']})" if m["instances"] else "-")
    return out


def row_names() -> list[str]:
    names = [
        "input (W x H)",
        "frames trained on / validated on",
        "epochs",
        "training loop, wall (min)",
        "an epoch (s, fastest-slowest)",
    ]
    names += ["operating point (min_score)", "validation at it: mean precision / recall / harmonic mean"]
    names += ["detection at 640x480, median (ms)", "detection at 640x480, p90 (ms)"]
    names += [f"{cond}, {part}: mean precision / recall" for cond in CONDITIONS for part in PARTS]
    names += [f"{GOAL}, {part}, matched by box: mean precision / recall" for part in PARTS]
    names += [f"recall by mask / by box, {c} ({GOAL}, test_scenes)" for c in S.goal_categories()]
    return names


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frame-data", type=Path, required=True, help="the frames the runs were evaluated on")
    ap.add_argument("--run", type=Path, action="append", required=True, help="a trained and evaluated run")
    ap.add_argument("--blocks", type=int, default=5, help="interleaved timing blocks")
    ap.add_argument("--per-block", type=int, default=20, help="detections per run and block")
    ap.add_argument(
        "--data-out", type=Path, default=docs_data_dir() / "perception" / "detector_input_size.json"
    )
    args = ap.parse_args()
    runs = [read_run(r) for r in args.run]
    frames = {json.dumps(ev["frames"], sort_keys=True) for _, ev in runs}
    if len(frames) != 1:
        raise SystemExit("error: the runs were evaluated on different frames; evaluate them on the same set")
    images, anns = read_part(args.frame_data, "test_scenes", limit=1)
    frame = read_frame(args.frame_data, images[0], anns[images[0]["id"]])[0]
    ms = detection_ms([r / "detector.safetensors" for r in args.run], frame, args.blocks, args.per_block)
    cols = [column(t, e, m) for (t, e), m in zip(runs, ms)]
    rows = [[name, *(c[i] for c in cols)] for i, name in enumerate(row_names())]
    for r in rows:
        print(*r, sep=" | ")
    first = runs[0][1]["frames"]
    notes = [
        f"Frames: {first['source']} (seed {first['seed']}, {'x'.join(map(str, first['size']))}); each run "
        "trained on their train part (seeds: "
        + ", ".join(str(t["seed"]) for t, _ in runs)
        + "), evaluated on the held-out parts.",
        f"Detection: {args.blocks} interleaved blocks of {args.per_block} target masks per run, one held-out "
        "frame resized to 640x480, 2 threads.",
        "Training time: each run's own on this machine at the time (train.json).",
    ]
    write_table(
        args.data_out,
        "The detector against its input size, on the same frames",
        ["measure", *(f"run {i + 1}" for i in range(len(runs)))],
        rows,
        notes,
    )


if __name__ == "__main__":
    main()
