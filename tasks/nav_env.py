"""``BioVLN-OpFace-v0``: navigate a mobile base to an instrument's operational-face goal (paper §3.2).

ManiSkill's task hooks, in ManiSkill's order. Beside it: the robot's locomotion in
:mod:`biovln_ms.agents.robots.locomotion`, the argument checks in :mod:`~.config_checks`, the episodes'
choice and context in :mod:`~.episodes`, the sensor-data processing in :mod:`~.observations`. The env is
handed its episodes; ``gym.make`` resolves ``split=`` and the like to them first (:mod:`~.episode_sources`).
"""

from __future__ import annotations

import math
from functools import lru_cache, partial

import numpy as np
import sapien
import torch
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.sensors.camera import CameraConfig
from mani_skill.utils import sapien_utils
from mani_skill.utils.structs.types import SimConfig

from biovln_ms.agents.robots import NAV_AGENTS
from biovln_ms.agents.robots.locomotion import as_action
from biovln_ms.catalog import load_catalog
from biovln_ms.episodes.schema import Episode
from biovln_ms.episodes.source import EpisodeCursor, EpisodeSource, GeneratedEpisodes
from biovln_ms.metrics.measure_set import MeasureSet
from biovln_ms.metrics.measures import BatchContext, EpisodeContext, StepState
from biovln_ms.metrics.reach_measures import REACH_MEASURES
from biovln_ms.render.camera_shaders import head_camera_shader, use_depth_only_format
from biovln_ms.render.progress import first_camera_render
from biovln_ms.render.step_capture import CapturesDuringStep
from biovln_ms.robot_specs import DEFAULT_ROBOT, ROBOTS, robot_spec
from biovln_ms.sim.maniskill_builder import LabSceneBuilder
from biovln_ms.sim.maniskill_compat import FreezesLiveObjects
from biovln_ms.sim.reach import FetchArm, ReachResult, reach_goals
from biovln_ms.task_config import EpisodeInfo, NavTaskConfig, TaskSpec
from biovln_ms.tasks.config_checks import SIM_FREQUENCIES, EnvConfigError, check_episode_kind
from biovln_ms.tasks.config_checks import REWARD_MODES, reset_arguments, task_config
from biovln_ms.tasks.episodes import SCENE_CACHE, scene_geometry
from biovln_ms.tasks.episodes import choose_episodes, episode_context
from biovln_ms.tasks.observations import HeadCameraNoise, segmentation_lookup
from biovln_ms.tasks.people import EnvPeople
from biovln_ms.tasks.privileged import PrivilegedView
from biovln_ms.tasks.sensors import SENSORS, SensorInputs, semantic_category
from biovln_ms.tasks.task_state import check_state, load_task_state, task_state
from biovln_ms.variants import BENCHMARK_ENV, VARIANTS

#: the follow camera of ``render()``: behind and above the robot, looking at a point ahead of it
FOLLOW_CAMERA_EYE = (-2.2, 0.0, 2.3)
FOLLOW_CAMERA_TARGET = (1.0, 0.0, 0.3)


class BioVLNNavEnv(FreezesLiveObjects, CapturesDuringStep, BaseEnv):
    """
    **Task Description:**
    Drive a mobile base (the BioVLN cylinder or Fetch) through a generated lab to the operational face of an
    instrument of the goal category (paper §3.2, Eq. 1), with the actions of the control mode
    (:mod:`biovln_ms.agents.robots.locomotion`) and the sensors of the config. One step is one action
    through SAPIEN physics: exact when free, stopped by walls and instruments. Batch-native: every per-step
    value has a leading ``num_envs`` dimension, and ``_initialize_episode(env_idx)`` resets the sub-envs
    named. Task parameters (:class:`NavTaskConfig` fields) may be passed as keyword arguments.

    **Randomizations:**
    - the episode (scene, start pose, goal category) comes from the episode source in order, or in a fixed
      shuffle (``shuffle_episodes``, a scene's episodes in visits of ``scene_visit_episodes``);
      ``reset(seed=k)`` jumps to position ``n · frac(k / φ)`` (seeds ``k, k + 1`` start far apart)
    - with a noise config (:mod:`biovln_ms.noise`): actuation noise, RGB and depth noise, keyed by each
      sub-env's episode seed and step so that a recorded episode replays exactly

    **Success Conditions:**
    - the config's ``success_measure``: by default STOP within the goal's success radius of an
      operational-face goal (``success``); the strict variants also ask for Zone 3 and facing the face.
      A STOP elsewhere fails (``fail_measure``); the episode ends at ``max_episode_steps``.
    """

    #: ManiSkill's agent uids of the robots (``robot_uids`` takes the ``biovln_ms.robot_specs.ROBOTS`` ids)
    SUPPORTED_ROBOTS = [NAV_AGENTS[r].uid for r in ROBOTS]
    SUPPORTED_REWARD_MODES = REWARD_MODES
    config: NavTaskConfig = VARIANTS[BENCHMARK_ENV]
    #: the episodes without a split, sampled in a scene generated from a template (:mod:`~.episode_sources`)
    generated_episodes = GeneratedEpisodes
    default_template = "single_room"

    def __init__(
        self,
        *args,
        episodes: EpisodeSource,
        control_mode: str = "discrete",
        robot_uids: str = DEFAULT_ROBOT,
        **kwargs,
    ) -> None:
        self.cfg = task_config(self.config, control_mode, kwargs, robot_uids)
        self.robot_id = robot_spec(robot_uids).uid  # a ROBOTS id; ManiSkill gets its agent's uid
        self._footprint = robot_spec(robot_uids).footprint_radius  # the swept checks' disc
        check_episode_kind(self.cfg, episodes, self._footprint)
        self.source = episodes
        self.cursor = EpisodeCursor(self.source, self.cfg.shuffle_episodes, self.cfg.scene_visit_episodes)
        self.category_names = load_catalog().goal_categories()
        n = int(kwargs.get("num_envs", 1))
        self._episode_index: list[int] = [self.cursor.first] * n  # per sub-env, into source.episodes
        self._episodes: list[Episode] = [self.source.episodes[self.cursor.first]] * n
        self._scene = lru_cache(SCENE_CACHE)(partial(scene_geometry, self.source, radius=self._footprint))
        self._set_scenes()
        self._arm: FetchArm | None = None  # Fetch's arm model for the reach check, made at the first STOP
        self._head_noise: HeadCameraNoise | None = None  # the image noise models, made once
        first_camera_render(kwargs["obs_mode"], software=not torch.cuda.is_available())  # its first render
        super().__init__(*args, robot_uids=NAV_AGENTS[self.robot_id].uid, control_mode=control_mode, **kwargs)

    @property
    def _default_sim_config(self):
        return SimConfig(**SIM_FREQUENCIES)  # 5 substeps: the stiff drive settles in them

    @property
    def _default_sensor_configs(self):
        c, visual = self.cfg, self.obs_mode_struct.visual
        shader = head_camera_shader(visual)  # the pack follows what is observed (render.camera_shaders)
        size = dict(
            width=c.camera_width, height=c.camera_height, fov=c.camera_vfov, near=0.05, far=c.camera_far
        )
        return [
            CameraConfig("head", sapien.Pose(), **size, mount=self.agent.camera_link, shader_config=shader)
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

    def _load_agent(self, options: dict):
        super()._load_agent(options, sapien.Pose())
        c = self.cfg
        for controller in self.agent.controllers.values():
            controller.configure(c.forward_step, c.turn_deg, c.noise.actuation, c.noise.sliding)

    def _load_scene(self, options: dict):
        scene_ids = list(dict.fromkeys(self._scene_ids))  # one build config per distinct scene
        specs = [self.scene_specs[self._scene_ids.index(s)] for s in scene_ids]
        # the instruments' looks only show in a picture: an env that makes none builds scenes without them
        images = self.obs_mode not in ("state", "state_dict", "none") or self.render_mode is not None
        self.scene_builder = LabSceneBuilder(self, specs, lighting=self.cfg.lighting, variants=images)
        self.scene_builder.build([scene_ids.index(s) for s in self._scene_ids])
        self._segmentation_lookup = segmentation_lookup(self.scene_builder, self.category_names, self.device)
        self._people = EnvPeople(self) if self.cfg.people else None  # figures, and "person" in segmentation
        for controller in self.agent.controllers.values():
            controller.motions, controller.people = self._motions, self._people

    def _load_lighting(self, options: dict):
        """Lights come from the scene builder."""

    def _after_reconfigure(self, options: dict):
        self._ctx, c = BatchContext(self.num_envs), self.cfg
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
        self._frozen = self._done.copy()  # ... already before the current step
        if self._head_noise is None:
            self._head_noise = HeadCameraNoise(c, self.device)

    def reset(self, seed=None, options=None):
        """ManiSkill's, after checking the seed and options (``env_idx`` as the base env's index tensor) and
        choosing each reset sub-env's episode (:func:`~.episodes.choose_episodes`); a sub-env's new scene
        reconfigures."""
        self._check_open()
        seed, options, rows = reset_arguments(seed, options, self.num_envs, self.device)
        partial = self.num_envs > 1 and "env_idx" in options
        chosen, self._episodes, changed = choose_episodes(
            self.cursor, self._episodes, rows, seed, options, partial
        )
        for i, k in chosen.items():
            self._episode_index[i] = k
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
            made = partial(self._episode_context, i)  # once per episode: kept with its scene
            self._ctx.set(i, self._geometry[i].context(self._episode_index[i], made))
            self._objectgoal[i] = 0.0
            self._objectgoal[i, self.category_names.index(ep["object_category"])] = 1.0
        self.agent.reset_planar(qpos if self.num_envs > 1 else qpos[:1])
        pose = self._pose()
        self._start[idx] = pose[idx]
        self._done[idx] = False
        self._frozen[idx] = False
        self.agent.controller.actuation_error[idx] = 0.0
        people = self._people.reset(idx.tolist(), pose) if self._people else None
        self._measures.reset(self._ctx, StepState.at_rest(pose, people), idx)

    def _step_action(self, action):
        """ManiSkill's, after checking the action (:func:`~biovln_ms.agents.robots.locomotion.as_action`).
        ``None`` is ManiSkill's no action: the robot holds its pose for the step, which counts (step limit,
        step penalty). An ended episode ignores actions until reset (Habitat's rule)."""
        self._check_open()
        action = as_action(action, self.control_mode, self.num_envs)
        self._frozen = self._done.copy()
        self.agent.controller.begin_step(self._frozen, self._episode_seed, self._elapsed_steps)
        if action is None:
            self.agent.controller.hold_still()
        return super()._step_action(action)

    def _after_control_step(self):
        """The measures of the move the controller made, once per step (``evaluate`` only reads them)."""
        move = self.agent.controller.end_step()
        people = self._people.step(move.pose, self._frozen) if self._people else None  # they move meanwhile
        self.start_capture(self._sync_people)  # the pictures render while the measures run
        state = StepState(move.pose[:, :2], move.pose[:, 2], move.stop, move.forward, move.moved, people)
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
            error = self.agent.controller.actuation_error
            info["actuation_error"] = torch.tensor(error, dtype=torch.float32, device=self.device)
        return info

    def _get_obs_agent(self):
        return super()._get_obs_agent() if self.cfg.agent_obs else {}

    def _get_obs_extra(self, info: dict):
        m, c = self._measures, self.cfg
        x = SensorInputs(m["agent_pose"], self._start, self._ctx.goal, self._objectgoal, m["clearance"], c)
        return {name: torch.from_numpy(SENSORS[name](x)).to(self.device) for name in self.cfg.sensors}

    def _get_obs_with_sensor_data(self, info: dict, apply_texture_transforms: bool = True) -> dict:
        """ManiSkill's, with the config's image noise, the goal category per pixel of a segmentation image,
        and without GPS+compass the cameras' extrinsics in the base frame (:mod:`~.observations`)."""
        obs = super()._get_obs_with_sensor_data(info, apply_texture_transforms)
        head = obs.get("sensor_data", {}).get("head", {})
        self._head_noise.apply_image_noise(head, self._episode_seed, self._elapsed_steps.cpu().numpy())
        if "segmentation" in head:
            obs["extra"]["semantic_category"] = semantic_category(
                head["segmentation"], self._segmentation_lookup
            )
        if not self.cfg.noise.gps_compass and "sensor_param" in obs:  # this step's pose, read from the joints
            self._head_noise.camera_params_in_base_frame(obs["sensor_param"], self._measures["agent_pose"])
        return obs

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
        """ManiSkill's simulation and controller state plus the task's (:mod:`~.task_state`), so a replay
        from it gives the same rewards and infos."""
        self._sync_people()
        state = super().get_state_dict()
        state["task"] = task_state(self)
        return state

    def set_state_dict(self, state: dict, env_idx: torch.Tensor | None = None):
        reference = self.get_state_dict()
        check_state(state, reference, self.num_envs)  # of this env's keys and shapes
        super().set_state_dict(state, env_idx)
        if state.get("task") is not None:
            load_task_state(self, state["task"], reference["task"], env_idx)

    # --- rendering: the people's figures are placed first (``EnvPeople.sync``) -------------------------
    def _sync_people(self) -> None:
        if self._people is not None:
            self._people.sync()

    def _get_obs_sensor_data(self, apply_texture_transforms: bool = True) -> dict:
        self._sync_people()
        return super()._get_obs_sensor_data(apply_texture_transforms)

    def render_human(self):
        self._sync_people()
        return super().render_human()

    def render_all(self):
        self._sync_people()
        return super().render_all()

    def render_rgb_array(self, camera_name: str | None = None):
        """The follow camera's view with the ceilings hidden (sensors keep them)."""
        self._sync_people()
        bodies = self.scene_builder.ceiling_bodies()
        for body in bodies:
            body.visibility = 0.0
        try:
            return super().render_rgb_array(camera_name)
        finally:
            for body in bodies:
                body.visibility = 1.0

    def close(self):
        self._closed = True
        super().close()

    # --- what policies and evaluators may know -------------------------------------------------
    @property
    def scene_spec(self):
        """The scene of sub-env 0 (the only one on the CPU)."""
        return self.scene_specs[0]

    @property
    def current_episode(self) -> Episode:
        """Sub-env 0's episode record (for evaluators and logs, not for policies)."""
        return self._episodes[0]

    def task_spec(self) -> TaskSpec:
        return self.cfg.task_spec(tuple(self.category_names), self.control_mode, self.agent.radius)

    def episode_info(self, i: int = 0, privileged: bool = False) -> EpisodeInfo:
        """What a policy may know of sub-env ``i``'s episode; ``privileged`` adds the oracle's
        read-only view."""
        ep = self._episodes[i]
        view = self._privileged_view(i) if privileged else None
        return EpisodeInfo(ep["scene_id"], ep["episode_id"], ep["object_category"], self.task_spec(), view)

    def _privileged_view(self, i: int, current=None) -> PrivilegedView:
        """Sub-env ``i``'s read-only oracle view (with people: where they are), ``current`` its goal index."""
        people = self._people.view(i) if self._people is not None else None
        return PrivilegedView(
            self._ctx.episode(i), self.navs[i], lambda: self._pose()[i], self.cfg.goal_mode, current, people
        )

    def reach_configuration(self, i: int = 0) -> np.ndarray | None:
        """Sub-env ``i``'s reaching joint positions (every active joint) found at its STOP, or None (not
        reachable, no STOP yet, or a robot without an arm)."""
        if "reachable" not in self._measures.measures:
            return None
        q = self._measures.measures["reachable"].qpos[i]
        return None if np.isnan(q).any() else q.copy()

    # --- helpers -------------------------------------------------------------------------------
    def _set_scenes(self) -> None:
        """Scene specs, navigation geometry and swept-motion checks of every sub-env's current episode."""
        self._scene_ids = [ep["scene_id"] for ep in self._episodes]
        kept = {sid: self._scene(sid) for sid in dict.fromkeys(self._scene_ids)}  # each looked up once
        self._geometry = [kept[sid] for sid in self._scene_ids]  # sub-envs in one scene share its geometry
        self.scene_specs = [g.spec for g in self._geometry]
        self.navs, self._motions = [g.nav for g in self._geometry], [g.motion for g in self._geometry]

    def _episode_context(self, i: int) -> EpisodeContext:
        """Sub-env ``i``'s episode for the measures (:func:`~.episodes.episode_context`)."""
        return episode_context(self._episodes[i], self.scene_specs[i], self.navs[i], self.cfg)

    def _reach(self, i: int, pose: np.ndarray) -> tuple[ReachResult, int]:
        """Whether Fetch's gripper reaches an interaction point of sub-env ``i``'s goals from planar ``pose``,
        and which goal (``biovln_ms.sim.reach``; the arm model is made from this env's articulation once)."""
        if self._arm is None:
            self._arm = FetchArm(self.agent.robot._objs[0])
        ids = [g["object_id"] for g in self._episodes[i]["goals"]]
        return reach_goals(self._arm, self.scene_specs[i], ids, pose)

    def _pose(self) -> np.ndarray:
        """(N, 3) float64 planar poses from the base joints (host)."""
        return self.agent.controller.planar_pose()

    def _check_open(self) -> None:
        if getattr(self, "_closed", False):
            raise EnvConfigError("the env is closed", field="env", fix="make a new one with gym.make(...)")

    def _episode_indices(self) -> torch.Tensor:
        return torch.tensor(self._episode_index, device=self.device)
