"""Baselines that cope with people, on synthetic inputs (no simulator): the frontier map forgets what moves
only with people, its controller steps round what stands in the way or waits and then plans with round
growth, the oracles' guard waits for a person in the way and for a free face, and the privileged view reads
the people read-only."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import shapely
from shapely.geometry import box

from biovln_ms.baselines.frontier import OCCUPIED, FrontierParams, OccupancyMap
from biovln_ms.baselines.frontier import forgets, sideways_spread
from biovln_ms.baselines.frontier.control import FrontierController
from biovln_ms.baselines.frontier.planner import Plan, PlanField
from biovln_ms.baselines.oracle import PeopleGuard
from biovln_ms.baselines.policy import FORWARD, STOP, TURN_LEFT, TURN_RIGHT
from biovln_ms.noise import resolve_noise
from biovln_ms.people.body import PERSON_RADIUS
from tests.test_frontier_units import PARAMS, TASK, FixedPlanner, _extrinsic, _grid, _intrinsic, _render


def _wall_cells(m: OccupancyMap, x: float) -> int:
    """Obstacle cells of the map's column at world ``x`` (within 0.5 m of the camera's line of sight)."""
    rows = m.cell(np.stack([np.full(21, x), np.linspace(-0.5, 0.5, 21)], axis=1))
    return int((m.grid[rows[:, 0], rows[:, 1]] == OCCUPIED).sum())


def test_the_map_forgets_what_moved_only_when_asked():
    pose = (0.0, 0.0, 0.0)
    maps = {forget: OccupancyMap((0.0, 0.0), 0.05, 20.0, forget=forget) for forget in (False, True)}
    for m in maps.values():
        m.integrate(_render(pose, 1.5)[0], _intrinsic(), _extrinsic(pose))  # someone 1.5 m ahead
        assert _wall_cells(m, 1.5) > 10
        m.integrate(_render(pose, 4.0)[0], _intrinsic(), _extrinsic(pose))  # ... gone: the wall behind
        assert _wall_cells(m, 4.0) > 10
    assert _wall_cells(maps[False], 1.5) > 10  # the paper's map: an obstacle for ever
    assert _wall_cells(maps[True], 1.5) == 0  # seen through: free again


def test_the_map_forgets_with_people_unless_told():
    assert not forgets(FrontierParams(), TASK) and forgets(FrontierParams(), replace(TASK, people=2))
    assert not forgets(FrontierParams(forget=False), replace(TASK, people=2))


def _forgetting_controller(obstacles, boxed: bool = False) -> tuple[FrontierController, FixedPlanner]:
    """A controller on a map that forgets, with obstacle cells at world ``obstacles`` and a fixed plan
    straight east to (2.5, 0) (``boxed``: made while boxed in)."""
    m = OccupancyMap((0.0, 0.0), 0.05, 20.0, forget=True)
    for xy in obstacles:
        m.mark_occupied(xy)
    planner = FixedPlanner(Plan("explore", np.array([2.5, 0.0]), [np.array([2.5, 0.0])], boxed))
    planner.round_growth = False
    return FrontierController(PARAMS, 0.25, math.radians(30), m, planner), planner


def test_the_frontier_controller_turns_aside_and_steps_past_what_stands_in_the_way():
    ctl, planner = _forgetting_controller([(0.45, -0.15)])  # ahead and a little right of the path
    assert ctl.act(np.zeros(3)) == TURN_LEFT and planner.calls == 2  # the step hits: re-planned, then aside
    assert ctl.act(np.array([0.0, 0.0, math.radians(30)])) == FORWARD  # the step that passes it


def test_the_frontier_controller_waits_then_plans_with_round_growth_for_a_while():
    wall = [(0.45, y) for y in np.arange(-0.6, 0.61, 0.05)]  # across the way: no step passes
    ctl, planner = _forgetting_controller(wall)
    actions = []
    for k in range(2 * PARAMS.wait_limit):  # a wait turns left, the next step turns back
        actions.append(ctl.act(np.array([0.0, 0.0, 0.0 if k % 2 == 0 else math.radians(30)])))
    assert actions == [TURN_LEFT, TURN_RIGHT] * PARAMS.wait_limit
    assert planner.round_growth  # waited long: the next plans grow obstacles by a disc
    ctl.occ_map.grid[:] = 0  # the way is free again
    for k in range(PARAMS.wait_limit):
        assert planner.round_growth
        assert ctl.act(np.array([0.25 * k, 0.0, 0.0])) == FORWARD
    assert not planner.round_growth  # ... for wait_limit FORWARDs


def test_a_boxed_in_frontier_controller_squeezes_out_after_a_long_wait():
    wall = [(0.45, y) for y in np.arange(-0.6, 0.61, 0.05)]
    ctl, planner = _forgetting_controller(wall, boxed=True)  # the plan of a robot boxed in
    actions = [
        ctl.act(np.array([0.0, 0.0, 0.0 if k % 2 == 0 else math.radians(30)]))
        for k in range(2 * PARAMS.wait_limit)
    ]
    assert actions == [TURN_LEFT, TURN_RIGHT] * PARAMS.wait_limit and not planner.round_growth
    assert ctl.act(np.zeros(3)) == FORWARD  # squeezes out along the escape plan, check off
    planner.fixed = planner.fixed._replace(boxed=False)  # out: a plan with the full growth
    ctl._replan_now = True
    assert ctl.act(np.array([0.25, 0.0, 0.0])) == TURN_LEFT  # the check is back


def test_on_an_evidence_map_the_last_frames_points_count_and_a_noisy_robot_keeps_further():
    m = OccupancyMap((0.0, 0.0), 0.05, 20.0, evidence=True, forget=True)
    m.last_hits = np.array([[0.5, 0.0]])  # seen once: no obstacle cell yet
    planner = FixedPlanner(
        Plan("explore", np.array([2.5, 0.0]), [np.array([2.5, 0.0])], PARAMS.inflate_cells)
    )
    ctl = FrontierController(PARAMS, 0.25, math.radians(30), m, planner)
    assert not (m.grid == OCCUPIED).any() and ctl.act(np.zeros(3)) != FORWARD
    m.last_hits = np.array([[0.65, 0.0]])  # 0.4 m beyond the step's end: clear, unless the step is noisy
    assert ctl.act(np.zeros(3)) == FORWARD
    noisy = replace(PARAMS, noise_margin=sideways_spread(resolve_noise("realistic")))
    assert (
        noisy.noise_margin == pytest.approx(0.173, abs=1e-3) and sideways_spread(resolve_noise("ideal")) == 0
    )
    ctl = FrontierController(noisy, 0.25, math.radians(30), m, planner)
    assert ctl.act(np.zeros(3)) != FORWARD


def test_round_growth_reaches_as_far_diagonally_as_straight_on():
    m = _grid(free=[(180, 220, 180, 220)], occupied=[(200, 201, 200, 201)])
    grow = PARAMS.inflate_cells  # 7 four-connected steps: diagonally the diamond reaches (3, 4) cells
    diamond = PlanField.compute(m, np.array([0.9, 0.9]), grow)
    disc = PlanField.compute(m, np.array([0.9, 0.9]), grow, round_growth=True)  # a disc of 8 cells
    for dr, dc in ((4, 4), (grow + 1, 0)):  # 0.28 m diagonally, 0.4 m straight on
        r, c = np.array([200 + dr, 200 + dc]) - diamond.lo
        assert diamond.trav[r, c] and not disc.trav[r, c]


class _View:
    """A privileged view's pose and people (what the guard reads)."""

    def __init__(self, pose, people) -> None:
        self._pose, self._people = np.asarray(pose, float), np.asarray(people, float).reshape(-1, 2)

    def pose(self) -> np.ndarray:
        return self._pose.copy()

    def people(self) -> np.ndarray:
        return self._people.copy()


ZONE = box(2.0, -0.3, 2.6, 0.3)  # the goal's Zone 3


def test_the_guard_waits_for_a_person_ahead_and_goes_on_when_they_left():
    gap = PERSON_RADIUS + TASK.robot_radius
    view = _View((0.0, 0.0, 0.0), [(gap + 0.3, 0.0)])  # a FORWARD would come within 0.05 m
    guard = PeopleGuard(view, TASK, ZONE)
    waits = [guard.check(FORWARD) for _ in range(4)]
    assert waits == [TURN_LEFT, TURN_RIGHT, TURN_LEFT, TURN_RIGHT] and guard.waits == 4
    view._people = np.array([[gap + 0.3, 2.0]])  # they walked on
    assert guard.check(FORWARD) == FORWARD
    view._people = np.array([[-0.6, 0.0]])  # behind the robot: a FORWARD moves away
    assert guard.check(FORWARD) == FORWARD
    assert guard.check(TURN_LEFT) == TURN_LEFT  # turns are never held


def test_the_guard_holds_a_stop_at_an_occupied_face_and_turns_back_first():
    view = _View((2.3, 0.5, -math.pi / 2), [(2.3, -0.1)])  # a person standing in the Zone 3
    guard = PeopleGuard(view, TASK, ZONE)
    assert guard.check(STOP) == TURN_LEFT
    view._people = np.array([[5.0, 5.0]])  # the face is free: first the turn back, then the STOP
    assert guard.check(STOP) == TURN_RIGHT and guard.check(STOP) == STOP
    near = ZONE.exterior.distance(shapely.Point(2.3, -0.3 - PERSON_RADIUS + 0.01))
    assert near < PERSON_RADIUS  # a body overlapping the edge counts
    view._people = np.array([[2.3, -0.3 - PERSON_RADIUS + 0.01]])
    assert guard.occupied()


def test_without_people_the_guard_changes_nothing():
    guard = PeopleGuard(_View((0.0, 0.0, 0.0), []), TASK, ZONE)
    assert [guard.check(a) for a in (FORWARD, STOP, TURN_LEFT)] == [FORWARD, STOP, TURN_LEFT]

    class NoPeople:  # a view without the accessor (another privileged view)
        def pose(self):
            return np.zeros(3)

    assert PeopleGuard(NoPeople(), TASK, ZONE).check(FORWARD) == FORWARD


def test_the_privileged_view_reads_people_as_copies():
    from biovln_ms.tasks.privileged import PrivilegedView

    crowd = np.array([[1.0, 2.0], [3.0, 4.0]])
    assert PrivilegedView(None, None, lambda: np.zeros(3), "opface").people().shape == (0, 2)
    view = PrivilegedView(None, None, lambda: np.zeros(3), "opface", people=lambda: crowd)
    seen = view.people()
    seen[0, 0] = 99.0
    assert crowd[0, 0] == 1.0 and view.people().tolist() == crowd.tolist()


def test_a_robot_that_drifted_against_someone_steps_away():
    """Actuation noise moves a turning robot: within RETREAT_GAP of a person it steps away, not turns on."""
    from biovln_ms.baselines.oracle import RETREAT_GAP

    touching = PERSON_RADIUS + TASK.robot_radius + RETREAT_GAP / 2
    away = _View((0.0, 0.0, 0.0), [(-touching, 0.0)])  # the person behind: FORWARD leads away
    assert PeopleGuard(away, TASK, ZONE).check(TURN_RIGHT) == FORWARD
    toward = _View((0.0, 0.0, math.pi), [(-touching, 0.0)])  # facing them: turn until it faces away
    guard = PeopleGuard(toward, TASK, ZONE)
    assert guard.check(FORWARD) == TURN_LEFT and guard.check(TURN_RIGHT) == TURN_LEFT
    assert guard.check(STOP) == STOP  # a STOP at a free face is never held
