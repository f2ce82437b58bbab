"""The policy interface every BioVLN baseline implements (paper §4.3), and what a policy may know.

A policy sees the episode's public description (:class:`EpisodeInfo`) at reset and, each step, the
env's observation dict and info — nothing else (Habitat's convention). The observation carries the
sensors of :mod:`biovln_ms.tasks.sensors`:

* ``obs["extra"]["gps"]`` (N, 2) and ``["compass"]`` (N, 1): the robot's position and heading in the
  episode frame (origin at the start position, x along the start heading).
* ``obs["extra"]["pointgoal_with_gps_compass"]`` (N, 2): distance to the task's goal and its bearing
  in the robot frame (radians, counter-clockwise positive).
* ``obs["extra"]["objectgoal"]`` (N, C): one-hot target category, in ``task.goal_categories`` order.
* ``obs["extra"]["semantic_category"]`` (N, H, W, 1), obs modes with segmentation only: per head-camera
  pixel, 1 + the index of the goal category of the object seen there, 0 for anything else.
* ``obs["agent"]`` (obs modes with proprioception): the base joints' ``qpos`` / ``qvel`` — the robot's
  odometry (x, y, yaw) in the world frame the camera extrinsics use.
* ``obs["sensor_data"]["head"]`` (rgb, depth in int16 mm, segmentation) and
  ``obs["sensor_param"]["head"]`` (``intrinsic_cv``, ``extrinsic_cv``, ``cam2world_gl``), ManiSkill's.

Only the declared oracles also get ``EpisodeInfo.privileged``, a read-only
:class:`~biovln_ms.tasks.privileged.PrivilegedView` (goal, success radius, zones, geodesics, pose).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

from biovln_ms.task_config import FORWARD, STOP, TURN_LEFT, TURN_RIGHT, EpisodeInfo, TaskSpec

__all__ = ["STOP", "FORWARD", "TURN_LEFT", "TURN_RIGHT", "EpisodeInfo", "TaskSpec", "Policy"]


class Policy(ABC):
    """``reset(episode_info)`` once per episode, then ``act(obs, info) -> action`` each step."""

    name: str = "policy"

    @abstractmethod
    def reset(self, episode_info: EpisodeInfo) -> None:
        """Start an episode."""

    @abstractmethod
    def act(self, obs, info: dict) -> int: ...
