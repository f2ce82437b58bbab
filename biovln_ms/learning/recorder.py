"""TrajectoryRecorder (appendix "Training Pipeline Architecture"): one gzip JSONL entry per episode.

Attached to the evaluation loop, it never changes the policy. Each entry holds the episode's
metadata and per-step records with the appendix's fields: ``step_idx``, ``action`` (0=STOP 1=FORWARD
2=LEFT 3=RIGHT), ``obs.position`` [x, y, z], ``obs.heading`` [hx, hy], ``obs.goal_position`` [x, y],
``obs.rgb_path`` (full mode), ``obs.depth`` (base64 of a float16 depth array, full mode),
``dist_to_goal`` and ``success``. Frames are stored at 224 x 224 (the BC input size) unless
``image_size=None``; PNG by default, JPEG (quality 90) as an option. Coordinates are this platform's
world frame (Z up, metres), stated in each entry as ``"frame": "z_up"`` (the paper's Habitat recorder
was Y-up). Full mode writes RGB PNGs to ``images/`` beside the JSONL; trace-only mode writes no images.

Each worker appends complete gzip members to its own file (``trajectories-<pid>.jsonl.gz``); a killed
run can leave only a truncated last member, which readers skip.

A frame's file name holds the episode's scene and episode ids (``<scene_id>_<episode_id>_<step>.png``):
each must be one plain name, and the file stays inside ``images/`` (``biovln_ms.io_utils.inside``), so an
episode from a crafted dataset or source never writes elsewhere; anything else is one ``RecordingError``.
"""

from __future__ import annotations

import base64
import gzip
import json
import os
import zlib
from pathlib import Path

import numpy as np
from PIL import Image

from biovln_ms.errors import BioVLNError
from biovln_ms.io_utils import inside
from biovln_ms.limits import ID_RULE

RECORDER_VERSION = 1
MODES = ("full", "trace")
IMAGE_FORMATS = ("png", "jpg", "jpeg")


class RecordingError(BioVLNError):
    """A recording that cannot be written where it belongs (a frame name leaving the recording folder)."""


class TrajectoryRecorder:
    def __init__(
        self,
        root: str | Path,
        mode: str = "full",
        depth_size: tuple[int, int] = (80, 60),
        image_size: tuple[int, int] | None = (224, 224),
        image_format: str = "png",
    ) -> None:
        if mode not in MODES:
            raise BioVLNError(
                f"unknown recording mode '{mode}'", field="record_mode", fix=f"use one of: {', '.join(MODES)}"
            )
        if image_format not in IMAGE_FORMATS:
            raise RecordingError(
                f"unknown image format {str(image_format)[:40]!r}",
                field="image_format",
                fix=f"use one of: {', '.join(IMAGE_FORMATS)}",
            )
        self.root = Path(root)
        self.mode = mode
        self.depth_size = depth_size
        self.image_size = image_size  # frames are stored at the BC input size by default (None: native)
        self.image_format = image_format
        self.root.mkdir(parents=True, exist_ok=True)
        if mode == "full":
            (self.root / "images").mkdir(exist_ok=True)
        self.path = self.root / f"trajectories-{os.getpid()}.jsonl.gz"
        self._steps: list[dict] = []
        self._meta: dict = {}

    @property
    def needs_images(self) -> bool:
        return self.mode == "full"

    def start(self, episode: dict, goal_xy) -> None:
        if self.mode == "full":  # frame names hold the ids: each one plain name, before the episode runs
            for key in ("scene_id", "episode_id"):
                self._frame_path(str(episode[key]), key)
        self._meta = {
            "recorder_version": RECORDER_VERSION,
            "mode": self.mode,
            "frame": "z_up",
            "scene_id": episode["scene_id"],
            "episode_id": episode["episode_id"],
            "object_category": episode["object_category"],
            "object_id": episode["object_id"],
            "difficulty": episode["info"]["difficulty"],
            "goal_position": [float(v) for v in goal_xy[:2]],
        }
        self._steps = []

    def step(self, step_idx: int, action: int, pose, goal_xy, dist_to_goal: float, obs=None) -> None:
        """Record the observation the policy acted on and the action it chose."""
        rec = {
            "step_idx": step_idx,
            "action": int(action),
            "obs": {
                "position": [round(float(pose[0]), 4), round(float(pose[1]), 4), 0.0],
                "heading": [round(float(np.cos(pose[2])), 5), round(float(np.sin(pose[2])), 5)],
                "goal_position": [round(float(goal_xy[0]), 4), round(float(goal_xy[1]), 4)],
            },
            "dist_to_goal": round(float(dist_to_goal), 4),
        }
        if self.mode == "full" and obs is not None:
            cam = obs["sensor_data"]["head"]
            img = Image.fromarray(cam["rgb"][0].cpu().numpy())
            if self.image_size is not None:
                img = img.resize(self.image_size, Image.BILINEAR)
            name = f"{self._meta['scene_id']}_{self._meta['episode_id']}_{step_idx:04d}.{self.image_format}"
            path = self._frame_path(name, "episode_id")
            if self.image_format == "png":
                img.save(path, compress_level=6)
            else:
                img.save(path, quality=90)
            rec["obs"]["rgb_path"] = f"images/{name}"
            if "depth" in cam:
                depth = cam["depth"][0, ..., 0].cpu().numpy().astype(np.float32) / 1000.0
                small = np.asarray(Image.fromarray(depth).resize(self.depth_size, Image.NEAREST), np.float16)
                rec["obs"]["depth"] = base64.b64encode(small.tobytes()).decode()
                rec["obs"]["depth_shape"] = [self.depth_size[1], self.depth_size[0]]
        self._steps.append(rec)

    def _frame_path(self, name: str, field: str) -> Path:
        """``images/<name>``, refused in one line unless ``name`` is one plain name that stays inside."""
        return inside(
            self.root / "images",
            name,
            what="frame name",
            error=RecordingError,
            field=field,
            fix=f"give the episode ids of {ID_RULE}",
        )

    def finish(self, success: bool) -> None:
        for s in self._steps:
            s["success"] = bool(success)
        entry = {**self._meta, "success": bool(success), "steps": self._steps}
        data = (json.dumps(entry, separators=(",", ":")) + "\n").encode()
        with open(self.path, "ab") as f:  # one complete gzip member per episode
            f.write(gzip.compress(data, mtime=0))
            f.flush()
            os.fsync(f.fileno())
        self._steps = []


def read_recordings(path: str | Path):
    """Entries of a recording file, member by member; a truncated last member (a kill) is skipped."""
    raw = Path(path).read_bytes()
    pos = 0
    while pos < len(raw):
        d = zlib.decompressobj(zlib.MAX_WBITS | 16)
        try:
            data = d.decompress(raw[pos:])
        except zlib.error:
            return
        if not d.eof:
            return  # truncated member
        for line in data.decode().splitlines():
            if line.strip():
                yield json.loads(line)
        pos = len(raw) - len(d.unused_data)


def decode_depth(obs: dict) -> np.ndarray:
    h, w = obs["depth_shape"]
    return np.frombuffer(base64.b64decode(obs["depth"]), np.float16).reshape(h, w).astype(np.float32)
