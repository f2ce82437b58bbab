"""Frontier exploration from depth only (paper §4.3, Table 15 parameters in :class:`FrontierParams`).

Three units: the occupancy map (:mod:`~biovln_ms.baselines.frontier.occupancy`: a 0.05 m grid of 100 x 100 m
from the head camera's depth, like a laser scan), the planner (:mod:`~biovln_ms.baselines.frontier.planner`:
the nearest frontier by path length on the robot's own map, re-planned as the map grows) and the
controller (:mod:`~biovln_ms.baselines.frontier.control`: path following and the STOP rule).

The policy runs from the observation alone (``biovln_ms.baselines.policy``): its pose is the robot's
odometry (the base joints in ManiSkill's proprioception, ``obs["agent"]["qpos"]``: x, y, yaw in the frame
the camera extrinsics use), the map is centred on the first pose, and the goal is read once, at the first
step, from the ``pointgoal_with_gps_compass`` sensor and kept fixed (re-reading it each step would make
float32 noise move the goal).

Without GPS+compass (``task.noise.gps_compass`` false, e.g. the ``realistic`` preset) there is no odometry:
the policy runs in the episode frame (origin at the start pose), keeps its pose by dead reckoning of its
commands corrected by matching each depth scan to its map (:mod:`~biovln_ms.baselines.frontier.localisation`),
builds the map with camera extrinsics of that pose (only the camera's mount, its height and tilt, is read from
the observed ones), and reads the goal once from ``pointgoal`` (the start frame). A FORWARD after which the
estimate moved less than half a step was blocked. ``episode_stats`` reports the pose it acted on at every step
(``pose_estimates``, in ``pose_frame``), from which the harness measures the drift.

In a lab with people (``TaskSpec.people``) the map forgets what moves (``OccupancyMap(forget=True)``): a
person seen once is no wall for ever, and the re-plan every few steps finds the way they freed; obstacles are
grown by ``people_margin`` more, as depth sees a person's figure inside the body the robot must not touch,
and under actuation noise the controller's people check reaches :func:`sideways_spread` further.

Goal rule (the paper leaves it implicit): the goal position is used only to decide when to go there
and stop: as soon as the goal cell is known free and reachable on the robot's map it navigates to it
and STOPs within half a step (or when a step would not bring it closer). With no frontier left and
the goal never seen, it goes to the known free cell nearest the goal and stops.

A head camera mounted ahead of the turning centre (Fetch's, 0.16 m; the cylinder's is on its axis) never
sees the ground within the circle it sweeps about the turning centre: every frame the map also frees
that disc (the robot stands on it), else the robot's own cell is cut off from the free space the camera
sees and no frontier is reachable (it STOPs at its first step), and unseen cells beside the base stay a
frontier it turns toward for ever. The offset is read at the first step from the observed camera
extrinsics (with the odometry, or in the base frame without GPS+compass), which also place the camera
on the estimated pose's base (:func:`camera_offset`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from biovln_ms.baselines.frontier.control import FrontierController
from biovln_ms.baselines.frontier.occupancy import FREE, OCCUPIED, UNKNOWN, OccupancyMap, Scan, backproject
from biovln_ms.baselines.frontier.params import FrontierParams
from biovln_ms.baselines.frontier.planner import (
    Candidate,
    FrontierPlanner,
    PlanField,
    goal_if_reachable,
    nearest_candidate,
    nearest_reachable,
)
from biovln_ms.baselines.frontier.localisation import Localiser, camera_mount, extrinsic_at, scan_points
from biovln_ms.baselines.policy import EpisodeInfo, Policy, TaskSpec
from biovln_ms.noise import LOCOBOT_FORWARD

__all__ = [
    "FREE",
    "OCCUPIED",
    "UNKNOWN",
    "FrontierParams",
    "FrontierPolicy",
    "OccupancyMap",
    "Scan",
    "backproject",
    "camera_offset",
    "goal_from_sensor",
    "head_depth",
    "head_frame",
    "pose_from_odometry",
    "sideways_spread",
    "to_numpy",
]


def to_numpy(x) -> np.ndarray:
    """A torch tensor (ManiSkill's observations) or array as a numpy array."""
    return x.cpu().numpy() if hasattr(x, "cpu") else np.asarray(x)


def pose_from_odometry(obs: dict) -> np.ndarray:
    """The robot's (x, y, yaw) from its base joints (ManiSkill's proprioception, the robot's odometry).
    The head camera's pose gives the same to ~1e-7 m, but a map origin that moves by that much re-bins
    depth points lying on cell borders, so the exact odometry keeps runs reproducible."""
    return to_numpy(obs["agent"]["qpos"][0, :3]).astype(float)


#: m: a head camera whose ground point lies nearer the turning centre than this is on the axis (the
#: cylinder's: its float32 extrinsics put it ~1e-7 m off, which is no offset)
ON_AXIS = 1e-3


def camera_offset(extrinsic: np.ndarray, base_pose: np.ndarray) -> np.ndarray:
    """The head camera's ground position in the base frame (x ahead, y left) from its OpenCV extrinsics
    (world to camera) and the base's (x, y, yaw) in the same frame; zero for a camera on the axis."""
    cam = -extrinsic[:3, :3].T @ extrinsic[:3, 3]  # the camera centre
    x, y, yaw = (float(v) for v in base_pose)
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = cam[0] - x, cam[1] - y
    offset = np.array([c * dx + s * dy, -s * dx + c * dy])
    return offset if np.linalg.norm(offset) >= ON_AXIS else np.zeros(2)


def goal_from_sensor(pose: np.ndarray, pointgoal) -> np.ndarray:
    """The world goal from the pose and the ``pointgoal_with_gps_compass`` reading (distance, bearing
    counter-clockwise from the heading)."""
    rho, phi = float(pointgoal[0]), float(pointgoal[1])
    return pose[:2] + rho * np.array([math.cos(pose[2] + phi), math.sin(pose[2] + phi)])


def head_frame(obs: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The head camera's depth (m, float32) and its OpenCV intrinsics and extrinsics."""
    params = obs["sensor_param"]["head"]
    return (*head_depth(obs), to_numpy(params["extrinsic_cv"][0]))


def head_depth(obs: dict) -> tuple[np.ndarray, np.ndarray]:
    """The head camera's depth (m, float32) and its OpenCV intrinsics."""
    depth = to_numpy(obs["sensor_data"]["head"]["depth"][0, ..., 0]).astype(np.float32) / 1000.0
    return depth, to_numpy(obs["sensor_param"]["head"]["intrinsic_cv"][0])


def sideways_spread(noise) -> float:
    """How far (m) a FORWARD may land beside where it was aimed under ``noise``'s actuation noise: the mean
    of its sideways error plus two standard deviations (the LoCoBot model, scaled; 0 without)."""
    across = LOCOBOT_FORWARD.position
    return (abs(across.mean[1]) + 2.0 * math.sqrt(across.variance[1])) * float(noise.actuation)


def forgets(params: FrontierParams, task: TaskSpec) -> bool:
    """Whether the map forgets what moves: ``params.forget``, else when people walk the lab."""
    return bool(task.people) if params.forget is None else params.forget


class FrontierPolicy(Policy):
    """Nearest-frontier exploration to the goal; the target rules (:class:`TargetRules`) are its methods."""

    name = "frontier"
    obs_mode = "depth"  # the head camera's depth only: no colour is read back from the renderer

    def __init__(self, params: FrontierParams | None = None) -> None:
        self.params = params or FrontierParams()

    def reset(self, episode_info: EpisodeInfo) -> None:
        self.task: TaskSpec = episode_info.task
        if self.params.robot_radius is None:  # the robot's own radius (Table 15: 0.2 m, ours too)
            self.params = replace(self.params, robot_radius=self.task.robot_radius)
        self.map: OccupancyMap | None = None  # built at the first step, centred on the start
        self.planner: FrontierPlanner | None = None
        self.control: FrontierController | None = None
        self.goal: np.ndarray | None = None
        self.pose: np.ndarray | None = None  # (x, y, yaw) at the current step
        # without GPS+compass: the pose in the episode frame, estimated (frontier.localisation)
        self.localiser = None if self.task.noise.gps_compass else Localiser()
        self.mount: np.ndarray | None = None  # the head camera on the base (height, tilt, offset)
        self.camera_offset = np.zeros(2)  # the head camera's ground point ahead of the turning centre
        self.pose_estimates: list[np.ndarray] = []

    def act(self, obs, info: dict) -> int:
        if self.map is None:
            self._mount(obs)
        self.pose = pose_from_odometry(obs) if self.localiser is None else self._localise(obs)
        if self.map is None:
            self._start(obs, self.pose)
        self._integrate(obs)
        self.pose_estimates.append(self.pose)
        return self.control.act(self.pose)

    def _mount(self, obs) -> None:
        """First step: the head camera's ground offset from the turning centre and, without GPS+compass
        (whose observed extrinsics are in the base frame), its mount on the base."""
        extrinsic = to_numpy(obs["sensor_param"]["head"]["extrinsic_cv"][0])
        base = pose_from_odometry(obs) if self.localiser is None else np.zeros(3)
        self.camera_offset = camera_offset(extrinsic, base)
        if self.localiser is not None:
            self.mount = camera_mount(extrinsic, self.camera_offset)

    def _localise(self, obs) -> np.ndarray:
        """The pose without odometry: the start at the first step, then the previous command's dead
        reckoning (a FORWARD the previous frame showed blocked is expected not to move) corrected by
        matching this frame's depth scan to the map built so far."""
        p = self.params
        depth, intrinsic = head_depth(obs)
        if self.map is None:
            self.localiser.reset()
        points = scan_points(depth, intrinsic, self.mount, p.pixel_stride, p.depth_clip, p.floor_z, p.top_z)
        last = None if self.map is None else self.control.last_action
        return self.localiser.step(last, points, depth, intrinsic, self.task, self.map, p.scan_match)

    def _frame(self, obs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The head camera's depth, intrinsics and extrinsics in the policy's frame: the observed ones
        with odometry, else those of the estimated pose."""
        if self.localiser is None:
            return head_frame(obs)
        return (*head_depth(obs), extrinsic_at(self.pose, self.mount))

    def _start(self, obs, pose: np.ndarray) -> None:
        """First step: the map, planner and controller, and the goal from the goal sensor (fixed from
        here on): ``pointgoal_with_gps_compass`` from the pose, or without GPS+compass ``pointgoal``
        from the start (the episode frame's origin)."""
        self._build(pose)
        if self.localiser is None:
            self.goal = goal_from_sensor(pose, to_numpy(obs["extra"]["pointgoal_with_gps_compass"][0]))
        else:
            self.goal = goal_from_sensor(np.zeros(3), to_numpy(obs["extra"]["pointgoal"][0]))

    def _build(self, pose: np.ndarray) -> None:
        p = self.params
        forget = forgets(p, self.task)
        # a noisy depth sensor (the robot knows its own): cells weigh evidence over frames
        self.map = OccupancyMap(
            pose[:2], p.resolution, p.extent, evidence=self.task.noise.depth, forget=forget
        )
        p = self.people_params(p)
        if not self.task.noise.sliding:  # a move that grazes an obstacle is lost: step clear when boxed in
            p = replace(p, step_clear=True)
        self.planner = FrontierPlanner(p, self)
        turn = math.radians(self.task.turn_deg)
        if self.localiser is not None:  # an estimated pose: a blocked FORWARD moved it less than half a step
            p = replace(p, blocked_move=max(p.blocked_move, self.task.forward_step / 2))
        self.control = FrontierController(p, self.task.forward_step, turn, self.map, self.planner)

    def people_params(self, p: FrontierParams) -> FrontierParams:
        """``p`` kept clear of people's bodies, not only of the figures depth sees, on a map that forgets
        (people walk the lab); ``p`` itself otherwise."""
        if not forgets(p, self.task):
            return p
        return replace(p, margin=p.margin + p.people_margin, noise_margin=sideways_spread(self.task.noise))

    def _integrate(self, obs) -> Scan:
        """Add the head camera's depth frame to the map (VLFM also scores and detects on it), and the disc
        under the base that a camera mounted ahead of the turning centre never sees."""
        p = self.params
        base = self.pose[:2] if self.camera_offset.any() else None
        return self.map.integrate(
            *self._frame(obs), p.pixel_stride, p.depth_clip, p.floor_z, p.top_z, base_xy=base
        )

    def episode_stats(self) -> dict:
        """The pose acted on at each step (x, y, yaw; ``pose_frame``: "world" from odometry, "episode"
        when estimated) and, when estimated, the scan matches accepted and dropped as weak; empty before
        the first step."""
        if not getattr(self, "pose_estimates", None):
            return {}
        out = {
            "pose_frame": "world" if self.localiser is None else "episode",
            "pose_estimates": [[round(float(v), 4) for v in pose] for pose in self.pose_estimates],
        }
        if self.localiser is not None:
            out.update(scan_matches=self.localiser.accepted, scan_matches_weak=self.localiser.rejected)
        return out

    # --- target rules (VLFM and LLM-Frontier override them) --------------------------------------
    def known_target(self, field: PlanField) -> np.ndarray | None:
        """The goal, once its cell is known free and reachable."""
        return goal_if_reachable(field, self.goal)

    def choose(self, candidates: list[Candidate], pose: np.ndarray) -> np.ndarray:
        """The nearest frontier by path length."""
        return nearest_candidate(candidates)

    def exhausted(self, field: PlanField, pose: np.ndarray) -> np.ndarray:
        """Nothing left to explore and the goal never seen: the reachable known free cell nearest the goal."""
        return nearest_reachable(field, self.goal, pose[:2])
