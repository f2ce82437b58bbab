"""Where the robot is without GPS+compass: dead reckoning of the commanded moves, corrected by matching each
depth scan against the robot's own occupancy map (a correlative scan matcher, Olson, ICRA 2009).

Everything runs in the episode frame: origin at the start pose, x along the start heading (the frame of
the ``pointgoal`` sensor). The policy never reads the simulator's pose: :meth:`Localiser.predict` moves
the estimate by what the command it sent is expected to do, and :meth:`Localiser.correct` searches a
window around that prediction for the most probable pose given the scan and the move.

**The move** (:func:`motion`). The robot knows its drive's error model (``task.noise``: the LoCoBot
figures of :mod:`biovln_ms.noise`, scaled by the configured multiplier), as a real robot knows its
calibrated odometry. The prediction is the expected executed move: a FORWARD goes 0.25 m plus the mean
overshoot (8.5 mm under ``realistic``) and drifts 21 mm to the left; a turn over-rotates by 1.2 degrees
on average. The errors' standard deviations (along, across, heading: 42 mm, 76 mm, 4.6 degrees per
FORWARD and 16 mm, 32 mm, 3.7 degrees per turn under ``realistic``), floored at ``floor`` (half a map
cell and half a degree: what the matcher resolves), make the move's prior. Without sliding, a FORWARD
that meets an obstacle leaves the robot where it was, turned as the move turned it: the move has two
outcomes, and the prior is that of the nearer one. :func:`blocked_ahead` tells from the frame the
command was chosen on which outcome to expect (an obstacle in the body's path within a step, or a
view too near for the depth sensor to read): that one is the prediction, kept when the scan cannot
decide.

**The scan against the map** (:class:`MatcherParams`):

* **Map.** The scan is matched to every cell more likely occupied than not: with a noisy depth sensor
  (the map's evidence mode) a cell with positive log-odds, not only the planner's obstacles, which take
  three hits; those would leave the first frames and every newly seen surface with nothing to match.
* **Score.** A likelihood field: exp(-d^2 / 2 sigma^2), d the distance to the nearest such cell
  (``scipy.ndimage.distance_transform_edt``), sigma = 0.08 m; a pose's score is the field's mean over
  the scan points placed by that pose. Points on unknown ground score ~0 whatever the pose.
* **Most probable pose.** The log-posterior of a pose is ``readings`` times its score (the scan's
  log-likelihood; neighbouring points share the map's errors, so a scan counts as ``readings``
  independent readings, or as its points where it has fewer) minus half the squared Mahalanobis
  distance of its offset from the move's outcome. Along a featureless wall or corridor the score is
  flat in the unconstrained direction and the move's prior decides; a far jump must be paid for by the
  scan. (On 20 recorded MS VAL and TWO ROOM trajectories the drift changed little for ``readings``
  from 30 to 300.)
* **Window.** +-0.30 m and +-15 degrees around the prediction: 3 sigma of the ``realistic`` errors
  (0.23 m across and 14 degrees per FORWARD) and a blocked FORWARD (0.25 m behind the moved outcome).
* **Coarse to fine.** Coarse: every 0.05 m (one map cell, so a translation is an index shift) and
  every 1 degree (a point 3 m away moves 5 cm): 31 x 13 x 13 poses. Fine: two rounds of the 27 poses
  +-1/2 then +-1/4 of a coarse step around the pick (1.25 cm, 0.25 degree), on the bilinearly
  interpolated field.
* **Weak scans.** The correction is dropped (the prediction kept) when fewer than ``min_support`` scan
  points, or fewer than ``min_support_fraction`` of them, lie on mapped cells at the picked pose: too
  little of the scan overlaps what was mapped to trust a match.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from biovln_ms.baselines.frontier.occupancy import OCCUPIED, SCAN_COLUMNS, OccupancyMap, backproject
from biovln_ms.baselines.policy import FORWARD, STOP, TURN_LEFT, TURN_RIGHT, TaskSpec
from biovln_ms.noise import LOCOBOT_FORWARD, LOCOBOT_TURN

__all__ = [
    "Localiser",
    "MatcherParams",
    "blocked_ahead",
    "camera_mount",
    "extrinsic_at",
    "motion",
    "scan_points",
    "wrap",
]


def wrap(angle: float) -> float:
    """``angle`` in [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


@dataclass(frozen=True)
class MatcherParams:
    """The correlative scan matcher's search window, resolution, prior and acceptance rules (see the
    module)."""

    linear_window: float = 0.30  # m, +- around the prediction in x and y
    angular_window: float = math.radians(15.0)  # rad, +- around the predicted heading
    linear_step: float = 0.05  # m, coarse translation step (a multiple of the map's resolution)
    angular_step: float = math.radians(1.0)  # rad, coarse rotation step
    sigma: float = 0.08  # m, width of the likelihood field around mapped cells
    max_range: float = 5.0  # m, scan points farther from the camera are not matched (depth noise grows)
    max_points: int = 600  # scan points matched at most (a deterministic subsample of the 5 cm cells)
    readings: float = 100.0  # independent readings a scan counts as (its log-likelihood's weight)
    floor: tuple[float, float, float] = (0.025, 0.025, math.radians(0.5))  # least prior sd: m, m, rad
    min_support: int = 30  # scan points within ~sigma of a mapped cell needed to accept a match
    min_support_fraction: float = 0.2  # ... and the fraction of the scan they must be


def motion(forward: float, turn: float, multiplier: float) -> tuple[np.ndarray, np.ndarray]:
    """The expected executed (along, across, heading) of a command of ``forward`` m and ``turn`` rad under
    the drive's actuation noise (``biovln_ms.noise``, scaled by ``multiplier``), and its standard
    deviations."""
    if forward == 0 and turn == 0:  # STOP: the robot does not move
        return np.zeros(3), np.zeros(3)
    model = LOCOBOT_FORWARD if forward > 0 else LOCOBOT_TURN
    sign = np.array([1.0 if forward >= 0 else -1.0, 1.0, 1.0 if turn >= 0 else -1.0])
    bias = np.r_[model.position.mean, model.heading.mean]
    sd = np.sqrt(np.r_[model.position.variance, model.heading.variance])
    return np.array([forward, 0.0, turn]) + multiplier * sign * bias, multiplier * sd


def blocked_ahead(points_xy: np.ndarray, depth_m: np.ndarray, intrinsic: np.ndarray, task: TaskSpec) -> bool:
    """Whether a FORWARD from here would meet an obstacle: scan points (base frame) in the body's path
    within a step (three or more: a stray depth pixel is not an obstacle), or most of the view ahead (the
    image columns whose rays pass within the body's radius a step and a radius ahead) reading no depth,
    a surface nearer than the sensor's minimum range."""
    reach, radius = task.forward_step + task.robot_radius, task.robot_radius
    pts = np.asarray(points_xy, float).reshape(-1, 2)
    in_path = (pts[:, 0] > 0) & (pts[:, 0] < reach) & (np.abs(pts[:, 1]) < radius)
    if in_path.sum() >= 3:
        return True
    u = np.arange(depth_m.shape[1])
    ahead = np.abs(u - intrinsic[0, 2]) <= intrinsic[0, 0] * radius / reach
    return bool((depth_m[:, ahead] <= 0).mean() > 0.5)


def camera_mount(extrinsic: np.ndarray, offset: np.ndarray | None = None) -> np.ndarray:
    """The head camera's 4x4 camera-to-base transform (OpenCV axes) for a camera looking along the base's
    heading: its height, tilt and roll taken from the extrinsics, whose planar part (x, y and heading in
    the world) is discarded; it stands on the base's vertical axis (the BioVLN base's), or ``offset``
    (x ahead, y left, m) from it (Fetch's, ``frontier.camera_offset``)."""
    cam2world = np.linalg.inv(np.vstack([np.asarray(extrinsic, float)[:3], [0.0, 0.0, 0.0, 1.0]]))
    optical = cam2world[:3, 2]
    yaw = math.atan2(optical[1], optical[0])
    c, s = math.cos(yaw), math.sin(yaw)
    mount = np.eye(4)
    mount[:3, :3] = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) @ cam2world[:3, :3]
    mount[2, 3] = cam2world[2, 3]
    if offset is not None:
        mount[:2, 3] = offset
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
        self._heading = self.pose[2]  # of the last move's start: the frame of its along / across errors
        self._sd = np.array(self.params.floor)
        self._outcomes = [(self.pose[:2].copy(), self._sd[:2])]  # (x, y) and (along, across) sd
        self.accepted = self.rejected = 0
        self.blocked = False  # the last frame showed a FORWARD blocked (blocked_ahead)
        return self.pose.copy()

    def step(
        self,
        action,
        points_xy: np.ndarray,
        depth_m: np.ndarray,
        intrinsic: np.ndarray,
        task: TaskSpec,
        occ_map: OccupancyMap | None,
        scan_match: bool = True,
    ) -> np.ndarray:
        """One frame: unless it is the first (``occ_map`` None: no move yet, nothing mapped), the command
        sent on the previous step (``action``; None: STOP) dead-reckoned with the outcome the previous frame
        showed (:attr:`blocked`), then corrected by matching this frame's scan (``points_xy``, base frame)
        against ``occ_map`` when ``scan_match``; then whether this frame shows a FORWARD blocked. Returns
        the pose."""
        if occ_map is not None:
            self.predict(STOP if action is None else action, task, self.blocked)
            if scan_match:
                self.correct(points_xy, occ_map)
        self.blocked = blocked_ahead(points_xy, depth_m, intrinsic, task)
        return self.pose.copy()

    def predict(self, action, task: TaskSpec, blocked: bool = False) -> np.ndarray:
        """Dead reckoning: move the estimate by what the commanded ``action`` (a discrete action, or a
        continuous [forward, turn, stop] in [-1, 1], decoded as the base does) is expected to do, and
        return it. ``blocked``: the frame the command was chosen on showed a FORWARD blocked
        (:func:`blocked_ahead`); without sliding the robot is then expected to stay where it was."""
        if np.ndim(action) == 0:
            a = int(action)
            forward = task.forward_step if a == FORWARD else 0.0
            turn = {TURN_LEFT: 1.0, TURN_RIGHT: -1.0}.get(a, 0.0) * math.radians(task.turn_deg)
        else:
            a0, a1, a2 = (float(v) for v in np.asarray(action, float).reshape(-1)[:3])
            stop = a2 > 0
            forward = 0.0 if stop else (a0 + 1) / 2 * task.forward_step
            turn = 0.0 if stop else a1 * math.radians(task.turn_deg)
        mean, sd = motion(forward, turn, task.noise.actuation)
        x, y, yaw = self.pose
        c, s = math.cos(yaw), math.sin(yaw)
        floor = np.array(self.params.floor)
        self._heading, self._sd = yaw, np.hypot(sd, floor)
        moved = np.array([x + mean[0] * c - mean[1] * s, y + mean[0] * s + mean[1] * c])
        self._outcomes = [(moved, self._sd[:2])]
        if forward > 0 and not task.noise.sliding:  # or blocked: where it was, turned as the move turned it
            stayed = (np.array([x, y]), floor[:2])
            self._outcomes = [stayed, *self._outcomes] if blocked else [*self._outcomes, stayed]
        self.pose = np.r_[self._outcomes[0][0], wrap(yaw + mean[2])]
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
        cell's corner; None when nothing is mapped there."""
        p, res = self.params, occ_map.res
        half = math.ceil((p.max_range + p.linear_window + 4 * p.sigma) / res) + 1
        rc = occ_map.cell(centre)
        lo = np.clip(rc - half, 0, occ_map.n)
        hi = np.clip(rc + half + 1, 0, occ_map.n)
        mapped = occ_map.grid[lo[0] : hi[0], lo[1] : hi[1]] == OCCUPIED
        if occ_map.log_odds is not None:  # evidence mode: every cell more likely occupied than not
            mapped |= occ_map.log_odds[lo[0] : hi[0], lo[1] : hi[1]] > 0
        if not mapped.any():
            return None
        d = ndimage.distance_transform_edt(~mapped) * res
        return np.exp(-0.5 * (d / p.sigma) ** 2).astype(np.float32), occ_map.origin + lo[::-1] * res

    def _match(self, pts: np.ndarray, occ_map: OccupancyMap) -> np.ndarray | None:
        p, pred, res = self.params, self.prediction, occ_map.res
        found = self._field(occ_map, pred[:2])
        if found is None:
            return None
        field, corner = found
        weight = min(float(len(pts)), p.readings)  # the score's weight in the log-posterior
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
        # (A, dy, dx): one heading at a time, so that each gather's indices stay in cache
        score = np.stack([padded.take(a + moves[:, :, None]).mean(-1) for a in at])
        t = steps * shift * res
        a, i, j = self._pick(weight * score, dth[:, None, None], t[None, :, None], t[None, None, :])
        off = np.array([t[j], t[i], dth[a]])  # (dx, dy, dth) from the prediction
        # fine: +-1/2, then +-1/4 of a coarse step around the pick, bilinear lookups
        k = np.array([-1.0, 0.0, 1.0])
        for level in (2, 4):
            ft, fth = k * shift * res / level, k * p.angular_step / level
            poses = off[:, None, None, None] + np.stack(np.meshgrid(ft, ft, fth, indexing="ij"))
            dx, dy, da = (v.ravel() for v in poses)
            values = self._lookup(field, corner, res, pts, pred + np.stack([dx, dy, da], 1))
            (best,) = self._pick(weight * values.mean(-1), da, dy, dx)
            off = np.array([dx[best], dy[best], da[best]])
        pose = pred + off
        # support: scan points on mapped cells at the picked pose
        support = int((self._lookup(field, corner, res, pts, pose[None])[0] > 0.5).sum())
        if support < p.min_support or support < p.min_support_fraction * len(pts):
            return None
        return np.array([pose[0], pose[1], wrap(pose[2])])

    @staticmethod
    def _lookup(
        field: np.ndarray, corner: np.ndarray, res: float, pts: np.ndarray, poses: np.ndarray
    ) -> np.ndarray:
        """The field, bilinearly interpolated (0 off it), at the scan points placed by each pose: (P, N)."""
        world = Localiser._place(pts, poses[:, :2], poses[:, 2])
        gx = (world[..., 0] - corner[0]) / res - 0.5  # cell i's centre is at index i
        gy = (world[..., 1] - corner[1]) / res - 0.5
        x0, y0 = np.floor(gx), np.floor(gy)
        fx, fy = gx - x0, gy - y0
        padded = np.pad(field, 1)  # a point within a cell of the field blends toward 0
        h, w = padded.shape
        c = np.clip(x0.astype(np.int64) + 1, 0, w - 2)
        r = np.clip(y0.astype(np.int64) + 1, 0, h - 2)
        off = (x0 + 1 != c) | (y0 + 1 != r)
        flat = padded.ravel()
        at = r * w + c
        top = flat[at] * (1 - fx) + flat[at + 1] * fx
        bottom = flat[at + w] * (1 - fx) + flat[at + w + 1] * fx
        return np.where(off, 0.0, top * (1 - fy) + bottom * fy)

    @staticmethod
    def _place(pts: np.ndarray, xy: np.ndarray, yaws: np.ndarray) -> np.ndarray:
        """The base-frame points placed by bases at ``xy`` ((2,) or (A, 2)) with each heading of ``yaws``
        ((A,)): (A, N, 2)."""
        xy = np.broadcast_to(xy, (len(yaws), 2))
        c, s = np.cos(yaws)[:, None], np.sin(yaws)[:, None]
        x = xy[:, :1] + c * pts[:, 0] - s * pts[:, 1]
        y = xy[:, 1:] + s * pts[:, 0] + c * pts[:, 1]
        return np.stack([x, y], -1)

    def _pick(self, loglik: np.ndarray, dth, dy, dx) -> tuple[int, ...]:
        """The index of the most probable pose: log-likelihood plus the move's log-prior (offsets ``dth``,
        ``dy``, ``dx`` from the prediction, broadcast to ``loglik``'s shape)."""
        c, s = math.cos(self._heading), math.sin(self._heading)
        distance = None  # squared Mahalanobis distance to the nearer outcome of the move
        for centre, (sa, sc) in self._outcomes:
            ox, oy = dx + self.prediction[0] - centre[0], dy + self.prediction[1] - centre[1]
            d2 = ((c * ox + s * oy) / sa) ** 2 + ((-s * ox + c * oy) / sc) ** 2
            distance = d2 if distance is None else np.minimum(distance, d2)
        posterior = loglik - 0.5 * (distance + (dth / self._sd[2]) ** 2)
        return tuple(int(v) for v in np.unravel_index(int(np.argmax(posterior)), loglik.shape))
