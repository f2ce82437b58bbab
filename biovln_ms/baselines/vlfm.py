"""VLFM (Yokoyama et al., ICRA 2024) re-implemented on BioVLN's frontier machinery (paper §4.3, Table 15).

The structure of VLFM, with pluggable components:

1. **Frontier map** from depth: the frontier baseline's 0.05 m occupancy grid, frontiers and planner.
2. **Value map**: every frame gets one image-text score s (``biovln_ms.perception.scorers``) that is
   painted into the camera's view cone on a 0.05 m grid with a confidence c(θ) = cos²(θ / (hfov/2) · π/2)
   (θ: angle from the optical axis); a cell seen again keeps the confidence-weighted mean,
   v ← (c_old v_old + c s) / (c_old + c), and c_old ← (c_old² + c²) / (c_old + c) (VLFM's fusion).
   Exploration goes to the frontier of highest value (path length breaks ties).
3. **Detection → object point cloud → navigate and stop**: every ``detect_every`` steps the detector
   (``biovln_ms.perception.detectors``) gives the target's pixels; as in VLFM, the mask is eroded
   (``erode_px``: a pixel at the mask's edge may read the depth of what lies behind or in front) and
   only the largest cluster of the frame's back-projected points is kept (VLFM uses DBSCAN; here points
   closer than ``cluster_eps`` are linked and the largest connected set wins), so a stray depth reading
   more than ``cluster_eps`` from the object cannot move the target. The pixels are taken on a regular
   grid, at most about 400. ``erode_px=0`` and ``cluster_eps=math.inf`` turn the two filters off. Known
   limits: mask regions narrower than ``2 erode_px + 1`` pixels, or thinner than the grid's stride after
   erosion, give no points; beyond about 5 m the ``realistic`` depth's steps exceed 0.15 m, so an object's
   points split into depth layers and only the largest layer is kept. The kept points accumulate into a
   world point cloud. Once the target is seen, the robot goes to the reachable known-free cell nearest
   to that cloud and stops there (VLFM's PointNav-to-object stage).

Unlike the frontier baseline, VLFM is never told the goal position: it only knows the target
category, as in ObjectNav (it reads the head camera's images and the odometry, never
``pointgoal_with_gps_compass``; without GPS+compass it localises as the frontier baseline does, see
:mod:`~biovln_ms.baselines.frontier`). Its default detector is the shipped trained one; the GT detector
(``detector="gt"``, the ablation ``vlfm_gt``) also reads the ``semantic_category`` sensor. It
early-stops after 100 consecutive steps without progress (paper Table 15): progress = the known free
area grew, or the distance to the current target shrank.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from biovln_ms.baselines.frontier import FrontierParams, FrontierPolicy, to_numpy
from biovln_ms.baselines.frontier.occupancy import FREE, Scan, backproject
from biovln_ms.baselines.frontier.planner import Candidate, PlanField
from biovln_ms.baselines.policy import STOP, EpisodeInfo
from biovln_ms.catalog import load_catalog
from biovln_ms.perception import detector_specs
from biovln_ms.perception.detectors import make_detector
from biovln_ms.perception.scorers import make_scorer


def largest_cluster(points: np.ndarray, eps: float) -> np.ndarray:
    """The largest set of ``points`` (n, d) connected by links shorter than ``eps`` (single linkage, the
    density-free case of DBSCAN); ties go to the set holding the earliest point."""
    if len(points) < 2:
        return points
    pairs = cKDTree(points).query_pairs(eps, output_type="ndarray")
    n = len(points)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return points[labels == np.argmax(np.bincount(labels))]


class VLFMPolicy(FrontierPolicy):
    name = "vlfm"

    def __init__(
        self,
        detector=detector_specs.DEFAULT_DETECTOR,
        scorer="default",
        detect_every: int = 5,
        score_every: int = 1,
        no_progress_limit: int = 100,
        min_object_points: int = 20,
        erode_px: int = 3,
        cluster_eps: float = 0.15,
        params: FrontierParams | None = None,
    ) -> None:
        super().__init__(params)

        self.detector_spec = detector  # a make_detector spec ("trained", "gt", ...) or a Detector object
        self.scorer = make_scorer(scorer) if isinstance(scorer, str) else scorer  # or any ImageTextScorer
        self.detect_every, self.score_every = detect_every, score_every
        self.no_progress_limit = no_progress_limit
        self.min_object_points = min_object_points
        self.erode_px, self.cluster_eps = erode_px, cluster_eps
        self._detector = None

    @property
    def obs_mode(self) -> str:
        """RGB and depth; the GT detector also reads the simulator's segmentation."""
        return detector_specs.obs_mode(self.detector_spec)

    @property
    def label(self) -> str:
        """The name results carry: "VLFM (learned detector)" with the shipped weights, "VLFM (GT detector)"
        with the simulator's segmentation."""
        return detector_specs.label(self.detector_spec)

    def reset(self, episode_info: EpisodeInfo) -> None:
        super().reset(episode_info)

        if self._detector is None:
            spec = self.detector_spec
            self._detector = make_detector(spec) if isinstance(spec, str) else spec
        self._detector.reset(episode_info.task)
        self.category = episode_info.object_category
        self.prompt_name = load_catalog().get(self.category).display_name.lower()
        self.hfov = math.radians(episode_info.task.hfov_deg)
        self.object_points = np.zeros((0, 2))
        self._t = 0
        self._no_progress = 0
        self._best_progress = (0, math.inf, None)
        self.detections = 0

    # --- perception ----------------------------------------------------------------------------
    def _paint(self, scan: Scan, score: float) -> None:
        rc, owner = self.map.ray_cells(scan)
        yaw_axis = scan.direction[len(scan.direction) // 2]
        cosang = np.clip(scan.direction @ yaw_axis, -1.0, 1.0)
        theta = np.arccos(cosang)[owner]
        c = np.cos(np.clip(theta / (self.hfov / 2), 0, 1) * math.pi / 2) ** 2
        # a cell crossed by several rays of this frame takes the most central ray's confidence
        key = rc[:, 0].astype(np.int64) * self.map.n + rc[:, 1]
        order = np.lexsort((-c, key))
        first = np.ones(len(order), bool)
        first[1:] = key[order][1:] != key[order][:-1]
        rc, c = rc[order[first]], c[order[first]]
        r, k = rc[:, 0], rc[:, 1]
        c_old, v_old = self.confidence[r, k], self.value[r, k]
        tot = np.maximum(c_old + c, 1e-9)
        self.value[r, k] = (c_old * v_old + c * score) / tot
        self.confidence[r, k] = (c_old**2 + c**2) / tot

    def _detect(self, obs) -> None:
        mask = self._detector.detect(obs, self.category)
        if not mask.any():  # the usual frame: nothing to erode
            return
        if self.erode_px:
            mask = ndimage.binary_erosion(mask, np.ones((2 * self.erode_px + 1,) * 2, bool))
        depth, intrinsic, extrinsic = self._frame(obs)
        v, u = np.nonzero(mask & (depth > 0) & (depth <= self.params.depth_clip))
        if len(v) < self.min_object_points:
            return
        # at most about 400 pixels on a regular grid: evenly spread over the object, so its points stay linked
        stride = math.ceil(math.sqrt(len(v) / 400))
        pick = (v % stride == 0) & (u % stride == 0)
        v, u = v[pick], u[pick]
        pw, _ = backproject(depth[v, u], u, v, intrinsic, extrinsic)
        pw = largest_cluster(pw, self.cluster_eps)
        if len(pw) < self.min_object_points:
            return
        self.object_points = np.concatenate([self.object_points, pw[:, :2]])[-4000:]
        self.detections += 1

    # --- target rules (overrides of the frontier policy's) ------------------------------------
    def choose(self, candidates: list[Candidate], pose: np.ndarray) -> np.ndarray:
        """The frontier with the highest value; the shorter path breaks ties."""

        def key(c: Candidate) -> tuple[float, float]:
            rc = self.map.cell(c.position)
            return (-round(float(self.value[rc[0], rc[1]]), 4), c.path_length)

        return min(candidates, key=key).position

    def known_target(self, field: PlanField) -> np.ndarray | None:
        """Once the target has been seen: the reachable known-free cell nearest its point cloud."""
        if len(self.object_points) < self.min_object_points:
            return None
        world = field.reachable_centres()
        if not len(world):
            return None
        pts = self.object_points[:: max(1, len(self.object_points) // 500)]
        d = np.min(np.linalg.norm(world[:, None, :] - pts[None, :, :], axis=2), axis=1)
        return world[int(np.argmin(d))]

    def exhausted(self, field: PlanField, pose: np.ndarray) -> np.ndarray:
        """No frontier left and the target never seen: stop where it stands (VLFM has no goal to fall
        back on)."""
        return pose[:2]

    # --- steps ---------------------------------------------------------------------------------
    def _start(self, obs, pose: np.ndarray) -> None:
        """First step: the map, planner and controller, and an empty value map (no goal sensor read)."""
        self._build(pose)
        n = self.map.n
        self.value = np.zeros((n, n), np.float32)
        self.confidence = np.zeros((n, n), np.float32)

    def _integrate(self, obs) -> Scan:
        scan = super()._integrate(obs)
        if self._t % self.score_every == 0:
            rgb = to_numpy(obs["sensor_data"]["head"]["rgb"][0])
            self._paint(scan, self.scorer.score(rgb, self.prompt_name))
        if self._t % self.detect_every == 0:
            self._detect(obs)
        self._t += 1
        return scan

    def act(self, obs, info: dict) -> int:
        action = super().act(obs, info)
        p, current = self.pose[:2], self.control.target
        lo, hi = self.map.lo, self.map.hi
        free = int(np.count_nonzero(self.map.grid[lo[0] : hi[0], lo[1] : hi[1]] == FREE))
        d = float(np.linalg.norm(current - p)) if current is not None else math.inf
        best_free, best_d, target = self._best_progress
        if target is None or current is None or not np.array_equal(target, current):
            best_d = math.inf  # a new target: distance progress starts over
        if free > best_free or d < best_d - 0.05:
            self._no_progress = 0
        else:
            self._no_progress += 1
        self._best_progress = (
            max(free, best_free),
            min(d, best_d),
            None if current is None else np.array(current),
        )
        if self._no_progress >= self.no_progress_limit:
            return self.control.record(p, STOP)
        return action

    def episode_stats(self) -> dict:
        return {
            **super().episode_stats(),
            "detections": self.detections,
            "object_seen": bool(len(self.object_points) >= self.min_object_points),
            "detector": self._detector.name,
            "scorer": self.scorer.name,
            "label": self.label,
        }
