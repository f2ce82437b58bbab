"""Oracle: follows the exact geodesic shortest path to the navmesh-snapped goal and stops there.

With 0.25 m steps and 30 deg turns it cannot always land inside the success radius (paper §4.3), so
it is an empirical upper bound, not 100 %. Rule: STOP when the goal is nearer than half a step or,
once the goal is in sight (the rest of the path is one straight segment), when a forward step would
not bring it closer; otherwise turn toward the next path vertex when the heading error exceeds half a
turn, else move forward. A blocked forward move turns it aside once.
"""

from __future__ import annotations

import math

import numpy as np

from biovln_ms.baselines.policy import FORWARD, STOP, TURN_LEFT, TURN_RIGHT, EpisodeInfo, Policy


class PointFollower:
    """Discrete-action follower of the exact shortest path to a point (shared by the oracles).

    ``step()`` returns an action, or STOP when it has arrived: nearer than half a step, or, with the
    point in sight, a forward step would not bring it closer.
    """

    def __init__(self, view, task, point) -> None:
        """``view``: the privileged view (pose, geodesics); ``task``: the TaskSpec (step and turn sizes)."""
        self.view = view
        self.point = np.asarray(point, float)
        self.step_len = task.forward_step
        self.turn = math.radians(task.turn_deg)
        self._last = None

    def step(self) -> int:
        pose = self.view.pose()
        p, yaw = pose[:2], float(pose[2])
        d = float(np.linalg.norm(self.point - p))
        if d < self.step_len / 2:
            return STOP
        blocked = (
            self._last is not None and self._last[1] == FORWARD and np.linalg.norm(p - self._last[0]) < 0.02
        )
        path = self.view.shortest_path(self.view.snap(p), self.point)
        target = next((q for q in path[1:] if np.linalg.norm(q - p) > 0.05), self.point)
        err = (math.atan2(target[1] - p[1], target[0] - p[0]) - yaw + math.pi) % (2 * math.pi) - math.pi
        if abs(err) > self.turn / 2 or blocked:
            action = TURN_LEFT if (err > 0) != blocked else TURN_RIGHT
        elif len(path) <= 2:  # the point in sight: stop when a step would not bring it closer
            ahead = p + self.step_len * np.array([math.cos(yaw), math.sin(yaw)])
            action = STOP if np.linalg.norm(self.point - ahead) >= d else FORWARD
        else:  # on a detour (round a bench or through a door) the straight-line distance may grow
            action = FORWARD
        self._last = (p.copy(), action)
        return action


class OraclePolicy(Policy):
    """Privileged: reads the goal, geodesics and its pose from ``EpisodeInfo.privileged``."""

    name = "oracle"
    obs_mode = "none"

    def reset(self, episode_info: EpisodeInfo) -> None:
        view = episode_info.privileged
        goal = view.goal if view.goal_mode == "opface" else view.snap(view.goal)
        self.follower = PointFollower(view, episode_info.task, goal)

    def act(self, obs, info: dict) -> int:
        return self.follower.step()
