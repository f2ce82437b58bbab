"""Behavioural-cloning policy (appendix Table 17): the trained BC network acting on the live frame.

Each step it reads the head camera's RGB frame and the env's GPS+compass goal sensor
(``extra.pointgoal_with_gps_compass`` = distance rho, bearing phi in the agent frame), forms the same 4-d goal
vector as the training data (``goal_features``: [cos phi, sin phi, rho, clip(rho / 5, 0, 1)]) and takes the
arg-max action (``sample=True`` samples the softmax instead, seeded per episode).

Without GPS+compass (the ``realistic`` preset) there is no goal sensor to read: rho and phi come from the
start-frame ``pointgoal`` and the policy's own pose estimate
(:class:`~biovln_ms.baselines.frontier.odometry.EpisodeOdometry`: its commands dead-reckoned, corrected by
matching its depth to a map it builds), as a PointNav agent without GPS must; the network is the same, trained
on GPS+compass readings.
"""

from __future__ import annotations

import zlib

import numpy as np
import torch

from biovln_ms.baselines.frontier.odometry import EpisodeOdometry
from biovln_ms.baselines.policy import EpisodeInfo, Policy


class BCPolicy(Policy):
    name = "bc"
    obs_mode = "rgbd"  # RGB for the network; depth for the pose estimate without GPS+compass

    def __init__(self, checkpoint: str, sample: bool = False, seed: int = 0) -> None:
        from biovln_ms.learning.bc import load_bc

        self.model, self.cfg, self.meta = load_bc(checkpoint)
        self.sample = sample
        self.seed = seed

    def reset(self, episode_info: EpisodeInfo) -> None:

        key = f"{self.seed}/{episode_info.scene_id}/{episode_info.episode_id}"
        self.rng = np.random.default_rng(zlib.crc32(key.encode()))
        task = episode_info.task
        self.odometry = None if task.noise.gps_compass else EpisodeOdometry(task)
        self.last_action: int | None = None

    def act(self, obs, info: dict) -> int:
        from biovln_ms.learning.bc import preprocess
        from biovln_ms.learning.dataset import goal_features

        rgb = obs["sensor_data"]["head"]["rgb"][0].cpu().numpy()
        if self.odometry is None:
            rho, phi = (float(v) for v in obs["extra"]["pointgoal_with_gps_compass"][0])
        else:
            self.odometry.update(obs, self.last_action)
            rho, phi = self.odometry.pointgoal()
        goal = torch.from_numpy(goal_features((np.cos(phi), np.sin(phi)), rho))[None]
        with torch.inference_mode():
            logits = self.model(preprocess(rgb, self.meta["frame_size"], self.cfg.image_size), goal)[0]
        if self.sample:
            p = torch.softmax(logits, 0).numpy().astype(float)
            self.last_action = int(self.rng.choice(len(p), p=p / p.sum()))
        else:
            self.last_action = int(logits.argmax())
        return self.last_action

    def episode_stats(self) -> dict:
        """Without GPS+compass, the pose estimates it acted on (the harness measures their drift)."""
        return {} if self.odometry is None or not self.odometry.poses else self.odometry.stats()
