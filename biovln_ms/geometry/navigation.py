"""Exact navigation geometry for a disc robot: navigable polygons, islands, geodesics, snapping, grid.

The navigable area is the floor minus every obstacle grown by the robot radius (``freespace``).
Shortest paths in it are exact Euclidean shortest paths: they bend only at reflex vertices of the
free space, so a visibility graph over those vertices (kept only where an edge is tangent at both
ends) with all-pairs distances precomputed answers a query by joining the start and goal to the
vertices they see. Unreachable pairs give ``inf`` (``path`` raises). Paths stay inside the free
space, so they never come closer than the radius to any obstacle (Habitat's Recast navmesh can).
A segment's visibility is tested against every boundary edge in a compiled loop (Numba, cached on disk)
that stops at the first crossing: an episode's measures ask for a geodesic at every move.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numba import njit
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import shortest_path
from shapely.geometry import MultiPolygon, Point, Polygon
from shapely.geometry.polygon import orient
from shapely.ops import nearest_points

from biovln_ms.errors import BioVLNError

EPS = 1e-9
SAMPLE_STEP = 0.5


class UnreachableError(BioVLNError):
    """No path joins two points (different islands, or a point off the navigable area)."""


def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


@njit(cache=True)
def _crossing_any(p, q, a, b, eps):
    """Whether segment p[i]->q[i] properly crosses some edge a[j]->b[j]: with ``cross(u, w) = u_x w_y -
    u_y w_x``, ``d1 = cross(q - p, a - p)``, ``d2 = cross(q - p, b - p)``, ``d3 = cross(b - a, p - a)``,
    ``d4 = cross(b - a, q - a)``, both ``d1 d2`` and ``d3 d4`` below ``-eps``. One pass that stops at a
    segment's first crossing, in the inputs' dtype (float64 here) without fused multiply-add."""
    out = np.zeros(p.shape[0], np.bool_)
    for i in range(p.shape[0]):
        px, py, qx, qy = p[i, 0], p[i, 1], q[i, 0], q[i, 1]
        for j in range(a.shape[0]):
            ax, ay, bx, by = a[j, 0], a[j, 1], b[j, 0], b[j, 1]
            d1 = (qx - px) * (ay - py) - (qy - py) * (ax - px)
            d2 = (qx - px) * (by - py) - (qy - py) * (bx - px)
            if not d1 * d2 < -eps:
                continue
            d3 = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
            d4 = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax)
            if d3 * d4 < -eps:
                out[i] = True
                break
    return out


@njit(cache=True)
def _through_any(p, q, v, tol):
    """Whether segment p[i]->q[i] passes within ``tol`` of a point of ``v`` strictly between its ends: some
    ``t = (v - p)·(q - p) / max(|q - p|², 1e-18)`` in (1e-9, 1 - 1e-9) with ``|p + t (q - p) - v| < tol``."""
    out = np.zeros(p.shape[0], np.bool_)
    for i in range(p.shape[0]):
        px, py = p[i, 0], p[i, 1]
        dx, dy = q[i, 0] - px, q[i, 1] - py
        length2 = max(dx * dx + dy * dy, 1e-18)
        for j in range(v.shape[0]):
            vx, vy = v[j, 0], v[j, 1]
            t = ((vx - px) * dx + (vy - py) * dy) / length2
            if t > 1e-9 and t < 1 - 1e-9:
                cx = px + t * dx - vx
                cy = py + t * dy - vy
                if cx * cx + cy * cy < tol * tol:
                    out[i] = True
                    break
    return out


def load_kernels() -> None:
    """Dispatch the crossing kernels once, loading them from Numba's cache. A process's first dispatch
    builds Numba's typing registries: tens of thousands of objects that live as long as the process.
    :func:`~biovln_ms.sim.maniskill_compat.freeze_live_objects` calls this before it freezes, so the full
    collection ManiSkill runs at each scene change does not walk them."""
    z = np.zeros((1, 2))
    _crossing_any(z, z, z, z, 1e-9)
    _through_any(z, z, z, 1e-9)


@dataclass(frozen=True)
class OccupancyGrid:
    """A raster of the navigable polygons: ``free`` (cell centre navigable), ``inner`` (whole cell
    navigable) and ``island`` (index of the island, -1 off the navigable area)."""

    origin: np.ndarray
    resolution: float
    free: np.ndarray
    inner: np.ndarray
    island: np.ndarray

    def world_to_cell(self, xy) -> tuple[np.ndarray, np.ndarray]:
        xy = np.atleast_2d(np.asarray(xy, float))
        ij = np.floor((xy - self.origin) / self.resolution).astype(int)
        return ij[:, 1], ij[:, 0]

    def cell_centres(self) -> np.ndarray:
        h, w = self.free.shape
        xs = self.origin[0] + (np.arange(w) + 0.5) * self.resolution
        ys = self.origin[1] + (np.arange(h) + 0.5) * self.resolution
        return np.stack(np.meshgrid(xs, ys), axis=-1)


class NavGeometry:
    """Navigable area of a floor with obstacles for one robot radius, with exact geodesics."""

    def __init__(self, free: MultiPolygon, radius: float, grid_resolution: float = 0.05) -> None:
        self.radius = radius
        self.free = MultiPolygon([orient(p, 1.0) for p in free.geoms if p.area > 1e-6])
        self.islands: list[Polygon] = list(self.free.geoms)
        shapely.prepare(self.free)
        self._tol_free = self.free.buffer(1e-7)
        shapely.prepare(self._tol_free)
        self._edges_a, self._edges_b = self._boundary_edges()
        self.vertices, self.vertex_island, self._prev, self._next = self._reflex_vertices()
        self._dist, self._pred = self._visibility_graph()
        self.grid = self._grid(grid_resolution)

    # --- construction ---------------------------------------------------------------------
    def _rings(self):
        for i, poly in enumerate(self.islands):
            for ring in [poly.exterior, *poly.interiors]:
                yield i, np.asarray(ring.coords)[:-1]

    def _boundary_edges(self):
        a, b = [], []
        for _, pts in self._rings():
            a.append(pts)
            b.append(np.roll(pts, -1, axis=0))
        return np.concatenate(a), np.concatenate(b)

    def _reflex_vertices(self):
        verts, isl, prev, nxt = [], [], [], []
        for i, pts in self._rings():
            p, n = np.roll(pts, 1, axis=0), np.roll(pts, -1, axis=0)
            # Free space lies left of every ring (orient(): exterior CCW, holes CW); a right turn is reflex.
            turn = _cross(pts[:, 0] - p[:, 0], pts[:, 1] - p[:, 1], n[:, 0] - pts[:, 0], n[:, 1] - pts[:, 1])
            keep = turn < -1e-12
            verts.append(pts[keep])
            prev.append(p[keep])
            nxt.append(n[keep])
            isl.append(np.full(keep.sum(), i))
        return np.concatenate(verts), np.concatenate(isl), np.concatenate(prev), np.concatenate(nxt)

    def _visible(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Segments p[i]->q[i] lying in the free space.

        No proper crossing of a boundary edge decides it, except for a segment that passes through a
        boundary vertex (it may slip out there): those are also sampled against the polygons.
        """
        if len(p) == 0:
            return np.zeros(0, bool)
        ok = ~_crossing_any(p, q, self._edges_a, self._edges_b, EPS)
        idx = np.flatnonzero(ok)
        if len(idx):
            through = self._through_vertex(p[idx], q[idx])
            idx = idx[through]
        if len(idx):
            length = np.linalg.norm(q[idx] - p[idx], axis=1)
            n = np.maximum(2, np.ceil(length / SAMPLE_STEP).astype(int) + 1)
            t = [np.linspace(0, 1, k)[1:-1] for k in n]
            owner = np.repeat(idx, [len(x) for x in t])
            tt = np.concatenate(t)
            pts = p[owner] + (q[owner] - p[owner]) * tt[:, None]
            inside = shapely.contains_xy(self._tol_free, pts[:, 0], pts[:, 1])
            bad = np.unique(owner[~inside])
            ok[bad] = False
        return ok

    def _through_vertex(self, p: np.ndarray, q: np.ndarray, tol: float = 1e-7) -> np.ndarray:
        """Which segments pass within ``tol`` of a boundary vertex strictly between their ends
        (:func:`_through_any`)."""
        return _through_any(p, q, self._edges_a, tol)

    def _tangent(self, v_idx: np.ndarray, other: np.ndarray) -> np.ndarray:
        """Edge from reflex vertex v to ``other`` keeps both ring neighbours of v on one side."""
        v = self.vertices[v_idx]
        d = other - v
        s1 = _cross(d[:, 0], d[:, 1], *(self._prev[v_idx] - v).T)
        s2 = _cross(d[:, 0], d[:, 1], *(self._next[v_idx] - v).T)
        return s1 * s2 >= -1e-12

    def _visibility_graph(self):
        n = len(self.vertices)
        if n == 0:
            return np.zeros((0, 0)), np.zeros((0, 0), int)
        i, j = np.triu_indices(n, k=1)
        same = self.vertex_island[i] == self.vertex_island[j]
        i, j = i[same], j[same]
        keep = self._tangent(i, self.vertices[j]) & self._tangent(j, self.vertices[i])
        i, j = i[keep], j[keep]
        vis = self._visible(self.vertices[i], self.vertices[j])
        i, j = i[vis], j[vis]
        w = np.linalg.norm(self.vertices[i] - self.vertices[j], axis=1)
        graph = csr_matrix(
            (np.concatenate([w, w]), (np.concatenate([i, j]), np.concatenate([j, i]))), shape=(n, n)
        )
        dist, pred = shortest_path(graph, method="D", directed=False, return_predecessors=True)
        return dist, pred

    def _grid(self, res: float) -> OccupancyGrid:
        minx, miny, maxx, maxy = self.free.bounds
        origin = np.array([minx - res, miny - res])
        w = int(np.ceil((maxx - origin[0]) / res)) + 1
        h = int(np.ceil((maxy - origin[1]) / res)) + 1
        xs = origin[0] + (np.arange(w) + 0.5) * res
        ys = origin[1] + (np.arange(h) + 0.5) * res
        gx, gy = np.meshgrid(xs, ys)
        island = np.full((h, w), -1, int)
        for k, poly in enumerate(self.islands):
            inside = shapely.contains_xy(poly, gx, gy)
            island[inside] = k
        free = island >= 0
        inner = shapely.contains_xy(self.free.buffer(-res * 0.7072), gx, gy) & free
        return OccupancyGrid(origin, res, free, inner, island)

    # --- queries ----------------------------------------------------------------------------
    def island_of(self, p) -> int | None:
        """Index of the island holding point p (on its boundary counts), or None."""
        g = self.grid
        i, j = int((p[1] - g.origin[1]) // g.resolution), int((p[0] - g.origin[0]) // g.resolution)
        if 0 <= i < g.inner.shape[0] and 0 <= j < g.inner.shape[1] and g.inner[i, j]:
            return int(g.island[i, j])  # the whole cell is navigable: no polygon test needed
        pt = Point(float(p[0]), float(p[1]))
        for k, poly in enumerate(self.islands):
            if poly.distance(pt) <= 1e-7:
                return k
        return None

    def is_navigable(self, p) -> bool:
        return self.island_of(p) is not None

    def snap(self, p, island: int | None = None) -> np.ndarray:
        """The nearest navigable point to p (on ``island`` when given)."""
        pt = Point(float(p[0]), float(p[1]))
        target = self.free if island is None else self.islands[island]
        if target.distance(pt) <= 1e-9:
            return np.array([pt.x, pt.y])
        q = nearest_points(target, pt)[0]
        return np.array([q.x, q.y])

    def _join(self, p: np.ndarray, isl: int) -> tuple[np.ndarray, np.ndarray]:
        idx = np.flatnonzero(self.vertex_island == isl)
        idx = idx[
            self._tangent(idx, np.repeat(p[None], len(idx), axis=0))
        ]  # a shortest path bends only there
        if len(idx) == 0:
            return idx, np.zeros(0)
        vis = self._visible(np.repeat(p[None], len(idx), axis=0), self.vertices[idx])
        idx = idx[vis]
        return idx, np.linalg.norm(self.vertices[idx] - p, axis=1)

    def _solve(self, s, g):
        s, g = np.asarray(s, float)[:2], np.asarray(g, float)[:2]
        i_s, i_g = self.island_of(s), self.island_of(g)
        if i_s is None or i_g is None or i_s != i_g:
            return np.inf, None
        if self._visible(s[None], g[None])[0]:
            return float(np.linalg.norm(g - s)), [s, g]
        vs, ds = self._join(s, i_s)
        vg, dg = self._join(g, i_g)
        if len(vs) == 0 or len(vg) == 0:
            return np.inf, None
        total = ds[:, None] + self._dist[np.ix_(vs, vg)] + dg[None, :]
        a, b = np.unravel_index(np.argmin(total), total.shape)
        best = float(total[a, b])
        if not np.isfinite(best):
            return np.inf, None
        chain = [vg[b]]
        while chain[-1] != vs[a]:
            chain.append(self._pred[vs[a], chain[-1]])
        return best, [s, *self.vertices[chain[::-1]], g]

    def distance_to(self, g):
        """A function p -> geodesic distance from p to the fixed goal g (the goal's join is cached)."""
        g = np.asarray(g, float)[:2]
        i_g = self.island_of(g)
        vg, dg = self._join(g, i_g) if i_g is not None else (np.zeros(0, int), np.zeros(0))

        def dist(p) -> float:
            p = np.asarray(p, float)[:2]
            i_p = self.island_of(p)
            if i_g is None or i_p != i_g:
                return np.inf
            if self._visible(p[None], g[None])[0]:
                return float(np.linalg.norm(g - p))
            vs, ds = self._join(p, i_p)
            if len(vs) == 0 or len(vg) == 0:
                return np.inf
            return float((ds[:, None] + self._dist[np.ix_(vs, vg)] + dg[None, :]).min())

        return dist

    def geodesic_distance(self, s, g) -> float:
        """Length of the shortest navigable path from s to g; inf when unreachable."""
        return self._solve(s, g)[0]

    def shortest_path(self, s, g) -> np.ndarray:
        """Waypoints (k, 2) of the shortest path; UnreachableError when there is none."""
        d, path = self._solve(s, g)
        if path is None:
            raise UnreachableError(
                f"no navigable path from {np.round(s, 3).tolist()} to {np.round(g, 3).tolist()} "
                f"for a {self.radius} m robot",
                fix="snap both points onto the same island first",
            )
        return np.asarray(path)
