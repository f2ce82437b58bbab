"""A pose estimate without GPS+compass for a policy that keeps no map of its own (BC and the SB3 policies
under ``realistic``).

The frontier agent's scheme (:mod:`~biovln_ms.baselines.frontier`,
:mod:`~biovln_ms.baselines.frontier.localisation`) as a module of its own: in the episode frame (origin at the
start pose, x along the start heading), dead reckoning of the commands the policy sent, corrected by matching
each depth scan against an occupancy map that the module builds from the same scans at the estimated poses.
The camera's mount on the base (height, tilt, the ground point's offset ahead of the turning centre) is read
once from the observed extrinsics, which without GPS+compass are in the base frame. It reads observations
only: depth, the camera parameters and the start-frame ``pointgoal``.
"""

from __future__ import annotations

import math

import numpy as np

from biovln_ms.baselines.frontier import camera_offset, goal_from_sensor, head_depth, to_numpy
from biovln_ms.baselines.frontier.occupancy import OCCUPIED, OccupancyMap
from biovln_ms.baselines.frontier.params import FrontierParams
from biovln_ms.baselines.frontier.localisation import (
    Localiser,
    camera_mount,
    extrinsic_at,
    scan_points,
    wrap,
)
from biovln_ms.baselines.policy import TaskSpec

__all__ = ["EpisodeOdometry"]


class EpisodeOdometry:
    """``update(obs, last_action)`` each step returns the estimated (x, y, yaw) in the episode frame;
    :meth:`pointgoal` gives the goal's distance and bearing from it (what ``pointgoal_with_gps_compass``
    would read with GPS+compass). Map and matcher use the frontier agent's parameters (paper Table 15)."""

    def __init__(self, task: TaskSpec, params: FrontierParams | None = None) -> None:
        self.task = task
        self.params = params or FrontierParams()
        self.localiser = Localiser()
        self.map: OccupancyMap | None = None
        self.mount: np.ndarray | None = None
        self.offset = np.zeros(2)
        self.goal: np.ndarray | None = None  # episode frame
        self.poses: list[np.ndarray] = []

    def update(self, obs, last_action) -> np.ndarray:
        """The pose at this step: the start at the first call, then ``last_action`` (the command sent
        on the previous step) dead-reckoned and corrected by this frame's scan; the frame then joins the
        map."""
        p = self.params
        depth, intrinsic = head_depth(obs)
        if self.map is None:
            extrinsic = to_numpy(obs["sensor_param"]["head"]["extrinsic_cv"][0])
            self.offset = camera_offset(extrinsic, np.zeros(3))
            self.mount = camera_mount(extrinsic, self.offset)
            self.localiser.reset()
            self.map = OccupancyMap(np.zeros(2), p.resolution, p.extent, evidence=self.task.noise.depth)
            self.goal = goal_from_sensor(np.zeros(3), to_numpy(obs["extra"]["pointgoal"][0]))
        points = scan_points(depth, intrinsic, self.mount, p.pixel_stride, p.depth_clip, p.floor_z, p.top_z)
        occ_map = self.map if self.poses else None  # the first frame: no move yet, nothing mapped
        pose = self.localiser.step(last_action, points, depth, intrinsic, self.task, occ_map, p.scan_match)
        base = pose[:2] if self.offset.any() else None
        extrinsic = extrinsic_at(pose, self.mount)
        self.map.integrate(
            depth, intrinsic, extrinsic, p.pixel_stride, p.depth_clip, p.floor_z, p.top_z, base_xy=base
        )
        self.poses.append(pose)
        return pose

    def clearance(self, xy, cap: float = 2.0) -> float:
        """The distance from ``xy`` (episode frame) to the nearest cell its map holds as an obstacle (with
        noisy depth, any cell more likely occupied than not, as the matcher reads it), at most ``cap`` m:
        what the RL state vector's clearance reads, walls included (a map cannot tell them from bodies)."""
        rc = self.map.disc_cells(np.asarray(xy, float), cap)
        hit = self.map.grid[rc[:, 0], rc[:, 1]] == OCCUPIED
        if self.map.log_odds is not None:
            hit |= self.map.log_odds[rc[:, 0], rc[:, 1]] > 0
        if not hit.any():
            return cap
        d = np.linalg.norm(self.map.centre(rc[hit]) - np.asarray(xy, float), axis=1)
        return min(cap, float(d.min()))

    def pointgoal(self) -> tuple[float, float]:
        """(rho, phi): the goal's distance and bearing (counter-clockwise from the heading) from the last
        estimated pose."""
        x, y, yaw = self.poses[-1]
        dx, dy = self.goal[0] - x, self.goal[1] - y
        return math.hypot(dx, dy), wrap(math.atan2(dy, dx) - yaw)

    def stats(self) -> dict:
        """The poses acted on (episode frame) and the scan matches accepted and dropped as weak."""
        return {
            "pose_frame": "episode",
            "pose_estimates": [[round(float(v), 4) for v in pose] for pose in self.poses],
            "scan_matches": self.localiser.accepted,
            "scan_matches_weak": self.localiser.rejected,
        }
