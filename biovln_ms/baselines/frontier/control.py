"""The frontier baseline's controller: follows the planner's path with the discrete actions (paper §4.3).

Each step it re-plans when due (every ``replan_every`` steps, when the path ran out, when an
exploration target is reached, or after a blocked move), turns toward the next waypoint when the
heading error exceeds half a turn and otherwise moves forward. A FORWARD that did not move marks an
obstacle just ahead (contact the depth map missed, e.g. a low object). With no path it turns left
to look around, banning an unreachable frontier, and gives up with STOP after ``stuck_turns`` steps.

On a map that forgets what moves (people in the lab), a FORWARD whose end would put the robot's body on an
obstacle cell (someone who stepped into the path since the plan) re-plans at once. When the new plan's step
does too, it turns aside if one turn either way gives a step that passes and gains on the path, then takes
that step; else it waits (a turn). The planner grows obstacles as a diamond (4-connected steps), which lets
a diagonal path pass a wall's corner nearer than this check allows: after ``wait_limit`` waits in a row the
plans grow obstacles by a disc for the next ``wait_limit`` FORWARDs, so that a path it can follow is found
(or, for a person who stands on, a way round them). Boxed in (the planner's escape growth), every step out
passes nearer than the check allows: after ``wait_limit`` waits it follows the escape plan without the
check until a plan has the full growth again; a person within reach then is touched (a person collision).

STOP rule (towards a target to stop at, mode "goal"): STOP within half a step of it, or, with the
target in sight (at most two waypoints left), when a forward step would not bring it closer.
"""

from __future__ import annotations

import math

import numpy as np

from biovln_ms.baselines.frontier.occupancy import OCCUPIED, OccupancyMap
from biovln_ms.baselines.frontier.params import FrontierParams
from biovln_ms.baselines.frontier.planner import FrontierPlanner, Plan
from biovln_ms.baselines.policy import FORWARD, STOP, TURN_LEFT, TURN_RIGHT


def heading(yaw: float) -> np.ndarray:
    """The unit ground vector of heading ``yaw``."""
    return np.array([math.cos(yaw), math.sin(yaw)])


class FrontierController:
    """Turns plans into actions; ``plan`` is the current one (mode, target, remaining waypoints)."""

    def __init__(
        self,
        params: FrontierParams,
        step_len: float,
        turn: float,
        occ_map: OccupancyMap,
        planner: FrontierPlanner,
    ) -> None:
        """``step_len``: m per FORWARD; ``turn``: radians per TURN_LEFT / TURN_RIGHT."""
        self.params, self.step_len, self.turn = params, step_len, turn
        self.occ_map, self.planner = occ_map, planner
        self.plan: Plan | None = None
        self._since_plan = 0
        self._replan_now = True
        self._last: tuple[np.ndarray, int] | None = None  # position and action of the previous step
        self._stuck = 0
        self._waits = 0  # consecutive waits for something in the way
        self._round_left = 0  # FORWARDs left before plans grow obstacles as a diamond again
        self._dodge = False  # the last step turned aside to pass something in the way
        self._squeeze = False  # boxed in after a long wait: follow the plan without the people check

    @property
    def target(self) -> np.ndarray | None:
        return None if self.plan is None else self.plan.target

    @property
    def last_action(self) -> int | None:
        """The action of the previous step (None before the first)."""
        return None if self._last is None else self._last[1]

    def act(self, pose: np.ndarray) -> int:
        """The action at ``pose`` (x, y, yaw)."""
        p, yaw = pose[:2], float(pose[2])
        dodge, self._dodge = self._dodge, False  # a turn aside last step asks for the step that passes
        if self._blocked(p):  # contact the map missed: mark it and re-plan
            self.occ_map.mark_occupied(p + (self.params.robot_radius + self.occ_map.res) * heading(yaw))
            self._replan_now = True
        plan = self.plan
        if plan is not None and plan.mode == "goal" and np.linalg.norm(plan.target - p) < self.step_len / 2:
            return self.record(p, STOP)
        if self._replan_due(p):
            self.plan = self.planner.plan(self.occ_map, pose)
            self._since_plan, self._replan_now = 0, False
        self._since_plan += 1
        if not self.plan.path:
            if self.plan.mode == "explore":
                self.planner.ban(self.plan.target)
            self._stuck += 1
            return self.record(p, TURN_LEFT if self._stuck < self.params.stuck_turns else STOP)
        self._stuck = 0
        if dodge and self._clear_ahead(p, yaw):
            return self.record(p, FORWARD)
        action = self._follow(p, yaw)
        self._squeeze &= self.plan.boxed  # until a plan with the full growth
        if action == FORWARD and self.occ_map.forget and not self._squeeze and self._step_hits(p, yaw):
            self.plan = self.planner.plan(self.occ_map, pose)  # something moved into the way: re-plan
            self._since_plan = 1
            action = self._follow(p, yaw) if self.plan.path else TURN_LEFT
            if action == FORWARD and self._step_hits(p, yaw):
                aside = self._aside(p, yaw)
                if aside is not None:  # a turn aside, then a step that passes it
                    self._dodge = True
                    return self.record(p, aside)
                action = TURN_LEFT  # still in the way: wait for it to move on
                self._waits += 1
                if self._waits >= self.params.wait_limit and self.plan.boxed:
                    self._squeeze, self._waits = True, 0  # boxed in, waited long: squeeze out along the plan
                elif self._waits >= self.params.wait_limit:  # waited long: plan with round growth a while
                    self.planner.round_growth, self._replan_now = True, True
                    self._waits, self._round_left = 0, self.params.wait_limit
        return self.record(p, action)

    def _step_hits(self, p: np.ndarray, yaw: float) -> bool:
        """A FORWARD's end puts the robot's body on an obstacle cell (a person's figure: their body reaches
        ``people_margin`` beyond it, and a noisy step may land ``noise_margin`` aside), or, on an evidence map
        (noisy depth), on an obstacle point of the last frame: a cell needs several frames of evidence, and a
        person walking up is there at once."""
        reach = self.params.robot_radius + self.params.people_margin + self.params.noise_margin
        end = p + self.step_len * heading(yaw)
        cells = self.occ_map.disc_cells(end, reach)
        if (self.occ_map.grid[cells[:, 0], cells[:, 1]] == OCCUPIED).any():
            return True
        if self.occ_map.log_odds is None:  # every obstacle point seen is an obstacle cell already
            return False
        near = self.occ_map.last_hits - end  # with evidence: what the last frame saw there counts too
        return bool(((near * near).sum(axis=1) < reach * reach).any())

    def _clear_ahead(self, p: np.ndarray, yaw: float) -> bool:
        """A FORWARD at ``yaw`` hits nothing and brings the robot nearer the path a little way on."""
        path = self.plan.path
        if not path:
            return False
        ahead = path[min(len(path) - 1, round(2 * self.step_len / self.occ_map.res))]
        end = p + self.step_len * heading(yaw)
        return not self._step_hits(p, yaw) and np.linalg.norm(ahead - end) < np.linalg.norm(ahead - p)

    def _aside(self, p: np.ndarray, yaw: float) -> int | None:
        """TURN_LEFT or TURN_RIGHT when, one turn that way, a FORWARD would pass (:meth:`_clear_ahead`)."""
        for action, sign in ((TURN_LEFT, 1.0), (TURN_RIGHT, -1.0)):
            if self._clear_ahead(p, yaw + sign * self.turn):
                return action
        return None

    def record(self, p: np.ndarray, action: int) -> int:
        """Remember the step's position and action (to detect a blocked move next step); returns it. A FORWARD
        ends a run of waits and counts down the round growth."""
        if action == FORWARD:
            self._waits = 0
            if self._round_left > 0:
                self._round_left -= 1
                self.planner.round_growth = self._round_left > 0
        self._last = (p.copy(), action)
        return action

    def _blocked(self, p: np.ndarray) -> bool:
        return (
            self._last is not None
            and self._last[1] == FORWARD
            and np.linalg.norm(p - self._last[0]) < self.params.blocked_move
        )

    def _replan_due(self, p: np.ndarray) -> bool:
        plan = self.plan
        return (
            self._replan_now
            or self._since_plan >= self.params.replan_every
            or not plan.path
            or (plan.mode == "explore" and np.linalg.norm(plan.target - p) < self.params.waypoint_reach)
        )

    def _follow(self, p: np.ndarray, yaw: float) -> int:
        """Pass the waypoints reached (keeping the last), then turn toward the next or move forward."""
        path = self.plan.path
        while len(path) > 1 and np.linalg.norm(path[0] - p) < self.params.waypoint_reach:
            path.pop(0)
        wp = path[0]
        err = (math.atan2(wp[1] - p[1], wp[0] - p[0]) - yaw + math.pi) % (2 * math.pi) - math.pi
        if abs(err) > self.turn / 2:
            return TURN_LEFT if err > 0 else TURN_RIGHT
        if self.plan.mode == "goal" and len(path) <= 2:
            d = np.linalg.norm(self.plan.target - p)
            if np.linalg.norm(self.plan.target - (p + self.step_len * heading(yaw))) >= d:
                return STOP
        return FORWARD
