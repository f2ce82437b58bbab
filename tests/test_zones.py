"""Property-based tests of the three-zone model, Eq. 1-4."""

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from shapely.geometry import Point, Polygon

from biovln_ms.catalog import FACE_VECTORS
from biovln_ms.geometry.zones import (
    PlacedInstrument,
    default_zone2_clearance,
    eq2_axis_aligned,
    goal_position,
    min_clearance,
    placement_z,
    rot2,
    yaw_facing,
    zone2_disjoint,
)

WALL_INTERIORS = {
    "south wall": (0.0, 1.0),
    "north wall": (0.0, -1.0),
    "west wall": (1.0, 0.0),
    "east wall": (-1.0, 0.0),
}
coord = st.floats(-10, 10, allow_nan=False)
size = st.floats(0.04, 3.0, allow_nan=False)
angle = st.floats(-math.pi, math.pi, allow_nan=False)
right_angle = st.sampled_from([0.0, math.pi / 2, math.pi, -math.pi / 2])


def inst(x, y, yaw, sx, sy, face="-Y", d_half=None, delta=0.6, z=0.5, sz=1.0):
    m = FACE_VECTORS[face]
    d = d_half if d_half is not None else (sx if face[1] == "X" else sy) / 2
    return PlacedInstrument((x, y, z), yaw, (sx, sy, sz), m, d, delta)


@pytest.mark.parametrize("wall", sorted(WALL_INTERIORS))
@pytest.mark.parametrize("face", sorted(FACE_VECTORS))
def test_eq3_turns_every_face_to_every_wall_interior(wall, face):
    w = np.array(WALL_INTERIORS[wall])
    theta = yaw_facing(FACE_VECTORS[face], w)
    assert np.allclose(rot2(theta) @ np.array(FACE_VECTORS[face]), w, atol=1e-12)


@given(angle, angle)
def test_eq3_for_arbitrary_directions(a, b):
    m = np.array([math.cos(a), math.sin(a)])
    w = np.array([math.cos(b), math.sin(b)])
    assert np.allclose(rot2(yaw_facing(m, w)) @ m, w, atol=1e-9)


@given(st.floats(0, 2, allow_nan=False), st.floats(-1, 1, allow_nan=False), size)
def test_eq4_bottom_rests_on_support(top, bb_center, height):
    bottom = bb_center - height / 2
    z = placement_z(top, bb_center, bottom)
    # The placed lowest vertex (origin z + bottom - bb_center) lies on the support.
    assert z + (bottom - bb_center) == pytest.approx(top)
    # Origin-centred assets: the origin sits half a height above the support.
    assert placement_z(top, 0.0, -height / 2) == pytest.approx(top + height / 2)


@given(coord, coord, angle, size, size, st.sampled_from(sorted(FACE_VECTORS)), st.floats(0.5, 0.9))
@example(4.0, 0.0, 1.0, 1.0, 1.1446884208557935, "-Y", 0.6117281949532553)  # the GEOS overlay case
def test_eq1_goal_on_zone3_outer_edge_along_face(x, y, yaw, sx, sy, face, delta):
    i = inst(x, y, yaw, sx, sy, face, delta=delta)
    g = i.goal()
    f = i.face
    assert np.allclose(g, goal_position((x, y), f, i.d_half, delta))
    assert np.linalg.norm(g - np.array([x, y])) == pytest.approx(i.d_half + delta)
    z3 = i.zone3()
    assert z3.area == pytest.approx(i.face_width * delta, rel=1e-6)
    assert z3.exterior.distance(Point(g)) < 1e-7  # the goal sits on Zone 3's outer boundary
    # Zone 3 lies outside the body. They share the face edge exactly, and GEOS 3.14's overlay can return
    # the whole of Zone 3 as the intersection of such touching polygons (found by hypothesis), so the
    # area is only consulted when GEOS's predicates do not already say the two merely touch.
    z1 = i.zone1()
    assert z1.touches(z3) or z1.intersection(z3).area < 1e-9
    assert i.clearance(g) == pytest.approx(delta, abs=1e-7)  # d_half equals the half-depth here


@given(coord, coord, angle, size, size)
def test_zone2_is_zone1_grown_by_eps(x, y, yaw, sx, sy):
    i = inst(x, y, yaw, sx, sy)
    eps = default_zone2_clearance()
    assert i.eps_c == eps  # an instrument without a catalog asset takes the packaged catalog's epsilon_c
    z1, z2 = i.zone1(), i.zone2()
    assert z2.area == pytest.approx((sx + 2 * eps) * (sy + 2 * eps), rel=1e-9)
    assert z2.contains(z1)
    assert z1.buffer(eps, join_style="mitre").symmetric_difference(z2).area < 1e-6


@settings(max_examples=300)
@given(coord, coord, right_angle, size, size, coord, coord, right_angle, size, size)
def test_eq2_equals_sat_for_axis_aligned(x1, y1, r1, sx1, sy1, x2, y2, r2, sx2, sy2):
    a, b = inst(x1, y1, r1, sx1, sy1), inst(x2, y2, r2, sx2, sy2)
    assert zone2_disjoint(a, b) == eq2_axis_aligned(a, b)


@settings(max_examples=300)
@given(
    st.floats(-3, 3),
    st.floats(-3, 3),
    angle,
    size,
    size,
    st.floats(-3, 3),
    st.floats(-3, 3),
    angle,
    size,
    size,
)
def test_rotated_zone2_test_matches_polygon_overlap(x1, y1, r1, sx1, sy1, x2, y2, r2, sx2, sy2):
    a, b = inst(x1, y1, r1, sx1, sy1), inst(x2, y2, r2, sx2, sy2)
    overlap = a.zone2().intersection(b.zone2()).area
    if overlap > 1e-6:
        assert not zone2_disjoint(a, b)
    elif a.zone2().distance(b.zone2()) > 1e-6:
        assert zone2_disjoint(a, b)


def test_rotated_instruments_caught_where_axis_aligned_eq2_would_miss():
    # Two 45-degree instruments whose world AABBs do not satisfy Eq. 2 but whose Zone 2 are disjoint.
    a = inst(0, 0, math.pi / 4, 1.0, 0.2)
    b = inst(0.9, -0.9, math.pi / 4, 1.0, 0.2)
    assert a.zone2().intersection(b.zone2()).area == 0
    assert zone2_disjoint(a, b)
    assert not eq2_axis_aligned(a, b)


@given(coord, coord, angle, size, size, st.floats(-12, 12), st.floats(-12, 12))
def test_clearance_matches_shapely_distance(x, y, yaw, sx, sy, px, py):
    i = inst(x, y, yaw, sx, sy)
    assert i.clearance(np.array([px, py])) == pytest.approx(
        Polygon(i.zone1_corners()).distance(Point(px, py)), abs=1e-7
    )


def test_clearance_3d_accounts_for_height():
    i = inst(0, 0, 0, 1.0, 1.0, z=0.76 + 0.25, sz=0.5)  # table-top body from 0.76 to 1.26 m
    p = np.array([0.8, 0.0])  # 0.3 m from the footprint
    assert i.clearance(p) == pytest.approx(0.3)
    assert i.clearance(p, z=0.0) == pytest.approx(math.hypot(0.3, 0.76))
    assert i.clearance(p, z=(0.0, 1.0)) == pytest.approx(0.3)  # a 1 m tall robot overlaps in height


def test_min_clearance_over_many():
    a, b = inst(0, 0, 0, 1, 1), inst(5, 0, 0, 1, 1)
    d = min_clearance(np.array([[2.5, 0], [0, 0], [9, 0]]), [a, b])
    assert np.allclose(d, [2.0, 0.0, 3.5])
    assert np.isinf(min_clearance(np.array([[0, 0]]), [])).all()


def test_furniture_without_face_has_no_goal():
    i = PlacedInstrument((0, 0, 0), 0.0, (1, 1, 1), None)
    with pytest.raises(ValueError, match="no operational face"):
        i.goal()
    with pytest.raises(ValueError, match="no operational face"):
        i.zone3()


@given(
    st.lists(st.tuples(coord, coord, angle, size, size), min_size=1, max_size=6),
    st.floats(-12, 12),
    st.floats(-12, 12),
)
def test_instrument_array_matches_the_scalar_geometry(items, px, py):
    from biovln_ms.geometry.zones import InstrumentArray

    insts = [inst(*it) for it in items]
    arr = InstrumentArray(insts)
    p = np.array([px, py])
    assert arr.clearance(p) == pytest.approx(min(i.clearance(p) for i in insts), abs=1e-9)
    inside = any(i.zone2().buffer(1e-9).contains(Point(px, py)) for i in insts)
    strictly = any(i.zone2().buffer(-1e-9).contains(Point(px, py)) for i in insts)
    if strictly:
        assert arr.in_zone2(p)
    elif not inside:
        assert not arr.in_zone2(p)
