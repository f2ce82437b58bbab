"""Swept-motion limits (no tunnelling): pure geometry."""

import math

import pytest
from shapely.geometry import box

from biovln_ms.geometry.motion import CONTACT_SLACK, SweptMotion

# two 4 x 4 m rooms joined along x = 4, separated by a 0.1 m-thick wall (the floor stops at x = 3.95 / 4.05)
FLOOR = box(0, 0, 3.95, 4).union(box(4.05, 0, 8, 4))
PILLAR = box(1.9, 3.0, 2.1, 3.2)


def test_a_long_move_stops_before_a_thin_wall():
    m = SweptMotion(FLOOR, [PILLAR], 0.2)
    allowed = m.max_forward(3.0, 1.0, 0.0, 2.0)  # would end at x = 5.0, in the other room
    assert allowed == pytest.approx(3.95 - (0.2 - CONTACT_SLACK) - 3.0, abs=1e-6)


def test_free_moves_and_moves_along_walls_are_untouched():
    m = SweptMotion(FLOOR, [PILLAR], 0.2)
    assert m.max_forward(1.0, 1.0, 0.0, 0.25) == 0.25
    assert m.max_forward(1.0, 0.5, 0.0, 2.0) == 2.0  # parallel to the south wall, 0.5 m from it


def test_an_instrument_stops_the_body_and_contact_can_be_left():
    m = SweptMotion(FLOOR, [PILLAR], 0.2)
    up = m.max_forward(2.0, 1.0, math.pi / 2, 3.0)  # straight at the pillar from below
    assert up == pytest.approx(3.0 - (0.2 - CONTACT_SLACK) - 1.0, abs=1e-6)
    assert m.max_forward(2.0, 2.9, -math.pi / 2, 0.25) == 0.25  # pressed against it, backing away
    assert m.max_forward(1.0, 1.0, 0.0, 0.0) == 0.0
