"""Task variants: each a few lines on top of ``BioVLNNavEnv`` (the way to add your own, see README)."""

from __future__ import annotations

import math

import numpy as np
import torch

from biovln_ms.registration import register_biovln_env
from biovln_ms.tasks.nav_env import BioVLNNavEnv, NavTaskConfig


@register_biovln_env("BioVLN-Centroid-v0", max_episode_steps=500)
class CentroidNavEnv(BioVLNNavEnv):
    """The paper's ablation (Table 9): the goal is the floor projection of the bounding-box centre."""

    config = NavTaskConfig(goal_mode="centroid")


@register_biovln_env("BioVLN-OpFace-RL-v0", max_episode_steps=500)
class OpFaceRLEnv(BioVLNNavEnv):
    """The paper's Gym variant for RL: 10 deg turns, positions / 4.0 m, heading as a unit vector,
    Eq. 5 with the proportional safety penalty, episodes shuffled once and cycled."""

    config = NavTaskConfig(turn_deg=10.0, proportional_safety=True, safety_penalty=1.0, shuffle_episodes=True)

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("obs_mode", "state")
        kwargs.setdefault("split", "train")
        super().__init__(*args, **kwargs)

    def _get_obs_agent(self):
        return {}

    def _get_obs_extra(self, info: dict):
        s = self.cfg.position_scale
        pose = self._pose
        goal = self._ctx.goal if self._ctx is not None else np.zeros(2)
        d = goal - pose[:2]
        c, sn = math.cos(pose[2]), math.sin(pose[2])
        local = np.array([c * d[0] + sn * d[1], -sn * d[0] + c * d[1]])
        clearance = float(info["clearance"][0]) if "clearance" in info else 0.0
        vec = np.concatenate([pose[:2] / s, [c, sn], goal / s, local / s, [min(clearance, 2.0) / 2.0]]).astype(np.float32)
        return dict(state=torch.tensor(vec[None], device=self.device), target_category=self._target_onehot())
