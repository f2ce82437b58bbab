"""Load a `biovln-ms export lerobot` dataset with LeRobot itself, offline, and check it frame by frame.

Run it with a Python that has LeRobot installed (LeRobot is not a dependency of biovln-ms):

    python scripts/check_lerobot_export.py DATASET [--recording REC]

``LeRobotDataset(repo_id, root=DATASET)`` must load it without the Hub; every frame is then read through
``__getitem__``, which decodes the video at the frame's timestamp (LeRobot raises when a frame is not
within its tolerance of 1e-4 s). Each item must carry the features of ``meta/info.json`` with their shapes,
its task text and an RGB frame in [0, 1]; ``meta.stats`` must have the features' shapes, and a DataLoader
with ``delta_timestamps`` (the previous frame, the next action) must go through every frame. With
``--recording`` (the folder the export was made from), each decoded frame is compared with the recorded
image (mean absolute error under ``--max-mae`` levels of 255: H.264 is lossy) and each depth map with the
recorded float16 values (exactly). Prints one summary line; a mismatch stops it with an AssertionError.
"""

from __future__ import annotations

import argparse
import base64
import json
import os
import sys
import zlib
from pathlib import Path

os.environ.setdefault("HF_HUB_OFFLINE", "1")  # before LeRobot imports huggingface_hub: never the network


def recorded_episodes(folder: Path) -> dict[tuple[str, str], dict]:
    """(scene_id, episode_id) -> the recorder's entry, from every ``trajectories-*.jsonl.gz``."""
    out = {}
    for path in sorted(folder.glob("trajectories-*.jsonl.gz")):
        raw, pos = path.read_bytes(), 0
        while pos < len(raw):
            d = zlib.decompressobj(zlib.MAX_WBITS | 16)
            data = d.decompress(raw[pos:])
            if not d.eof:
                break  # a truncated last member, as the exporter skips it
            for line in data.decode().splitlines():
                if line.strip():
                    e = json.loads(line)
                    out[(e["scene_id"], e["episode_id"])] = e
            pos = len(raw) - len(d.unused_data)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dataset", type=Path)
    ap.add_argument("--recording", type=Path, help="the recording folder the export was made from")
    ap.add_argument("--repo-id", default="biovln/export", help="any name: the dataset is read from DATASET")
    ap.add_argument("--max-mae", type=float, default=8.0, help="mean absolute RGB error allowed (0-255)")
    args = ap.parse_args()

    import numpy as np
    import pandas as pd
    from lerobot.datasets.lerobot_dataset import CODEBASE_VERSION, LeRobotDataset

    ds = LeRobotDataset(args.repo_id, root=args.dataset)
    info = ds.meta.info
    assert info["codebase_version"] == CODEBASE_VERSION, (info["codebase_version"], CODEBASE_VERSION)
    assert len(ds) == info["total_frames"] and ds.num_episodes == info["total_episodes"]
    episodes = pd.concat(
        pd.read_parquet(p) for p in sorted((args.dataset / "meta" / "episodes").glob("*/*.parquet"))
    )
    recording = recorded_episodes(args.recording) if args.recording else None
    cameras = ds.meta.video_keys
    worst_mae = 0.0
    for row in episodes.to_dict("records"):
        first, last = int(row["dataset_from_index"]), int(row["dataset_to_index"])
        entry = None
        if recording is not None:
            entry = recording[(row["biovln/scene_id"], row["biovln/episode_id"])]
            assert len(entry["steps"]) == last - first, "episode length differs from the recording"
        for i in range(first, last):
            item = ds[i]
            t = i - first
            assert int(item["frame_index"]) == t and int(item["episode_index"]) == int(row["episode_index"])
            assert item["task"] == row["tasks"][0]
            assert bool(item["next.done"]) == (i == last - 1)
            for key, ft in ds.features.items():
                shape = tuple(ft["shape"])
                got = tuple(item[key].shape)
                if ft["dtype"] == "video":
                    h, w, c = shape
                    assert got == (c, h, w), (key, got, shape)
                    assert 0.0 <= float(item[key].min()) and float(item[key].max()) <= 1.0
                else:
                    assert got in (shape, ()) if shape == (1,) else got == shape, (key, got, shape)
            if entry is None:
                continue
            step = entry["steps"][t]
            assert int(item["action"]) == step["action"]
            if cameras:
                from PIL import Image

                rec = np.asarray(Image.open(args.recording / step["obs"]["rgb_path"]).convert("RGB"), float)
                got = item[cameras[0]].permute(1, 2, 0).numpy() * 255.0
                mae = float(np.abs(got - rec).mean())
                worst_mae = max(worst_mae, mae)
                assert mae <= args.max_mae, f"frame {i}: RGB mean absolute error {mae:.2f} > {args.max_mae}"
                h, w = step["obs"]["depth_shape"]
                depth = np.frombuffer(base64.b64decode(step["obs"]["depth"]), np.float16).reshape(h, w)
                assert np.array_equal(item["observation.depth"].numpy(), depth.astype(np.float32)), i
    # statistics as policies' normalisers read them, and a training-style pass: a DataLoader over every
    # frame with each camera's previous frame and the next action (delta_timestamps, padded at the edges)
    for key, ft in ds.features.items():
        want = (3, 1, 1) if ft["dtype"] == "video" else tuple(ft["shape"])
        assert tuple(np.shape(ds.meta.stats[key]["mean"])) == want, (
            key,
            np.shape(ds.meta.stats[key]["mean"]),
        )
    import torch

    dt = 1.0 / info["fps"]
    deltas = {key: [-dt, 0.0] for key in cameras} | {"action": [0.0, dt]}
    seq = LeRobotDataset(args.repo_id, root=args.dataset, delta_timestamps=deltas)
    n = 0
    for batch in torch.utils.data.DataLoader(seq, batch_size=8, shuffle=False):
        assert tuple(batch["action"].shape[:2]) == (len(batch["index"]), 2)
        for key in cameras:
            assert batch[key].shape[1] == 2 and batch[f"{key}_is_pad"].shape[1] == 2
        n += len(batch["index"])
    assert n == len(ds)
    print(
        f"ok: LeRobotDataset {info['codebase_version']} loaded offline from {args.dataset}: "
        f"{ds.num_episodes} episodes, {len(ds)} frames decoded, cameras {cameras}, delta_timestamps batches"
        + (f", worst RGB mean abs error {worst_mae:.2f}/255, depth exact" if recording and cameras else "")
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
