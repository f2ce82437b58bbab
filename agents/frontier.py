"""Frontier exploration from depth only (paper §4.3, Table 15 parameters).

A 0.05 m occupancy grid (100 x 100 m) is built from the head camera's depth: sampled pixels are
back-projected with the camera's intrinsics and extrinsics (depth clipped at 10 m); points between
0.05 m and 1.0 m high are obstacles, and along each image column (one ground azimuth for a level
camera) the cells before the nearest obstacle are free, like a laser scan. Frontiers
are free cells next to unknown ones; 8-connected groups of at least 10 cells whose extent stays within
the 1.0 m cluster radius (larger groups are split into 1 m tiles) are the candidates. The robot goes to
the nearest candidate by path length on its own map (Dijkstra over known-free cells, obstacles grown
by the robot radius) and re-plans as the map grows.

Goal rule (the paper leaves it implicit): the policy is given the goal position, and uses it only to
decide when to go there and stop — as soon as the goal cell is known free and reachable on its own
map it navigates to it and STOPs within half a step (or when a step would not bring it closer). With
no frontier left and the goal never seen, it goes to the known free cell nearest the goal and stops.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from biovln_ms.agents.policy import FORWARD, STOP, TURN_LEFT, TURN_RIGHT, Policy

UNKNOWN, FREE, OCCUPIED = 0, 1, 2
_NEIGHBOURS = [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)]


class Scan(NamedTuple):
    """One depth frame as a laser scan: camera ground position, per-column unit direction, free length."""

    cam: np.ndarray
    direction: np.ndarray
    free_len: np.ndarray


def backproject(z: np.ndarray, u: np.ndarray, v: np.ndarray, intrinsic: np.ndarray, extrinsic: np.ndarray):
    """World points (..., 3) of pixels (u, v) at depth z (OpenCV camera conventions), and the camera centre."""
    fx, fy, cx, cy = intrinsic[0, 0], intrinsic[1, 1], intrinsic[0, 2], intrinsic[1, 2]
    pc = np.stack([(u - cx) * z / fx, (v - cy) * z / fy, z], axis=-1)
    R, t = extrinsic[:3, :3], extrinsic[:3, 3]
    return (pc - t) @ R, -R.T @ t  # world = R^T (p - t)


class OccupancyMap:
    """A fixed-size grid centred on the start; ``bbox`` tracks the observed part."""

    def __init__(self, centre_xy, resolution: float = 0.05, extent: float = 100.0) -> None:
        self.res = resolution
        self.n = int(round(extent / resolution))
        self.origin = np.asarray(centre_xy, float) - extent / 2
        self.grid = np.zeros((self.n, self.n), np.uint8)
        self.lo = np.array([self.n, self.n])
        self.hi = np.array([0, 0])

    def cell(self, xy) -> np.ndarray:
        return np.floor((np.asarray(xy, float) - self.origin) / self.res).astype(int)[..., ::-1]  # (row, col)

    def centre(self, rc) -> np.ndarray:
        rc = np.asarray(rc)
        return self.origin + (rc[..., ::-1] + 0.5) * self.res

    def _grow_bbox(self, rc: np.ndarray) -> None:
        if len(rc):
            self.lo = np.minimum(self.lo, rc.min(0))
            self.hi = np.maximum(self.hi, rc.max(0) + 1)

    def integrate(self, depth_m: np.ndarray, intrinsic: np.ndarray, extrinsic: np.ndarray, stride: int = 8,
                  clip: float = 10.0, floor_z: float = 0.05, top_z: float = 1.0, column_stride: int | None = None) -> Scan:
        """Add one depth frame. The camera is level, so every image column maps to one ground
        azimuth: per column the cells up to the nearest obstacle point are free (a laser scan from
        depth); every sampled pixel between ``floor_z`` and ``top_z`` marks an obstacle. Columns are
        sampled densely enough (about 320 across the image) that rays 5 m away are ~2 cm apart.
        Returns the scan (camera position, per-column ground direction and free length)."""
        h, w = depth_m.shape
        column_stride = column_stride or max(1, w // 320)
        v, u = np.mgrid[stride // 2:h:stride, column_stride // 2:w:column_stride]
        z = depth_m[v, u]
        hit = (z > 0) & (z <= clip)
        pw, cam = backproject(np.where(hit, z, clip), u, v, intrinsic, extrinsic)
        d2 = np.linalg.norm(pw[..., :2] - cam[:2], axis=-1)
        obstacle = hit & (pw[..., 2] > floor_z) & (pw[..., 2] < top_z)
        nearest = np.where(obstacle, d2, np.inf).min(axis=0)
        seen = np.where(hit, d2, 0.0).max(axis=0)
        free_len = np.where(np.isfinite(nearest), nearest - self.res, seen)
        # ground direction of each column (from its farthest point)
        direction = pw[-1, :, :2] - cam[:2]
        direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-9)
        scan = Scan(cam[:2], direction, free_len)
        rc, _ = self.ray_cells(scan)
        keep = self.grid[rc[:, 0], rc[:, 1]] != OCCUPIED
        self.grid[rc[keep, 0], rc[keep, 1]] = FREE
        orc = self.cell(pw[obstacle][:, :2])
        orc = orc[self._in_bounds(orc)]
        self.grid[orc[:, 0], orc[:, 1]] = OCCUPIED
        self._grow_bbox(rc)
        self._grow_bbox(orc)
        return scan

    def ray_cells(self, scan: Scan) -> tuple[np.ndarray, np.ndarray]:
        """Grid cells (row, col) along each column's free ray, sampled at 0.7 cell, and the column of each."""
        steps = np.maximum(1, (scan.free_len / (self.res * 0.7)).astype(int))
        owner = np.repeat(np.arange(len(steps)), steps)
        frac = (np.arange(owner.size) - np.repeat(np.cumsum(steps) - steps, steps)) / np.repeat(steps, steps)
        pts = scan.cam + scan.direction[owner] * (scan.free_len[owner] * frac)[:, None]
        rc = self.cell(pts)
        ok = self._in_bounds(rc)
        return rc[ok], owner[ok]

    def _in_bounds(self, rc: np.ndarray) -> np.ndarray:
        """Mask of the (row, col) cells that lie on the grid."""
        return (rc[:, 0] >= 0) & (rc[:, 1] >= 0) & (rc[:, 0] < self.n) & (rc[:, 1] < self.n)

    def mark_occupied(self, xy) -> None:
        rc = self.cell(xy)
        self.grid[rc[0], rc[1]] = OCCUPIED


class FrontierPolicy(Policy):
    name = "frontier"
    obs_mode = "rgbd"

    def __init__(self, resolution: float = 0.05, extent: float = 100.0, cluster_radius: float = 1.0,
                 min_frontier_cells: int = 10, depth_clip: float = 10.0, pixel_stride: int = 8, replan_every: int = 4,
                 robot_radius: float = 0.2, margin: float = 0.05) -> None:
        self.res, self.extent = resolution, extent
        self.cluster_radius, self.min_cells = cluster_radius, min_frontier_cells
        self.clip, self.stride, self.replan_every = depth_clip, pixel_stride, replan_every
        self.inflate = int(math.ceil((robot_radius + margin) / resolution))

    def reset(self, episode_info: dict) -> None:
        env = episode_info["env"]
        self.env = env
        self.goal = np.asarray(episode_info["episode"]["goals"][0]["position"][:2], float)
        if env.cfg.goal_mode == "centroid":
            self.goal = np.asarray(env._ctx.goal, float)
        pose = env._planar()
        self.map = OccupancyMap(pose[:2], self.res, self.extent)
        self.step_len = env.cfg.forward_step
        self.turn = math.radians(env.cfg.turn_deg)
        self.path: list[np.ndarray] = []
        self.target = None
        self.mode = "explore"
        self.banned: list[np.ndarray] = []
        self._since_plan = 10 ** 6
        self._last = None
        self._stuck = 0

    # --- map ---------------------------------------------------------------------------------
    def _integrate(self, obs) -> Scan:
        depth = obs["sensor_data"]["head"]["depth"][0, ..., 0].cpu().numpy().astype(np.float32) / 1000.0
        params = obs["sensor_param"]["head"]
        return self.map.integrate(depth, params["intrinsic_cv"][0].cpu().numpy(), params["extrinsic_cv"][0].cpu().numpy(),
                           self.stride, self.clip)

    def _crop(self):
        lo = np.maximum(self.map.lo - 2, 0)
        hi = np.minimum(self.map.hi + 2, self.map.n)
        return lo, hi, self.map.grid[lo[0]:hi[0], lo[1]:hi[1]]

    def _plan_field(self, start_xy):
        """Path distances (cells) from the robot over traversable known-free cells of the crop."""
        lo, hi, g = self._crop()
        occ = ndimage.binary_dilation(g == OCCUPIED, iterations=self.inflate)
        trav = (g == FREE) & ~occ
        s = self.map.cell(start_xy) - lo
        s = np.clip(s, 0, np.array(g.shape) - 1)
        trav[s[0], s[1]] = True  # the robot's own cell
        idx = -np.ones(g.shape, int)
        idx[trav] = np.arange(trav.sum())
        rows, cols, wts = [], [], []
        ys, xs = np.nonzero(trav)
        for dy, dx in _NEIGHBOURS:
            y2, x2 = ys + dy, xs + dx
            ok = (y2 >= 0) & (y2 < g.shape[0]) & (x2 >= 0) & (x2 < g.shape[1])
            ok[ok] &= trav[y2[ok], x2[ok]]
            rows.append(idx[ys[ok], xs[ok]])
            cols.append(idx[y2[ok], x2[ok]])
            wts.append(np.full(ok.sum(), math.hypot(dy, dx)))
        n = int(trav.sum())
        graph = coo_matrix((np.concatenate(wts), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsr()
        dist, pred = dijkstra(graph, indices=idx[s[0], s[1]], return_predecessors=True)
        return lo, g, trav, idx, dist, pred

    def _frontier_targets(self, lo, g, trav, idx, dist) -> list[tuple[float, np.ndarray]]:
        free = g == FREE
        unknown = g == UNKNOWN
        frontier = free & ndimage.binary_dilation(unknown, structure=np.ones((3, 3)))
        labels, k = ndimage.label(frontier, structure=np.ones((3, 3)))
        out = []
        tile = max(1, int(round(2 * self.cluster_radius / self.res)))
        for lab in range(1, k + 1):
            cells = np.argwhere(labels == lab)
            # split clusters larger than the cluster radius into tiles of that size
            keys = cells // tile
            for key in np.unique(keys, axis=0):
                part = cells[(keys == key).all(1)]
                if len(part) < self.min_cells:
                    continue
                reach = [(dist[idx[c[0], c[1]]], c) for c in part if trav[c[0], c[1]] and np.isfinite(dist[idx[c[0], c[1]]])]
                if not reach:
                    continue
                d, c = min(reach, key=lambda t: t[0])
                world = self.map.centre(c + lo)
                if any(np.linalg.norm(world - b) < self.cluster_radius for b in self.banned):
                    continue
                out.append((d * self.res, world, len(part)))
        return out

    def _path_to(self, lo, idx, pred, target_xy) -> list[np.ndarray]:
        t = self.map.cell(target_xy) - lo
        node = idx[t[0], t[1]]
        if node < 0:
            return []
        chain = []
        while node >= 0:
            chain.append(node)
            node = pred[node]
        cells = np.argwhere(idx >= 0)  # row-major, the order in which _plan_field numbered the nodes
        return [self.map.centre(cells[n] + lo) for n in chain[::-1]]

    def choose(self, candidates: list, pose) -> np.ndarray:
        """Nearest frontier by path length (LLM-Frontier overrides this)."""
        return min(candidates, key=lambda c: c[0])[1]

    def _known_target(self, lo, g, trav, idx, dist) -> np.ndarray | None:
        """Where to go instead of exploring: the goal, once its cell is known free and reachable."""
        gc = self.map.cell(self.goal) - lo
        if (0 <= gc).all() and (gc < np.array(g.shape)).all() and trav[gc[0], gc[1]] and np.isfinite(dist[idx[gc[0], gc[1]]]):
            return self.goal
        return None

    def _exhausted(self, lo, trav, idx, dist, pose) -> np.ndarray:
        """Nothing left to explore and the goal never seen: the reachable known free cell nearest the goal."""
        cells = np.argwhere(trav & np.isfinite(np.where(idx >= 0, dist[np.maximum(idx, 0)], np.inf)))
        if len(cells) == 0:
            return pose[:2]
        world = self.map.centre(cells + lo)
        return world[np.argmin(np.linalg.norm(world - self.goal, axis=1))]

    def _replan(self, pose) -> None:
        lo, g, trav, idx, dist, pred = self._plan_field(pose[:2])
        known = self._known_target(lo, g, trav, idx, dist)
        if known is not None:
            self.mode, self.target = "goal", known
        else:
            cands = self._frontier_targets(lo, g, trav, idx, dist)
            if cands:
                self.mode, self.target = "explore", self.choose(cands, pose)
            else:
                self.mode, self.target = "goal", self._exhausted(lo, trav, idx, dist, pose)
        self.path = self._path_to(lo, idx, pred, self.target)
        self._since_plan = 0

    # --- control -----------------------------------------------------------------------------
    def act(self, obs, info: dict) -> int:
        self._integrate(obs)
        pose = self.env._planar()
        p, yaw = pose[:2], float(pose[2])
        blocked = self._last is not None and self._last[1] == FORWARD and np.linalg.norm(p - self._last[0]) < 0.02
        if blocked:  # contact the map missed (e.g. a low object): mark it and re-plan
            self.map.mark_occupied(p + (0.2 + self.res) * np.array([math.cos(yaw), math.sin(yaw)]))
            self._since_plan = 10 ** 6
        if self.mode == "goal" and self.target is not None and np.linalg.norm(self.target - p) < self.step_len / 2:
            return self._remember(p, STOP)
        if self._since_plan >= self.replan_every or not self.path or (self.mode == "explore" and np.linalg.norm(self.target - p) < 0.3):
            self._replan(pose)
        self._since_plan += 1
        if not self.path:
            if self.mode == "explore" and self.target is not None:
                self.banned.append(self.target)
            self._stuck += 1
            return self._remember(p, TURN_LEFT if self._stuck < 12 else STOP)
        self._stuck = 0
        while len(self.path) > 1 and np.linalg.norm(self.path[0] - p) < 0.3:
            self.path.pop(0)
        wp = self.path[0]
        err = (math.atan2(wp[1] - p[1], wp[0] - p[0]) - yaw + math.pi) % (2 * math.pi) - math.pi
        if abs(err) > self.turn / 2:
            return self._remember(p, TURN_LEFT if err > 0 else TURN_RIGHT)
        if self.mode == "goal":
            d = np.linalg.norm(self.target - p)
            ahead = p + self.step_len * np.array([math.cos(yaw), math.sin(yaw)])
            if np.linalg.norm(self.target - ahead) >= d and len(self.path) <= 2:
                return self._remember(p, STOP)
        return self._remember(p, FORWARD)

    def _remember(self, p, action: int) -> int:
        self._last = (p.copy(), action)
        return action
