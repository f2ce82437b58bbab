"""The read-only privileged view the declared oracles get (``EpisodeInfo.privileged``).

Only methods registered as privileged (the oracle and the 3-Zone oracle) receive it: the goal the task
scores against, its success radius, the target's and all instruments' zones, exact geodesics on the
scene's navigation geometry, and the robot's true planar pose. Every accessor returns a copy or an
immutable object, so an oracle can read the episode but cannot change it. In a protocol episode
(``BioVLN-Protocol-v0``) the goal, success radius and target are the current sub-goal's, following
``info["subgoal_index"]``; in every other episode they are its first goal's. In an env with people
(``people=N``) it also reads where they are now (:meth:`PrivilegedView.people`), so an oracle can wait for
a free face.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from biovln_ms.geometry.navigation import NavGeometry
from biovln_ms.geometry.zones import PlacedInstrument
from biovln_ms.metrics.measures import EpisodeContext


class PrivilegedView:
    """One sub-env's episode as an oracle may see it."""

    __slots__ = ("_ctx", "_nav", "_pose", "_goal_mode", "_current", "_people")

    def __init__(
        self,
        ctx: EpisodeContext,
        nav: NavGeometry,
        pose: Callable[[], np.ndarray],
        goal_mode: str,
        current: Callable[[], int] | None = None,
        people: Callable[[], np.ndarray] | None = None,
    ) -> None:
        """``current``: the index, into ``ctx.goals``, of the goal asked for now (None: the first goal);
        ``people``: the (P, 2) centres of the people in the episode now (None: an env without people)."""
        self._ctx, self._nav, self._pose, self._goal_mode = ctx, nav, pose, goal_mode
        self._current, self._people = current, people

    def _now(self) -> tuple[np.ndarray, float, PlacedInstrument]:
        """(goal, success radius, target) of the goal asked for now."""
        return self._ctx.goals[0 if self._current is None else int(self._current())]

    @property
    def goal(self) -> np.ndarray:
        """The goal the task scores against (Eq. 1, or the centroid projection in the centroid variant)."""
        return np.array(self._now()[0], float)

    @property
    def goal_mode(self) -> str:
        return self._goal_mode

    @property
    def success_radius(self) -> float:
        return float(self._now()[1])

    @property
    def target(self) -> PlacedInstrument:
        """The target instrument (a frozen dataclass: Zone 1/2/3 polygons, face, centroid goal)."""
        return self._now()[2]

    @property
    def instruments(self) -> tuple[PlacedInstrument, ...]:
        return tuple(self._ctx.instruments)

    def geodesic_distance(self, a, b) -> float:
        return float(self._nav.geodesic_distance(np.asarray(a, float), np.asarray(b, float)))

    def shortest_path(self, a, b) -> list[np.ndarray]:
        return [
            np.array(p, float) for p in self._nav.shortest_path(np.asarray(a, float), np.asarray(b, float))
        ]

    def snap(self, p) -> np.ndarray:
        """The nearest navigable point."""
        return np.array(self._nav.snap(np.asarray(p, float)), float)

    def contains_free(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Which points (x, y) lie in the robot's free space."""
        import shapely

        return shapely.contains_xy(self._nav.free, x, y)

    def pose(self) -> np.ndarray:
        """The robot's true planar pose (x, y, yaw) in the world frame, now."""
        return np.array(self._pose(), float)

    def people(self) -> np.ndarray:
        """The (P, 2) centres of the people in the episode now (bodies of ``PERSON_RADIUS``); (0, 2) in
        an env without people."""
        return np.zeros((0, 2)) if self._people is None else np.array(self._people(), float).reshape(-1, 2)
