"""``BioVLN-OpFace-v0``: navigate a mobile base to an instrument's operational-face goal (paper §3.2).

One ``step`` is one action of the paper's space, executed by the robot's ManiSkill controller
(``control_mode="discrete"``: 0=STOP, 1=FORWARD 0.25 m, 2=TURN_LEFT 30 deg, 3=TURN_RIGHT 30 deg;
``"continuous"``: [forward, turn, stop] in [-1, 1]) through SAPIEN physics: exact when free, stopped
by walls and instruments. STOP ends the episode; it succeeds within the goal's success radius.

Batch-native as ManiSkill's tasks: every sub-env has its own episode and scene build config, all
per-step state (poses, measures, reward, success) is a tensor with a leading ``num_envs`` dimension,
and ``_initialize_episode(env_idx)`` resets only the sub-envs named. Measures update once per step
after the controller ran (``_after_control_step``); ``evaluate()`` only reads them. Policies see the
sensors of ``NavTaskConfig.sensors`` (see ``biovln_ms.baselines.policy``); oracles get a
:class:`~biovln_ms.tasks.privileged.PrivilegedView` through :meth:`episode_info`.
"""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np
import sapien
import torch
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.sensors.camera import CameraConfig
from mani_skill.utils import sapien_utils
from mani_skill.utils.structs.types import SimConfig

from biovln_ms.agents.robots import NAV_AGENTS
from biovln_ms.agents.robots.biovln_base import CONTROL_MODES
from biovln_ms.benchmark import dataset_root
from biovln_ms.catalog import load_catalog
from biovln_ms.episodes.source import (
    EPISODE_OPTIONS,
    DatasetEpisodes,
    EpisodeCursor,
    EpisodeSource,
    GeneratedEpisodes,
)
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.motion import SweptMotion
from biovln_ms.scene.rules import floor_polygon, scene_navigation
from biovln_ms.metrics.measures import BatchContext, EpisodeContext, MeasureSet, StepState
from biovln_ms.metrics.protocol_measures import check_protocol_options
from biovln_ms.noise import actuation_errors, actuation_uniforms, resolve_noise
from biovln_ms.render.camera_shaders import head_camera_shader, use_depth_only_format
from biovln_ms.render.lighting import lighting_preset
from biovln_ms.robots import DEFAULT_ROBOT, ROBOTS, robot_spec
from biovln_ms.sensor_noise import DepthNoise, RGBNoise, frame_keys
from biovln_ms.sim.footprints import collision_footprints
from biovln_ms.sim.maniskill_builder import LabSceneBuilder
from biovln_ms.sim.reach import REACH_MEASURES, FetchArm, ReachResult, reach_goals
from biovln_ms.task_config import EpisodeInfo, NavTaskConfig, TaskSpec
from biovln_ms.tasks.privileged import PrivilegedView
from biovln_ms.tasks.sensors import SENSORS, SensorInputs, semantic_category
from biovln_ms.variants import VARIANTS

GOAL_MODES = ("opface", "centroid")
SIM_BACKENDS = ("auto", "cpu", "physx_cpu", "gpu", "cuda", "physx_cuda")  # ManiSkill's names
RENDER_BACKENDS = ("auto", "cpu", "sapien_cpu", "gpu", "cuda", "sapien_cuda", "none")
#: a move that ends farther than this (m) from its target was blocked (``noise.sliding=False``)
SLIDE_TOLERANCE = 0.01
#: steps of actuation noise drawn at once per sub-env: a generator's first draw after a render costs ten
#: times the next ones (cold caches), so the draws of the next steps come with it (the same numbers)
ACTUATION_CHUNK = 32
#: the image noise banks' seed; a frame's noise is chosen by (episode seed, step) (biovln_ms.sensor_noise)
IMAGE_NOISE_SEED = 0x696D67
#: the follow camera of ``render()``: behind and above the robot, looking at a point ahead of it
FOLLOW_CAMERA_EYE = (-2.2, 0.0, 2.3)
FOLLOW_CAMERA_TARGET = (1.0, 0.0, 0.3)


class EnvConfigError(BioVLNError):
    """Invalid env arguments (split, episode, obs mode, control mode, action)."""


class BioVLNNavEnv(BaseEnv):
    """Operational-face navigation. Episodes from ``split`` (of ``dataset`` or the default dataset),
    or sampled in a scene generated from ``template`` / ``scene_seed``. Task parameters
    (:class:`NavTaskConfig` fields) may be passed as keyword arguments."""

    #: ManiSkill's agent uids of the robots (``robot_uids`` takes the ``biovln_ms.robots.ROBOTS`` ids)
    SUPPORTED_ROBOTS = [NAV_AGENTS[r].uid for r in ROBOTS]
    SUPPORTED_REWARD_MODES = ("normalized_dense", "dense", "sparse", "none")
    config: NavTaskConfig = VARIANTS["BioVLN-OpFace-v0"]

    def __init__(
        self,
        *args,
        split: str | None = None,
        dataset: str | None = None,
        template: str = "single_room",
        scene_seed: int = 0,
        control_mode: str = "discrete",
        robot_uids: str = DEFAULT_ROBOT,
        **kwargs,
    ) -> None:
        overrides = {f.name: kwargs.pop(f.name) for f in fields(NavTaskConfig) if f.name in kwargs}
        self.cfg = replace(self.config, **overrides)
        kwargs.setdefault("obs_mode", self.cfg.default_obs_mode)
        noise = resolve_noise(self.cfg.noise)
        _check_pose_state(self.cfg, noise, kwargs["obs_mode"])
        self.cfg = self.cfg.with_noise(noise)
        if not torch.cuda.is_available():  # ManiSkill's default asks for "sapien_cuda" and warns each make
            kwargs.setdefault("render_backend", "cpu")
        _check_arguments(self.cfg, control_mode, kwargs)
        self.robot_id = robot_spec(robot_uids).uid  # a ROBOTS id; ManiSkill gets its agent's uid
        split = split or self.cfg.default_split
        if split:
            self.source: EpisodeSource = DatasetEpisodes(
                split, dataset_root(dataset, self.robot_id), self.robot_id
            )
        elif dataset:
            raise EnvConfigError(
                f"a dataset ({dataset}) was given without a split",
                field="split",
                fix="pass split=, e.g. split='ms_val'",
            )
        else:
            self.source = self._generated_episodes(template, scene_seed)
        _check_episode_kind(self.cfg, self.config.protocol, self.source, split)
        self.cursor = EpisodeCursor(self.source, self.cfg.shuffle_episodes)
        self.category_names = load_catalog().goal_categories()
        n = int(kwargs.get("num_envs", 1))
        self._episode_index: list[int] = [self.cursor.first] * n  # per sub-env, into source.episodes
        self._episodes: list[dict] = [self.source.episodes[self.cursor.first]] * n
        self._scene_ids: list[str | None] = [None] * n
        self._set_scenes()
        self._arm: FetchArm | None = None  # Fetch's arm model for the reach check, made at the first STOP
        super().__init__(*args, robot_uids=NAV_AGENTS[self.robot_id].uid, control_mode=control_mode, **kwargs)

    def _generated_episodes(self, template: str, scene_seed: int) -> EpisodeSource:
        """The episodes without a split: sampled in a scene generated from ``template`` / ``scene_seed``."""
        return GeneratedEpisodes(template, scene_seed, robot=self.robot_id)

    # --- configuration -------------------------------------------------------------------------
    @property
    def _default_sim_config(self):
        return SimConfig(sim_freq=100, control_freq=20)  # 5 substeps: the stiff drive settles in them

    @property
    def _default_sensor_configs(self):
        c, visual = self.cfg, self.obs_mode_struct.visual
        shader = head_camera_shader(visual)  # the pack follows what is observed (render.camera_shaders)
        return [
            CameraConfig(
                "head",
                sapien.Pose(),
                c.camera_width,
                c.camera_height,
                c.camera_vfov,
                0.05,
                c.camera_far,
                mount=self.agent.camera_link,
                shader_config=shader,
            )
        ]

    def _setup_sensors(self, options: dict) -> None:
        """ManiSkill's, with the picture format of the depth-only pack set first: the head camera (the task's
        sensor) is the first camera made, and SAPIEN fixes its format then."""
        use_depth_only_format()
        super()._setup_sensors(options)

    @property
    def _default_human_render_camera_configs(self):
        """A follow camera inside the room, behind and above the robot (``render()`` hides the ceiling)."""
        pose = sapien_utils.look_at(FOLLOW_CAMERA_EYE, FOLLOW_CAMERA_TARGET)
        return CameraConfig("follow", pose, 960, 720, math.radians(60), 0.05, 100, mount=self.agent.base_link)

    def _set_scenes(self) -> None:
        """Scene specs and navigation geometry of every sub-env's current episode."""
        scene_ids = [ep["scene_id"] for ep in self._episodes]
        built = {}  # once per distinct scene: sub-envs sharing a scene share its geometry
        for sid in dict.fromkeys(scene_ids):
            spec = self.source.spec(sid)
            motion = SweptMotion(floor_polygon(spec), collision_footprints(spec), spec.robot_radius)
            built[sid] = (spec, scene_navigation(spec), motion)
        self.scene_specs, self.navs, self._motions = (
            list(v) for v in zip(*(built[sid] for sid in scene_ids))
        )
        self._scene_ids = scene_ids

    @property
    def scene_spec(self):
        """The scene of sub-env 0 (the only one on the CPU)."""
        return self.scene_specs[0]

    # --- ManiSkill hooks -----------------------------------------------------------------------
    def _load_agent(self, options: dict):
        super()._load_agent(options, sapien.Pose())
        for controller in self.agent.controllers.values():
            controller.set_motion(self.cfg.forward_step, self.cfg.turn_deg)
            controller.limit = self._limit_targets
            controller.perturb = self._perturb if self.cfg.noise.actuation > 0 else None

    def _load_scene(self, options: dict):
        scene_ids = list(dict.fromkeys(self._scene_ids))  # one build config per distinct scene
        self.scene_builder = LabSceneBuilder(
            self, [self.scene_specs[self._scene_ids.index(s)] for s in scene_ids], lighting=self.cfg.lighting
        )
        self.scene_builder.build([scene_ids.index(s) for s in self._scene_ids])
        self._build_segmentation_lookup()

    def _load_lighting(self, options: dict):
        """Lights come from the scene builder."""

    def _after_reconfigure(self, options: dict):
        self._ctx = BatchContext(self.num_envs)
        c = self.cfg
        # what info reports, and what the task needs besides (reward, success, fail, the sensors' clearance)
        reach = REACH_MEASURES if self.robot_id == "fetch" and not c.protocol else ()  # only Fetch has an arm
        self._info_names = tuple(
            dict.fromkeys(c.measures + ("stopped", "agent_pose", "goal_position") + reach)
        )
        needed = (c.reward_measure, c.success_measure, c.fail_measure, "clearance")
        self._measures = MeasureSet(
            tuple(dict.fromkeys(self._info_names + needed)), self.num_envs, self.device, c
        )
        if reach:
            self._measures.measures["reachable"].solver = self._reach
        # the task's per-sub-env bookkeeping is on the host, like the measures (biovln_ms.metrics.measures)
        self._start = np.zeros((self.num_envs, 3))
        self._objectgoal = np.zeros((self.num_envs, len(self.category_names)), np.float32)
        self._done = np.zeros(self.num_envs, dtype=bool)  # the episode has ended
        self._actuation_error = np.zeros((self.num_envs, 3))  # the last step's (along, across, heading)
        self._uniform_chunks: dict[int, tuple] = {}  # sub-env -> ((episode seed, first step), uniforms)
        self._frozen = self._done.copy()  # ... already before the current step

    def close(self):
        self._closed = True
        super().close()

    def _check_open(self) -> None:
        if getattr(self, "_closed", False):
            raise EnvConfigError("the env is closed", field="env", fix="make a new one with gym.make(...)")

    def reset(self, seed=None, options=None):
        self._check_open()
        options = dict(options or {})
        env_idx = options.get("env_idx")
        rows = range(self.num_envs) if env_idx is None else torch.as_tensor(env_idx).reshape(-1).tolist()
        if env_idx is not None:  # ManiSkill's SB3 wrapper passes NumPy indices; the base env wants a tensor
            options["env_idx"] = torch.tensor(rows, dtype=torch.int64, device=self.device)
        # a partial reset of a batched env cannot rebuild a sub-env's scene: its next episode is there
        # (a seed does not move the cursor then); otherwise the cursor's, a seed positioning it once
        partial = self.num_envs > 1 and env_idx is not None
        in_scene = partial and not EPISODE_OPTIONS & set(options)
        chosen, cursor_seed = {}, seed
        for i in rows:
            if in_scene:
                chosen[i] = self.cursor.next_in_scene(self._scene_ids[i])
            else:
                chosen[i], cursor_seed = self.cursor.select(cursor_seed, options), None
        episodes = [
            self.source.episodes[chosen[i]] if i in chosen else e for i, e in enumerate(self._episodes)
        ]
        changed = [ep["scene_id"] for ep in episodes] != self._scene_ids
        if changed and partial:
            raise EnvConfigError(
                "a partial reset cannot change a sub-env's scene on the GPU",
                field="env_idx",
                fix="reset all sub-envs (reconfigure), or keep each sub-env's episodes in its scene",
            )
        for i, k in chosen.items():
            self._episode_index[i] = k
        self._episodes = episodes
        if changed:
            self._set_scenes()
            options["reconfigure"] = True
        return super().reset(seed=seed, options=options)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        idx = env_idx.cpu().numpy()
        qpos = torch.zeros(len(idx), 3, dtype=torch.float32, device=self.device)
        for k, i in enumerate(idx.tolist()):
            ep = self._episodes[i]
            x, y = ep["start_position"][:2]
            w, _, _, z = ep["start_rotation"]
            qpos[k] = torch.tensor([x, y, 2 * math.atan2(z, w)])
            self._ctx.set(i, self._episode_context(i))
            self._objectgoal[i] = 0.0
            self._objectgoal[i, self.category_names.index(ep["object_category"])] = 1.0
        self.agent.reset_planar(qpos if self.num_envs > 1 else qpos[:1])
        pose = self._pose()
        self._start[idx] = pose[idx]
        self._done[idx] = False
        self._frozen[idx] = False
        self._actuation_error[idx] = 0.0
        self._measures.reset(self._ctx, StepState.at_rest(pose), idx)

    def _episode_context(self, i: int) -> EpisodeContext:
        """Sub-env ``i``'s episode for the measures: every goal of the episode counts (one, or each instance
        of the category where any instance counts), with the geodesic to the nearest."""
        ep, spec, nav = self._episodes[i], self.scene_specs[i], self.navs[i]
        goals, distance_fns = [], []
        for g in ep["goals"]:
            target = spec.get(g["object_id"]).placed()
            if self.cfg.goal_mode == "centroid":
                goal = target.centroid_goal()
                distance_fns.append(nav.distance_to(nav.snap(goal)))
            else:
                goal = np.asarray(g["position"][:2], float)
                distance_fns.append(nav.distance_to(goal))
            goals.append((goal, float(g["radius"]), target))
        geodesic = distance_fns[0] if len(distance_fns) == 1 else (lambda p: min(f(p) for f in distance_fns))
        start = np.asarray(ep["start_position"][:2], float)
        (goal, radius, target), *others = goals
        return EpisodeContext(
            goal=goal,
            success_radius=radius,
            target=target,
            instruments=[o.placed() for o in spec.instruments],
            geodesic=geodesic,
            start_geodesic=float(geodesic(start)),
            hfov=self.cfg.hfov,
            other_goals=tuple(others),
        )

    def _reach(self, i: int, pose: np.ndarray) -> tuple[ReachResult, int]:
        """Whether Fetch's gripper reaches an interaction point of sub-env ``i``'s goals from planar ``pose``,
        and which goal (``biovln_ms.sim.reach``; the arm model is made from this env's articulation once)."""
        if self._arm is None:
            self._arm = FetchArm(self.agent.robot._objs[0])
        ids = [g["object_id"] for g in self._episodes[i]["goals"]]
        return reach_goals(self._arm, self.scene_specs[i], ids, pose)

    def reach_configuration(self, i: int = 0) -> np.ndarray | None:
        """Sub-env ``i``'s reaching joint positions (every active joint) found at its STOP, or None (not
        reachable, no STOP yet, or a robot without an arm)."""
        if "reachable" not in self._measures.measures:
            return None
        q = self._measures.measures["reachable"].qpos[i]
        return None if np.isnan(q).any() else q.copy()

    def _pose(self) -> np.ndarray:
        """(N, 3) float64 planar poses from the base joints (host)."""
        return self.agent.planar_pose().astype(np.float64)

    def _step_action(self, action):
        """ManiSkill's, after turning what gymnasium users pass for ``Discrete(4)`` — ``2``, ``np.int64(2)``,
        0-d arrays and tensors, lists — into the (N,)-shaped tensor ManiSkill batches."""
        self._check_open()
        if isinstance(action, (int, float, np.generic, list, tuple)) and not isinstance(action, bool):
            action = torch.as_tensor(np.asarray(action))
        if isinstance(action, (np.ndarray, torch.Tensor)) and action.ndim == 0:
            action = action.reshape(1)
        self._frozen = self._done.copy()  # an ended episode ignores actions until reset (Habitat's rule)
        self.agent.controller.frozen = self._frozen
        return super()._step_action(action)

    def _limit_targets(self, pose: np.ndarray, target: np.ndarray, moving: np.ndarray) -> np.ndarray:
        """Drive targets of forward moves cut before an obstacle the straight path would cross (per scene)."""
        out = target.copy()
        for i in np.flatnonzero(moving).tolist():
            x, y = pose[i, :2].tolist()
            out[i, 0], out[i, 1] = self._motions[i].target(x, y, *target[i, :2].tolist())
        return out

    def _perturb(self, forward: np.ndarray, turn: np.ndarray, acting: np.ndarray) -> tuple[np.ndarray, ...]:
        """Actuation noise (``biovln_ms.noise``): the executed (along, across, turn) of each sub-env's move,
        drawn from its episode seed and step (STOP and ended episodes move exactly: not at all)."""
        err = np.zeros((len(forward), 3))
        moving = np.flatnonzero(acting & ((forward > 0) | (turn != 0))).tolist()
        if moving:
            steps = self._elapsed_steps.tolist()
            for i in moving:
                u = self._actuation_uniforms(i, steps[i])
                err[i] = actuation_errors(u, float(forward[i]), float(turn[i]), self.cfg.noise.actuation)
        self._actuation_error = err
        return forward + err[:, 0], err[:, 1], turn + err[:, 2]

    def _actuation_uniforms(self, i: int, step: int) -> list[float]:
        """Sub-env ``i``'s actuation uniforms at ``step`` (:func:`~biovln_ms.noise.actuation_uniforms`),
        drawn ``ACTUATION_CHUNK`` steps at a time and kept per sub-env."""
        seed, first = int(self._episode_seed[i]), step - step % ACTUATION_CHUNK
        chunk = self._uniform_chunks.get(i)
        if chunk is None or chunk[0] != (seed, first):
            chunk = ((seed, first), actuation_uniforms(seed, first, ACTUATION_CHUNK))
            self._uniform_chunks[i] = chunk
        return chunk[1][step - first]

    def _put_back(self, rows: list[int], poses: np.ndarray) -> None:
        """Sub-envs ``rows`` stand at ``poses`` (their rows), at rest."""
        self.agent.controller.put_back(rows, poses)

    def _undo_crossings(self, start: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """Sub-envs whose body went through or deep into an obstacle this step go back to where the move
        started (a blocked move); returns the poses after that."""
        moved = np.flatnonzero((pose[:, :2] != start[:, :2]).any(1)).tolist()
        back = [i for i in moved if self._motions[i].crossed(*start[i, :2].tolist(), *pose[i, :2].tolist())]
        if not back:
            return pose
        self._put_back(back, start)
        return self._pose()

    def _no_sliding(self, cmd, pose: np.ndarray) -> np.ndarray:
        """Without sliding, a move that did not reach its target (an obstacle stopped or deflected it) leaves
        the robot where it started, turned as the move turned it (Habitat's ``allow_sliding=False``)."""
        start, target = cmd.start_pose, cmd.target
        moved = (target[:, 0] != start[:, 0]) | (target[:, 1] != start[:, 1])
        off = np.hypot(pose[:, 0] - target[:, 0], pose[:, 1] - target[:, 1]) > SLIDE_TOLERANCE
        back = np.flatnonzero(moved & off).tolist()
        if not back:
            return pose
        stay = pose.copy()
        stay[back, :2] = start[back, :2]
        self._put_back(back, stay)
        return self._pose()

    def _after_control_step(self):
        cmd = self.agent.controller.command
        start = cmd.start_pose
        pose = self._undo_crossings(start, self._pose())
        if not self.cfg.noise.sliding:
            pose = self._no_sliding(cmd, pose)
        d = pose[:, :2] - start[:, :2]
        moved = d[:, 0] * np.cos(start[:, 2]) + d[:, 1] * np.sin(start[:, 2])
        state = StepState(pose[:, :2], pose[:, 2], cmd.stop, cmd.forward, moved)
        active = None if not self._frozen.any() else np.flatnonzero(~self._frozen)
        self._measures.update(self._ctx, state, active)
        c = self.cfg
        self._done |= self._measures[c.success_measure] | self._measures[c.fail_measure]
        self._done |= self._elapsed_steps.cpu().numpy() + 1 >= c.max_episode_steps

    def evaluate(self) -> dict:
        """The measures' values (a pure query: it changes nothing)."""
        c = self.cfg
        info = self._measures.info(self._info_names)
        info["success"] = self._measures.tensor(c.success_measure)
        info["fail"] = self._measures.tensor(c.fail_measure)
        if c.noise.actuation > 0:  # what the noise did this step: a replay checks it
            info["actuation_error"] = torch.tensor(
                self._actuation_error, dtype=torch.float32, device=self.device
            )
        return info

    def _get_obs_agent(self):
        return super()._get_obs_agent() if self.cfg.agent_obs else {}

    def _get_obs_extra(self, info: dict):
        x = SensorInputs(
            self._measures["agent_pose"],
            self._start,
            self._ctx.goal,
            self._objectgoal,
            self._measures["clearance"],
            self.cfg,
        )
        return {name: torch.from_numpy(SENSORS[name](x)).to(self.device) for name in self.cfg.sensors}

    def _get_obs_with_sensor_data(self, info: dict, apply_texture_transforms: bool = True) -> dict:
        obs = super()._get_obs_with_sensor_data(info, apply_texture_transforms)
        head = obs.get("sensor_data", {}).get("head", {})
        self._apply_image_noise(head)
        if "segmentation" in head:
            obs["extra"]["semantic_category"] = semantic_category(
                head["segmentation"], self._segmentation_lookup
            )
        if not self.cfg.noise.gps_compass and "sensor_param" in obs:
            self._camera_params_in_base_frame(obs["sensor_param"])
        return obs

    def _camera_params_in_base_frame(self, params: dict) -> None:
        """Without GPS+compass the cameras' extrinsics are given relative to the robot's base (the mount,
        as a robot knows it), not the world: world-frame extrinsics would tell the pose
        (:mod:`biovln_ms.geometry.base_frame`)."""
        from biovln_ms.geometry import base_frame  # Numba's import (0.3 s) only where it is used

        pose = self._measures["agent_pose"]  # this step's pose, already read from the joints
        for cam in params.values():
            ext, c2w = cam["extrinsic_cv"], cam["cam2world_gl"]
            cpu = ext.device.type == "cpu" and ext.dtype == c2w.dtype == torch.float32
            if cpu and len(pose) == ext.shape[0] == c2w.shape[0]:
                cam["extrinsic_cv"] = torch.empty(ext.shape, dtype=ext.dtype)
                cam["cam2world_gl"] = torch.empty(c2w.shape, dtype=c2w.dtype)
                base_frame.camera_params_in_base_frame(
                    pose, ext.numpy(), c2w.numpy(), cam["extrinsic_cv"].numpy(), cam["cam2world_gl"].numpy()
                )
            else:
                b2w, w2b = (
                    torch.from_numpy(m).to(ext.device, ext.dtype) for m in base_frame.base_transforms(pose)
                )
                cam["extrinsic_cv"], cam["cam2world_gl"] = ext @ b2w, w2b @ c2w

    def _apply_image_noise(self, head: dict) -> None:
        """The noise config's RGB and depth noise on the head camera's images (in place), keyed by each
        sub-env's (episode, step) so that a recorded episode replays exactly."""
        rgb_noise, depth_noise = self._image_noise()
        if (rgb_noise and "rgb" in head) or (depth_noise and "depth" in head):
            keys = frame_keys(self._episode_seed, self._elapsed_steps.cpu().numpy())
            if rgb_noise and "rgb" in head:
                rgb_noise(head["rgb"], keys, out=head["rgb"])
            if depth_noise and "depth" in head:
                depth_noise(head["depth"], keys, out=head["depth"])

    def _image_noise(self) -> tuple[RGBNoise | None, DepthNoise | None]:
        """The noise config's RGB and depth noise models for the head camera (built once, on first use)."""
        if not hasattr(self, "_image_noise_models"):
            c, noise = self.cfg, self.cfg.noise
            h, w, seed = c.camera_height, c.camera_width, IMAGE_NOISE_SEED
            focal = w / (2 * math.tan(c.hfov / 2))  # pixels, as the camera's intrinsic matrix has it
            self._image_noise_models = (
                RGBNoise(h, w, sigma=noise.rgb, seed=seed, device=self.device) if noise.rgb > 0 else None,
                DepthNoise(h, w, focal_px=focal, seed=seed, device=self.device) if noise.depth else None,
            )
        return self._image_noise_models

    def _build_segmentation_lookup(self) -> None:
        """Segmentation id -> 1 + goal-category index (0: not a goal-category object), over all sub-scenes."""
        ids = {}
        for bci, spec in enumerate(self.scene_builder.build_configs):
            for sid, oid in self.scene_builder.segmentation_ids(bci).items():
                cat = spec.get(oid).category
                ids[sid] = self.category_names.index(cat) + 1 if cat in self.category_names else 0
        lookup = torch.zeros(max(ids, default=0) + 1, dtype=torch.int16, device=self.device)
        for sid, v in ids.items():
            lookup[sid] = v
        self._segmentation_lookup = lookup

    # --- rewards: measures chosen by the config (Eq. 5) ----------------------------------------
    def compute_dense_reward(self, obs, action, info):
        reward = np.where(self._frozen, 0.0, self._measures[self.cfg.reward_measure])  # nothing after the end
        return torch.from_numpy(reward.astype(np.float32)).to(self.device)

    def compute_normalized_dense_reward(self, obs, action, info):
        return self.compute_dense_reward(obs, action, info) / self.cfg.success_bonus

    def compute_sparse_reward(self, obs, action, info):
        return (info["success"] & ~torch.from_numpy(self._frozen).to(self.device)).to(torch.float32)

    # --- state: the simulator's and the task's -------------------------------------------------
    def get_state_dict(self):
        """ManiSkill's simulation and controller state plus the task's: each sub-env's episode, start pose,
        elapsed steps and every measure's state, so a replay from it gives the same rewards and infos."""
        state = super().get_state_dict()
        state["task"] = dict(
            episode=self._episode_indices(),
            start=torch.tensor(self._start, device=self.device),
            elapsed_steps=torch.as_tensor(self._elapsed_steps).clone(),
            done=torch.tensor(self._done, device=self.device),
            episode_seed=torch.tensor(self._episode_seed, device=self.device),  # seeds the actuation noise
            actuation_error=torch.tensor(self._actuation_error, device=self.device),
            measures=self._measures.state_dict(),
        )
        return state

    def set_state_dict(self, state: dict, env_idx: torch.Tensor | None = None):
        super().set_state_dict(state, env_idx)
        task = state.get("task")
        if task is None:
            return
        idx = torch.arange(self.num_envs, device=self.device) if env_idx is None else env_idx.to(self.device)
        saved = torch.as_tensor(task["episode"]).to(self.device)
        if not torch.equal(saved[idx], self._episode_indices()[idx]):
            raise EnvConfigError(
                "the state belongs to another episode",
                field="state['task']['episode']",
                fix="reset to that episode first: env.reset(options={'episode_index': k})",
            )
        rows = idx.cpu().numpy()
        self._start[rows] = torch.as_tensor(task["start"]).cpu().numpy()[rows]
        self._elapsed_steps[idx] = torch.as_tensor(task["elapsed_steps"], device=self.device)[idx].to(
            self._elapsed_steps.dtype
        )
        self._done[rows] = torch.as_tensor(task["done"]).cpu().numpy()[rows]
        self._episode_seed[rows] = torch.as_tensor(task["episode_seed"]).cpu().numpy()[rows]
        self._actuation_error[rows] = torch.as_tensor(task["actuation_error"]).cpu().numpy()[rows]
        self._measures.load_state_dict(task["measures"], idx)

    def _episode_indices(self) -> torch.Tensor:
        return torch.tensor(self._episode_index, device=self.device)

    # --- rendering -----------------------------------------------------------------------------
    def render_rgb_array(self, camera_name: str | None = None):
        """The follow camera's view with the ceilings hidden (sensors keep them)."""
        bodies = [
            e.find_component_by_type(sapien.render.RenderBodyComponent)
            for b in self.scene_builder.built.values()
            for a in b.shell
            if a.name.endswith("ceiling")
            for e in a._objs
        ]
        for body in bodies:
            body.visibility = 0.0
        try:
            return super().render_rgb_array(camera_name)
        finally:
            for body in bodies:
                body.visibility = 1.0

    # --- what policies and evaluators may know -------------------------------------------------
    @property
    def current_episode(self) -> dict:
        """Sub-env 0's episode record (for evaluators and logs, not for policies)."""
        return self._episodes[0]

    def task_spec(self) -> TaskSpec:
        c = self.cfg
        return TaskSpec(
            c.forward_step,
            c.turn_deg,
            c.camera_hfov_deg,
            c.max_episode_steps,
            tuple(self.category_names),
            self.control_mode,
            self.agent.radius,
            c.noise,
            c.position_scale,
        )

    def episode_info(self, i: int = 0, privileged: bool = False) -> EpisodeInfo:
        """What a policy may know of sub-env ``i``'s episode; ``privileged`` adds the oracle's
        read-only view."""
        ep = self._episodes[i]
        view = None
        if privileged:
            view = PrivilegedView(
                self._ctx.episode(i), self.navs[i], lambda: self._pose()[i], self.cfg.goal_mode
            )
        return EpisodeInfo(ep["scene_id"], ep["episode_id"], ep["object_category"], self.task_spec(), view)


def _check_episode_kind(
    cfg: NavTaskConfig, protocol_env: bool, source: EpisodeSource, split: str | None
) -> None:
    """Protocol (multi-goal) episodes run only in the protocol env, and single-goal ones only elsewhere: a
    protocol episode's goals read as any-instance goals would be a silently wrong task."""
    if cfg.protocol != protocol_env:
        raise EnvConfigError(
            f"protocol={cfg.protocol} does not fit this env",
            field="protocol",
            fix="make BioVLN-Protocol-v0 for protocol episodes, or a single-goal variant for the others",
        )
    kinds = {"protocol" in ep for ep in source.episodes}
    if kinds != {cfg.protocol}:
        where = f"split '{split}'" if split else "the generated episodes"
        held = "protocol (multi-goal)" if True in kinds else "single-goal"
        runs = "protocol" if cfg.protocol else "single-goal"
        raise EnvConfigError(
            f"{where} holds {held} episodes, this env runs {runs} ones",
            field="split",
            fix="use the protocol_* splits with BioVLN-Protocol-v0, the others with the single-goal variants",
        )


def _check_pose_state(cfg: NavTaskConfig, noise, obs_mode: str) -> None:
    """The RL state vector is the robot's pose: without GPS+compass a flat state observation would hold only
    the start-frame ``pointgoal`` and ``objectgoal``, nothing a policy could act on; refuse it in one line."""
    if "rl_state" in cfg.sensors and not noise.gps_compass and obs_mode in ("state", "state_dict"):
        raise BioVLNError(
            f"sensor rl_state is the robot's pose, and noise '{noise.name}' has no GPS+compass",
            field="obs_mode",
            fix="observe depth and keep a pose estimate (obs_mode='depth', as baselines/sb3_policy.py does), "
            "or keep GPS+compass: noise={'preset': '" + noise.name + "', 'gps_compass': True}",
        )


def _check_arguments(cfg: NavTaskConfig, control_mode: str, kwargs: dict) -> None:
    """One-line errors for arguments ManiSkill would reject with a traceback, or accept silently."""
    if control_mode not in CONTROL_MODES:
        raise EnvConfigError(
            f"unknown control mode '{control_mode}'",
            field="control_mode",
            fix=f"use one of: {', '.join(CONTROL_MODES)}",
        )
    if cfg.goal_mode not in GOAL_MODES:
        raise EnvConfigError(
            f"unknown goal mode '{cfg.goal_mode}'",
            field="goal_mode",
            fix=f"use one of: {', '.join(GOAL_MODES)}",
        )
    lighting_preset(cfg.lighting)  # one-line error listing the presets
    check_protocol_options(cfg.wrong_stop, cfg.subgoal_rule, cfg.steps_per_goal)
    for name in (
        "forward_step",
        "turn_deg",
        "camera_width",
        "camera_height",
        "camera_hfov_deg",
        "max_episode_steps",
    ):
        v = getattr(cfg, name)
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise EnvConfigError(
                f"{name} must be a positive number, got {v!r}", field=name, fix=f"pass a positive {name}"
            )
    for key, known in (("sim_backend", SIM_BACKENDS), ("render_backend", RENDER_BACKENDS)):
        name = str(kwargs.get(key, "auto")).split(":")[0]
        if name not in known:
            raise EnvConfigError(
                f"unknown {key} '{kwargs[key]}'",
                field=key,
                fix=f"use one of: {', '.join(known)} (optionally ':<device id>')",
            )
    backend = str(kwargs.get("sim_backend", "auto"))
    gpu_backend = backend.split(":")[0] in ("gpu", "cuda", "physx_cuda")
    if gpu_backend and not torch.cuda.is_available():
        raise EnvConfigError(
            f"sim_backend='{backend}' needs a CUDA GPU and none is visible",
            field="sim_backend",
            fix="use sim_backend='physx_cpu' (the default on a machine without a GPU)",
        )
    n = kwargs.get("num_envs", 1)
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
        raise EnvConfigError(
            f"num_envs must be a positive integer, got {n!r}", field="num_envs", fix="pass num_envs=1 or more"
        )
    if n > 1 and not (gpu_backend and torch.cuda.is_available()):
        raise EnvConfigError(
            "num_envs > 1 needs sim_backend='physx_cuda' and a CUDA GPU; on the CPU run one env per "
            "process (gymnasium AsyncVectorEnv or SB3 SubprocVecEnv, see the envs guide)",
            field="num_envs",
        )
