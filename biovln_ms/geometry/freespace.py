"""Free space for a disc robot: the floor minus every obstacle grown by the robot radius (shapely).

Obstacles are the outside of the floor (walls) and every object's Zone 1 footprint. They are grown
by ``r / cos(pi/16)`` with 4 segments per quarter circle, so the polygonal offset encloses the true
rounded one: a point in the free space is at least ``r`` from every obstacle.
"""

from __future__ import annotations

import math
from typing import Iterable, Sequence

from shapely.geometry import MultiPolygon, Point, Polygon, box
from shapely.ops import unary_union

QUAD_SEGS = 4
GROW_FACTOR = 1.0 / math.cos(math.pi / (4 * QUAD_SEGS))


def grow(geom, radius: float):
    """Minkowski-grow a geometry by a disc of ``radius``, conservatively (encloses the exact offset)."""
    return geom.buffer(radius * GROW_FACTOR, quad_segs=QUAD_SEGS)


def free_space(floor: Polygon | MultiPolygon, obstacles: Iterable[Polygon], radius: float) -> MultiPolygon:
    """Positions where a disc of ``radius`` fits on ``floor`` without touching any obstacle."""
    minx, miny, maxx, maxy = floor.bounds
    outside = box(
        minx - 2 * radius - 1, miny - 2 * radius - 1, maxx + 2 * radius + 1, maxy + 2 * radius + 1
    ).difference(floor)
    blocked = grow(unary_union([outside, *obstacles]), radius)
    free = floor.difference(blocked)
    if isinstance(free, Polygon):
        free = MultiPolygon([free]) if not free.is_empty else MultiPolygon()
    elif not isinstance(free, MultiPolygon):  # a GeometryCollection with slivers
        free = MultiPolygon([g for g in getattr(free, "geoms", []) if isinstance(g, Polygon) and g.area > 0])
    return free


def island_of(free: MultiPolygon, point: Sequence[float], tol: float = 1e-6) -> int | None:
    """Index of the connected component (island) containing ``point``, or None."""
    p = Point(point[0], point[1])
    for i, poly in enumerate(free.geoms):
        if poly.distance(p) <= tol:
            return i
    return None
