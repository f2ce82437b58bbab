"""The frontier baseline's planner: where to go next on the occupancy map, and by which path (paper §4.3).

Path lengths come from Dijkstra over the known-free cells of the observed part of the map, with
obstacles grown by the robot radius plus a margin (:class:`PlanField`). Frontiers are free cells next
to unknown ones (seen ones: not the ground under a base that its camera never sees, ``OccupancyMap.seen``);
their 8-connected groups are split into square tiles of the cluster diameter (2 x 1.0 m, Table 15), and
every tile of at least 10 cells with a reachable cell is a candidate, at its reachable cell nearest the
robot. While the robot is boxed in (every cell around its own lies in the grown obstacles: beside a wall
seen late, in a doorway, or where a protocol leg starts, after a STOP at an instrument) the full growth
leaves it no cell to go to and it would give up with a STOP; it then plans on obstacles grown only
``ESCAPE_INFLATE`` cells (0.1 m) until it is out. Without sliding (``FrontierParams.step_clear``) a path
that grazes an obstacle loses the move, and a frontier along the obstacle (its noisy fringe) would draw
the robot into it, so while boxed in it first goes to the nearest cell clear of the full growth; a
known target still comes first. Which target wins is decided by the policy's
:class:`TargetRules`: a known target first (the frontier baseline's goal, VLFM's detected object), else the
chosen frontier, else the exhausted fallback.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from biovln_ms.baselines.frontier.occupancy import FREE, OCCUPIED, UNKNOWN, OccupancyMap
from biovln_ms.baselines.frontier.params import FrontierParams

CROP_PAD = 2  # cells kept around the observed part of the map, so that its border cells have neighbours
ESCAPE_INFLATE = 2  # cells: obstacle growth for planning while boxed in by the full growth
_NEIGHBOURS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]  # row-major order


class Candidate(NamedTuple):
    """A frontier tile the robot may explore."""

    path_length: float  # m from the robot
    position: np.ndarray  # world (x, y) of the tile's reachable cell nearest the robot
    cells: int  # frontier cells in the tile


class Plan(NamedTuple):
    """``mode``: "explore" (to a frontier) or "goal" (to a target to stop at); the path's waypoints end
    at the target's cell and are empty when it is unreachable; ``boxed``: planned while boxed in, on
    obstacles grown ``ESCAPE_INFLATE`` cells only."""

    mode: str
    target: np.ndarray
    path: list[np.ndarray]
    boxed: bool = False


@dataclass
class PlanField:
    """Shortest path lengths from the robot over the traversable cells of the map's observed crop."""

    occ_map: OccupancyMap
    lo: np.ndarray  # the crop's first (row, col) on the map
    grid: np.ndarray  # the crop of the map
    trav: np.ndarray  # known free and clear of the grown obstacles, plus the robot's own cell
    index: np.ndarray  # graph node of each traversable cell (row-major), -1 elsewhere
    dist: np.ndarray  # path length in cells from the robot, per node (inf: unreachable)
    pred: np.ndarray  # Dijkstra predecessor per node (negative at the robot and for unreachable nodes)

    @classmethod
    def compute(
        cls, occ_map: OccupancyMap, start_xy: np.ndarray, inflate_cells: int, round_growth: bool = False
    ) -> PlanField:
        """``inflate_cells``: obstacle growth, in 4-connected steps (a diamond: diagonally it reaches
        1/sqrt(2) as far), or with ``round_growth`` a disc of one cell more (as far every way)."""
        lo = np.maximum(occ_map.lo - CROP_PAD, 0)
        hi = np.minimum(occ_map.hi + CROP_PAD, occ_map.n)
        g = occ_map.grid[lo[0] : hi[0], lo[1] : hi[1]]
        if round_growth:
            occ = ndimage.binary_dilation(g == OCCUPIED, disk(inflate_cells + 1))
        else:
            occ = ndimage.binary_dilation(g == OCCUPIED, iterations=inflate_cells)
        trav = (g == FREE) & ~occ
        s = np.clip(occ_map.cell(start_xy) - lo, 0, np.array(g.shape) - 1)
        trav[s[0], s[1]] = True  # the robot's own cell
        n = int(trav.sum())
        h, w = g.shape
        padded = np.full((h + 2, w + 2), -1)  # graph node of each cell, -1 elsewhere and off the crop
        padded[1:-1, 1:-1][trav] = np.arange(n)
        index = padded[1:-1, 1:-1]
        # each node's neighbours, in ascending node order (row-major numbering): CSR rows with sorted indices
        neighbours = np.stack([padded[1 + y : h + 1 + y, 1 + x : w + 1 + x][trav] for y, x in _NEIGHBOURS], 1)
        edge = neighbours >= 0
        weights = np.broadcast_to([math.hypot(y, x) for y, x in _NEIGHBOURS], edge.shape)[edge]
        graph = csr_matrix((weights, neighbours[edge], np.r_[0, np.cumsum(edge.sum(1))]), shape=(n, n))
        graph.has_sorted_indices = True
        dist, pred = dijkstra(graph, indices=index[s[0], s[1]], return_predecessors=True)
        return cls(occ_map, lo, g, trav, index, dist, pred)

    def reachable(self) -> np.ndarray:
        """Mask (over the crop) of the traversable cells the robot can reach."""
        mask = np.zeros_like(self.trav)
        mask[self.trav] = np.isfinite(self.dist)
        return mask

    def reachable_centres(self) -> np.ndarray:
        """World (x, y) of the reachable cells, row-major."""
        return self.occ_map.centre(np.argwhere(self.reachable()) + self.lo)

    def is_reachable(self, xy: np.ndarray) -> bool:
        """Whether the cell of world point ``xy`` is in the crop, traversable and reachable."""
        rc = self.occ_map.cell(xy) - self.lo
        if not ((0 <= rc).all() and (rc < np.array(self.grid.shape)).all()):
            return False
        node = self.index[rc[0], rc[1]]
        return bool(node >= 0 and np.isfinite(self.dist[node]))

    def path_to(self, xy: np.ndarray) -> list[np.ndarray]:
        """Cell centres from the robot's cell to that of ``xy`` (empty when that cell is not traversable)."""
        t = self.occ_map.cell(xy) - self.lo
        node = self.index[t[0], t[1]]
        if node < 0:
            return []
        chain = []
        while node >= 0:
            chain.append(node)
            node = self.pred[node]
        cells = np.argwhere(self.index >= 0)  # row-major: the nodes' numbering
        return [self.occ_map.centre(cells[k] + self.lo) for k in chain[::-1]]


class TargetRules(Protocol):
    """The policy's decisions on a plan field (the frontier baseline's; VLFM and LLM-Frontier override)."""

    def known_target(self, field: PlanField) -> np.ndarray | None:
        """Where to go instead of exploring, or None."""

    def choose(self, candidates: list[Candidate], pose: np.ndarray) -> np.ndarray:
        """Which frontier to explore."""

    def exhausted(self, field: PlanField, pose: np.ndarray) -> np.ndarray:
        """Where to go (and stop) when no frontier is left."""


def disk(radius: int) -> np.ndarray:
    """A boolean disc of ``radius`` cells (a structuring element)."""
    y, x = np.mgrid[-radius : radius + 1, -radius : radius + 1]
    return x * x + y * y <= radius * radius


def boxed_in(occ_map: OccupancyMap, xy: np.ndarray, grow: int) -> bool:
    """Whether at most the cell of ``xy`` is clear, among it and its 8 neighbours, of the occupied cells
    grown by ``grow`` cells."""
    rc = occ_map.cell(xy)
    lo = np.maximum(rc - grow - 1, 0)
    window = occ_map.grid[lo[0] : rc[0] + grow + 2, lo[1] : rc[1] + grow + 2] == OCCUPIED
    r, c = rc - lo
    near = ndimage.binary_dilation(window, disk(grow))[r - 1 : r + 2, c - 1 : c + 2]
    return bool(near.sum() >= near.size - 1)


def clear_cell(field: PlanField, grow: int) -> np.ndarray | None:
    """The reachable cell of ``field`` nearest the robot by path that lies clear of the occupied cells grown
    by ``grow`` cells (world x, y), or None."""
    occ = ndimage.binary_dilation(field.grid == OCCUPIED, iterations=grow)
    cells = np.argwhere(field.reachable() & ~occ)
    if not len(cells):
        return None
    d = field.dist[field.index[cells[:, 0], cells[:, 1]]]
    return field.occ_map.centre(cells[int(np.argmin(d))] + field.lo)


class FrontierPlanner:
    """Plans a target and its path on the map; frontiers found unreachable are banned for the episode."""

    def __init__(self, params: FrontierParams, rules: TargetRules) -> None:
        self.params, self.rules = params, rules
        self.banned: list[np.ndarray] = []
        #: grow obstacles by a disc, not a diamond (set by the controller for a while after a long wait: a
        #: diagonal path that the diamond lets pass nearer an obstacle than the people check allows)
        self.round_growth = False

    def plan(self, occ_map: OccupancyMap, pose: np.ndarray) -> Plan:
        """A known target if the rules have one, else the chosen frontier, else the exhausted fallback."""
        grow = self.params.inflate_cells
        boxed = boxed_in(occ_map, pose[:2], grow + self.round_growth)
        field = PlanField.compute(
            occ_map, pose[:2], ESCAPE_INFLATE if boxed else grow, self.round_growth and not boxed
        )
        mode, target = "goal", self.rules.known_target(field)
        if target is None and boxed and self.params.step_clear:
            mode, target = "explore", clear_cell(field, grow)
        if target is None:
            candidates = self.candidates(field)
            if candidates:
                mode, target = "explore", self.rules.choose(candidates, pose)
            else:
                mode, target = "goal", self.rules.exhausted(field, pose)
        return Plan(mode, target, field.path_to(target), boxed)

    def ban(self, target: np.ndarray) -> None:
        """No frontier within the cluster radius of ``target`` is a candidate any more."""
        self.banned.append(target)

    def candidates(self, field: PlanField) -> list[Candidate]:
        """The reachable frontier tiles of at least ``min_frontier_cells`` cells, away from banned targets."""
        p = self.params
        eight = np.ones((3, 3))  # 8-connectivity
        frontier = (field.grid == FREE) & ndimage.binary_dilation(field.grid == UNKNOWN, structure=eight)
        if field.occ_map.seen is not None:  # the ground under the base that no frame has seen is no frontier
            lo, hi = field.lo, field.lo + np.array(field.grid.shape)
            frontier &= field.occ_map.seen[lo[0] : hi[0], lo[1] : hi[1]]
        labels, _ = ndimage.label(frontier, structure=eight)
        cells = np.argwhere(frontier)  # row-major
        tile = max(1, round(2 * p.cluster_radius / field.occ_map.res))
        keys = cells // tile  # a group wider than the cluster diameter is split into tiles of it
        # tiles in the order (group label, tile row, tile column), each tile's cells row-major
        tiles = np.c_[labels[cells[:, 0], cells[:, 1]], keys]
        order = np.lexsort((np.arange(len(cells)), tiles[:, 2], tiles[:, 1], tiles[:, 0]))
        cells, tiles = cells[order], tiles[order]
        starts = np.flatnonzero(np.r_[True, (tiles[1:] != tiles[:-1]).any(1)])
        reachable = field.reachable()[cells[:, 0], cells[:, 1]]
        out = []
        for a, b in zip(starts, np.r_[starts[1:], len(cells)]):
            if b - a < p.min_frontier_cells or not reachable[a:b].any():
                continue
            reach = cells[a:b][reachable[a:b]]
            d = field.dist[field.index[reach[:, 0], reach[:, 1]]]
            best = int(np.argmin(d))
            world = field.occ_map.centre(reach[best] + field.lo)
            if any(np.linalg.norm(world - t) < p.cluster_radius for t in self.banned):
                continue
            out.append(Candidate(float(d[best]) * field.occ_map.res, world, int(b - a)))
        return out


def nearest_candidate(candidates: list[Candidate]) -> np.ndarray:
    """The frontier with the shortest path (the first of equals)."""
    return min(candidates, key=lambda c: c.path_length).position


def goal_if_reachable(field: PlanField, goal: np.ndarray) -> np.ndarray | None:
    """The goal, once its cell is known free and reachable on the map."""
    return goal if field.is_reachable(goal) else None


def nearest_reachable(field: PlanField, point: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """The reachable cell nearest ``point`` (``fallback`` when none is reachable)."""
    world = field.reachable_centres()
    if len(world) == 0:
        return fallback
    return world[np.argmin(np.linalg.norm(world - point, axis=1))]
