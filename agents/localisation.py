"""Where the robot is without GPS+compass: dead reckoning of the commanded moves, corrected by matching each
depth scan against the robot's own occupancy map (a correlative scan matcher, Olson, ICRA 2009).

Everything runs in the episode frame: origin at the start pose, x along the start heading (the frame of
the ``pointgoal`` sensor). The policy never reads the simulator's pose: :meth:`Localiser.predict` moves
the estimate by the command it sent (a FORWARD of ``forward_step``, a turn of ``turn_deg``, or the
decoded continuous command), and :meth:`Localiser.correct` searches a window around that prediction for
the pose at which the scan's obstacle points fall best on the obstacles of the map built so far.

The matcher (:class:`MatcherParams`):

* **Score.** A likelihood field over the map near the prediction: exp(-d^2 / 2 sigma^2), d the distance
  to the nearest occupied cell (``scipy.ndimage.distance_transform_edt``), sigma = 0.08 m; a pose's score
  is the field's mean over the scan points placed by that pose. Points on unknown ground score ~0
  whatever the pose, so they do not pull.
* **Window.** +-0.30 m and +-15 degrees around the prediction: the ``realistic`` preset's LoCoBot errors
  (x0.5) reach 0.23 m across and 14 degrees in heading per move at 3 sigma, and a blocked FORWARD
  without sliding leaves the robot 0.25 m behind the prediction.
* **Coarse to fine.** Coarse: every 0.05 m (one map cell, so a translation is an index shift) and
  every 1 degree (a point 3 m away moves 5 cm): 31 x 13 x 13 poses, with a field smooth enough not to
  fall between cells. Fine: +-1 coarse step around the coarse pick, in quarter steps (1.25 cm,
  0.25 degree), on the bilinearly interpolated field.
* **Ambiguity and weakness.** At each level the pick is, among the poses that score within
  ``tolerance`` (0.02) of the best, the one nearest the prediction: along a featureless wall or corridor
  the scores tie in the unconstrained direction and the prediction is kept there, while the constrained
  directions are corrected. Elsewhere this leans the pick toward the prediction by up to about a cell
  and half a degree (a prior; tighter tolerances drifted more on MS VAL, the map being the robot's
  own). The correction is dropped (the prediction kept) when fewer than ``min_support`` scan points,
  or fewer than ``min_support_fraction`` of them, lie on the map's obstacles at the picked pose: too
  little of the scan overlaps what was mapped to trust a match.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from biovln_ms.agents.frontier_map import OCCUPIED, SCAN_COLUMNS, OccupancyMap, backproject
from biovln_ms.agents.policy import FORWARD, TURN_LEFT, TURN_RIGHT, TaskSpec

__all__ = [
    "Localiser",
    "MatcherParams",
    "camera_mount",
    "extrinsic_at",
    "scan_points",
    "wrap",
]


def wrap(angle: float) -> float:
    """``angle`` in [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


@dataclass(frozen=True)
class MatcherParams:
    """The correlative scan matcher's search window, resolution and acceptance rules (see the module)."""

    linear_window: float = 0.30  # m, +- around the prediction in x and y
    angular_window: float = math.radians(15.0)  # rad, +- around the predicted heading
    linear_step: float = 0.05  # m, coarse translation step (a multiple of the map's resolution)
    angular_step: float = math.radians(1.0)  # rad, coarse rotation step
    refine: int = 4  # fine steps per coarse step, over +-1 coarse step around the coarse pick
    sigma: float = 0.08  # m, width of the likelihood field around occupied cells
    max_range: float = 5.0  # m, scan points farther from the camera are not matched (depth noise grows)
    max_points: int = 600  # scan points matched at most (a deterministic subsample of the 5 cm cells)
    tolerance: float = 0.02  # scores within this of the best are ties (mean field value, 0..1)
    prior_linear: float = 0.1  # m and ...
    prior_angular: float = 0.1  # ... rad: the scales of "nearest the prediction" among ties
    min_support: int = 30  # scan points within ~sigma of a mapped obstacle needed to accept a match
    min_support_fraction: float = 0.2  # ... and the fraction of the scan they must be


def camera_mount(extrinsic: np.ndarray) -> np.ndarray:
    """The head camera's 4x4 camera-to-base transform (OpenCV axes) for a camera on the base's vertical
    axis looking along its heading (the BioVLN base's): its height, tilt and roll taken from the
    extrinsics, whose planar part (x, y and heading in the world) is discarded."""
    cam2world = np.linalg.inv(np.vstack([np.asarray(extrinsic, float)[:3], [0.0, 0.0, 0.0, 1.0]]))
    optical = cam2world[:3, 2]
    yaw = math.atan2(optical[1], optical[0])
    c, s = math.cos(yaw), math.sin(yaw)
    mount = np.eye(4)
    mount[:3, :3] = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) @ cam2world[:3, :3]
    mount[2, 3] = cam2world[2, 3]
    return mount


def _base_to_frame(pose) -> np.ndarray:
    x, y, yaw = (float(v) for v in pose)
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0, x], [s, c, 0.0, y], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def extrinsic_at(pose, mount: np.ndarray) -> np.ndarray:
    """The 3x4 extrinsics (frame to camera, OpenCV) of a camera on ``mount`` with the base at ``pose``."""
    return np.linalg.inv(_base_to_frame(pose) @ mount)[:3]


def scan_points(
    depth_m: np.ndarray,
    intrinsic: np.ndarray,
    mount: np.ndarray,
    stride: int,
    clip: float,
    floor_z: float,
    top_z: float,
    max_range: float = MatcherParams.max_range,
    cell: float = 0.05,
) -> np.ndarray:
    """The obstacle points of a depth frame in the base frame (M, 2), sampled as the map samples them
    (every ``stride`` rows, ``SCAN_COLUMNS`` columns), within ``max_range`` of the camera and one per
    ``cell`` square (the centre of the points in it), so that near surfaces do not outweigh far ones."""
    h, w = depth_m.shape
    column_stride = max(1, w // SCAN_COLUMNS)
    v, u = np.mgrid[stride // 2 : h : stride, column_stride // 2 : w : column_stride]
    z = depth_m[v, u]
    hit = (z > 0) & (z <= clip)
    pb, cam = backproject(np.where(hit, z, clip), u, v, intrinsic, np.linalg.inv(mount)[:3])
    near = np.linalg.norm(pb[..., :2] - cam[:2], axis=-1) <= max_range
    pts = pb[hit & near & (pb[..., 2] > floor_z) & (pb[..., 2] < top_z)][:, :2]
    if not len(pts):
        return np.zeros((0, 2))
    k = np.floor(pts / cell).astype(np.int64)
    k -= k.min(0)
    # one key per cell, ordered as the cells' (x, y) keys sort
    _, inverse = np.unique(k[:, 0] * (k[:, 1].max() + 1) + k[:, 1], return_inverse=True)
    count = np.bincount(inverse)
    sums = np.stack([np.bincount(inverse, pts[:, i], len(count)) for i in (0, 1)], 1)
    return sums / count[:, None]


class Localiser:
    """The pose (x, y, yaw) in the episode frame: :meth:`predict` from each command, :meth:`correct` from
    each scan. ``accepted`` / ``rejected`` count the corrections made and those dropped as weak."""

    def __init__(self, params: MatcherParams | None = None) -> None:
        self.params = params or MatcherParams()
        self.reset()

    def reset(self, start_pose=(0.0, 0.0, 0.0)) -> np.ndarray:
        """Start at ``start_pose`` (the episode frame's origin by default); returns it."""
        self.pose = np.array(start_pose, float)
        self.prediction = self.pose.copy()
        self.accepted = self.rejected = 0
        return self.pose.copy()

    def predict(self, action, task: TaskSpec) -> np.ndarray:
        """Dead reckoning: move the estimate by the commanded ``action`` (a discrete action, or a
        continuous [forward, turn, stop] in [-1, 1], decoded as the base does) and return it."""
        if np.ndim(action) == 0:
            a = int(action)
            forward = task.forward_step if a == FORWARD else 0.0
            turn = {TURN_LEFT: 1.0, TURN_RIGHT: -1.0}.get(a, 0.0) * math.radians(task.turn_deg)
        else:
            a0, a1, a2 = (float(v) for v in np.asarray(action, float).reshape(-1)[:3])
            stop = a2 > 0
            forward = 0.0 if stop else (a0 + 1) / 2 * task.forward_step
            turn = 0.0 if stop else a1 * math.radians(task.turn_deg)
        x, y, yaw = self.pose
        self.pose = np.array([x + forward * math.cos(yaw), y + forward * math.sin(yaw), wrap(yaw + turn)])
        self.prediction = self.pose.copy()
        return self.pose.copy()

    def correct(self, points_xy: np.ndarray, occ_map: OccupancyMap) -> np.ndarray:
        """Match the scan (obstacle points in the base frame, (N, 2)) against ``occ_map`` around the
        prediction; returns the corrected pose, or the prediction when the match is weak."""
        pts = np.asarray(points_xy, float).reshape(-1, 2)
        p = self.params
        if len(pts) > p.max_points:
            pts = pts[np.linspace(0, len(pts) - 1, p.max_points).astype(int)]
        pose = self._match(pts, occ_map) if len(pts) >= p.min_support else None
        if pose is None:
            self.rejected += 1
        else:
            self.accepted += 1
            self.pose = pose
        return self.pose.copy()

    # --- the matcher ---------------------------------------------------------------------------------
    def _field(self, occ_map: OccupancyMap, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The likelihood field over the map's square around ``centre`` and the world (x, y) of its first
        cell's corner; None when no obstacle is mapped there."""
        p, res = self.params, occ_map.res
        half = math.ceil((p.max_range + p.linear_window + 4 * p.sigma) / res) + 1
        rc = occ_map.cell(centre)
        lo = np.clip(rc - half, 0, occ_map.n)
        hi = np.clip(rc + half + 1, 0, occ_map.n)
        occupied = occ_map.grid[lo[0] : hi[0], lo[1] : hi[1]] == OCCUPIED
        if not occupied.any():
            return None
        d = ndimage.distance_transform_edt(~occupied) * res
        return np.exp(-0.5 * (d / p.sigma) ** 2), occ_map.origin + lo[::-1] * res

    def _match(self, pts: np.ndarray, occ_map: OccupancyMap) -> np.ndarray | None:
        p, pred, res = self.params, self.prediction, occ_map.res
        found = self._field(occ_map, pred[:2])
        if found is None:
            return None
        field, corner = found
        # coarse: nearest-cell lookups, translations as index shifts
        shift = max(1, round(p.linear_step / res))
        nl, na = round(p.linear_window / (shift * res)), round(p.angular_window / p.angular_step)
        steps = np.arange(-nl, nl + 1)
        dth = np.arange(-na, na + 1) * p.angular_step
        world = self._place(pts, pred[:2], pred[2] + dth)  # (A, N, 2)
        col = np.floor((world[..., 0] - corner[0]) / res).astype(np.int64)
        row = np.floor((world[..., 1] - corner[1]) / res).astype(np.int64)
        # the field padded with zeros by 2 m + 1 cells (m the largest shift): a point m cells or more off
        # the field stays off it under every shift, so it is clamped to just outside, where it reads 0
        m = shift * nl
        (h, w), pad = field.shape, 2 * m + 1
        padded = np.pad(field, pad).ravel()
        at = (np.clip(row, -m - 1, h + m) + pad) * (w + 2 * pad) + np.clip(col, -m - 1, w + m) + pad
        moves = shift * (steps[:, None] * (w + 2 * pad) + steps[None, :])  # (dy, dx) as flat offsets
        score = padded.take(at[:, None, None, :] + moves[None, :, :, None]).mean(-1)  # (A, dy, dx)
        t = steps * shift * res
        a, i, j = self._pick(score, dth[:, None, None], t[None, :, None], t[None, None, :])
        coarse = pred + [t[j], t[i], dth[a]]
        # fine: +-1 coarse step around the coarse pick, bilinear lookups
        k = np.arange(-p.refine, p.refine + 1) / p.refine
        fdth, ft = k * p.angular_step, k * shift * res
        world = self._place(pts, coarse[:2], coarse[2] + fdth)  # (A, N, 2)
        gx = (world[..., 0] - corner[0]) / res - 0.5
        gy = (world[..., 1] - corner[1]) / res - 0.5
        gy = gy[:, None, None, :] + ft[None, :, None, None] / res
        gx = gx[:, None, None, :] + ft[None, None, :, None] / res
        gx, gy = np.broadcast_arrays(gx, gy)
        vals = ndimage.map_coordinates(field, [gy.ravel(), gx.ravel()], order=1, mode="constant", cval=0.0)
        score = vals.reshape(gx.shape).mean(-1)
        off = coarse - pred
        a, i, j = self._pick(
            score, off[2] + fdth[:, None, None], off[1] + ft[None, :, None], off[0] + ft[None, None, :]
        )
        pose = coarse + [ft[j], ft[i], fdth[a]]
        # support: scan points on mapped obstacles at the picked pose
        world = self._place(pts, pose[:2], np.array([pose[2]]))[0]
        on = ndimage.map_coordinates(
            field, [(world[:, 1] - corner[1]) / res - 0.5, (world[:, 0] - corner[0]) / res - 0.5], order=1
        )
        support = int((on > 0.5).sum())
        if support < p.min_support or support < p.min_support_fraction * len(pts):
            return None
        return np.array([pose[0], pose[1], wrap(pose[2])])

    @staticmethod
    def _place(pts: np.ndarray, xy: np.ndarray, yaws: np.ndarray) -> np.ndarray:
        """The base-frame points placed by a base at ``xy`` with each heading of ``yaws``: (A, N, 2)."""
        c, s = np.cos(yaws)[:, None], np.sin(yaws)[:, None]
        x = xy[0] + c * pts[:, 0] - s * pts[:, 1]
        y = xy[1] + s * pts[:, 0] + c * pts[:, 1]
        return np.stack([x, y], -1)

    def _pick(self, score: np.ndarray, dth, dy, dx) -> tuple[int, int, int]:
        """Among the poses scoring within ``tolerance`` of the best, the one nearest the prediction
        (offsets ``dth``, ``dy``, ``dx`` from it, broadcast to the score's shape)."""
        p = self.params
        near = score >= score.max() - p.tolerance
        cost = (dx / p.prior_linear) ** 2 + (dy / p.prior_linear) ** 2 + (dth / p.prior_angular) ** 2
        cost = np.where(near, np.broadcast_to(cost, score.shape), np.inf)
        a, i, j = np.unravel_index(int(np.argmin(cost)), score.shape)
        return int(a), int(i), int(j)
