"""The detector's labelled-frame dataset: plan, render and write it (``biovln-ms perception dataset``).

On disk (written into a locked temporary folder, the manifest last, then renamed into place):

| path | what |
|---|---|
| ``frames/NNNNNN.rgb.png`` | RGB, 8-bit |
| ``frames/NNNNNN.depth.png`` | depth, 16-bit, millimetres along the optical axis, 0: no reading |
| ``frames/NNNNNN.instances.png`` | 16-bit instance ids (0: no goal-category object) |
| ``annotations/<part>.json`` | COCO (see below), one per part of :data:`~biovln_ms.perception.frames.PARTS` |
| ``scenes/<scene>[__dressing<k>].json`` | the scene specs the frames show |
| ``manifest.json`` | seed, sizes, camera, per part its frames and instances per category, the held-out |
| | scenes and paint looks, each annotation and scene file's SHA-256 |

COCO's ``images`` carry the frame's scene, dressing, lighting, noise preset, camera (eye, yaw, pitch),
part, the looks of the objects it shows and its files' SHA-256; ``annotations`` the category (ids from 1 in
the catalog's goal-category order), box ``[x, y, w, h]`` in pixels, area, mask as compressed RLE,
``instance`` (its id in the instance image) and ``object_id``.

The same sources, seed, frame count and resolution give the same bytes, whatever ``workers``.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import multiprocessing
import os
from collections import Counter
from pathlib import Path

import numpy as np

from biovln_ms.catalog import load_catalog
from biovln_ms.cluster import exit_on_sigterm
from biovln_ms.episodes.writer import partial_folder, put_in_place
from biovln_ms.errors import shown
from biovln_ms.limits import parse_size
from biovln_ms.perception import frames as F
from biovln_ms.perception.frames import FramesError, SceneSource
from biovln_ms.perception.render_frames import NEAR, TASK

#: bounds of a build's arguments
MAX_FRAMES = 1_000_000
MIN_SIZE, MAX_SIZE = 32, 1920
MAX_WORKERS = 64


def check_request(frames: object, width: object, height: object, workers: object, seed: object) -> None:
    """One-line errors for arguments out of range, before anything is built."""

    def whole(v: object) -> bool:
        return isinstance(v, (int, np.integer)) and not isinstance(v, bool)

    for name, v, lo, hi in (
        ("frames", frames, 1, MAX_FRAMES),
        ("resolution", width, MIN_SIZE, MAX_SIZE),
        ("resolution", height, MIN_SIZE, MAX_SIZE),
        ("workers", workers, 1, MAX_WORKERS),
        ("seed", seed, 0, 2**32 - 1),
    ):
        if not whole(v) or not lo <= v <= hi:
            raise FramesError(
                f"{name} must be a whole number in [{lo}, {hi}], got {v!r}",
                field=name,
                fix="e.g. --frames 2000 --frame-size 320x240 --workers 1 --seed 0",
            )


def parse_resolution(text: str) -> tuple[int, int]:
    """``"WxH"`` as (width, height); a one-line error otherwise."""
    size = parse_size(text)
    if size is None:
        raise FramesError(
            f"resolution {shown(text)} is not WIDTHxHEIGHT", field="resolution", fix="e.g. 320x240"
        )
    w, h = size
    check_request(1, w, h, 1, 0)
    return w, h


def _png(arr: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(arr).save(buf, format="PNG", compress_level=6)
    return buf.getvalue()


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


#: per worker process: the renderer of the current size
_RENDERER = None


def _render_group(job: tuple) -> list[dict]:
    """Render and write one group's frames into ``folder``; their image entries and annotations."""
    global _RENDERER
    folder, seed, group, first, count, sources, size = job
    from biovln_ms.perception.render_frames import FrameRenderer

    if _RENDERER is None or (_RENDERER.width, _RENDERER.height) != size:
        _RENDERER = FrameRenderer(*size)
    cat_ids = {c["name"]: c["id"] for c in F.coco_categories()}
    out = []
    for i in range(first, first + count):
        draw = F.plan_frame(seed, i, group, sources)
        frame = _RENDERER.render(draw, sources[group.scene])
        names = {k: f"frames/{i:06d}.{k}.png" for k in ("rgb", "depth", "instances")}
        hashes = {}
        for kind, arr in (("rgb", frame.rgb), ("depth", frame.depth_mm), ("instances", frame.instances)):
            data = _png(arr)
            (Path(folder) / names[kind]).write_bytes(data)
            hashes[kind] = _sha(data)
        anns = F.instance_annotations(frame.instances, {k: cat_ids[c] for k, c in frame.categories.items()})
        for a in anns:
            a["object_id"] = frame.objects[a["instance"]]
        image = {
            "id": i,
            "file_name": names["rgb"],
            "depth_file": names["depth"],
            "instances_file": names["instances"],
            "width": size[0],
            "height": size[1],
            "part": group.part,
            "scene": group.scene,
            "dressing": group.dressing,
            "lighting": group.lighting,
            "noise": draw.noise,
            "group": group.index,
            "eye": list(draw.eye),
            "yaw": draw.yaw,
            "pitch": draw.pitch,
            "facing": draw.facing,
            "looks": {a["object_id"]: group.looks[a["object_id"]] for a in anns},
            "sha256": hashes,
        }
        out.append({"image": image, "annotations": anns})
    return out


def build_frames_dataset(
    out: str | Path,
    sources: list[SceneSource],
    frames: int = 2000,
    seed: int = 0,
    resolution: tuple[int, int] = (320, 240),
    workers: int = 1,
    progress: bool = False,
    source_name: str = "",
) -> dict:
    """Render ``frames`` labelled frames of ``sources`` into the folder ``out`` (see the module docstring);
    returns the manifest. ``workers`` > 1 renders groups in that many spawned processes."""
    from tqdm import tqdm

    check_request(frames, *resolution, workers, seed)
    names = [s.spec.name for s in sources]
    if len(set(names)) != len(names) or len(names) < 2:
        raise FramesError(
            f"the frames need at least two scenes with distinct names, got {len(names)}",
            field="scenes",
            fix="give a split with two scenes or more",
        )
    out = Path(out)
    by_name = {s.spec.name: s for s in sources}
    held_out = F.hold_out_scenes(sources)
    G, size = F.FRAMES_PER_GROUP, (int(resolution[0]), int(resolution[1]))
    n_groups = math.ceil(frames / G)
    groups = [F.draw_group(seed, g, by_name, held_out) for g in range(n_groups)]
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp, lock = partial_folder(out)
    try:
        (tmp / "frames").mkdir()
        (tmp / "annotations").mkdir()
        # a group's job carries only its own scene: spawned workers unpickle less
        jobs = [
            (str(tmp), seed, g, g.index * G, min(G, frames - g.index * G), {g.scene: by_name[g.scene]}, size)
            for g in groups
        ]
        bar = tqdm(total=frames, desc="perception frames", unit="frame", disable=not progress)
        results: list[dict] = []
        if workers == 1:
            for job in jobs:
                results += _render_group(job)
                bar.update(job[4])
        else:
            ctx = multiprocessing.get_context("spawn")
            env = {"LP_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
            saved = {k: os.environ.get(k) for k in env}
            os.environ.update(env)  # the spawned workers inherit them: one core each
            restore = exit_on_sigterm()  # a kill ends the workers too (the pool's exit terminates them)
            try:
                with ctx.Pool(workers) as pool:
                    for part in pool.imap(_render_group, jobs):
                        results += part
                        bar.update(len(part))
            finally:
                restore()
                for k, v in saved.items():
                    os.environ.pop(k) if v is None else os.environ.__setitem__(k, v)
        bar.close()
        manifest = _write_annotations(tmp, results, seed, frames, resolution, held_out, by_name, groups)
        manifest["source"] = source_name
        return put_in_place(out, tmp, manifest)
    finally:
        if lock is not None:
            os.close(lock)


def _write_annotations(tmp: Path, results, seed, frames, resolution, held_out, by_name, groups) -> dict:
    cats = F.coco_categories()
    by_id = {c["id"]: c["name"] for c in cats}
    parts: dict[str, dict] = {p: {"images": [], "annotations": [], "categories": cats} for p in F.PARTS}
    ann_id = 0
    for r in sorted(results, key=lambda r: r["image"]["id"]):
        part = parts[r["image"]["part"]]
        part["images"].append(r["image"])
        for a in r["annotations"]:
            ann_id += 1
            part["annotations"].append({"id": ann_id, "image_id": r["image"]["id"], **a})
    files, counts = {}, {}
    for name, coco in parts.items():
        data = (json.dumps(coco, sort_keys=True, separators=(",", ":")) + "\n").encode()
        rel = f"annotations/{name}.json"
        (tmp / rel).write_bytes(data)
        files[rel] = _sha(data)
        per_cat = Counter(by_id[a["category_id"]] for a in coco["annotations"])
        counts[name] = {
            "frames": len(coco["images"]),
            "instances": {c["name"]: per_cat.get(c["name"], 0) for c in cats},
            "scenes": sorted({im["scene"] for im in coco["images"]}),
        }
    scenes = {}
    for key in sorted({(g.scene, g.dressing) for g in groups}):
        spec = F.dressed_spec(by_name[key[0]].spec, key[1])
        rel = f"scenes/{key[0]}{f'__dressing{key[1]}' if key[1] else ''}.json"
        data = spec.to_json().encode()
        (tmp / rel).write_bytes(data)
        scenes[rel] = _sha(data)
    w, h = resolution
    return {
        "format_version": F.FORMAT_VERSION,
        "seed": seed,
        "frames": frames,
        "width": w,
        "height": h,
        "camera": {"hfov_deg": TASK.camera_hfov_deg, "near_m": NEAR, "far_m": TASK.camera_far},
        "depth_unit": "mm",
        "frames_per_group": F.FRAMES_PER_GROUP,
        "parts": counts,
        "held_out_scenes": sorted(held_out),
        "train_scenes": sorted(set(by_name) - held_out),
        "held_out_paints": list(F.HELD_OUT_PAINTS),
        "train_paints": list(F.TRAIN_PAINTS),
        "categories": [c["name"] for c in cats],
        "catalog_sha256": load_catalog().sha256,
        "files": files,
        "scenes": scenes,
    }
