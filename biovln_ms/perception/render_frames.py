"""The detector's labelled frames, simulator side: a SAPIEN scene of a group's scene build and a camera like
the env's head camera (ManiSkill's "minimal" shader pack with its 8-bit colour and int16 millimetre
position/segmentation pictures, the task's field of view and near/far planes), moved between the group's
viewpoints.

Per frame: RGB (uint8), depth (uint16 millimetres along the optical axis, 0: no reading) and the instance
image (uint16: 1 + the object's index among the scene's goal-category objects, 0 elsewhere), read from the
segmentation picture's per-actor ids. The ``realistic`` frames get the env's image noise models
(:mod:`biovln_ms.sensor_noise`, seeded as the env seeds them) keyed by the frame's noise key; labels come
from the noiseless segmentation, as a real annotator's would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from biovln_ms.catalog import load_catalog
from biovln_ms.noise import PRESETS
from biovln_ms.paths import ASSET_DIR
from biovln_ms.render.lighting import apply_lighting
from biovln_ms.perception.frames import FrameDraw, GroupDraw, SceneSource, dressed_spec, look_variant
from biovln_ms.render.sapien_utils import env_camera_scene, look_at_pose
from biovln_ms.sensor_noise import DepthNoise, RGBNoise
from biovln_ms.task_config import NavTaskConfig
from biovln_ms.tasks.observations import IMAGE_NOISE_SEED

#: the env's head camera (near plane as in ``BioVLNNavEnv._default_sensor_configs``)
NEAR = 0.05
TASK = NavTaskConfig()


@dataclass
class RenderedFrame:
    """One frame's pictures and the goal-category objects its instance ids stand for."""

    rgb: np.ndarray  # (H, W, 3) uint8
    depth_mm: np.ndarray  # (H, W) uint16
    instances: np.ndarray  # (H, W) uint16
    objects: dict[int, str]  # instance id -> object id
    categories: dict[int, str]  # instance id -> category


class FrameRenderer:
    """Renders frames of group after group; a group's scene is built once (its spec, dressing, lighting and
    every object's look), then its frames are taken from their viewpoints."""

    def __init__(
        self, width: int, height: int, hfov_deg: float = TASK.camera_hfov_deg, far: float = TASK.camera_far
    ):
        self.width, self.height = width, height
        self.hfov = math.radians(hfov_deg)
        self.vfov = 2 * math.atan(math.tan(self.hfov / 2) * height / width)
        self.far = far
        self._scene = self._camera = None
        self._group: GroupDraw | None = None
        self._ids: dict[int, int] = {}
        self._objects: dict[int, str] = {}
        self._categories: dict[int, str] = {}
        realistic = PRESETS["realistic"]
        focal = width / (2 * math.tan(self.hfov / 2))
        self._rgb_noise = RGBNoise(height, width, sigma=realistic.rgb, seed=IMAGE_NOISE_SEED)
        self._depth_noise = DepthNoise(height, width, focal_px=focal, seed=IMAGE_NOISE_SEED)

    def _build(self, group: GroupDraw, source: SceneSource) -> None:

        from biovln_ms.sim.instance_looks import apply_variant
        from biovln_ms.sim.sapien_builder import add_spec_to_scene

        self._scene = self._camera = None  # the last group's scene goes first
        scene = env_camera_scene()
        spec = dressed_spec(source.spec, group.dressing)
        built = add_spec_to_scene(scene, spec, variants=False)
        uploads: dict = {}
        for o in spec.objects():
            glb = Path(ASSET_DIR) / f"{o.category}.glb"
            apply_variant(built.objects[o.id], o.category, glb, look_variant(group.looks[o.id]), uploads)
        apply_lighting(scene, spec, lighting=group.lighting)
        self._camera = scene.add_camera("head", self.width, self.height, self.vfov, NEAR, self.far)
        goals = set(load_catalog().goal_categories())
        self._ids, self._objects, self._categories = {}, {}, {}
        k = 0
        for o in spec.objects():
            if o.category not in goals:
                continue
            k += 1
            self._ids[int(built.objects[o.id].per_scene_id)] = k
            self._objects[k], self._categories[k] = o.id, o.category
        self._lut = np.zeros(max(self._ids, default=0) + 1, np.uint16)
        for sid, k in self._ids.items():
            self._lut[sid] = k
        self._scene, self._uploads, self._group = scene, uploads, group

    def render(self, frame: FrameDraw, source: SceneSource) -> RenderedFrame:
        """Frame ``frame`` of ``source``'s scene (its group's scene is built when it is not the current)."""
        if self._group != frame.group:
            self._build(frame.group, source)
        eye = np.asarray(frame.eye, float)
        c = math.cos(frame.pitch)
        ahead = eye + np.array([c * math.cos(frame.yaw), c * math.sin(frame.yaw), math.sin(frame.pitch)])
        self._camera.entity.set_pose(look_at_pose(eye, ahead))
        self._scene.update_render()
        self._camera.take_picture()
        rgb = np.ascontiguousarray(np.asarray(self._camera.get_picture("Color"))[..., :3])
        if rgb.dtype != np.uint8:
            rgb = (np.clip(rgb, 0, 1) * 255).round().astype(np.uint8)
        pos = np.asarray(self._camera.get_picture("PositionSegmentation"))
        depth = np.clip(-pos[..., 2].astype(np.int32), 0, np.iinfo(np.int16).max).astype(np.int16)
        seg = pos[..., 3].astype(np.int64)
        instances = np.where(seg < len(self._lut), self._lut[np.clip(seg, 0, len(self._lut) - 1)], 0)
        if frame.noise == "realistic":
            rgb = self._rgb_noise(torch.from_numpy(rgb)[None], [frame.noise_key])[0].numpy()
            depth = self._depth_noise(torch.from_numpy(depth)[None, ..., None], [frame.noise_key])[
                0, ..., 0
            ].numpy()
        depth = depth.astype(np.uint16)  # never negative: 0 is no reading
        present = {int(k) for k in np.unique(instances) if k}
        return RenderedFrame(
            rgb,
            depth,
            instances.astype(np.uint16),
            {k: v for k, v in self._objects.items() if k in present},
            {k: v for k, v in self._categories.items() if k in present},
        )
