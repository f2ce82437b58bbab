"""Random baseline: uniform over FORWARD / LEFT / RIGHT with a 5 % STOP probability per step."""

from __future__ import annotations

import zlib

import numpy as np

from biovln_ms.baselines.policy import FORWARD, STOP, TURN_LEFT, TURN_RIGHT, EpisodeInfo, Policy


class RandomPolicy(Policy):
    name = "random"
    obs_mode = "none"

    def __init__(self, stop_probability: float = 0.05, seed: int = 0) -> None:
        self.p_stop = stop_probability
        self.seed = seed

    def reset(self, episode_info: EpisodeInfo) -> None:
        key = f"{self.seed}/{episode_info.scene_id}/{episode_info.episode_id}"
        self.rng = np.random.default_rng(zlib.crc32(key.encode()))  # the same episode draws the same actions

    def act(self, obs, info: dict) -> int:
        if self.rng.random() < self.p_stop:
            return STOP
        return int(self.rng.choice([FORWARD, TURN_LEFT, TURN_RIGHT]))
