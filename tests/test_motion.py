"""Swept-motion checks (no tunnelling; ordinary contact untouched): pure geometry."""

import pytest
from shapely.geometry import box

from biovln_ms.geometry.motion import ALLOWANCE, SweptMotion

# two 4 x 4 m rooms joined along x = 4, separated by a 0.1 m-thick wall (the floor stops at x = 3.95 / 4.05)
FLOOR = box(0, 0, 3.95, 4).union(box(4.05, 0, 8, 4))
PILLAR = box(1.9, 3.0, 2.1, 3.2)
R = 0.2


@pytest.fixture(scope="module")
def m():
    return SweptMotion(FLOOR, [PILLAR], R)


def test_a_target_beyond_a_thin_wall_is_cut_where_the_path_meets_it(m):
    tx, ty = m.target(3.0, 1.0, 5.0, 1.0)  # would end in the other room
    assert (tx, ty) == pytest.approx((3.95 - (R - ALLOWANCE), 1.0), abs=1e-6)


def test_free_moves_and_pressing_into_a_wall_are_untouched(m):
    assert m.target(1.0, 1.0, 1.25, 1.0) == (1.25, 1.0)
    assert m.target(1.0, 0.5, 3.0, 0.5) == (3.0, 0.5)  # along the south wall, 0.5 m from it
    assert m.target(3.75, 1.0, 4.0, 1.0) == (
        4.0,
        1.0,
    )  # from contact, 0.25 m into the wall: the physics stops it


def test_a_path_through_an_instrument_is_cut(m):
    tx, ty = m.target(2.0, 2.0, 2.0, 4.0)  # straight through the pillar, free floor beyond it
    assert ty == pytest.approx(3.0 - (R - ALLOWANCE), abs=1e-6) and tx == pytest.approx(2.0)


def test_crossings_are_detected_and_contact_is_not(m):
    assert not m.crossed(1.0, 1.0, 1.25, 1.0)
    assert not m.crossed(3.6, 1.0, 3.75, 1.0)  # ends in contact with the wall
    assert m.crossed(3.75, 1.0, 4.3, 1.0)  # through the wall into the other room
    assert m.crossed(3.75, 1.0, 3.95, 1.0)  # deep inside the wall
    assert m.crossed(2.0, 2.75, 2.0, 3.45)  # through the pillar, out on its far side
    assert m.crossed(3.75, 1.0, 8.5, 1.0)  # out of the building


def test_the_kept_clearance_answers_as_the_polygon_tests_do():
    """Moves answered from a cell's kept distance to B (no polygon test) give what the polygon tests give:
    the kept value never exceeds the true distance (cell corners included), and random moves of every length
    in a generated suite, from everywhere on and off its floor, and moves just longer than it toward a thin
    wall are answered alike."""
    import math

    import numpy as np
    import shapely
    from shapely.geometry import Point

    from biovln_ms.geometry.motion import CLEAR_CELL
    from biovln_ms.scene.generator import generate_scene
    from biovln_ms.scene.rules import floor_polygon
    from biovln_ms.sim.footprints import collision_footprints

    spec = generate_scene("suite", 2)
    fast = SweptMotion(floor_polygon(spec), collision_footprints(spec), 0.3)
    exact = SweptMotion(floor_polygon(spec), collision_footprints(spec), 0.3)
    exact.room = lambda x, y: -np.inf  # every move through the polygon tests
    rng = np.random.default_rng(0)
    minx, miny, maxx, maxy = exact.core.bounds
    corners = np.floor(rng.uniform((minx, miny), (maxx, maxy), (500, 2)) / CLEAR_CELL) * CLEAR_CELL
    probes = np.concatenate([rng.uniform((minx, miny), (maxx, maxy), (2000, 2)), corners, corners + 1e-9])
    for x, y in probes.tolist():
        assert fast.room(x, y) <= shapely.distance(fast.blocked, Point(x, y))
    starts = rng.uniform((minx, miny), (maxx, maxy), (3000, 2))
    steps = rng.normal(0.0, 1.0, (3000, 2)) * rng.choice([0.05, 0.25, 1.0, 3.0], (3000, 1))
    answered = 0
    for (x, y), (dx, dy) in zip(starts.tolist(), steps.tolist()):
        assert fast.target(x, y, x + dx, y + dy) == exact.target(x, y, x + dx, y + dy)
        assert fast.crossed(x, y, x + dx, y + dy) == exact.crossed(x, y, x + dx, y + dy)
        answered += np.hypot(dx, dy) < fast.room(x, y)
    assert 300 < answered < 2700  # both ways taken
    # toward the thin wall of the two rooms, a move just longer than the kept room is tested exactly
    m, polygons = SweptMotion(FLOOR, [PILLAR], R), SweptMotion(FLOOR, [PILLAR], R)
    polygons.room = lambda x, y: -np.inf
    for x in np.linspace(2.0, 3.7, 40).tolist():
        far = max(m.room(x, 1.0), 0.0) + 0.5
        assert m.target(x, 1.0, x + far, 1.0) == polygons.target(x, 1.0, x + far, 1.0)
        assert m.crossed(x, 1.0, x + far, 1.0) == polygons.crossed(x, 1.0, x + far, 1.0)
    # no shortcut where B does not contain the obstacles, nor from a point that is not finite
    assert SweptMotion(FLOOR, [PILLAR], 0.05).room(1.0, 1.0) == -math.inf
    assert m.room(math.nan, 1.0) == -math.inf and m.room(math.inf, 1.0) == -math.inf
    assert SweptMotion(FLOOR, [PILLAR], 0.02).crossed(3.9, 1.0, 4.1, 1.0)  # through the wall
