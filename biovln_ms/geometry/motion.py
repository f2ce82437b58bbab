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
navigable region. Most moves start farther from ``B`` than they are long, and then neither can fire: a
lower bound of that distance, kept per :data:`CLEAR_CELL` cell, answers them without a polygon test.
"""

from __future__ import annotations

import math

import shapely
from shapely.geometry import LineString, MultiPolygon, Point, Polygon, box
from shapely.ops import unary_union

#: how deep inside contact (m) a robot centre or a path may go before a move counts as crossing
ALLOWANCE = 0.08
#: m: the side of the cells whose distance to ``B`` a scene's checks keep
CLEAR_CELL = 0.1
#: cells kept per scene (a robot's walk visits few; the bound keeps memory flat)
MAX_CLEAR_CELLS = 50_000


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
        # clear of B is clear of the core only when B contains it (a footprint no smaller than ALLOWANCE)
        self._room: dict[tuple[int, int], float] | None = {} if radius >= ALLOWANCE else None

    def room(self, x: float, y: float) -> float:
        """A lower bound of the distance from (x, y) to ``B`` (negative inside it): the distance of the
        centre of its :data:`CLEAR_CELL` cell less half the cell's diagonal and 1 µm, computed once per cell.
        No segment from (x, y) shorter than this meets ``B`` (nor the core, which ``B`` contains); -inf for a
        footprint smaller than ALLOWANCE (``B`` then does not contain the core) and for a point not finite."""
        if self._room is None or not (math.isfinite(x) and math.isfinite(y)):
            return -math.inf
        key = (math.floor(x / CLEAR_CELL), math.floor(y / CLEAR_CELL))
        d = self._room.get(key)
        if d is None:
            if len(self._room) >= MAX_CLEAR_CELLS:
                self._room.clear()
            centre = Point((key[0] + 0.5) * CLEAR_CELL, (key[1] + 0.5) * CLEAR_CELL)
            d = float(shapely.distance(self.blocked, centre)) - CLEAR_CELL * math.sqrt(0.5) - 1e-6
            self._room[key] = d
        return d

    def target(self, x: float, y: float, tx: float, ty: float) -> tuple[float, float]:
        """The drive target for a move from (x, y) toward (tx, ty): cut where the straight path first enters
        ``B`` when it would leave ``B`` again (cross an obstacle), else unchanged."""
        if math.hypot(tx - x, ty - y) < self.room(x, y):  # the path stays out of B
            return tx, ty
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
        if math.hypot(ex - x, ey - y) < self.room(x, y):  # the move stayed out of B, in one component
            return False
        # (for a point and a polygon, intersects_xy is covers)
        if shapely.contains_xy(self.blocked, x, y):  # it started deep in contact: only a crossing counts
            return self.core.intersects(LineString([(x, y), (ex, ey)])) if (x, y) != (ex, ey) else False
        if shapely.contains_xy(self.blocked, ex, ey):
            return True
        own = next((c for c in self.components if shapely.intersects_xy(c, x, y)), None)
        if own is not None and not shapely.intersects_xy(own, ex, ey):
            return True
        return (x, y) != (ex, ey) and self.core.intersects(LineString([(x, y), (ex, ey)]))
