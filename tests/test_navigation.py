"""Exact geodesics checked against an independent method (a 16-connected grid Dijkstra)."""

import math

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from shapely.geometry import MultiPolygon, Point, box

from biovln_ms.geometry.freespace import free_space
from biovln_ms.geometry.navigation import NavGeometry, UnreachableError
from biovln_ms.scene.rules import scene_navigation
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import floor_polygon

MOVES = [(1, 0), (0, 1), (1, 1), (1, -1), (2, 1), (1, 2), (2, -1), (1, -2)]


def grid_geodesic(nav: NavGeometry, s, g) -> float:
    """Independent estimate: 16-connected Dijkstra over grid cells fully inside the free space."""
    grid = nav.grid
    mask = grid.inner
    h, w = mask.shape
    idx = -np.ones(mask.shape, int)
    idx[mask] = np.arange(mask.sum())
    rows, cols, wts = [], [], []
    ys, xs = np.nonzero(mask)
    for dx, dy in MOVES:
        y2, x2 = ys + dy, xs + dx
        ok = (y2 >= 0) & (y2 < h) & (x2 >= 0) & (x2 < w)
        ok[ok] &= mask[y2[ok], x2[ok]]
        if abs(dx) + abs(dy) == 3:  # knight move: both cells it passes must be free too
            ya, xa = (
                ys + (dy if abs(dy) == 2 else 0) // (2 if abs(dy) == 2 else 1),
                xs + (dx if abs(dx) == 2 else 0) // (2 if abs(dx) == 2 else 1),
            )
            ok2 = (ya >= 0) & (ya < h) & (xa >= 0) & (xa < w)
            ok &= ok2
            ok[ok] &= mask[ya[ok], xa[ok]]
        rows.append(idx[ys[ok], xs[ok]])
        cols.append(idx[y2[ok], x2[ok]])
        wts.append(np.full(ok.sum(), math.hypot(dx, dy) * grid.resolution))
    graph = coo_matrix(
        (np.concatenate(wts), (np.concatenate(rows), np.concatenate(cols))), shape=(mask.sum(),) * 2
    ).tocsr()
    centres = grid.cell_centres()[mask]

    def nearest(p):
        return int(np.argmin(np.linalg.norm(centres - np.asarray(p)[:2], axis=1)))

    a, b = nearest(s), nearest(g)
    d = dijkstra(graph, directed=False, indices=a)[b]
    return d + np.linalg.norm(centres[a] - s) + np.linalg.norm(centres[b] - g)


@pytest.mark.parametrize(
    "template,seed",
    [("single_room", 150), ("single_room", 4), ("two_room", 1), ("suite", 2), ("open_plan", 5)],
)
def test_exact_geodesic_agrees_with_grid_and_is_never_longer(template, seed):
    spec = generate_scene(template, seed)
    nav = scene_navigation(spec)
    rng = np.random.default_rng(seed)
    cells = np.argwhere(nav.grid.inner)
    centres = nav.grid.cell_centres()
    goals = [nav.snap(o.goal) for o in spec.goal_objects()]
    ratios = []
    for k in range(25):
        s = centres[tuple(cells[rng.integers(len(cells))])]
        g = goals[k % len(goals)]
        exact = nav.geodesic_distance(s, g)
        approx = grid_geodesic(nav, s, g)
        assert np.isfinite(exact)
        assert exact >= np.linalg.norm(g - s) - 1e-9
        assert exact <= approx + 0.1  # the grid path is feasible, so the exact one is no longer
        ratios.append(approx / max(exact, 1e-9))
    assert np.median(ratios) < 1.05  # 16-connected grids are ~1-3% long


def test_paths_keep_the_robot_radius_from_every_obstacle():
    spec = generate_scene(
        "single_room", 151, required_categories=("cabinet", "centrifuge", "refrigerator", "waste_bin")
    )
    nav = scene_navigation(spec)
    floor = floor_polygon(spec)
    rng = np.random.default_rng(0)
    cells = np.argwhere(nav.grid.inner)
    centres = nav.grid.cell_centres()
    for o in spec.goal_objects():
        s = centres[tuple(cells[rng.integers(len(cells))])]
        path = nav.shortest_path(s, nav.snap(o.goal))
        pts = np.concatenate([np.linspace(a, b, 40) for a, b in zip(path[:-1], path[1:])])
        clear = np.min([obj.placed().clearance(pts) for obj in spec.objects()], axis=0)
        wall = np.array([floor.exterior.distance(Point(p)) for p in pts])
        assert clear.min() >= nav.radius - 1e-6
        assert wall.min() >= nav.radius - 1e-6
        assert math.isclose(
            np.linalg.norm(np.diff(path, axis=0), axis=1).sum(),
            nav.geodesic_distance(s, nav.snap(o.goal)),
            rel_tol=1e-9,
        )


def test_open_room_geodesic_is_straight_and_obstacle_detour_is_exact():
    floor = box(0, 0, 4, 4)
    nav = NavGeometry(free_space(floor, [], 0.2), 0.2)
    assert nav.geodesic_distance([0.5, 0.5], [3.5, 3.0]) == pytest.approx(math.hypot(3.0, 2.5))
    # A wall segment in the middle forces a detour around its grown end.
    nav = NavGeometry(free_space(floor, [box(1.9, 0.0, 2.1, 3.0)], 0.2), 0.2)
    s, g = np.array([1.0, 1.0]), np.array([3.0, 1.0])
    d = nav.geodesic_distance(s, g)
    # Exact for a disc robot: tangent to the rounded corner at (1.9, 3.0), arc to the top, 0.2 m
    # along the top, and the mirror image down to the goal.
    r, c = 0.2, np.array([1.9, 3.0])
    dist_c = np.linalg.norm(s - c)
    tangent = math.sqrt(dist_c**2 - r**2)
    theta_s = math.atan2(*(s - c)[::-1])
    theta_t = theta_s - math.acos(r / dist_c) + 2 * math.pi
    exact = 2 * (tangent + r * (theta_t - math.pi / 2)) + 0.2
    assert exact - 1e-6 <= d <= exact * 1.005  # polygonal offsets enclose the round one: never shorter


def test_islands_unreachable_and_snapping():
    free = MultiPolygon([box(0, 0, 2, 2), box(3, 0, 5, 2)])
    nav = NavGeometry(free, 0.2)
    assert len(nav.islands) == 2
    assert nav.island_of([1, 1]) != nav.island_of([4, 1])
    assert math.isinf(nav.geodesic_distance([1, 1], [4, 1]))
    with pytest.raises(UnreachableError, match="no navigable path"):
        nav.shortest_path([1, 1], [4, 1])
    assert math.isinf(nav.geodesic_distance([2.5, 1], [1, 1]))  # off the navigable area
    snapped = nav.snap([2.6, 1.0], island=nav.island_of([4, 1]))
    assert np.allclose(snapped, [3.0, 1.0])
    assert np.allclose(nav.snap([2.4, 1.0]), [2.0, 1.0])
    assert nav.is_navigable(snapped)


def test_grid_is_derived_from_the_polygons():
    spec = generate_scene("two_room", 0)
    nav = scene_navigation(spec)
    assert nav.grid.resolution == 0.05
    centres = nav.grid.cell_centres()
    for k in np.random.default_rng(1).integers(0, nav.grid.free.size, 300):
        i, j = np.unravel_index(k, nav.grid.free.shape)
        inside = nav.free.contains(Point(*centres[i, j]))
        assert nav.grid.free[i, j] == inside
    assert (nav.grid.inner <= nav.grid.free).all()
    assert set(np.unique(nav.grid.island)) == {-1, 0}


def _crossings_vectorised(p, q, a, b, eps):
    """The proper-crossing test as array formulas: the kernel's specification."""

    def cross(ux, uy, wx, wy):
        return ux * wy - uy * wx

    px, py, qx, qy = p[:, None, 0], p[:, None, 1], q[:, None, 0], q[:, None, 1]
    ax, ay, bx, by = a[None, :, 0], a[None, :, 1], b[None, :, 0], b[None, :, 1]
    d1 = cross(qx - px, qy - py, ax - px, ay - py)
    d2 = cross(qx - px, qy - py, bx - px, by - py)
    d3 = cross(bx - ax, by - ay, px - ax, py - ay)
    d4 = cross(bx - ax, by - ay, qx - ax, qy - ay)
    return ((d1 * d2 < -eps) & (d3 * d4 < -eps)).any(axis=1)


def _through_vectorised(p, q, v, tol):
    d = q - p
    length2 = np.maximum((d**2).sum(axis=1), 1e-18)
    t = (
        (v[None, :, 0] - p[:, None, 0]) * d[:, None, 0] + (v[None, :, 1] - p[:, None, 1]) * d[:, None, 1]
    ) / (length2[:, None])
    cx = p[:, None, 0] + t * d[:, None, 0] - v[None, :, 0]
    cy = p[:, None, 1] + t * d[:, None, 1] - v[None, :, 1]
    return (((t > 1e-9) & (t < 1 - 1e-9)) & (cx * cx + cy * cy < tol * tol)).any(axis=1)


def test_visibility_kernels_equal_the_array_formulas():
    """The compiled visibility tests answer as the array formulas do, segment for segment: between a
    scene's vertices, from random points, along edges, through vertices, and for zero-length segments."""
    from biovln_ms.geometry.navigation import EPS, _crossing_any, _through_any

    nav = scene_navigation(generate_scene("suite", 2))
    a, b, v = nav._edges_a, nav._edges_b, nav.vertices
    rng = np.random.default_rng(0)
    lo, hi = np.asarray(nav.free.bounds[:2]), np.asarray(nav.free.bounds[2:])
    i, j = rng.integers(0, len(v), 3000), rng.integers(0, len(v), 3000)
    pts = rng.uniform(lo, hi, (2000, 2))
    p = np.concatenate([v[i], pts[:1000], a[:200], a[:50], pts[1000:1100]])
    q = np.concatenate([v[j], pts[1000:], b[:200], 2 * b[:50] - a[:50], pts[1000:1100]])
    assert np.array_equal(_crossing_any(p, q, a, b, EPS), _crossings_vectorised(p, q, a, b, EPS))
    assert np.array_equal(_through_any(p, q, a, 1e-7), _through_vectorised(p, q, a, 1e-7))
    assert _through_any(a[:50], 2 * b[:50] - a[:50], a, 1e-7).all()  # each passes through its edge's end
