"""TrajectoryDataset: a lazy torch Dataset over TrajectoryRecorder folders (appendix "Dataset
Construction and Training").

Each item is one recorded step: the RGB frame (full mode), the 4-d agent-centric goal vector
[v0, v1] = unit direction to the goal in the agent frame (x forward, y left), v2 = distance (m),
v3 = clip(distance / 5, 0, 1), and the action. Only an index (file, member offset and length, step)
is kept in memory; a step's episode is decompressed on demand (a small cache keeps the last ones),
so recordings larger than memory work. Transforms: resize, ImageNet normalisation, horizontal flip
(which swaps LEFT and RIGHT and mirrors v1), brightness jitter, position noise; STOP steps can be
dropped.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from PIL import Image

from biovln_ms.errors import BioVLNError
from biovln_ms.io_utils import inside
from biovln_ms.learning.recorder import RECORDER_VERSION
from biovln_ms.learning.recordings import episode_members, read_member
from biovln_ms.task_config import TURN_LEFT, TURN_RIGHT

IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


class TrajectoryDataError(BioVLNError):
    """Empty, mixed-version or otherwise unusable recordings."""


@dataclass(frozen=True)
class Transforms:
    size: tuple[int, int] = (224, 224)
    normalize: bool = True
    hflip_p: float = 0.0
    brightness: float = 0.0  # +- fraction, e.g. 0.05
    position_noise: float = 0.0  # metres (std) added to the agent position before the goal vector


def goal_features(unit, dist: float) -> np.ndarray:
    """The 4-d goal vector from a unit direction in the agent frame and a distance:
    [unit x (forward), unit y (left), distance, clip(distance / 5, 0, 1)]."""
    return np.array([unit[0], unit[1], dist, min(max(dist / 5.0, 0.0), 1.0)], np.float32)


def goal_vector(position, heading, goal) -> np.ndarray:
    """``goal_features`` of the goal seen from ``position`` with unit ``heading`` (x forward, y left)."""
    d = np.asarray(goal[:2], float) - np.asarray(position[:2], float)
    hx, hy = heading
    local = np.array([hx * d[0] + hy * d[1], -hy * d[0] + hx * d[1]])
    dist = float(np.linalg.norm(d))
    return goal_features(local / dist if dist > 1e-9 else np.zeros(2), dist)


def image_tensor(
    img: Image.Image, size: tuple[int, int], normalize: bool = True, flip: bool = False, gain: float = 1.0
) -> torch.Tensor:
    """A PIL RGB image -> (3, H, W) float tensor: bilinear resize to ``size`` (H, W), optional mirror,
    brightness gain and ImageNet normalisation. Training and the BC policy's inference share it."""
    if img.size != size[::-1]:
        img = img.resize(size[::-1], Image.BILINEAR)
    x = torch.from_numpy(np.asarray(img, np.float32) / 255.0).permute(2, 0, 1)
    if flip:
        x = torch.flip(x, dims=[2])
    if gain != 1.0:
        x = (x * gain).clamp(0, 1)
    if normalize:
        x = (x - torch.tensor(IMAGENET_MEAN)[:, None, None]) / torch.tensor(IMAGENET_STD)[:, None, None]
    return x


class TrajectoryDataset(torch.utils.data.Dataset):
    def __init__(
        self,
        roots,
        transforms: Transforms = Transforms(),
        drop_stop: bool = False,
        success_only: bool = True,
        require_images: bool = True,
        seed: int = 0,
        cache_episodes: int = 8,
    ) -> None:
        roots = [Path(r) for r in ([roots] if isinstance(roots, (str, Path)) else roots)]
        self.t = transforms
        self.require_images = require_images
        self.rng = np.random.default_rng(seed)
        self._cache: OrderedDict = OrderedDict()
        self._cache_size = cache_episodes
        self.index: list[tuple[Path, Path, int, int, int]] = []
        versions, modes, episodes, successes = set(), set(), 0, 0
        for root in roots:
            files = sorted(root.glob("trajectories-*.jsonl.gz"))
            if not files:
                raise TrajectoryDataError(
                    "no recordings here",
                    source=str(root),
                    fix="record some: biovln-ms eval --method frontier --split ms_dev --record DIR",
                )
            for f in files:
                for off, length, entry in episode_members(f):
                    self._keep((f, off), entry)
                    versions.add(entry.get("recorder_version"))
                    modes.add(entry.get("mode"))
                    episodes += 1
                    successes += bool(entry["success"])
                    if success_only and not entry["success"]:
                        continue
                    for k, step in enumerate(entry["steps"]):
                        if drop_stop and step["action"] == 0:
                            continue
                        self.index.append((root, f, off, length, k))
        if versions != {RECORDER_VERSION}:
            raise TrajectoryDataError(
                f"recordings of versions {sorted(map(str, versions))} (this build reads {RECORDER_VERSION})",
                source=", ".join(map(str, roots)),
                field="recorder_version",
                fix="re-record with this version of biovln-ms, or keep one version per dataset",
            )
        if require_images and "trace" in modes:
            raise TrajectoryDataError(
                "trace-only recordings have no images",
                source=", ".join(map(str, roots)),
                field="mode",
                fix="record with --record-mode full, or pass require_images=False",
            )
        if success_only and successes == 0:
            raise TrajectoryDataError(
                f"none of the {episodes} recorded episodes succeeded",
                source=", ".join(map(str, roots)),
                fix="record a stronger policy, or pass success_only=False",
            )
        if not self.index:
            raise TrajectoryDataError("no steps left after filtering", source=", ".join(map(str, roots)))
        self.episodes, self.successful_episodes = episodes, successes

    def _load(self, f: Path, off: int, length: int) -> dict:
        key = (f, off)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        return self._keep(key, read_member(f, off, length))

    def _keep(self, key: tuple[Path, int], entry: dict) -> dict:
        """``entry`` in the cache of the last ``cache_episodes`` episodes read."""
        self._cache[key] = entry
        if len(self._cache) > self._cache_size:
            self._cache.popitem(last=False)
        return entry

    @staticmethod
    def _frame(root: Path, f: Path, step: dict) -> Path:
        """A step's RGB frame, refused in one line unless its path stays inside the recording folder."""
        return inside(
            root,
            str(step["obs"].get("rgb_path")),
            what="frame",
            error=TrajectoryDataError,
            source=str(f),
            field="obs.rgb_path",
            fix="train on recordings as eval writes them (frames under images/)",
            nested=True,
        )

    def __len__(self) -> int:
        return len(self.index)

    def frame_size(self) -> list[int]:
        """(width, height) of the recorded frames, so inference can resize live frames the same way."""
        root, f, off, n, k = self.index[0]
        with Image.open(self._frame(root, f, self._load(f, off, n)["steps"][k])) as im:
            return list(im.size)

    def actions(self) -> np.ndarray:
        return np.array([self._load(f, off, n)["steps"][k]["action"] for _, f, off, n, k in self.index])

    def __getitem__(self, i: int) -> dict:
        root, f, off, length, k = self.index[i]
        step = self._load(f, off, length)["steps"][k]
        obs = step["obs"]
        pos = np.asarray(obs["position"][:2], float)
        if self.t.position_noise > 0:
            pos = pos + self.rng.normal(0, self.t.position_noise, 2)
        gv = goal_vector(pos, obs["heading"], obs["goal_position"])
        action = int(step["action"])
        flip = self.t.hflip_p > 0 and self.rng.random() < self.t.hflip_p
        if flip:
            gv[1] = -gv[1]
            action = {TURN_LEFT: TURN_RIGHT, TURN_RIGHT: TURN_LEFT}.get(action, action)
        item = {"goal": torch.from_numpy(gv), "action": torch.tensor(action, dtype=torch.long)}
        if self.require_images:
            gain = (
                1 + self.rng.uniform(-self.t.brightness, self.t.brightness) if self.t.brightness > 0 else 1.0
            )
            rgb = Image.open(self._frame(root, f, step)).convert("RGB")
            item["image"] = image_tensor(rgb, self.t.size, self.t.normalize, flip, gain)
        return item
