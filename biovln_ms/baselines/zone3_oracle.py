"""3-Zone Oracle: tries up to 8 approach points inside the target's Zone 3 (0.15 m grid), in order of
distance to the operational-face goal, until one succeeds; the centroid projection is the fallback.

"Succeeds" is checked with the privileged goal and success radius, as an oracle may: at each
reached candidate it STOPs if that is a success, else it moves on to the next candidate. With people it
waits as the oracle does (:class:`~biovln_ms.baselines.oracle.PeopleGuard`): for a person in its way, and
before a STOP for the target's Zone 3 to be free.
"""

from __future__ import annotations

import numpy as np
import shapely

from biovln_ms.baselines.oracle import PeopleGuard, PointFollower
from biovln_ms.baselines.policy import STOP, EpisodeInfo, Policy

SPACING = 0.15
CANDIDATES = 8


class Zone3OraclePolicy(Policy):
    """Privileged: reads the target's Zone 3, the goal and its pose from ``EpisodeInfo.privileged``."""

    name = "zone3_oracle"
    obs_mode = "none"

    def reset(self, episode_info: EpisodeInfo) -> None:
        view = self.view = episode_info.privileged
        self.task = episode_info.task
        self.goal, self.radius = view.goal, view.success_radius
        self.candidates = self.zone3_candidates(view)
        if not self.candidates:
            self.candidates = [view.snap(view.target.centroid_goal())]
        self._k = 0
        self.follower = PointFollower(view, self.task, self.candidates[0])
        zone = view.target.zone3() if view.target.model_face is not None else None
        self.guard = PeopleGuard(view, self.task, zone)

    @staticmethod
    def zone3_candidates(view) -> list[np.ndarray]:
        target, goal = view.target, view.goal
        if target.model_face is None:
            return []
        z3 = target.zone3()
        minx, miny, maxx, maxy = z3.bounds
        xs = np.arange(minx + SPACING / 2, maxx, SPACING)
        ys = np.arange(miny + SPACING / 2, maxy, SPACING)
        gx, gy = (a.ravel() for a in np.meshgrid(xs, ys))
        inside = shapely.contains_xy(z3, gx, gy) & view.contains_free(gx, gy)
        pts = np.stack([gx[inside], gy[inside]], axis=1)
        order = np.argsort(np.linalg.norm(pts - goal, axis=1), kind="stable")
        return [pts[i] for i in order[:CANDIDATES]]

    def act(self, obs, info: dict) -> int:
        a = self.guard.check(self._next())
        self.follower.sent(a)
        return a

    def _next(self) -> int:
        """The follower's action toward the current candidate, moving on from a reached one that fails."""
        while True:
            a = self.follower.step()
            if a != STOP:
                return a
            p = self.view.pose()[:2]
            if np.linalg.norm(p - self.goal) <= self.radius or self._k + 1 >= len(self.candidates):
                return STOP
            self._k += 1
            self.follower = PointFollower(self.view, self.task, self.candidates[self._k])
