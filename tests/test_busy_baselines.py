"""Baselines that cope with people, on synthetic inputs (no simulator): the frontier map forgets what moves
only with people, the oracles' guard waits for a person in the way and for a free face, and the privileged
view reads the people read-only."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import shapely
from shapely.geometry import box

from biovln_ms.baselines.frontier import OCCUPIED, FrontierParams, OccupancyMap
from biovln_ms.baselines.frontier import forgets
from biovln_ms.baselines.oracle import PeopleGuard
from biovln_ms.baselines.policy import FORWARD, STOP, TURN_LEFT, TURN_RIGHT
from biovln_ms.people.body import PERSON_RADIUS
from tests.test_frontier_units import TASK, _extrinsic, _intrinsic, _render


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
