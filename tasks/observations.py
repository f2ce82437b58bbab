"""What the navigation env does to ManiSkill's sensor data before a policy sees it: the noise config's RGB and
depth noise on the head camera (:mod:`biovln_ms.sensor_noise`), the cameras' extrinsics in the robot's base
frame when there is no GPS+compass, and the segmentation ids' goal categories
(:func:`biovln_ms.tasks.sensors.semantic_category` reads them)."""

from __future__ import annotations

import math

import numpy as np
import torch

from biovln_ms.geometry import base_frame
from biovln_ms.sensor_noise import DepthNoise, RGBNoise, frame_keys
from biovln_ms.task_config import NavTaskConfig

#: the image noise banks' seed; a frame's noise is chosen by (episode seed, step) (biovln_ms.sensor_noise)
IMAGE_NOISE_SEED = 0x696D67


class HeadCameraNoise:
    """The noise config's image noise and pose-free extrinsics for the head camera (noise models built on
    first use)."""

    def __init__(self, cfg: NavTaskConfig, device) -> None:
        self.cfg, self.device = cfg, device
        self._models: tuple[RGBNoise | None, DepthNoise | None] | None = None

    def models(self) -> tuple[RGBNoise | None, DepthNoise | None]:
        """The RGB and depth noise models (None where the config has none)."""
        if self._models is None:
            c, noise = self.cfg, self.cfg.noise
            h, w, seed = c.camera_height, c.camera_width, IMAGE_NOISE_SEED
            focal = w / (2 * math.tan(c.hfov / 2))  # pixels, as the camera's intrinsic matrix has it
            self._models = (
                RGBNoise(h, w, sigma=noise.rgb, seed=seed, device=self.device) if noise.rgb > 0 else None,
                DepthNoise(h, w, focal_px=focal, seed=seed, device=self.device) if noise.depth else None,
            )
        return self._models

    def apply_image_noise(self, head: dict, episode_seed: np.ndarray, steps: np.ndarray) -> None:
        """RGB and depth noise on the head camera's images (in place), keyed by each sub-env's (episode seed,
        step) so that a recorded episode replays exactly."""
        rgb_noise, depth_noise = self.models()
        if (rgb_noise and "rgb" in head) or (depth_noise and "depth" in head):
            keys = frame_keys(episode_seed, steps)
            if rgb_noise and "rgb" in head:
                rgb_noise(head["rgb"], keys, out=head["rgb"])
            if depth_noise and "depth" in head:
                depth_noise(head["depth"], keys, out=head["depth"])

    def camera_params_in_base_frame(self, params: dict, pose: np.ndarray) -> None:
        """Without GPS+compass the cameras' extrinsics are given relative to the robot's base at planar
        ``pose`` (the mount, as a robot knows it), not the world: world-frame extrinsics would tell the pose
        (:mod:`biovln_ms.geometry.base_frame`)."""

        for cam in params.values():
            ext, c2w = cam["extrinsic_cv"], cam["cam2world_gl"]
            cpu = ext.device.type == "cpu" and ext.dtype == c2w.dtype == torch.float32
            if cpu and len(pose) == ext.shape[0] == c2w.shape[0]:
                cam["extrinsic_cv"] = torch.empty(ext.shape, dtype=ext.dtype)
                cam["cam2world_gl"] = torch.empty(c2w.shape, dtype=c2w.dtype)
                base_frame.camera_params_in_base_frame(
                    pose, ext.numpy(), c2w.numpy(), cam["extrinsic_cv"].numpy(), cam["cam2world_gl"].numpy()
                )
            else:
                b2w, w2b = (
                    torch.from_numpy(m).to(ext.device, ext.dtype) for m in base_frame.base_transforms(pose)
                )
                cam["extrinsic_cv"], cam["cam2world_gl"] = ext @ b2w, w2b @ c2w


def segmentation_lookup(scene_builder, category_names: list[str], device) -> torch.Tensor:
    """Segmentation id -> 1 + goal-category index (0: not a goal-category object), over all sub-scenes."""
    ids = {}
    for bci, spec in enumerate(scene_builder.build_configs):
        for sid, oid in scene_builder.segmentation_ids(bci).items():
            cat = spec.get(oid).category
            ids[sid] = category_names.index(cat) + 1 if cat in category_names else 0
    lookup = torch.zeros(max(ids, default=0) + 1, dtype=torch.int16, device=device)
    for sid, v in ids.items():
        lookup[sid] = v
    return lookup
