"""VLFM (Yokoyama et al., ICRA 2024) re-implemented on BioVLN's frontier machinery (paper §4.3, Table 15).

The structure of VLFM, with pluggable components:

1. **Frontier map** from depth: the frontier baseline's 0.05 m occupancy grid, frontiers and planner.
2. **Value map**: every frame gets one image-text score s (``biovln_ms.perception.scorers``) that is
   painted into the camera's view cone on a 0.05 m grid with a confidence c(θ) = cos²(θ / (hfov/2) · π/2)
   (θ: angle from the optical axis); a cell seen again keeps the confidence-weighted mean,
   v ← (c_old v_old + c s) / (c_old + c), and c_old ← (c_old² + c²) / (c_old + c) (VLFM's fusion).
   Exploration goes to the frontier of highest value (path length breaks ties).
3. **Detection → object point cloud → navigate and stop**: every ``detect_every`` steps the detector
   (``biovln_ms.perception.detectors``) gives the target's pixels; they are back-projected with depth
   into a world point cloud that accumulates. Once the target is seen, the robot goes to the reachable
   known-free cell nearest to that cloud and stops there (VLFM's PointNav-to-object stage).

Unlike the frontier baseline, VLFM is never told the goal position: it only knows the target
category, as in ObjectNav. It early-stops after 100 consecutive steps without progress (paper
Table 15): progress = the known free area grew, or the distance to the current target shrank.
"""

from __future__ import annotations

import math

import numpy as np

from biovln_ms.agents.frontier import FREE, FrontierPolicy, Scan, backproject
from biovln_ms.agents.policy import STOP


class VLFMPolicy(FrontierPolicy):
    name = "vlfm"
    obs_mode = "rgb+depth+segmentation"

    def __init__(self, detector="gt", scorer="default", detect_every: int = 5,
                 score_every: int = 1, no_progress_limit: int = 100, min_object_points: int = 20, **frontier_kw) -> None:
        super().__init__(**frontier_kw)
        from biovln_ms.perception.scorers import make_scorer

        self.detector_spec = detector  # "gt", "owlvit:<dir>", or a Detector object
        self.scorer = make_scorer(scorer) if isinstance(scorer, str) else scorer  # or any ImageTextScorer
        self.detect_every, self.score_every = detect_every, score_every
        self.no_progress_limit = no_progress_limit
        self.min_object_points = min_object_points
        self._detector = None

    @property
    def label(self) -> str:
        """The name results should carry ("VLFM (GT detector)" with the simulator's segmentation)."""
        name = self.detector_spec if isinstance(self.detector_spec, str) else self.detector_spec.name
        return "VLFM (GT detector)" if name == "gt" else f"VLFM ({name})"

    def reset(self, episode_info: dict) -> None:
        super().reset(episode_info)
        from biovln_ms.catalog import load_catalog
        from biovln_ms.perception.detectors import make_detector

        env = episode_info["env"]
        if not isinstance(self.detector_spec, str):
            self._detector = self.detector_spec
        elif self._detector is None or getattr(self._detector, "env", env) is not env:
            self._detector = make_detector(self.detector_spec, env)
        self.category = episode_info["episode"]["object_category"]
        self.prompt_name = load_catalog().get(self.category).display_name.lower()
        self.hfov = float(env._ctx.hfov)
        n = self.map.n
        self.value = np.zeros((n, n), np.float32)
        self.confidence = np.zeros((n, n), np.float32)
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
        self.confidence[r, k] = (c_old ** 2 + c ** 2) / tot

    def _detect(self, obs) -> None:
        mask = self._detector.detect(obs, self.category)
        if not mask.any():
            return
        cam = obs["sensor_data"]["head"]
        depth = cam["depth"][0, ..., 0].cpu().numpy().astype(np.float32) / 1000.0
        params = obs["sensor_param"]["head"]
        v, u = np.nonzero(mask & (depth > 0) & (depth <= self.clip))
        if len(v) < self.min_object_points:
            return
        pick = np.linspace(0, len(v) - 1, min(len(v), 400)).astype(int)  # a bounded, deterministic subsample
        pw, _ = backproject(depth[v[pick], u[pick]], u[pick], v[pick], params["intrinsic_cv"][0].cpu().numpy(),
                            params["extrinsic_cv"][0].cpu().numpy())
        self.object_points = np.concatenate([self.object_points, pw[:, :2]])[-4000:]
        self.detections += 1

    # --- decisions (overrides of the frontier policy) ------------------------------------------
    def choose(self, candidates: list, pose) -> np.ndarray:
        """The frontier with the highest value; the shorter path breaks ties."""
        def key(c):
            rc = self.map.cell(c[1])
            return (-round(float(self.value[rc[0], rc[1]]), 4), c[0])

        return min(candidates, key=key)[1]

    def _known_target(self, lo, g, trav, idx, dist) -> np.ndarray | None:
        """Once the target has been seen: the reachable known-free cell nearest its point cloud."""
        if len(self.object_points) < self.min_object_points:
            return None
        cells = np.argwhere(trav)
        reach = np.isfinite(dist[idx[cells[:, 0], cells[:, 1]]])
        if not reach.any():
            return None
        world = self.map.centre(cells[reach] + lo)
        pts = self.object_points[:: max(1, len(self.object_points) // 500)]
        d = np.min(np.linalg.norm(world[:, None, :] - pts[None, :, :], axis=2), axis=1)
        return world[int(np.argmin(d))]

    def _exhausted(self, lo, trav, idx, dist, pose) -> np.ndarray:
        """No frontier left and the target never seen: stop where it stands (VLFM has no goal to fall back on)."""
        return pose[:2]

    # --- control -------------------------------------------------------------------------------
    def _integrate(self, obs) -> Scan:
        scan = super()._integrate(obs)
        if self._t % self.score_every == 0:
            self._paint(scan, self.scorer.score(obs["sensor_data"]["head"]["rgb"][0].cpu().numpy(), self.prompt_name))
        if self._t % self.detect_every == 0:
            self._detect(obs)
        self._t += 1
        return scan

    def act(self, obs, info: dict) -> int:
        action = super().act(obs, info)
        p = self.env._planar()[:2]
        free = int(np.count_nonzero(self.map.grid[self.map.lo[0]:self.map.hi[0], self.map.lo[1]:self.map.hi[1]] == FREE))
        d = float(np.linalg.norm(self.target - p)) if self.target is not None else math.inf
        best_free, best_d, target = self._best_progress
        if target is None or self.target is None or not np.array_equal(target, self.target):
            best_d = math.inf  # a new target: distance progress starts over
        if free > best_free or d < best_d - 0.05:
            self._no_progress = 0
        else:
            self._no_progress += 1
        self._best_progress = (max(free, best_free), min(d, best_d),
                               None if self.target is None else np.array(self.target))
        if self._no_progress >= self.no_progress_limit:
            return self._remember(p, STOP)
        return action

    def episode_stats(self) -> dict:
        return {"detections": self.detections, "object_seen": bool(len(self.object_points) >= self.min_object_points),
                "detector": self._detector.name, "scorer": self.scorer.name, "label": self.label}
