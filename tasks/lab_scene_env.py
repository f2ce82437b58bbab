"""``BioVLN-LabScene-v0``: a lab scene with no robot, for viewing, rendering and timing scene builds.

Its arguments, ``reset`` seeds and options are checked as the navigation envs' are
(:func:`~.config_checks.check_scene_env_arguments`): a bad one is one line naming it and the fix, before
anything is built."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.sensors.camera import CameraConfig
from mani_skill.utils import sapien_utils
from mani_skill.utils.structs.types import SimConfig

from biovln_ms.variants import LAB_SCENE_ENV
from biovln_ms.registration import register_biovln_env
from biovln_ms.render.lighting import lighting_preset
from biovln_ms.scene.generator import generate_scene
from biovln_ms.sim.maniskill_builder import LabSceneBuilder
from biovln_ms.scene.spec import SceneSpec
from biovln_ms.tasks.config_checks import (
    SCENE_RESET_OPTIONS,
    SIM_FREQUENCIES,
    check_scene_env_arguments,
    reset_arguments,
)


def overview_pose(spec: SceneSpec):
    """A camera above the scene at an angle, looking at the middle of the floor."""
    xy = np.concatenate([np.asarray(r.polygon) for r in spec.rooms])
    lo, hi = xy.min(0), xy.max(0)
    centre = (lo + hi) / 2
    span = float(np.max(hi - lo))
    eye = [centre[0], lo[1] - 0.25 * span, 1.25 * span + 2.0]
    return sapien_utils.look_at(eye, [centre[0], centre[1] - 0.02 * span, 0.0])


@register_biovln_env(LAB_SCENE_ENV, max_episode_steps=1)
class LabSceneEnv(BaseEnv):
    """Builds one or more scene specs (``specs=``), or the scene of ``template``/``seed``."""

    SUPPORTED_REWARD_MODES = ("none",)
    SUPPORTED_ROBOTS = ("none",)

    def __init__(
        self,
        *args,
        specs: Sequence[SceneSpec | str | Path] | None = None,
        template: str = "single_room",
        seed: int = 0,
        ceiling: bool = True,
        render_size: tuple[int, int] = (960, 720),
        lighting: str = "fast",
        **kwargs,
    ) -> None:
        own = dict(
            specs=specs,
            template=template,
            seed=seed,
            ceiling=ceiling,
            render_size=render_size,
            lighting=lighting,
        )
        check_scene_env_arguments(own, kwargs)
        self._specs = list(specs) if specs else [generate_scene(template, seed)]
        self._ceiling = ceiling
        lighting_preset(lighting)
        self._lighting = lighting
        self._render_size = render_size
        # Every other ManiSkill obs mode works; the default, "state", is empty (no robot, no task state).
        kwargs.setdefault("robot_uids", "none")
        kwargs.setdefault("reward_mode", "none")
        super().__init__(*args, **kwargs)

    def reset(self, seed=None, options=None):
        """ManiSkill's, after checking the seed and options (``env_idx`` as the base env's index tensor)."""
        seed, options, _ = reset_arguments(seed, options, self.num_envs, self.device, SCENE_RESET_OPTIONS)
        return super().reset(seed=seed, options=options)

    @property
    def _default_sim_config(self):
        return SimConfig(**SIM_FREQUENCIES)  # the task's rates, not ManiSkill's default (which may change)

    @property
    def _default_sensor_configs(self):
        return []

    @property
    def _default_human_render_camera_configs(self):
        spec = self.scene_builder.build_configs[0] if hasattr(self, "scene_builder") else self._specs[0]
        w, h = self._render_size
        return CameraConfig("overview", overview_pose(spec), w, h, np.deg2rad(55), 0.05, 100)

    def _load_scene(self, options: dict):
        self.scene_builder = LabSceneBuilder(
            self, self._specs, ceiling=self._ceiling, lighting=self._lighting
        )
        self.scene_builder.build(
            list(range(len(self._specs)))[: self.num_envs] if len(self._specs) == self.num_envs else 0
        )

    def _load_lighting(self, options: dict):
        """Lights come from the scene builder."""

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        self.scene_builder.initialize(env_idx)

    def evaluate(self):
        return {}

    def get_state_dict(self):
        """Simulation state only (ManiSkill 3.0.1's version assumes a robot)."""
        return self.scene.get_sim_state()

    def _get_obs_agent(self) -> dict:
        """No robot, so no proprioception: ManiSkill's default reads ``self.agent`` (None here), which made
        every obs mode but ``"none"`` crash, including the default ``"state"``."""
        return {}

    def _get_obs_extra(self, info: dict):
        return {}
