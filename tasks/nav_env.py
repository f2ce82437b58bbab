"""``BioVLN-OpFace-v0``: navigate a mobile base to an instrument's operational-face goal (paper §3.2).

One ``step`` is one action of the paper's space (0=STOP, 1=FORWARD 0.25 m, 2=TURN_LEFT 30 deg,
3=TURN_RIGHT 30 deg), executed by SAPIEN physics through a stiff PD drive on the base's planar
joints: exact when free, stopped by walls and instruments. STOP ends the episode; it succeeds when
the robot is within the goal's success radius. Zone metrics are measures updated in ``evaluate``;
the dense reward is Eq. 5.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np
import sapien
import torch
from gymnasium import spaces
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.sensors.camera import CameraConfig
from mani_skill.utils.structs.types import SimConfig

import biovln_ms.agents.biovln_base  # noqa: F401  (registers the robot)
from biovln_ms.catalog import load_catalog
from biovln_ms.episodes.source import DatasetEpisodes, EpisodeSource, GeneratedEpisodes
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.navigation import scene_navigation
from biovln_ms.geometry.zones import SAFETY_THRESHOLD
from biovln_ms.metrics.measures import EpisodeContext, MeasureSet, StepState
from biovln_ms.registration import register_biovln_env
from biovln_ms.scene.maniskill_builder import LabSceneBuilder
from biovln_ms.tasks.lab_scene_env import overview_pose

ACTIONS = {0: "STOP", 1: "FORWARD", 2: "TURN_LEFT", 3: "TURN_RIGHT"}
CONTROL_MODES = ("discrete", "continuous")
OBS_MODES = ("state", "state_dict", "none", "sensor_data", "rgb", "depth", "segmentation", "rgbd", "rgb+depth",
             "rgb+depth+segmentation", "rgb+segmentation", "depth+segmentation", "pointcloud")


class EnvConfigError(BioVLNError):
    """Invalid env arguments (split, episode, obs mode, control mode, action)."""


@dataclass(frozen=True)
class NavTaskConfig:
    """Task parameters (paper §3.2, Eq. 5, appendix "Gym Environment for RL Training")."""

    forward_step: float = 0.25
    turn_deg: float = 30.0
    goal_mode: str = "opface"  # "opface" (Eq. 1) or "centroid" (Table 9 ablation)
    camera_width: int = 640
    camera_height: int = 480
    camera_hfov_deg: float = 79.0  # Habitat's horizontal FOV; SAPIEN takes the vertical one
    camera_far: float = 20.0
    success_bonus: float = 10.0
    step_penalty: float = 0.01
    safety_penalty: float = 0.05
    proportional_safety: bool = False  # RL variant: penalty * (1 - clearance / 0.5)
    shuffle_episodes: bool = False  # RL variant: shuffle once (scene order, and episodes within a scene), then cycle
    position_scale: float = 4.0  # RL variant observation normalisation (m)

    @property
    def camera_vfov(self) -> float:
        """Vertical FOV (radians) for SAPIEN from the horizontal one: 2 atan(tan(h/2) H/W)."""
        return 2 * math.atan(math.tan(math.radians(self.camera_hfov_deg) / 2) * self.camera_height / self.camera_width)


@register_biovln_env("BioVLN-OpFace-v0", max_episode_steps=500)
class BioVLNNavEnv(BaseEnv):
    """Operational-face navigation. Episodes from ``split`` (of ``dataset`` or the default dataset),
    or sampled in a scene generated from ``template`` / ``scene_seed``."""

    SUPPORTED_ROBOTS = ["biovln_base"]
    SUPPORTED_REWARD_MODES = ("normalized_dense", "dense", "sparse", "none")
    config = NavTaskConfig()

    def __init__(self, *args, split: str | None = None, dataset: str | None = None, template: str = "single_room",
                 scene_seed: int = 0, control_mode: str = "discrete", robot_uids: str = "biovln_base", **kwargs) -> None:
        overrides = {f.name: kwargs.pop(f.name) for f in fields(NavTaskConfig) if f.name in kwargs}
        self.cfg = replace(self.config, **overrides)
        if control_mode not in CONTROL_MODES:
            raise EnvConfigError(f"unknown control mode '{control_mode}'", field="control_mode",
                                 fix=f"use one of: {', '.join(CONTROL_MODES)}")
        obs_mode = kwargs.get("obs_mode", "state")
        if obs_mode not in OBS_MODES:
            raise EnvConfigError(f"unknown obs mode '{obs_mode}'", field="obs_mode", fix=f"use one of: {', '.join(OBS_MODES)}")
        if kwargs.get("num_envs", 1) > 1:
            gpu = torch.cuda.is_available() and str(kwargs.get("sim_backend", "")).startswith(("physx_cuda", "gpu"))
            if not gpu:
                raise EnvConfigError("num_envs > 1 needs sim_backend='physx_cuda' and a CUDA GPU; on the CPU run one env per "
                                     "process (gymnasium AsyncVectorEnv or SB3 SubprocVecEnv, see README)", field="num_envs")
            raise EnvConfigError("batched sub-envs (num_envs > 1 on physx_cuda) are not implemented in this version: the "
                                 "episode bookkeeping and measures are per single env", field="num_envs",
                                 fix="run one env per process (AsyncVectorEnv / SubprocVecEnv), see README")
        self.nav_control_mode = control_mode
        if split:
            self.source: EpisodeSource = DatasetEpisodes(split, dataset)
        elif dataset:
            raise EnvConfigError(f"a dataset ({dataset}) was given without a split", field="split",
                                 fix="pass split=, e.g. split='ms_val'")
        else:
            self.source = GeneratedEpisodes(template, scene_seed)
        self.category_names = load_catalog().goal_categories()
        self._order = self._episode_order()
        self._cursor = -1
        self._episode = self.source.episodes[self._order[0]]
        self._scene_name = None
        self._set_scene(self._episode["scene_id"])
        self._pending: dict | None = None
        self._measures = MeasureSet()
        self._ctx: EpisodeContext | None = None
        super().__init__(*args, robot_uids=robot_uids, control_mode="pd_base_pos", **kwargs)
        space = spaces.Discrete(4) if control_mode == "discrete" else spaces.Box(-1.0, 1.0, (3,), np.float32)
        self.single_action_space = space
        self.action_space = space

    def _episode_order(self) -> list[int]:
        """Dataset order, or (``shuffle_episodes``) a fixed shuffle that keeps each scene's episodes together,
        as Habitat's episode iterator groups by scene: the scene is rebuilt once per scene, not per episode."""
        n = len(self.source)
        if not self.cfg.shuffle_episodes:
            return list(range(n))
        rng = np.random.default_rng(0)
        by_scene: dict[str, list[int]] = {}
        for i, ep in enumerate(self.source.episodes):
            by_scene.setdefault(ep["scene_id"], []).append(i)
        scenes = sorted(by_scene)
        order: list[int] = []
        for k in rng.permutation(len(scenes)):
            episodes = by_scene[scenes[k]]
            order += [episodes[j] for j in rng.permutation(len(episodes))]
        return order

    # --- configuration -------------------------------------------------------------------------
    @property
    def _default_sim_config(self):
        return SimConfig(sim_freq=100, control_freq=20)  # 5 substeps: the stiff drive settles in them

    @property
    def _default_sensor_configs(self):
        c = self.cfg
        return [CameraConfig("head", sapien.Pose(), c.camera_width, c.camera_height, c.camera_vfov, 0.05, c.camera_far,
                             mount=self.agent.camera_link)]

    @property
    def _default_human_render_camera_configs(self):
        return CameraConfig("overview", overview_pose(self.scene_spec), 960, 720, math.radians(55), 0.05, 100)

    def _set_scene(self, scene_id: str) -> None:
        self.scene_spec = self.source.spec(scene_id)
        self.nav = scene_navigation(self.scene_spec)
        self._scene_name = scene_id

    # --- ManiSkill hooks -----------------------------------------------------------------------
    def _load_agent(self, options: dict):
        super()._load_agent(options, sapien.Pose())

    def _load_scene(self, options: dict):
        self.scene_builder = LabSceneBuilder(self, [self.scene_spec])
        self.scene_builder.build(0)

    def _load_lighting(self, options: dict):
        """Lights come from the scene builder."""

    def reset(self, seed=None, options=None):
        options = dict(options or {})
        idx = self._select_episode(seed, options)
        self._episode = self.source.episodes[idx]
        if self._episode["scene_id"] != self._scene_name:
            self._set_scene(self._episode["scene_id"])
            options["reconfigure"] = True
        return super().reset(seed=seed, options=options)

    def _select_episode(self, seed, options: dict) -> int:
        if "episode_index" in options:
            k = options.pop("episode_index")
            if not (isinstance(k, (int, np.integer)) and 0 <= k < len(self.source)):
                raise EnvConfigError(f"episode_index {k!r} is out of range", field="episode_index",
                                     fix=f"use 0 <= episode_index < {len(self.source)}")
            return int(k)
        if "episode_id" in options:
            return self.source.find(options.pop("episode_id"), options.pop("scene_id", None))
        if seed is not None:  # the same seed gives the same episode, and the same ones after it
            self._cursor = int(np.ravel(seed)[0]) % len(self._order)
            return self._order[self._cursor]
        self._cursor = (self._cursor + 1) % len(self._order)
        return self._order[self._cursor]

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        ep = self._episode
        x, y = ep["start_position"][:2]
        w, _, _, z = ep["start_rotation"]
        yaw = 2 * math.atan2(z, w)
        qpos = torch.tensor([[x, y, yaw]], dtype=torch.float32, device=self.device).repeat(len(env_idx), 1)
        self.agent.reset(qpos)
        target = self.scene_spec.get(ep["object_id"]).placed()
        if self.cfg.goal_mode == "centroid":
            goal = target.centroid_goal()
            goal_nav = self.nav.snap(goal)
        else:
            goal = np.asarray(ep["goals"][0]["position"][:2], float)
            goal_nav = goal
        geodesic = self.nav.distance_to(goal_nav)
        self._ctx = EpisodeContext(goal=goal, success_radius=float(ep["goals"][0]["radius"]), target=target,
                                   instruments=[o.placed() for o in self.scene_spec.instruments], geodesic=geodesic,
                                   start_geodesic=float(geodesic(np.array([x, y]))), hfov=math.radians(self.cfg.camera_hfov_deg))
        self._measures.reset(self._ctx, StepState(np.array([x, y]), yaw, None, False))
        self._prev_distance = self._measures["distance_to_goal"]
        self._pending = None
        self._stopped = False

    def _planar(self) -> np.ndarray:
        return self.agent.planar_pose()[0].astype(float)

    def step(self, action):
        stop, forward, turn = self._parse_action(action)
        pose = self._planar()
        target = pose.copy()
        if not stop:
            target[0] += forward * math.cos(pose[2])
            target[1] += forward * math.sin(pose[2])
            target[2] += turn
        self._pending = {"pose": pose, "stop": stop, "forward": forward,
                         "action": int(action) if self.nav_control_mode == "discrete" else None}
        return super().step(torch.tensor(target[None], dtype=torch.float32, device=self.device))

    def _parse_action(self, action) -> tuple[bool, float, float]:
        c = self.cfg
        turn = math.radians(c.turn_deg)
        if self.nav_control_mode == "discrete":
            a = np.asarray(action.cpu() if hasattr(action, "cpu") else action)
            if a.size != 1 or not np.issubdtype(a.dtype, np.number) or not float(a.ravel()[0]).is_integer():
                raise EnvConfigError(f"action {action!r} is not one integer", field="action", fix=_action_help())
            k = int(a.ravel()[0])
            if k not in ACTIONS:
                raise EnvConfigError(f"action {k} is outside Discrete(4)", field="action", fix=_action_help())
            return k == 0, (c.forward_step if k == 1 else 0.0), {2: turn, 3: -turn}.get(k, 0.0)
        a = np.asarray(action.cpu() if hasattr(action, "cpu") else action, float).ravel()
        if a.shape != (3,) or not np.isfinite(a).all() or np.abs(a).max() > 1.0 + 1e-6:
            raise EnvConfigError(f"action {a.tolist()} is outside Box(-1, 1, (3,))", field="action",
                                 fix="continuous actions are [forward, turn, stop] in [-1, 1]: forward (a0+1)/2 * step, "
                                     "turn a1 * turn angle, stop when a2 > 0")
        return bool(a[2] > 0), (a[0] + 1) / 2 * c.forward_step, a[1] * turn

    def evaluate(self):
        self._pose = self._planar()  # read once per step; _get_obs_extra reuses it
        if self._pending is not None and self._ctx is not None:
            p = self._pending
            pose = self._pose
            heading = np.array([math.cos(p["pose"][2]), math.sin(p["pose"][2])])
            moved = float(np.dot(pose[:2] - p["pose"][:2], heading))
            self._prev_distance = self._measures["distance_to_goal"]
            self._stopped = p["stop"]
            self._measures.update(self._ctx, StepState(pose[:2], float(pose[2]), p["action"], p["stop"], p["forward"], moved))
            self._pending = None
        if self._ctx is None:
            return {}
        info = self._measures.info()
        info["fail"] = self._stopped and not info["success"]
        info["stopped"] = self._stopped
        return _batched(info, self.device)

    def _get_obs_extra(self, info: dict):
        pose = self._pose
        goal = self._ctx.goal if self._ctx is not None else np.zeros(2)
        d = goal - pose[:2]
        rho = float(np.linalg.norm(d))
        phi = (math.atan2(d[1], d[0]) - pose[2] + math.pi) % (2 * math.pi) - math.pi
        return dict(agent_pose=torch.tensor(pose[None], dtype=torch.float32, device=self.device),
                    goal_gps_compass=torch.tensor([[rho, phi]], dtype=torch.float32, device=self.device),
                    target_category=self._target_onehot())

    def _target_onehot(self) -> torch.Tensor:
        """(1, n_categories) one-hot of the episode's target category."""
        onehot = np.zeros((1, len(self.category_names)), np.float32)
        onehot[0, self.category_names.index(self._episode["object_category"])] = 1.0
        return torch.from_numpy(onehot).to(self.device)

    # --- rewards (Eq. 5) -----------------------------------------------------------------------
    def _safety_penalty(self, clearance: float) -> float:
        c = self.cfg
        if clearance >= SAFETY_THRESHOLD:
            return 0.0
        return c.safety_penalty * ((1.0 - clearance / SAFETY_THRESHOLD) if c.proportional_safety else 1.0)

    def compute_dense_reward(self, obs, action, info):
        c = self.cfg
        d = float(info["distance_to_goal"][0])
        # Eq. 5. The success bonus is paid once, at a successful STOP ("a sparse success bonus"):
        # paying 1[d_t < r] every step, as printed, would reward hovering inside the radius.
        r = (self._prev_distance - d) - c.step_penalty + c.success_bonus * float(info["success"][0])
        r -= self._safety_penalty(float(info["clearance"][0]))
        return torch.tensor([r], dtype=torch.float32, device=self.device)

    def compute_normalized_dense_reward(self, obs, action, info):
        return self.compute_dense_reward(obs, action, info) / self.cfg.success_bonus

    def compute_sparse_reward(self, obs, action, info):
        return info["success"].to(torch.float32)

    # --- helpers for users ---------------------------------------------------------------------
    @property
    def current_episode(self) -> dict:
        return self._episode

    def instrument_segmentation(self) -> dict[int, tuple[str, str]]:
        """Segmentation id -> (object id, category) for the current scene."""
        ids = self.scene_builder.segmentation_ids(0)
        return {sid: (oid, self.scene_spec.get(oid).category) for sid, oid in ids.items()}


def _batched(info: dict, device) -> dict:
    """Info values as (1,)-shaped tensors, made from three tensors (bool, int, float) in one go."""
    kinds = {bool: ([], torch.bool), int: ([], torch.int32), float: ([], torch.float32)}
    for k, v in info.items():
        kinds[bool if isinstance(v, bool) else int if isinstance(v, int) else float][0].append(k)
    out = {}
    for keys, dtype in kinds.values():
        if keys:
            t = torch.tensor([info[k] for k in keys], dtype=dtype, device=device)
            out.update({k: t[i:i + 1] for i, k in enumerate(keys)})
    return out


def _action_help() -> str:
    return "discrete actions are " + ", ".join(f"{k}={v}" for k, v in ACTIONS.items())

