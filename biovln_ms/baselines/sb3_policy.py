"""A Stable-Baselines3 policy (PPO, A2C or SAC trained by ``biovln-ms train``) behind the policy interface.

It reads the flat state observation of ``BioVLN-OpFace-RL-v0`` (the env it was trained on) and returns
the deterministic action: an int for PPO/A2C (Discrete(4)), a [forward, turn, stop] array for SAC.

Without GPS+compass (the ``realistic`` preset) the env has no RL state vector to give: it is the robot's pose.
The policy then builds the vector itself (:func:`biovln_ms.rl_state.rl_state_vector`) from what a robot can
know, as BC does: its pose estimate (:class:`~biovln_ms.baselines.frontier.odometry.EpisodeOdometry`, dead
reckoning corrected by matching depth to a map it builds) in the episode frame (origin at the start pose, x
along the start heading) where training used the world frame, the goal from the start-frame ``pointgoal``, and
the clearance from that map: the distance to the nearest mapped obstacle, walls
included, where the env measures the nearest instrument body. The network is the same, trained with
GPS+compass; so this measures what the paper's state vector is worth without its privileged pose.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from biovln_ms.baselines.frontier import to_numpy
from biovln_ms.baselines.frontier.odometry import EpisodeOdometry
from biovln_ms.baselines.policy import EpisodeInfo, Policy
from biovln_ms.catalog import PAPER_GOAL_CATEGORIES, load_catalog
from biovln_ms.errors import BioVLNError
from biovln_ms.rl_state import rl_state_vector


class SB3Policy(Policy):
    obs_mode = "state"
    obs_mode_without_gps = "depth"  # its pose estimate reads depth (the registry's entry says the same)
    odometry = None  # its pose estimate, made by reset without GPS+compass
    last_action = None

    def __init__(self, checkpoint: str, algo: str = "ppo", deterministic: bool = True) -> None:
        from biovln_ms.learning.sb3_safe import load_sb3_model

        path = Path(checkpoint)
        if not path.is_file():
            raise BioVLNError(
                "no such checkpoint",
                source=str(path),
                field="checkpoint",
                fix=f"train one: biovln-ms train {algo} --timesteps N --out DIR (it writes DIR/model.zip)",
            )
        self.model = load_sb3_model(path, algo)  # never unpickles: a checkpoint is untrusted input
        self.name = algo
        self.deterministic = deterministic

    def reset(self, episode_info: EpisodeInfo) -> None:
        """The network is stateless; without GPS+compass a fresh pose estimate for the episode."""

        self.task = episode_info.task
        self.odometry = None if self.task.noise.gps_compass else EpisodeOdometry(self.task)
        self.last_action = None

    def act(self, obs, info: dict):
        x = self._state(obs)
        expected = self.model.observation_space.shape
        if x.shape != expected:
            fix = "evaluate on the env it was trained on (--env BioVLN-OpFace-RL-v0)"
            paper = len(PAPER_GOAL_CATEGORIES)
            if x.size - int(np.prod(expected)) == len(load_catalog().goal_categories()) - paper:
                fix = (
                    f"it was trained when the objectgoal one-hot held {paper} categories (the catalog has "
                    f"added some since): retrain it, biovln-ms train {self.name} --timesteps N --out DIR"
                )
            raise BioVLNError(
                f"the model expects observations of shape {expected}, this env gives {x.shape}",
                field="env",
                fix=fix,
            )
        action, _ = self.model.predict(x, deterministic=self.deterministic)
        self.last_action = int(action) if np.ndim(action) == 0 else np.asarray(action, np.float32)
        return self.last_action

    def _state(self, obs) -> np.ndarray:
        """The flat observation the network was trained on: the env's, or without GPS+compass the RL state
        vector from the pose estimate, then the ``objectgoal`` one-hot (the state obs mode's order)."""
        if self.odometry is None:
            return obs.cpu().numpy()[0] if hasattr(obs, "cpu") else np.asarray(obs)[0]
        pose = self.odometry.update(obs, self.last_action)
        clearance = self.odometry.clearance(pose[:2])
        state = rl_state_vector(
            pose[None], self.odometry.goal[None], np.array([clearance]), self.task.position_scale
        )
        return np.concatenate([state[0], to_numpy(obs["extra"]["objectgoal"][0])]).astype(np.float32)

    def episode_stats(self) -> dict:
        """Without GPS+compass, the pose estimates it acted on (the harness measures their drift)."""
        return {} if self.odometry is None or not self.odometry.poses else self.odometry.stats()
