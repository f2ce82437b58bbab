"""Measures against hand-built trajectories (pure geometry, no simulator)."""

import math

import numpy as np
import pytest

from biovln_ms.geometry.zones import PlacedInstrument
from biovln_ms.metrics.measures import EpisodeContext, MeasureSet, StepState

# A 1 x 1 m instrument at the origin facing -Y; its Zone 3 (delta 0.6) is y in [-1.1, -0.5].
BOX = PlacedInstrument((0.0, 0.0, 0.5), 0.0, (1.0, 1.0, 1.0), (0.0, -1.0), 0.5, 0.6, "box_0", "cabinet")


def ctx(goal=(0.0, -1.1), radius=0.8, start_geodesic=4.0):
    g = np.asarray(goal)
    return EpisodeContext(goal=g, success_radius=radius, target=BOX, instruments=[BOX],
                          geodesic=lambda p: float(np.linalg.norm(np.asarray(p) - g)), start_geodesic=start_geodesic,
                          hfov=math.radians(79))


def run(points, yaws=None, stop_last=True, commanded=None, moved=None):
    m = MeasureSet()
    c = ctx(start_geodesic=float(np.linalg.norm(np.asarray(points[0]) - np.array([0.0, -1.1]))))
    yaws = yaws or [math.pi / 2] * len(points)
    m.reset(c, StepState(np.asarray(points[0], float), yaws[0], None, False))
    for i, (p, y) in enumerate(zip(points[1:], yaws[1:]), 1):
        last = i == len(points) - 1
        m.update(c, StepState(np.asarray(p, float), y, 1, stop_last and last,
                              (commanded or [0.25] * len(points))[i], (moved or [0.25] * len(points))[i]))
    return m


def test_straight_success_has_spl_one():
    pts = [(0.0, -4.1 + 0.25 * k) for k in range(13)]  # 3.0 m straight to y = -1.1
    m = run(pts)
    assert m["success"] and m["steps"] == 12
    assert m["path_length"] == pytest.approx(3.0)
    assert m["spl"] == pytest.approx(1.0)
    assert m["soft_spl"] == pytest.approx(1.0)
    assert m["distance_to_goal"] == pytest.approx(0.0, abs=1e-9)
    assert m["in_zone3"] and m["facing_instrument"]


def test_detour_halves_spl_and_failure_zeroes_it():
    pts = [(0.0, -4.1), (3.0, -4.1), (3.0, -1.1), (0.0, -1.1)]  # 9 m for a 3 m shortest path
    m = run(pts)
    assert m["success"] and m["spl"] == pytest.approx(3.0 / 9.0)
    m = run(pts[:3])  # stops at (3.0, -1.1): 3 m from the goal, radius 0.8
    assert not m["success"] and m["spl"] == 0.0
    assert m["soft_spl"] == pytest.approx((1 - 3.0 / 3.0) * 3.0 / 6.0)


def test_mcr_vrt_zone2_and_clearance_use_the_robot_centre():
    # x = 0.5 + clearance: poses at clearance 1.0, 0.4, 0.2, 1.0
    pts = [(1.5, 0.0), (0.9, 0.0), (0.7, 0.0), (1.5, 0.0)]
    m = run(pts, stop_last=False)
    assert m["mcr"] == pytest.approx(0.2)
    assert m["vrt"] == pytest.approx(2 / 4)  # start included
    assert m["clearance"] == pytest.approx(1.0)
    m = run(pts[:3], stop_last=False)
    assert m["zone2_violation"]  # 0.2 m from the body is inside the 0.25 m Zone 2


def test_collisions_count_blocked_forward_moves():
    pts = [(2.0, 0.0), (2.0, 0.0), (2.0, 0.0)]
    m = run(pts, stop_last=False, commanded=[0, 0.25, 0.25], moved=[0, 0.0, 0.25])
    assert m["collisions"] == 1


def test_facing_uses_half_the_horizontal_fov():
    m = run([(0.0, -3.0), (0.0, -3.0)], yaws=[math.pi / 2, math.pi / 2 + math.radians(39)], stop_last=False)
    assert m["facing_instrument"]
    m = run([(0.0, -3.0), (0.0, -3.0)], yaws=[math.pi / 2, math.pi / 2 + math.radians(41)], stop_last=False)
    assert not m["facing_instrument"]


def test_unknown_measure_and_cycles_are_refused():
    with pytest.raises(KeyError, match="unknown measure 'teleports'"):
        MeasureSet(names=("teleports",))
