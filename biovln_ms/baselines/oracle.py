"""Oracle: follows the exact geodesic shortest path to the navmesh-snapped goal and stops there.

With 0.25 m steps and 30 deg turns it cannot always land inside the success radius (paper §4.3), so
it is an empirical upper bound, not 100 %. Rule: STOP when the goal is nearer than half a step or,
once the goal is in sight (the rest of the path is one straight segment), when a forward step would
not bring it closer; otherwise turn toward the next path vertex when the heading error exceeds half a
turn, else move forward. A blocked forward move turns it aside once.

With people (the privileged view's :meth:`people`), both oracles wait rather than bump into anyone or STOP
at an occupied face (:class:`PeopleGuard`): a FORWARD that would bring the robot's body within
:data:`PERSON_GAP` of a person's, or a STOP while a person's body is in the goal's Zone 3, becomes a
wait (a turn one way, then back). People step aside or walk on; the oracle goes on when they have. A
waiting robot that drifted within :data:`RETREAT_GAP` of someone (actuation noise moves it as it turns)
steps away: FORWARD when that leads away from everyone near and stays in the free space, else a turn.
"""

from __future__ import annotations

import math

import numpy as np

from biovln_ms.baselines.policy import FORWARD, STOP, TURN_LEFT, TURN_RIGHT, EpisodeInfo, Policy
from biovln_ms.people.body import PERSON_RADIUS, overlaps_zone

#: m kept between the robot's body and a person's by a FORWARD of the oracles
PERSON_GAP = 0.15
#: m: a waiting robot nearer a person's body than this (actuation noise moves it as it turns) steps away
RETREAT_GAP = 0.05


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

    def sent(self, action: int) -> None:
        """The action sent instead of the one :meth:`step` returned (a wait is no blocked move)."""
        if self._last is not None:
            self._last = (self._last[0], action)


class PeopleGuard:
    """Turns a follower's action into a wait where people are in the way: a FORWARD toward a person's
    body, or a STOP with a person in the goal's Zone 3 (``zone``: that polygon, None: no face to keep
    free). Waiting alternates TURN_LEFT and TURN_RIGHT, so every second step the heading is back."""

    def __init__(self, view, task, zone=None) -> None:
        self.view, self.step_len = view, task.forward_step
        self.people = getattr(view, "people", lambda: np.zeros((0, 2)))  # a view without people: none
        self.contact = PERSON_RADIUS + task.robot_radius + PERSON_GAP
        self.zone, self.waits = zone, 0
        self._turned = False  # the last wait turned left: the next turns back

    def occupied(self) -> bool:
        """A person's body overlaps the goal's Zone 3."""
        if self.zone is None:
            return False
        return overlaps_zone(self.zone, self.people())

    def _gaps(self, xy: np.ndarray) -> np.ndarray:
        """m from a robot body centred at ``xy`` to each person's body."""
        return np.linalg.norm(self.people() - xy, axis=1) - (self.contact - PERSON_GAP)

    def _too_close(self) -> bool:
        people = self.people()
        return bool(len(people)) and bool(self._gaps(self.view.pose()[:2]).min() < RETREAT_GAP)

    def _away(self) -> bool:
        """A FORWARD now leads away from everyone within a metre and ends in the free space."""
        pose = self.view.pose()
        ahead = pose[:2] + self.step_len * np.array([math.cos(pose[2]), math.sin(pose[2])])
        now, then = self._gaps(pose[:2]), self._gaps(ahead)
        near = now < 1.0
        free = getattr(self.view, "contains_free", None)
        inside = free is None or bool(free(ahead[:1], ahead[1:])[0])
        return inside and bool((then[near] > now[near]).all())

    def blocked(self) -> bool:
        """A FORWARD from the pose now would come within the gap of a person's body (and closer)."""
        people = self.people()
        if not len(people):
            return False
        pose = self.view.pose()
        ahead = pose[:2] + self.step_len * np.array([math.cos(pose[2]), math.sin(pose[2])])
        near, now = (np.linalg.norm(people - q, axis=1) for q in (ahead, pose[:2]))
        return bool(((near < self.contact) & (near < now)).any())

    def check(self, action: int) -> int:
        """``action``, or a wait."""
        if action != STOP and self._too_close():  # drifted into someone's way: step away first
            self.waits += 1
            self._turned = False
            return FORWARD if self._away() else TURN_LEFT
        wait = (action == FORWARD and self.blocked()) or (action == STOP and self.occupied())
        if not wait and not self._turned:
            return action
        self.waits += wait
        self._turned = not self._turned  # a wait, or the turn back after one
        return TURN_LEFT if self._turned else TURN_RIGHT


class OraclePolicy(Policy):
    """Privileged: reads the goal, geodesics and its pose from ``EpisodeInfo.privileged``."""

    name = "oracle"
    obs_mode = "none"

    def reset(self, episode_info: EpisodeInfo) -> None:
        view = episode_info.privileged
        goal = view.goal if view.goal_mode == "opface" else view.snap(view.goal)
        self.follower = PointFollower(view, episode_info.task, goal)
        zone = view.target.zone3() if view.target.model_face is not None else None
        self.guard = PeopleGuard(view, episode_info.task, zone)

    def act(self, obs, info: dict) -> int:
        a = self.guard.check(self.follower.step())
        self.follower.sent(a)
        return a
