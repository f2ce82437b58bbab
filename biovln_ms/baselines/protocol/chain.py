"""Sub-goal chains: a single-goal policy run once per goal of a lab protocol (``BioVLN-Protocol-v0``).

In the protocol env the goal sensors (``pointgoal_with_gps_compass``, ``pointgoal``, ``objectgoal``) and an
oracle's privileged view follow the current sub-goal, and ``info["subgoal_index"]`` says which one it is: it
advances at each correct STOP (MultiON's FOUND) and, with ``wrong_stop="miss"``, at a wrong one. A chain
resets its inner policy onto the next sub-goal whenever the index advances. The inner policy starts over as
if a new episode began where the last leg ended (a mapping policy with an empty map); its
:class:`EpisodeInfo` carries the leg's category, read from ``objectgoal`` when the observation has it.

Each leg after the first starts where the last ended: at an instrument, closer than a single-goal episode
ever starts (1.0 m from every obstacle), often inside the frontier planner's grown obstacles; the planner's
escape rule (:mod:`~biovln_ms.baselines.frontier.planner`) gets it out.

Without GPS+compass the inner policy localises in the frame of its leg's start, while ``pointgoal`` is in the
episode's start frame: the chain keeps where each leg started (the previous leg's last pose estimate, in the
episode frame), hands the inner policy ``pointgoal`` in its leg's frame, and reports every pose estimate in
the episode frame (``episode_stats``).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from biovln_ms.baselines.policy import EpisodeInfo, Policy

POSE_KEYS = ("pose_frame", "pose_estimates")


def subgoal_index(info: dict) -> int:
    """The current sub-goal of sub-env 0 (``info["subgoal_index"]``, a tensor or array of one)."""
    value = info["subgoal_index"]
    value = value.cpu().numpy() if hasattr(value, "cpu") else np.asarray(value)
    return int(value.reshape(-1)[0])


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The planar pose ``b`` (x, y, yaw), given in the frame of pose ``a``, in ``a``'s own frame."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2]])


class SubgoalChain(Policy):
    """Runs ``inner`` on each sub-goal in turn, resetting it when ``info["subgoal_index"]`` advances."""

    def __init__(self, inner: Policy) -> None:
        self.inner = inner
        self.obs_mode = getattr(inner, "obs_mode", "rgbd")

    def reset(self, episode_info: EpisodeInfo) -> None:
        self.episode_info = episode_info
        self.leg = 0
        self.leg_start = np.zeros(3)  # where the current leg started, in the episode frame (no GPS+compass)
        self.leg_steps: list[int] = [0]
        self.finished: list[dict] = []  # the inner policy's stats of each finished leg
        self.inner.reset(episode_info)

    def leg_info(self, obs) -> EpisodeInfo:
        """The episode as the inner policy may know it on the current leg: the category of ``objectgoal``."""
        extra = obs.get("extra", {}) if isinstance(obs, dict) else {}
        if "objectgoal" not in extra:
            return self.episode_info
        onehot = extra["objectgoal"]
        onehot = onehot.cpu().numpy() if hasattr(onehot, "cpu") else np.asarray(onehot)
        category = self.episode_info.task.goal_categories[int(np.argmax(onehot.reshape(-1)))]
        return replace(self.episode_info, object_category=category)

    def _localising(self) -> bool:
        return getattr(self.inner, "localiser", None) is not None

    def act(self, obs, info: dict) -> int:
        j = subgoal_index(info)
        if j != self.leg:
            self.finished.append(self._inner_stats())
            if self._localising() and getattr(self.inner, "pose", None) is not None:
                self.leg_start = compose(self.leg_start, self.inner.pose)
            self.leg = j
            self.leg_steps.append(0)
            self.inner.reset(self.leg_info(obs))
        self.leg_steps[-1] += 1
        return self.inner.act(self._leg_obs(obs), info)

    def _leg_obs(self, obs):
        """``obs`` with ``pointgoal`` (episode start frame) expressed in the current leg's frame."""
        if self.leg == 0 or not isinstance(obs, dict) or "pointgoal" not in obs.get("extra", {}):
            return obs
        pg = obs["extra"]["pointgoal"]
        rho, phi = (pg.cpu().numpy() if hasattr(pg, "cpu") else np.asarray(pg)).reshape(-1)[:2]
        goal = np.array([rho * math.cos(phi), rho * math.sin(phi)]) - self.leg_start[:2]
        c, s = math.cos(self.leg_start[2]), math.sin(self.leg_start[2])
        local = np.array([c * goal[0] + s * goal[1], -s * goal[0] + c * goal[1]])
        moved = np.array([[np.hypot(*local), math.atan2(local[1], local[0])]], np.float32)
        return {**obs, "extra": {**obs["extra"], "pointgoal": moved}}

    def _inner_stats(self) -> dict:
        """The inner policy's stats of the current leg, its pose estimates in the episode frame."""
        stats = self.inner.episode_stats() if hasattr(self.inner, "episode_stats") else {}
        if stats.get("pose_frame") == "episode" and self.leg:
            stats["pose_estimates"] = [
                [round(float(v), 4) for v in compose(self.leg_start, np.asarray(p, float))]
                for p in stats["pose_estimates"]
            ]
        return stats

    def episode_stats(self) -> dict:
        """Per leg the steps and the inner policy's stats; the pose estimates of all legs, in order."""
        legs = [*self.finished, self._inner_stats()]
        out: dict = {
            "leg_steps": list(self.leg_steps),
            "legs": [{k: v for k, v in s.items() if k not in POSE_KEYS} for s in legs],
        }
        poses = [p for s in legs for p in s.get("pose_estimates", [])]
        if poses:
            out.update(pose_frame=legs[-1]["pose_frame"], pose_estimates=poses)
        return out
