"""The frontier baseline's occupancy grid, built from head-camera depth like a laser scan (paper §4.3).

In a lab with people (``TaskSpec.people``) the map forgets what moves: an obstacle cell that a later ray
passes through, with :data:`FORGET_MARGIN` of free ray beyond it, is free again (a person who walked on);
without people an obstacle cell stays one, as the paper's map keeps it. With evidence (noisy depth) the
rays' misses already lower an obstacle's log-odds until it is free.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from biovln_ms.baselines.frontier.params import FrontierParams

UNKNOWN, FREE, OCCUPIED = 0, 1, 2
SCAN_COLUMNS = 320  # image columns sampled per frame: rays 5 m away are ~2 cm apart
RAY_STEP = 0.7  # cells between the samples that mark a ray's cells free
# evidence mode (a noisy depth sensor): log-odds per cell, a hit adds HIT, a ray through it adds MISS;
# a cell is an obstacle above OCCUPIED_ABOVE (three hits in all: a noisy hit or two are cleared by the
# rays that later pass through the cell), free below FREE_BELOW
HIT, MISS, LOG_ODDS_LIMIT = 0.85, -0.4, 3.5
OCCUPIED_ABOVE, FREE_BELOW = 2.0, -0.2
#: cells of free ray that must lie beyond an obstacle cell for the ray to clear it (a ray grazing a wall's
#: cell where it ends clears nothing)
FORGET_MARGIN = 2


class Scan(NamedTuple):
    """One depth frame as a laser scan: camera ground position, per-column unit direction, free length."""

    cam: np.ndarray
    direction: np.ndarray
    free_len: np.ndarray


def backproject(
    z: np.ndarray, u: np.ndarray, v: np.ndarray, intrinsic: np.ndarray, extrinsic: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """World points (..., 3) of pixels (u, v) at depth z (OpenCV camera conventions), and the camera
    centre."""
    fx, fy, cx, cy = intrinsic[0, 0], intrinsic[1, 1], intrinsic[0, 2], intrinsic[1, 2]
    pc = np.stack([(u - cx) * z / fx, (v - cy) * z / fy, z], axis=-1)
    R, t = extrinsic[:3, :3], extrinsic[:3, 3]
    return (pc - t) @ R, -R.T @ t  # world = R^T (p - t)


class OccupancyMap:
    """A fixed-size grid centred on the start; ``lo``/``hi`` bound the observed part (rows, cols)."""

    def __init__(
        self,
        centre_xy,
        resolution: float = FrontierParams.resolution,
        extent: float = FrontierParams.extent,
        evidence: bool = False,
        forget: bool = False,
    ) -> None:
        """``evidence``: cells accumulate log-odds over frames (for noisy depth) instead of keeping the first
        obstacle they see; ``forget``: rays clear the obstacle cells they pass (things that move)."""
        self.forget = forget
        self.res = resolution
        self.n = round(extent / resolution)
        self.origin = np.asarray(centre_xy, float) - extent / 2
        self.grid = np.zeros((self.n, self.n), np.uint8)
        self.log_odds = np.zeros((self.n, self.n), np.float32) if evidence else None
        self.lo = np.array([self.n, self.n])
        self.hi = np.array([0, 0])
        # cells a depth frame has reached, kept once a frame frees the ground under the base (``base_xy``):
        # that ground is known free but not seen, so its edge is no frontier (None: every free cell is seen)
        self.seen: np.ndarray | None = None
        #: the last frame's obstacle points (world x, y): with evidence its cells need several frames to be
        #: obstacles, and a person walking up is here at once
        self.last_hits = np.zeros((0, 2))

    def cell(self, xy) -> np.ndarray:
        """The (row, col) of world point(s) ``xy`` (..., 2)."""
        return np.floor((np.asarray(xy, float) - self.origin) / self.res).astype(int)[..., ::-1]

    def centre(self, rc) -> np.ndarray:
        """The world (x, y) of the centre of cell(s) ``rc`` (..., 2)."""
        rc = np.asarray(rc)
        return self.origin + (rc[..., ::-1] + 0.5) * self.res

    def _grow_bbox(self, rc: np.ndarray) -> None:
        if len(rc):  # per column: a reduction along an (N, 2) array's first axis is slow
            r, c = rc[:, 0], rc[:, 1]
            self.lo = np.minimum(self.lo, [r.min(), c.min()])
            self.hi = np.maximum(self.hi, [r.max() + 1, c.max() + 1])

    def integrate(
        self,
        depth_m: np.ndarray,
        intrinsic: np.ndarray,
        extrinsic: np.ndarray,
        stride: int = FrontierParams.pixel_stride,
        clip: float = FrontierParams.depth_clip,
        floor_z: float = FrontierParams.floor_z,
        top_z: float = FrontierParams.top_z,
        column_stride: int | None = None,
        base_xy: np.ndarray | None = None,
    ) -> Scan:
        """Add one depth frame. The camera is level, so every image column maps to one ground
        azimuth: per column the cells up to the nearest obstacle point are free (a laser scan from
        depth); every sampled pixel between ``floor_z`` and ``top_z`` marks an obstacle. Rows are
        sampled every ``stride`` pixels, columns about ``SCAN_COLUMNS`` across the image.
        ``base_xy``: the robot's turning centre, for a camera mounted ahead of it (Fetch's): the rays start
        on the circle the camera sweeps about it and point outward, so none ever crosses the disc inside;
        the robot stands on that ground, and it is free too (with half a cell more, so that the camera's
        own cell joins the base's). Those cells are not :attr:`seen`.
        Returns the scan (camera position, per-column ground direction and free length)."""
        h, w = depth_m.shape
        column_stride = column_stride or max(1, w // SCAN_COLUMNS)
        v, u = np.mgrid[stride // 2 : h : stride, column_stride // 2 : w : column_stride]
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
        rc, owner = self.ray_cells(scan)
        clear = self._passed(scan, rc, owner) if self.forget and self.log_odds is None else None
        self.last_hits = pw[obstacle][:, :2]
        orc = self.cell(self.last_hits)
        orc = orc[self._in_bounds(orc)]
        if base_xy is not None:
            if self.seen is None:
                self.seen = np.zeros((self.n, self.n), bool)
            self.seen[rc[:, 0], rc[:, 1]] = self.seen[orc[:, 0], orc[:, 1]] = True
            base_xy = np.asarray(base_xy, float)
            blind = float(np.linalg.norm(scan.cam - base_xy)) + self.res / 2
            rc = np.concatenate([rc, self.disc_cells(base_xy, blind)])
        if self.log_odds is None:
            keep = self.grid[rc[:, 0], rc[:, 1]] != OCCUPIED
            if clear is not None:  # a ray passed them with free ray to spare: what stood there moved
                keep[: len(clear)] |= clear
            self.grid[rc[keep, 0], rc[keep, 1]] = FREE
            self.grid[orc[:, 0], orc[:, 1]] = OCCUPIED
        else:
            self._add_evidence(rc, orc)
        self._grow_bbox(rc)
        self._grow_bbox(orc)
        return scan

    def _add_evidence(self, free_rc: np.ndarray, hit_rc: np.ndarray) -> None:
        """A frame's misses and hits (each cell once), then the cells' states from their log-odds."""
        lo = self.log_odds
        flat = lo.reshape(-1)
        for rc, step in ((free_rc, MISS), (hit_rc, HIT)):
            if len(rc):  # each cell once: a repeated index writes the same value again
                cells = rc[:, 0] * self.n + rc[:, 1]
                flat[cells] = np.clip(flat[cells] + step, -LOG_ODDS_LIMIT, LOG_ODDS_LIMIT)
        touched = np.concatenate([free_rc, hit_rc]) if len(hit_rc) else free_rc
        r, c = touched.T
        value = lo[r, c]
        state = np.where(value < FREE_BELOW, FREE, UNKNOWN)
        self.grid[r, c] = np.where(value > OCCUPIED_ABOVE, OCCUPIED, state)

    def ray_cells(self, scan: Scan) -> tuple[np.ndarray, np.ndarray]:
        """Grid cells (row, col) along each column's free ray, sampled every ``RAY_STEP`` cell, and the
        column of each."""
        steps = np.maximum(1, (scan.free_len / (self.res * RAY_STEP)).astype(int))
        owner = np.repeat(np.arange(len(steps)), steps)
        frac = (np.arange(owner.size) - np.repeat(np.cumsum(steps) - steps, steps)) / np.repeat(steps, steps)
        pts = scan.cam + scan.direction[owner] * (scan.free_len[owner] * frac)[:, None]
        rc = self.cell(pts)
        ok = self._in_bounds(rc)
        return rc[ok], owner[ok]

    def _passed(self, scan: Scan, rc: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """Which ray cells ``rc`` (of columns ``owner``) lie at least :data:`FORGET_MARGIN` cells before
        their ray's end."""
        along = np.linalg.norm(self.centre(rc) - scan.cam, axis=1)
        return along <= scan.free_len[owner] - FORGET_MARGIN * self.res

    def disc_cells(self, centre: np.ndarray, radius: float) -> np.ndarray:
        """Grid cells (row, col) whose centres lie within ``radius`` of world point ``centre``."""
        c = self.cell(centre)
        k = int(np.ceil(radius / self.res))
        rc = c + np.stack(np.mgrid[-k : k + 1, -k : k + 1], axis=-1).reshape(-1, 2)
        rc = rc[np.linalg.norm(self.centre(rc) - centre, axis=1) <= radius]
        return rc[self._in_bounds(rc)]

    def _in_bounds(self, rc: np.ndarray) -> np.ndarray:
        """Mask of the (row, col) cells that lie on the grid."""
        return (rc[:, 0] >= 0) & (rc[:, 1] >= 0) & (rc[:, 0] < self.n) & (rc[:, 1] < self.n)

    def mark_occupied(self, xy) -> None:
        """Mark the cell of world point ``xy`` as an obstacle."""
        rc = self.cell(xy)
        self.grid[rc[0], rc[1]] = OCCUPIED
