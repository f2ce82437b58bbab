"""Swept-motion checks for a disc robot, so that no step size can tunnel through a thin wall or an
instrument between two physics substeps, while ordinary contact (pressing, sliding) stays the physics'.

``B`` is every obstacle (the outside of the floor and each collision footprint: boxes, or the convex hull
of a round instrument's collision parts) grown by ``radius - ALLOWANCE``: a robot centre inside ``B`` is
more than ``ALLOWANCE`` (8 cm) inside contact, which the contact solver never allows for the benchmark's
0.25 m steps (the deepest of 500 baseline episodes on MS VAL and Two-Room came 5.4 cm inside a round
instrument's footprint, pushing against its convex parts). Two checks use it:

* before a move (:meth:`SweptMotion.target`): a straight path that enters ``B`` and leaves it again before
  its end would cross an obstacle; the drive target is cut to where the path first enters ``B``;
* after a move (:meth:`SweptMotion.crossed`): the body went through or deep into an obstacle (its centre
  ended in ``B``, in another free component, or its displacement crosses an obstacle's footprint or a
  wall); the task then puts the robot back where the move started (a blocked move).

Neither fires for the benchmark's steps; they keep large steps, noise and continuous control inside the
navigable region.
"""

from __future__ import annotations

import shapely
from shapely.geometry import LineString, MultiPolygon, Point, Polygon, box
from shapely.ops import unary_union

#: how deep inside contact (m) a robot centre or a path may go before a move counts as crossing
ALLOWANCE = 0.08


class SweptMotion:
    """The motion checks of one scene."""

    def __init__(self, floor, footprints, radius: float) -> None:
        minx, miny, maxx, maxy = floor.bounds
        pad = 2 * radius + 1.0
        outside = box(minx - pad, miny - pad, maxx + pad, maxy + pad).difference(floor)
        self.core = unary_union([outside, *footprints])
        self.blocked = self.core.buffer(radius - ALLOWANCE, quad_segs=8)
        free = floor.difference(self.blocked)
        parts = free.geoms if isinstance(free, MultiPolygon) else [free]
        self.components = [g for g in parts if isinstance(g, Polygon) and not g.is_empty]
        for g in (self.core, self.blocked, *self.components):
            shapely.prepare(g)

    def target(self, x: float, y: float, tx: float, ty: float) -> tuple[float, float]:
        """The drive target for a move from (x, y) toward (tx, ty): cut where the straight path first enters
        ``B`` when it would leave ``B`` again (cross an obstacle), else unchanged."""
        seg = LineString([(x, y), (tx, ty)])
        if shapely.contains_xy(self.blocked, x, y) or not self.blocked.intersects(seg):
            return tx, ty
        inside = seg.intersection(self.blocked)
        pieces = sorted(
            sorted((seg.project(Point(g.coords[0])), seg.project(Point(g.coords[-1]))))
            for g in getattr(inside, "geoms", [inside])
            if g.length > 0
        )
        if pieces and pieces[0][1] < seg.length - 1e-9:
            p = seg.interpolate(pieces[0][0])
            return p.x, p.y
        return tx, ty

    def crossed(self, x: float, y: float, ex: float, ey: float) -> bool:
        """Whether a move from (x, y) that ended at (ex, ey) went through or deep into an obstacle."""
        # (for a point and a polygon, intersects_xy is covers)
        if shapely.contains_xy(self.blocked, x, y):  # it started deep in contact: only a crossing counts
            return self.core.intersects(LineString([(x, y), (ex, ey)])) if (x, y) != (ex, ey) else False
        if shapely.contains_xy(self.blocked, ex, ey):
            return True
        own = next((c for c in self.components if shapely.intersects_xy(c, x, y)), None)
        if own is not None and not shapely.intersects_xy(own, ex, ey):
            return True
        return (x, y) != (ex, ey) and self.core.intersects(LineString([(x, y), (ex, ey)]))
