"""Swept-motion limits: how far a disc robot may move straight ahead before its body would enter a wall or an
instrument, so a large step cannot tunnel through a thin obstacle between two physics substeps."""

from __future__ import annotations

import math

import shapely
from shapely.geometry import LineString, Point, box
from shapely.ops import unary_union

#: the body may come this close to an obstacle before the commanded move is cut; contact (at the full
#: radius) is left to the physics, so an ordinary step against a wall ends exactly as before
CONTACT_SLACK = 0.01


class SweptMotion:
    """Obstacles (the outside of the floor and every footprint) grown by ``radius - CONTACT_SLACK``."""

    def __init__(self, floor, footprints, radius: float) -> None:
        minx, miny, maxx, maxy = floor.bounds
        pad = 2 * radius + 1.0
        outside = box(minx - pad, miny - pad, maxx + pad, maxy + pad).difference(floor)
        self.blocked = unary_union([outside, *footprints]).buffer(radius - CONTACT_SLACK, quad_segs=8)
        shapely.prepare(self.blocked)

    def max_forward(self, x: float, y: float, yaw: float, distance: float) -> float:
        """The part of a straight move of ``distance`` from (x, y) along ``yaw`` that keeps the body out of
        every obstacle (``distance`` itself when nothing is in the way, or when the start already touches
        one: the physics then decides, so the robot can always back away from contact)."""
        if distance <= 0:
            return distance
        start = Point(x, y)
        if self.blocked.contains(start):
            return distance
        seg = LineString([(x, y), (x + distance * math.cos(yaw), y + distance * math.sin(yaw))])
        if not self.blocked.intersects(seg):
            return distance
        hit = seg.intersection(self.blocked)
        first = min(seg.project(Point(c)) for g in getattr(hit, "geoms", [hit]) for c in _coords(g))
        return max(0.0, first)


def _coords(geom) -> list:
    if hasattr(geom, "exterior"):
        return list(geom.exterior.coords)
    return list(geom.coords)
