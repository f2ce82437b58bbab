"""Measures of multi-goal protocol episodes (``BioVLN-Protocol-v0``), batched like
:mod:`biovln_ms.metrics.measures` (host arrays with a leading ``num_envs`` dimension, rows ``idx``).

An episode has K = 2-5 goals in visit order: the context's goal axis (``goals``, ``radii``, ``goal_ok``).
``subgoal_index`` is the goal asked for now. A STOP (MultiON's FOUND) is *correct* when the robot stands
within that goal's success radius r (``NavTaskConfig.subgoal_rule="radius"``, the paper's rule); with
``"strict"`` it must also stand in that goal's Zone 3 facing its operational face within 30 degrees
(``strict_success``'s rule). A correct STOP marks the goal reached and moves on to the next one; a STOP
anywhere else ends the episode (``wrong_stop="end"``) or marks the goal missed and moves on (``"miss"``).
The episode ends when every goal is reached or missed, at a wrong STOP under ``"end"``, or when its step
budget, ``steps_per_goal`` x K, is spent (``out_of_budget``).

Episode metrics (``info`` every step; final at the end):

* ``protocol_success``: every goal reached. ``progress``: goals reached / K.
* ``ppl``: progress x L / max(l, L), with l the path length and L the geodesic length of the whole ordered
  route start -> g1 -> ... -> gK (progress weighted by path length).
* ``stage_success``: per goal slot, reached (K of the ``MAX_VISITS`` slots are used); ``subgoal_status``: per
  slot -1 (no such goal), 0 pending, 1 reached, 2 missed.
* ``zone2_steps``: steps that ended with the robot's centre in some instrument's Zone 2 (the start pose is
  not a step). MCR, VRT, collisions, steps and path length are the single-goal measures, over the whole
  trajectory.
* ``protocol_reward``: Eq. 5 towards the current goal: (d_{t-1} - d_t) to the goal asked for before the step,
  - step penalty + success bonus per correct STOP - safety penalty; after a switch d is measured to the new
  goal, so the switch itself pays no progress.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from biovln_ms.constants import MAX_VISITS
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.zones import SAFETY_THRESHOLD
from biovln_ms.metrics.measures import (
    FRACTION,
    OUTCOME,
    Aggregate,
    BatchContext,
    EpisodeContext,
    Measure,
    Metric,
    _facing_face,
    _goal_distances,
    _in_zone3,
    _zone3_occupied,
    rate,
    register_measure,
)

WRONG_STOP = ("end", "miss")
SUBGOAL_RULES = ("radius", "strict")
NONE, PENDING, REACHED, MISSED = -1, 0, 1, 2  # subgoal_status values


class ProtocolConfigError(BioVLNError):
    """A protocol option of the task configuration is not one of its values."""


def check_protocol_options(wrong_stop: str, subgoal_rule: str, steps_per_goal: int) -> None:
    """One-line errors for the protocol fields of ``NavTaskConfig``."""
    if wrong_stop not in WRONG_STOP:
        raise ProtocolConfigError(
            f"unknown wrong_stop {wrong_stop!r}",
            field="wrong_stop",
            fix=f"use one of: {', '.join(WRONG_STOP)}",
        )
    if subgoal_rule not in SUBGOAL_RULES:
        raise ProtocolConfigError(
            f"unknown subgoal_rule {subgoal_rule!r}",
            field="subgoal_rule",
            fix=f"use one of: {', '.join(SUBGOAL_RULES)}",
        )
    if isinstance(steps_per_goal, bool) or not isinstance(steps_per_goal, int) or steps_per_goal < 1:
        raise ProtocolConfigError(
            f"steps_per_goal must be a positive integer, got {steps_per_goal!r}",
            field="steps_per_goal",
            fix="pass steps_per_goal=500 (the paper's single-goal budget) or another positive integer",
        )


@dataclass
class ProtocolEpisodeContext(EpisodeContext):
    """A protocol episode: ``goals`` are its K goals in visit order (``goal`` the first, ``other_goals`` the
    rest); ``goal_geodesics[j]`` is p -> geodesic distance to goal j; ``route_length`` is L."""

    goal_geodesics: tuple[Callable[[np.ndarray], float], ...] = ()
    route_length: float = 0.0


class ProtocolBatchContext(BatchContext):
    """:class:`BatchContext` plus each sub-env's number of goals K and route length L."""

    def __init__(self, n: int) -> None:
        super().__init__(n)
        self.num_goals = np.zeros(n, dtype=np.int64)
        self.route_length = np.zeros(n)

    def set(self, i: int, ctx: EpisodeContext) -> None:
        if not isinstance(ctx, ProtocolEpisodeContext):
            raise TypeError(f"sub-env {i}: a protocol batch needs a ProtocolEpisodeContext")
        super().set(i, ctx)
        self.num_goals[i], self.route_length[i] = len(ctx.goals), ctx.route_length


def _column(a: np.ndarray, col: np.ndarray) -> np.ndarray:
    """Row r's entry ``col[r]`` of (N, k) ``a``."""
    return a[np.arange(len(col)), col]


@register_measure
class SubgoalIndex(Measure):
    """The goal asked for now (0..K; K once every goal is reached or missed), and the goal-switching rule:
    per slot status, and this step's correct (``found``) and wrong STOP."""

    uuid = "subgoal_index"
    dtype = np.int64
    dependencies = ("stopped",)
    state_names = ("value", "status", "found", "wrong")

    def __init__(self, n, cfg):
        super().__init__(n, cfg)
        check_protocol_options(cfg.wrong_stop, cfg.subgoal_rule, cfg.steps_per_goal)
        self.status = np.full((n, MAX_VISITS), NONE, dtype=np.int64)
        self.found = np.zeros(n, dtype=bool)
        self.wrong = np.zeros(n, dtype=bool)

    def reset(self, ctx, s, m, idx):
        k = ctx.num_goals[idx]
        self.value[idx] = 0
        self.status[idx] = np.where(np.arange(MAX_VISITS) < k[:, None], PENDING, NONE)
        self.found[idx] = False
        self.wrong[idx] = False

    def update(self, ctx, s, m, idx):
        j, k = self.value[idx], ctx.num_goals[idx]
        col = np.minimum(j, k - 1)
        at = _column(_goal_distances(ctx, s, idx), col) <= _column(ctx.radii[idx], col)
        if self.cfg.subgoal_rule == "strict":  # strict_success's rule: with people, a free Zone 3 too
            at &= _column(_in_zone3(ctx, s, idx), col) & _column(_facing_face(ctx, s, idx, self.cfg), col)
            if s.people is not None and at.any():
                at &= ~_column(_zone3_occupied(ctx, s, idx), col)
        stop = m["stopped"][idx] & (j < k)
        found, wrong = stop & at, stop & ~at
        status = self.status[idx]
        rows = np.arange(len(j))
        status[rows[found], j[found]] = REACHED
        moved_on = found
        if self.cfg.wrong_stop == "miss":
            status[rows[wrong], j[wrong]] = MISSED
            moved_on = found | wrong
        self.status[idx] = status
        self.value[idx] = j + moved_on
        self.found[idx], self.wrong[idx] = found, wrong


class _FromSubgoal(Measure):
    """A view of :class:`SubgoalIndex`'s state, updated after it."""

    dependencies = ("subgoal_index",)

    def compute(self, ctx, s, m, idx):
        return self.view(m.measures["subgoal_index"], ctx, idx)

    def view(self, core: SubgoalIndex, ctx: ProtocolBatchContext, idx) -> np.ndarray:
        raise NotImplementedError


@register_measure
class NumGoals(Measure):
    """K, the episode's number of goals."""

    uuid = "num_goals"
    dtype = np.int64

    def compute(self, ctx, s, m, idx):
        return ctx.num_goals[idx]


@register_measure
class SubgoalStatus(_FromSubgoal):
    """Per goal slot: -1 no such goal, 0 pending, 1 reached, 2 missed."""

    uuid = "subgoal_status"
    metric = Metric("subgoal_status", required=False)
    dtype = np.int64
    shape = (MAX_VISITS,)

    def view(self, core, ctx, idx):
        return core.status[idx]


@register_measure
class StageSuccess(_FromSubgoal):
    """Per goal slot: reached by a correct STOP (per-stage success)."""

    uuid = "stage_success"
    metric = Metric(
        "stage_success",
        required=False,
        aggregates=(
            Aggregate(
                "stage_sr",
                "stage SR",
                "% of the episodes with that many goals",
                "stages",
                scale=100.0,
                count="stage_episodes",
            ),
        ),
    )
    dtype = bool
    shape = (MAX_VISITS,)

    def view(self, core, ctx, idx):
        return core.status[idx] == REACHED


@register_measure
class SubgoalFound(_FromSubgoal):
    """A correct STOP this step (MultiON's FOUND at the current goal)."""

    uuid = "subgoal_found"
    metric = Metric("found_at", at="steps", required=False)
    dtype = bool

    def view(self, core, ctx, idx):
        return core.found[idx]


@register_measure
class WrongStop(_FromSubgoal):
    """A STOP away from the current goal this step."""

    uuid = "wrong_stop"
    metric = Metric(
        "wrong_stops",
        at="count",
        required=False,
        aggregates=(Aggregate("wrong_stops", "wrong STOPs", "per episode", bounds=None, missing=0.0),),
    )
    dtype = bool

    def view(self, core, ctx, idx):
        return core.wrong[idx]


def _current_column(ctx: BatchContext, m, idx) -> np.ndarray:
    """The goal slot now asked for (the last goal once all are done)."""
    return np.minimum(m["subgoal_index"][idx], ctx.num_goals[idx] - 1)


@register_measure
class SubgoalPosition(Measure):
    """The current goal (x, y) in the world frame: the pointgoal sensors' goal and the logs'."""

    uuid = "subgoal_position"
    shape = (2,)
    exact_info = True
    dependencies = ("subgoal_index",)

    def compute(self, ctx, s, m, idx):
        col = _current_column(ctx, m, idx)
        return ctx.goals[idx][np.arange(len(col)), col]


@register_measure
class DistanceToSubgoal(Measure):
    """Euclidean distance to the current goal."""

    uuid = "distance_to_subgoal"
    dependencies = ("subgoal_index",)

    def compute(self, ctx, s, m, idx):
        return _column(_goal_distances(ctx, s, idx), _current_column(ctx, m, idx))


@register_measure
class GeodesicDistanceToSubgoal(Measure):
    """Geodesic distance to the current goal, queried again only where the position or the goal changed."""

    uuid = "geodesic_distance_to_subgoal"
    dependencies = ("subgoal_index",)
    state_names = ("value", "at", "goal")

    def __init__(self, n, cfg):
        super().__init__(n, cfg)
        self.at = np.full((n, 2), math.nan)
        self.goal = np.full(n, -1, dtype=np.int64)

    def reset(self, ctx, s, m, idx):
        self.at[idx] = math.nan
        self.update(ctx, s, m, idx)

    def update(self, ctx, s, m, idx):
        col, pos, at = _current_column(ctx, m, idx), s.position[idx], self.at[idx]
        changed = (pos[:, 0] != at[:, 0]) | (pos[:, 1] != at[:, 1]) | (col != self.goal[idx])
        todo = np.arange(ctx.n)[idx][changed]
        for i, j in zip(todo.tolist(), col[changed].tolist()):
            self.value[i] = ctx.episode(i).goal_geodesics[j](s.position[i])
        self.at[todo], self.goal[todo] = s.position[todo], col[changed]


@register_measure
class ProtocolSuccess(_FromSubgoal):
    """Every goal reached by a correct STOP."""

    uuid = "protocol_success"
    metric = Metric(OUTCOME, aggregates=(rate("sr", "SR", unit="% (every goal reached)", count="successes"),))
    dtype = bool

    def view(self, core, ctx, idx):
        return (core.status[idx] == REACHED).sum(axis=1) == ctx.num_goals[idx]


@register_measure
class Progress(_FromSubgoal):
    """The fraction of the episode's goals reached."""

    uuid = "progress"
    metric = Metric(
        "progress",
        aggregates=(
            Aggregate(
                "progress", "progress", "fraction of goals reached, in [0, 1]", over="all", bounds=(0.0, 1.0)
            ),
        ),
    )

    def view(self, core, ctx, idx):
        return (core.status[idx] == REACHED).sum(axis=1) / ctx.num_goals[idx]


@register_measure
class StepBudget(Measure):
    """The episode's step budget: ``steps_per_goal`` x K."""

    uuid = "step_budget"
    dtype = np.int64

    def compute(self, ctx, s, m, idx):
        return self.cfg.step_budget(ctx.num_goals[idx])


@register_measure
class OutOfBudget(Measure):
    """The step budget is spent with goals still pending."""

    uuid = "out_of_budget"
    metric = Metric(
        "out_of_budget",
        required=False,
        aggregates=(
            Aggregate(
                "out_of_budget", "out of budget", "% of episodes", scale=100.0, bounds=None, missing=0.0
            ),
        ),
    )
    dtype = bool
    dependencies = ("steps", "step_budget", "subgoal_index")

    def compute(self, ctx, s, m, idx):
        return (m["steps"][idx] >= m["step_budget"][idx]) & (m["subgoal_index"][idx] < ctx.num_goals[idx])


@register_measure
class ProtocolFail(Measure):
    """The episode ended without success: a wrong STOP under ``wrong_stop="end"``, every goal done with a
    miss among them, or the step budget spent."""

    uuid = "protocol_fail"
    dtype = bool
    dependencies = ("wrong_stop", "subgoal_index", "protocol_success", "out_of_budget")

    def compute(self, ctx, s, m, idx):
        done = m["subgoal_index"][idx] >= ctx.num_goals[idx]
        fail = (done & ~m["protocol_success"][idx]) | m["out_of_budget"][idx]
        if self.cfg.wrong_stop == "end":
            fail |= m["wrong_stop"][idx]
        return fail


@register_measure
class PPL(Measure):
    """Progress weighted by path length: progress x L / max(l, L), L the ordered route's geodesic length."""

    uuid = "ppl"
    metric = Metric("ppl", aggregates=(Aggregate("ppl", "PPL", FRACTION, over="all", bounds=(0.0, 1.0)),))
    dependencies = ("progress", "path_length")

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0.0

    def compute(self, ctx, s, m, idx):
        route = ctx.route_length[idx]
        return m["progress"][idx] * route / np.maximum(np.maximum(m["path_length"][idx], route), 1e-9)


@register_measure
class Zone2Steps(Measure):
    """Steps that ended with the robot's centre inside some instrument's Zone 2."""

    uuid = "zone2_steps"
    metric = Metric(
        "zone2_steps", aggregates=(Aggregate("zone2_steps", "Zone-2 steps", "steps per episode"),)
    )
    dtype = np.int64
    dependencies = ("zone2_violation",)

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0

    def update(self, ctx, s, m, idx):
        self.value[idx] += m["zone2_violation"][idx]


@register_measure
class ProtocolReward(Measure):
    """Eq. 5 towards the current goal, the success bonus paid at each correct STOP (see the module)."""

    uuid = "protocol_reward"
    dependencies = ("subgoal_index", "distance_to_subgoal", "subgoal_found", "clearance")
    state_names = ("value", "previous_distance", "previous_goal")

    def __init__(self, n, cfg):
        super().__init__(n, cfg)
        self.previous_distance = np.zeros(n)
        self.previous_goal = np.zeros(n, dtype=np.int64)

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0.0
        self.previous_distance[idx] = m["distance_to_subgoal"][idx]
        self.previous_goal[idx] = _current_column(ctx, m, idx)

    def update(self, ctx, s, m, idx):
        c = self.cfg
        before = _column(_goal_distances(ctx, s, idx), self.previous_goal[idx])  # to the goal asked before
        clearance = m["clearance"][idx]
        scale = (1.0 - clearance / SAFETY_THRESHOLD) if c.proportional_safety else 1.0
        safety = np.where(clearance < SAFETY_THRESHOLD, c.safety_penalty * scale, 0.0)
        self.value[idx] = (
            (self.previous_distance[idx] - before)
            - c.step_penalty
            + c.success_bonus * m["subgoal_found"][idx]
            - safety
        )
        self.previous_distance[idx] = m["distance_to_subgoal"][idx]
        self.previous_goal[idx] = _current_column(ctx, m, idx)
