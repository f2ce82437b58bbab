"""The navigation env's input checks: one-line errors (field and fix) for ``gym.make`` arguments, ``reset``
seeds and options and ``set_state_dict`` states that ManiSkill would reject with a traceback, or accept
silently, and for episodes of the other task kind. They run before anything is built or read. The
scene-only env (``BioVLN-LabScene-v0``) gets the same checks of ManiSkill's arguments and of its own
(:func:`check_scene_env_arguments`), and of its ``reset`` seeds and options.

:func:`task_config` turns an env's keyword arguments into its :class:`~biovln_ms.task_config.NavTaskConfig`
(the config's fields may be passed as keyword arguments, paper §3.2's parameters among them). The limits are
the envs guide's argument table (docs/guides/envs-and-variants/arguments.md).
"""

from __future__ import annotations

import difflib
import inspect
import math
import os
import sys
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace

import dacite
import numpy as np
import sapien
import torch
from gymnasium.envs.registration import make as gym_make
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.envs.utils.observations import ALL_VISUAL_TEXTURES, parse_obs_mode_to_struct
from mani_skill.render.shaders import PREBUILT_SHADER_CONFIGS
from mani_skill.utils.common import dict_merge
from mani_skill.utils.structs.types import SimConfig

from biovln_ms.agents.robots.locomotion import CONTROL_MODES, MAX_FORWARD_STEP
from biovln_ms.episodes.source import EpisodeSource
from biovln_ms.errors import BioVLNError
from biovln_ms.metrics import protocol_measures
from biovln_ms.metrics.measures import measure_names, measure_type
from biovln_ms.metrics.protocol_measures import check_protocol_options
from biovln_ms.metrics.reach_measures import REACH_MEASURES
from biovln_ms.metrics import people_measures  # noqa: F401  (registers the measures of people=)
from biovln_ms.people.crowd import MAX_PEOPLE, people_config
from biovln_ms.noise import NoiseConfig, resolve_noise
from biovln_ms.render.lighting import LIGHTING
from biovln_ms.render.sapien_utils import render_backend
from biovln_ms.robot_specs import DEFAULT_ROBOT, robot_spec
from biovln_ms.scene.spec import SceneSpec
from biovln_ms.task_config import INSTRUCTION_SENSORS, NavTaskConfig, ProtocolTaskConfig
from biovln_ms.tasks.sensors import SENSORS

GOAL_MODES = ("opface", "centroid")
SIM_BACKENDS = ("auto", "cpu", "physx_cpu", "gpu", "cuda", "physx_cuda")  # ManiSkill's names
GPU_BACKENDS = ("gpu", "cuda", "physx_cuda")


def is_gpu_backend(backend: str) -> bool:
    """Whether ``sim_backend`` (optionally ``:<device id>``) simulates on a GPU: ``auto`` does when one is
    visible, as ManiSkill resolves it."""
    name = str(backend).split(":")[0]
    return name in GPU_BACKENDS or (name == "auto" and torch.cuda.is_available())


RENDER_BACKENDS = ("auto", "cpu", "sapien_cpu", "gpu", "cuda", "sapien_cuda", "none")
REWARD_MODES = ("normalized_dense", "dense", "sparse", "none")
RENDER_MODES = BaseEnv.SUPPORTED_RENDER_MODES
#: obs modes ManiSkill names as a whole; any other is textures (and state) joined by "+"
OBS_MODES = ("state", "state_dict", "none", "sensor_data", "pointcloud", "rgbd")
OBS_MODE_PARTS = ("state", "state_dict", "none", "pointcloud", *ALL_VISUAL_TEXTURES)
#: the config fields of the protocol task only
PROTOCOL_FIELDS = tuple(
    sorted({f.name for f in fields(ProtocolTaskConfig)} - {f.name for f in fields(NavTaskConfig)})
)
#: ManiSkill's ``BaseEnv`` arguments, which ``gym.make`` passes through
MANISKILL_ARGUMENTS = tuple(inspect.signature(BaseEnv.__init__).parameters)[1:]
#: what ``gym.make`` resolves to the env's episodes (``biovln_ms.tasks.episode_sources``)
EPISODE_ARGUMENTS = ("split", "dataset", "template", "scene_seed", "episodes")
#: the physics rates: 5 substeps per action, in which the stiff drive settles (a move is exact when free)
SIM_FREQUENCIES = dict(sim_freq=100, control_freq=20)
MIN_SUBSTEPS, MAX_SUBSTEPS, MAX_SIM_FREQ = 5, 100, 10_000
#: what ``sensor_configs`` may set: the head camera's size, field of view and range are task parameters
SENSOR_CONFIG_KEYS = ("shader_pack",)
#: what ``human_render_camera_configs`` and ``viewer_camera_configs`` may set
VIEW_CONFIG_KEYS = ("shader_pack", "width", "height", "fov", "near", "far", "pose")
#: the cameras of each camera-config argument (a key naming one configures it alone)
CAMERAS = {"sensor_configs": ("head",), "human_render_camera_configs": ("follow",)}
CAMERAS["viewer_camera_configs"] = ("viewer",)
#: what ``reset(options=...)`` may hold
RESET_OPTIONS = ("episode_index", "episode_id", "scene_id", "env_idx", "reconfigure")
#: what the scene-only env's ``reset(options=...)`` may hold, and its cameras of each camera-config argument
SCENE_RESET_OPTIONS = ("env_idx", "reconfigure")
SCENE_CAMERAS = {"sensor_configs": (), "human_render_camera_configs": ("overview",)}
SCENE_CAMERAS["viewer_camera_configs"] = ("viewer",)
#: the scene-only env's own arguments
SCENE_ARGUMENTS = ("specs", "template", "seed", "ceiling", "render_size", "lighting")
MAX_SEED = 2**32 - 1  # NumPy's RandomState, which ManiSkill seeds with it
MAX_NUM_ENVS = 16_384


class EnvConfigError(BioVLNError):
    """Invalid env arguments (split, episode, obs mode, control mode, seed, reset options, state)."""


def _show(v, limit: int = 80) -> str:
    """A value as an error line quotes it: its repr on one line, cut to ``limit`` characters."""
    text = " ".join(repr(v).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


@dataclass(frozen=True)
class Bound:
    """A numeric argument's range: above ``lo`` (or from it, ``closed``) up to ``hi``; integers only when
    ``integer``."""

    lo: float
    hi: float
    unit: str = ""
    integer: bool = False
    closed: bool = False

    def __str__(self) -> str:
        kind = "an integer" if self.integer else "a number"
        unit = f" {self.unit}" if self.unit else ""
        lo, hi = (f"{x:,}" if float(x).is_integer() else f"{x:g}" for x in (self.lo, self.hi))
        return f"{kind} in {'[' if self.closed else '('}{lo}, {hi}]{unit}"

    def check(self, name: str, v):
        """``v`` as a Python int or float, or a one-line error naming ``name`` and the range."""
        numeric = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
        if self.integer:
            numeric = numeric and isinstance(v, (int, np.integer))
        if numeric and isinstance(v, (float, np.floating)) and not math.isfinite(v):
            numeric = False
        if not numeric or not (self.lo <= v if self.closed else self.lo < v) or v > self.hi:
            raise EnvConfigError(
                f"{name} must be {self}, got {_show(v)}", field=name, fix=f"pass {name} as {self}"
            )
        return int(v) if self.integer else float(v)


#: the numeric config fields' limits (the envs guide's argument table)
CONFIG_LIMITS = {
    "forward_step": Bound(0, MAX_FORWARD_STEP, "m"),
    "turn_deg": Bound(0, 180, "degrees"),
    "max_episode_steps": Bound(1, 1_000_000, integer=True, closed=True),
    "camera_width": Bound(1, 4096, "pixels", integer=True, closed=True),
    "camera_height": Bound(1, 4096, "pixels", integer=True, closed=True),
    "camera_hfov_deg": Bound(0, 170, "degrees"),  # a pinhole camera sees less than 180 degrees
    "strict_facing_deg": Bound(0, 180, "degrees"),
    "camera_far": Bound(0.05, 1000, "m"),  # beyond the head camera's near plane
    "success_bonus": Bound(0, 1e6),  # normalized_dense divides by it
    "step_penalty": Bound(0, 1e6, closed=True),
    "safety_penalty": Bound(0, 1e6, closed=True),
    "position_scale": Bound(0.01, 1000, "m", closed=True),
    "steps_per_goal": Bound(1, 100_000, integer=True, closed=True),
    "people": Bound(0, MAX_PEOPLE, integer=True, closed=True),
    "scene_visit_episodes": Bound(0, 1_000_000, integer=True, closed=True),
}
BOOL_FIELDS = ("proportional_safety", "shuffle_episodes", "agent_obs", "person_collision_ends")
VIEW_LIMITS = {
    "width": Bound(1, 4096, "pixels", integer=True, closed=True),
    "height": Bound(1, 4096, "pixels", integer=True, closed=True),
    "fov": Bound(0, math.radians(170), "radians"),
    "near": Bound(0, 100, "m", closed=True),
    "far": Bound(0, 10_000, "m"),
}


def task_config(
    base: NavTaskConfig, control_mode: str, kwargs: dict, robot_uids: str = DEFAULT_ROBOT
) -> NavTaskConfig:
    """``base`` with the config fields of ``kwargs`` (taken out of it) and its noise resolved, checked; the
    ManiSkill defaults that follow from it are set in ``kwargs`` (the obs mode, a CPU renderer without a
    GPU, fresh camera-config dicts: ManiSkill's ``shader_dir`` writes into its defaults). ``gym.make``'s own
    ``max_episode_steps`` becomes the config's, so the env ends its episodes where the time limit does."""
    protocol = kwargs.pop("protocol", base.protocol)  # a property of the config's type, not a field
    if protocol != base.protocol:
        raise EnvConfigError(
            f"protocol={protocol} does not fit this env",
            field="protocol",
            fix="make BioVLN-Protocol-v0 for protocol episodes, or a single-goal variant for the others",
        )
    extra = [name for name in PROTOCOL_FIELDS if name in kwargs and not base.protocol]
    if extra:
        raise EnvConfigError(
            f"{extra[0]} is an option of the protocol task",
            field=extra[0],
            fix="make BioVLN-Protocol-v0 (or another protocol variant) to pass it",
        )
    check_known_arguments(base, kwargs)
    limit = gym_make_step_limit()
    if limit is not None:
        kwargs.setdefault("max_episode_steps", limit)
    cfg = replace(base, **{f.name: kwargs.pop(f.name) for f in fields(base) if f.name in kwargs})
    cfg = checked_config(cfg, robot_spec(kwargs.get("robot_uids", robot_uids)).uid)
    if cfg.scene_visit_episodes and not cfg.shuffle_episodes:
        raise EnvConfigError(
            "scene_visit_episodes orders a shuffle, and this env plays its episodes in dataset order",
            field="scene_visit_episodes",
            fix="pass shuffle_episodes=True with it (the RL variants shuffle), or leave it at 0",
        )
    if kwargs.get("obs_mode") is None:  # ManiSkill's None is the default
        kwargs["obs_mode"] = cfg.default_obs_mode
    noise = resolve_noise(cfg.noise)
    check_pose_state(cfg, noise, kwargs["obs_mode"])
    cfg = cfg.with_noise(noise)
    if render_backend() == "cpu":  # ManiSkill's default asks for "sapien_cuda" and warns each make
        kwargs.setdefault("render_backend", "cpu")
    check_arguments(cfg, control_mode, kwargs)
    return cfg


def check_known_arguments(base: NavTaskConfig, kwargs: dict) -> None:
    """An argument that is neither a config field nor ManiSkill's would reach ``BaseEnv.__init__`` as a
    TypeError after the episodes are read; refuse it first, naming the nearest known one."""
    known = [f.name for f in fields(base)] + list(MANISKILL_ARGUMENTS)
    for name in kwargs:
        if name not in known:
            near = difflib.get_close_matches(str(name), known + list(EPISODE_ARGUMENTS), n=1)
            hint = f"did you mean {near[0]}? " if near else ""
            raise EnvConfigError(
                f"unknown argument {_show(name)}",
                field=str(name),
                fix=f"{hint}the arguments are NavTaskConfig's fields, ManiSkill's BaseEnv arguments and "
                f"{', '.join(EPISODE_ARGUMENTS[:-1])} (the envs guide's argument table)",
            )


def gym_make_step_limit() -> int | None:
    """The ``max_episode_steps`` given to the ``gym.make`` call making this env, checked (None: none given).
    gymnasium keeps it for its ``TimeLimit``, and ManiSkill's ``TimeLimitWrapper`` reads it from that call's
    frame as this does; -1 (gymnasium's "no limit") would make ManiSkill's wrapper truncate every step."""
    frame = sys._getframe(1)
    while frame is not None and frame.f_code is not gym_make.__code__:
        frame = frame.f_back
    limit = None if frame is None else frame.f_locals.get("max_episode_steps")
    return None if limit is None else CONFIG_LIMITS["max_episode_steps"].check("max_episode_steps", limit)


def checked_config(cfg: NavTaskConfig, robot: str) -> NavTaskConfig:
    """``cfg`` with every field checked against its limits (numbers as Python numbers, lists as tuples)."""
    values = {
        name: bound.check(name, getattr(cfg, name))
        for name, bound in CONFIG_LIMITS.items()
        if hasattr(cfg, name)
    }
    for name in BOOL_FIELDS:
        v = getattr(cfg, name)
        if not isinstance(v, (bool, np.bool_)):
            raise EnvConfigError(
                f"{name} must be True or False, got {_show(v)}", field=name, fix="pass a bool"
            )
        values[name] = bool(v)
    for name, known in (("goal_mode", GOAL_MODES), ("lighting", tuple(LIGHTING))):
        v = getattr(cfg, name)
        if not isinstance(v, str) or v not in known:
            raise EnvConfigError(
                f"unknown {name} {_show(v)}", field=name, fix=f"use one of: {', '.join(known)}"
            )
    check_obs_mode("default_obs_mode", cfg.default_obs_mode)
    if cfg.default_split is not None and not isinstance(cfg.default_split, str):
        raise EnvConfigError(
            f"default_split must be a split name or None, got {_show(cfg.default_split)}",
            field="default_split",
            fix="pass e.g. default_split='ms_val'",
        )
    values["measures"] = _names("measures", cfg.measures, measure_names())
    sensors = [s for s in SENSORS if cfg.protocol or s not in INSTRUCTION_SENSORS]
    values["sensors"] = _names("sensors", cfg.sensors, sensors)
    check_measures(cfg, values["measures"], robot)
    if cfg.protocol:
        check_protocol_options(cfg.wrong_stop, cfg.subgoal_rule, values["steps_per_goal"])
    return people_config(replace(cfg, **values))


def _names(name: str, v, known) -> tuple[str, ...]:
    """A tuple or list of names, each one of ``known``, as a tuple."""
    if not isinstance(v, (tuple, list)) or not all(isinstance(s, str) for s in v):
        raise EnvConfigError(
            f"{name} must be a tuple of names, got {_show(v)}",
            field=name,
            fix=f"pass names of: {', '.join(known)}",
        )
    for s in v:
        if s not in known:
            raise EnvConfigError(
                f"unknown {name[:-1]} '{s}'", field=name, fix=f"use names of: {', '.join(known)}"
            )
    return tuple(v)


def check_measures(cfg: NavTaskConfig, measures: tuple[str, ...], robot: str) -> None:
    """The reward measure is a number and success and fail are true or false, per sub-env; the protocol
    measures need the protocol task, and the reach measures Fetch's arm."""
    known = measure_names()
    for name, kind in (("reward_measure", "f"), ("success_measure", "b"), ("fail_measure", "b")):
        m = getattr(cfg, name)
        if not isinstance(m, str) or m not in known:
            raise EnvConfigError(
                f"unknown measure {_show(m)}", field=name, fix=f"use one of: {', '.join(known)}"
            )
        cls = measure_type(m)
        if np.dtype(cls.dtype).kind != kind or cls.shape != ():
            what = "a number" if kind == "f" else "true or false"
            raise EnvConfigError(f"measure '{m}' is not {what} per sub-env", field=name, fix="choose another")
    for m in _closure(measures + (cfg.reward_measure, cfg.success_measure, cfg.fail_measure)):
        if not cfg.protocol and measure_type(m).__module__ == protocol_measures.__name__:
            raise EnvConfigError(
                f"measure '{m}' is a protocol measure", field="measures", fix="use it in BioVLN-Protocol-v0"
            )
        if measure_type(m).__module__ == people_measures.__name__ and not cfg.people:
            raise EnvConfigError(
                f"measure '{m}' is a measure of people", field="measures", fix="pass people=1 or more"
            )
        if m in REACH_MEASURES and (robot != "fetch" or cfg.protocol):
            raise EnvConfigError(
                f"measure '{m}' needs Fetch's arm",
                field="measures",
                fix="make a single-goal env with robot_uids='fetch' (it reports the reach measures itself)",
            )


def _closure(names) -> list[str]:
    """``names`` and every measure they depend on."""
    out, todo = [], list(names)
    while todo:
        m = todo.pop()
        if m not in out:
            out.append(m)
            todo += measure_type(m).dependencies
    return out


def check_obs_mode(name: str, v) -> None:
    """ManiSkill's obs modes: a named one, or textures (and state) joined by '+'."""
    ok = isinstance(v, str) and (v in OBS_MODES or all(p in OBS_MODE_PARTS for p in v.split("+")))
    if not ok:
        raise EnvConfigError(
            f"unknown obs mode {_show(v)}",
            field=name,
            fix=f"use one of: {', '.join(OBS_MODES)}, or '+'-joined {', '.join(ALL_VISUAL_TEXTURES)}",
        )


def check_episode_kind(cfg: NavTaskConfig, source: EpisodeSource, footprint: float) -> None:
    """Protocol (multi-goal) episodes run only in the protocol env, and single-goal ones only elsewhere: a
    protocol episode's goals read as any-instance goals would be a silently wrong task. The episodes' scenes
    are made for this robot's footprint (free space, geodesics and starts are the footprint's). Episodes
    carrying their own crowd (the busy splits) need as many of the env's ``people`` figures, or none
    (``people=0`` runs them in an empty lab)."""
    if not isinstance(source, EpisodeSource) or not getattr(source, "episodes", None):
        raise EnvConfigError(
            f"episodes must be a non-empty EpisodeSource, got {type(source).__name__}",
            field="episodes",
            fix="pass split= (or template=), or an EpisodeSource of biovln_ms.episodes.source",
        )
    made_for = source.spec(source.episodes[0]["scene_id"]).robot_radius
    if made_for != footprint:
        raise EnvConfigError(
            f"the episodes' scenes are made for a {made_for} m footprint, this robot's is {footprint} m",
            field="episodes",
            fix="make them for this robot (GeneratedEpisodes(..., robot=...)), or pass split= instead",
        )
    kinds = {"protocol" in ep for ep in source.episodes}
    if kinds != {cfg.protocol}:
        split = getattr(source, "split", None)
        where = f"split '{split}'" if split else "the generated episodes"
        held = "protocol (multi-goal)" if True in kinds else "single-goal"
        runs = "protocol" if cfg.protocol else "single-goal"
        raise EnvConfigError(
            f"{where} holds {held} episodes, this env runs {runs} ones",
            field="split",
            fix="use the protocol_* splits with BioVLN-Protocol-v0, the others with the single-goal variants",
        )
    crowd = max((ep["people"]["count"] for ep in source.episodes if "people" in ep), default=0)
    if 0 < cfg.people < crowd:  # people=0: the same episodes in an empty lab
        split = getattr(source, "split", None)
        where = f"the episodes of split {split!r}" if split else "the episodes"
        raise EnvConfigError(
            f"{where} bring crowds of up to {crowd} people, and "
            f"people={cfg.people} gives the env {cfg.people} figures",
            field="people",
            fix=f"pass people={crowd} or more, leave people out (gym.make takes the split's), or pass "
            "people=0 for an empty lab",
        )


def check_source_arguments(given: dict) -> None:
    """The episode arguments' types (their values are checked where they are resolved)."""
    for name, kinds, example in (
        ("split", (str,), "split='ms_val'"),
        ("dataset", (str, os.PathLike), "dataset='path/to/dataset'"),
        ("template", (str,), "template='single_room'"),
        ("scene_seed", (int, np.integer), "scene_seed=0"),
    ):
        v = given.get(name)
        if v is not None and (not isinstance(v, kinds) or isinstance(v, bool)):
            raise EnvConfigError(
                f"{name} must be a {kinds[0].__name__}, got {_show(v)}",
                field=name,
                fix=f"pass e.g. {example}",
            )


def check_pose_state(cfg: NavTaskConfig, noise: NoiseConfig, obs_mode: str) -> None:
    """The RL state vector is the robot's pose: without GPS+compass a flat state observation would hold only
    the start-frame ``pointgoal`` and ``objectgoal``, nothing a policy could act on; refuse it in one line."""
    if "rl_state" in cfg.sensors and not noise.gps_compass and obs_mode in ("state", "state_dict"):
        raise BioVLNError(
            f"sensor rl_state is the robot's pose, and noise '{noise.name}' has no GPS+compass",
            field="obs_mode",
            fix="observe depth and keep a pose estimate (obs_mode='depth', as baselines/sb3_policy.py does), "
            "or keep GPS+compass: noise={'preset': '" + noise.name + "', 'gps_compass': True}",
        )


def check_arguments(cfg: NavTaskConfig, control_mode: str, kwargs: dict) -> None:
    """One-line errors for ManiSkill's arguments that it would reject with a traceback, or accept silently."""
    if not isinstance(control_mode, str) or control_mode not in CONTROL_MODES:
        raise EnvConfigError(
            f"unknown control mode '{control_mode}'",
            field="control_mode",
            fix=f"use one of: {', '.join(CONTROL_MODES)}",
        )
    check_backends(kwargs)
    check_maniskill_arguments(kwargs)


def check_backends(kwargs: dict) -> None:
    """The simulation and render backends, and the number of sub-envs they can run."""
    for key, known in (("sim_backend", SIM_BACKENDS), ("render_backend", RENDER_BACKENDS)):
        name = str(kwargs.get(key, "auto")).split(":")[0]
        if not isinstance(kwargs.get(key, "auto"), str) or name not in known:
            raise EnvConfigError(
                f"unknown {key} '{kwargs[key]}'",
                field=key,
                fix=f"use one of: {', '.join(known)} (optionally ':<device id>')",
            )
    backend = str(kwargs.get("sim_backend", "auto"))
    gpu_backend = backend.split(":")[0] in GPU_BACKENDS
    if gpu_backend and not torch.cuda.is_available():
        raise EnvConfigError(
            f"sim_backend='{backend}' needs a CUDA GPU and none is visible",
            field="sim_backend",
            fix="use sim_backend='physx_cpu' (the default on a machine without a GPU)",
        )
    n = kwargs.get("num_envs", 1)
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or not 1 <= n <= MAX_NUM_ENVS:
        raise EnvConfigError(
            f"num_envs must be an integer in [1, {MAX_NUM_ENVS}], got {_show(n)}",
            field="num_envs",
            fix="pass num_envs=1 or more",
        )
    if n > 1 and not (gpu_backend and torch.cuda.is_available()):
        raise EnvConfigError(
            "num_envs > 1 needs sim_backend='physx_cuda' and a CUDA GPU; on the CPU run one env per "
            "process (gymnasium AsyncVectorEnv or SB3 SubprocVecEnv, see the envs guide)",
            field="num_envs",
        )


def check_maniskill_arguments(kwargs: dict, cameras: dict[str, tuple[str, ...]] = CAMERAS) -> None:
    """ManiSkill's own arguments: modes, flags, camera configs (of the env's ``cameras``) and the physics
    rates."""
    obs_mode = kwargs.get("obs_mode", "state")
    check_obs_mode("obs_mode", obs_mode)
    for key, known in (("reward_mode", REWARD_MODES), ("render_mode", RENDER_MODES)):
        v = kwargs.get(key)
        if v is not None and (not isinstance(v, str) or v not in known):
            raise EnvConfigError(
                f"unknown {key} {_show(v)}", field=key, fix=f"use one of: {', '.join(known)}"
            )
    shader = kwargs.get("shader_dir")
    if shader is not None and (not isinstance(shader, str) or shader not in PREBUILT_SHADER_CONFIGS):
        raise EnvConfigError(
            f"unknown shader pack {_show(shader)}",
            field="shader_dir",
            fix=f"use one of: {', '.join(PREBUILT_SHADER_CONFIGS)}",
        )
    for key in ("enable_shadow", "parallel_in_single_scene", "enhanced_determinism"):
        if not isinstance(kwargs.get(key, False), (bool, np.bool_)):
            raise EnvConfigError(
                f"{key} must be True or False, got {_show(kwargs[key])}", field=key, fix="pass a bool"
            )
    visual = vars(parse_obs_mode_to_struct(obs_mode).visual)
    if kwargs.get("parallel_in_single_scene") and any(visual.values()):
        raise EnvConfigError(
            "parallel_in_single_scene renders no camera observations",
            field="parallel_in_single_scene",
            fix="pass it with obs_mode='state' (or 'state_dict', 'none')",
        )
    for key, names in cameras.items():
        keys = SENSOR_CONFIG_KEYS if key == "sensor_configs" else VIEW_CONFIG_KEYS
        kwargs[key] = check_camera_configs(key, kwargs.get(key, {}), names, keys)
    if "sim_config" in kwargs:
        check_sim_config(kwargs["sim_config"])
    freq = kwargs.get("reconfiguration_freq")
    if freq is not None:
        Bound(0, 1_000_000, integer=True, closed=True).check("reconfiguration_freq", freq)


def check_camera_configs(name: str, value, cameras: tuple[str, ...], keys: tuple[str, ...]) -> dict:
    """A copy of a camera-config argument (ManiSkill writes into it), each setting checked: settings for
    every camera, or under a camera's name for that camera."""
    if value is None:
        value = {}
    if not isinstance(value, Mapping):
        raise EnvConfigError(
            f"{name} must be a dict, got {_show(value)}",
            field=name,
            fix="pass e.g. {'shader_pack': 'minimal'}",
        )
    out = {}
    for k, v in value.items():
        if k in cameras:
            if not isinstance(v, Mapping):
                raise EnvConfigError(
                    f"{name}['{k}'] must be a dict, got {_show(v)}", field=name, fix="pass a dict"
                )
            for kk, vv in v.items():
                _camera_setting(f"{name}['{k}']", kk, vv, keys)
            out[k] = dict(v)
        else:
            _camera_setting(name, k, v, keys)
            out[k] = v
    return out


def _camera_setting(where: str, key, v, keys: tuple[str, ...]) -> None:
    if key not in keys:
        task = " (the head camera's size, field of view and range are camera_width, camera_height, "
        task += "camera_hfov_deg and camera_far)" if keys == SENSOR_CONFIG_KEYS else ""
        raise EnvConfigError(
            f"{where} sets {_show(key)}", field=where, fix=f"set one of: {', '.join(keys)}{task}"
        )
    if key == "shader_pack" and (not isinstance(v, str) or v not in PREBUILT_SHADER_CONFIGS):
        raise EnvConfigError(
            f"unknown shader pack {_show(v)}",
            field=where,
            fix=f"use one of: {', '.join(PREBUILT_SHADER_CONFIGS)}",
        )
    if key in VIEW_LIMITS:
        VIEW_LIMITS[key].check(f"{where}['{key}']", v)
    if key == "pose" and not isinstance(v, sapien.Pose):
        p = np.asarray(v, dtype=object)
        if (
            p.shape != (7,)
            or not all(isinstance(x, (int, float, np.integer, np.floating)) and math.isfinite(x) for x in p)
            or not np.any(np.asarray(p[3:], float))
        ):
            raise EnvConfigError(
                f"pose must be 7 finite numbers (position, then a non-zero quaternion), got {_show(v)}",
                field=where,
                fix="pass [x, y, z, qw, qx, qy, qz] or a sapien.Pose",
            )


def check_sim_config(value) -> None:
    """ManiSkill's ``sim_config`` (a dict or SimConfig): known keys of the right types, finite numbers, and
    from ``MIN_SUBSTEPS`` to ``MAX_SUBSTEPS`` physics substeps per action."""
    if isinstance(value, SimConfig):
        value = value.dict()
    if not isinstance(value, Mapping):
        raise EnvConfigError(
            f"sim_config must be a dict, got {_show(value)}", field="sim_config", fix="pass a dict"
        )
    merged = SimConfig(**SIM_FREQUENCIES).dict()
    try:
        dict_merge(merged, dict(value))
        cfg = dacite.from_dict(SimConfig, merged, dacite.Config(strict=True))
    except (dacite.DaciteError, TypeError, ValueError, KeyError, AttributeError) as e:
        raise EnvConfigError(
            f"sim_config: {e}", field="sim_config", fix=f"use the keys of SimConfig: {', '.join(merged)}"
        ) from None
    if not _finite(merged):
        raise EnvConfigError(
            "sim_config holds a number that is not finite", field="sim_config", fix="pass finite numbers"
        )
    sim, control = cfg.sim_freq, cfg.control_freq
    ok = all(isinstance(f, int) and not isinstance(f, bool) and 0 < f <= MAX_SIM_FREQ for f in (sim, control))
    if not ok or sim % control or not MIN_SUBSTEPS <= sim // control <= MAX_SUBSTEPS:
        raise EnvConfigError(
            f"sim_freq {_show(sim)} / control_freq {_show(control)} is not "
            f"{MIN_SUBSTEPS}-{MAX_SUBSTEPS} substeps",
            field="sim_config",
            fix=f"pass integers up to {MAX_SIM_FREQ} Hz, sim_freq a multiple of control_freq "
            f"({MIN_SUBSTEPS} or more substeps: the drive settles in them)",
        )


def _finite(obj) -> bool:
    if isinstance(obj, dict):
        return all(_finite(v) for v in obj.values())
    if isinstance(obj, (list, tuple)):
        return all(_finite(v) for v in obj)
    return not isinstance(obj, float) or math.isfinite(obj)


# --- the scene-only env ----------------------------------------------------------------------------------
def check_scene_env_arguments(own: dict, kwargs: dict) -> None:
    """``BioVLN-LabScene-v0``'s arguments: its own (``own``: specs, template, seed, ceiling, render size,
    lighting) and ManiSkill's (``kwargs``), as the navigation envs check theirs; an unknown argument names
    the nearest known one. Only a robot-less, reward-less env: ``robot_uids`` and ``reward_mode`` 'none'."""
    for name in kwargs:
        if name not in MANISKILL_ARGUMENTS:
            near = difflib.get_close_matches(str(name), list(SCENE_ARGUMENTS + MANISKILL_ARGUMENTS), n=1)
            hint = f"did you mean {near[0]}? " if near else ""
            raise EnvConfigError(
                f"unknown argument {_show(name)}",
                field=str(name),
                fix=f"{hint}the arguments are {', '.join(SCENE_ARGUMENTS)} and ManiSkill's BaseEnv arguments",
            )
    specs = own["specs"]
    if specs is not None:
        kinds = (SceneSpec, str, os.PathLike)
        ok = isinstance(specs, (list, tuple)) and 0 < len(specs) <= MAX_NUM_ENVS
        if not ok or not all(isinstance(s, kinds) for s in specs):
            raise EnvConfigError(
                f"specs must be a list of scene specs or spec files, got {_show(specs)}",
                field="specs",
                fix="pass e.g. specs=[generate_scene('single_room', 0)] or specs=['scene.json']",
            )
    if not isinstance(own["template"], str):
        raise EnvConfigError(
            f"template must be a template name, got {_show(own['template'])}",
            field="template",
            fix="pass e.g. template='single_room'",
        )
    Bound(0, MAX_SEED, integer=True, closed=True).check("seed", own["seed"])
    if not isinstance(own["ceiling"], (bool, np.bool_)):
        raise EnvConfigError(
            f"ceiling must be True or False, got {_show(own['ceiling'])}", field="ceiling", fix="pass a bool"
        )
    size = own["render_size"]
    if not isinstance(size, (list, tuple)) or len(size) != 2:
        raise EnvConfigError(
            f"render_size must be (width, height), got {_show(size)}",
            field="render_size",
            fix="pass e.g. render_size=(960, 720)",
        )
    for name, v in zip(("width", "height"), size):
        VIEW_LIMITS[name].check("render_size", v)
    lighting = own["lighting"]
    if not isinstance(lighting, str) or lighting not in LIGHTING:
        raise EnvConfigError(
            f"unknown lighting {_show(lighting)}", field="lighting", fix=f"use one of: {', '.join(LIGHTING)}"
        )
    for key in ("robot_uids", "reward_mode"):
        v = kwargs.get(key)
        if v is not None and not (isinstance(v, str) and v == "none"):
            raise EnvConfigError(
                f"{key} {_show(v)}: this env has no robot and no task",
                field=key,
                fix=f"leave {key} out (or pass 'none'); make a navigation env (BioVLN-OpFace-v0) for a robot",
            )
    if kwargs.get("obs_mode", 0) is None:  # ManiSkill's default, "state"
        del kwargs["obs_mode"]
    check_obs_mode("obs_mode", kwargs.get("obs_mode", "state"))
    if kwargs.get("obs_mode") == "pointcloud":
        raise EnvConfigError(
            "obs_mode 'pointcloud': BioVLN-LabScene-v0 has no sensor to fuse one from",
            field="obs_mode",
            fix="use render() (the overview camera) or obs_mode 'none'/'state'",
        )
    check_backends(kwargs)
    check_maniskill_arguments(kwargs, SCENE_CAMERAS)


# --- reset and state ---------------------------------------------------------------------------------------
def reset_arguments(seed, options, num_envs: int, device, known: tuple[str, ...] = RESET_OPTIONS) -> tuple:
    """``reset``'s seed and options (of ``known`` keys) checked: (the seed as an int or a list of ints, a copy
    of the options with ``env_idx`` as ManiSkill's index tensor, the sub-envs reset)."""
    seed = check_seed(seed, num_envs)
    if options is None:
        return seed, {}, list(range(num_envs))
    if not isinstance(options, Mapping):
        raise EnvConfigError(
            f"options must be a dict, got {_show(options)}",
            field="options",
            fix="pass e.g. {'episode_index': 0}",
        )
    options = dict(options)
    for key in options:
        if key == "reset_to_env_states" and "episode_index" in known:  # a navigation env's
            raise EnvConfigError(
                "a reset to a saved state is not supported (the task's episode state would not follow)",
                field="options['reset_to_env_states']",
                fix="reset to its episode (options={'episode_index': k}), then env.set_state_dict(state)",
            )
        if key not in known:
            raise EnvConfigError(
                f"unknown reset option {_show(key)}",
                field="options",
                fix=f"use one of: {', '.join(known)}",
            )
    _check_episode_options(options)
    if not isinstance(options.get("reconfigure", False), (bool, np.bool_)):
        raise EnvConfigError(
            f"reconfigure must be True or False, got {_show(options['reconfigure'])}",
            field="options['reconfigure']",
            fix="pass a bool",
        )
    if "env_idx" not in options:
        return seed, options, list(range(num_envs))
    rows = _env_rows(options["env_idx"], num_envs)
    if options.get("reconfigure") and len(rows) != num_envs:
        raise EnvConfigError(
            "a partial reset cannot reconfigure",
            field="options['reconfigure']",
            fix="reset all sub-envs to reconfigure",
        )
    options["env_idx"] = torch.tensor(rows, dtype=torch.int64, device=device)
    return seed, options, rows


def check_seed(seed, num_envs: int):
    """A seed in [0, 2**32 - 1] (an int, a NumPy integer, a 0-d array or tensor), or one per sub-env in a
    list, array or tensor; as an int or a list of ints."""
    if seed is None:
        return None
    values = seed.tolist() if isinstance(seed, (np.ndarray, torch.Tensor)) else seed
    scalar = not isinstance(values, (list, tuple))
    items = [values] if scalar else list(values)
    ok = all(
        isinstance(s, (int, np.integer)) and not isinstance(s, (bool, np.bool_)) and 0 <= s <= MAX_SEED
        for s in items
    )
    if not ok or (not scalar and len(items) not in (1, num_envs)):
        raise EnvConfigError(
            f"seed must be an integer in [0, {MAX_SEED}] or a list of one per sub-env ({num_envs}), "
            f"got {_show(seed)}",
            field="seed",
            fix="pass e.g. seed=0",
        )
    return int(items[0]) if scalar else [int(s) for s in items]


def _check_episode_options(options: dict) -> None:
    """One way of naming an episode: an index, or an id (with an optional scene id)."""
    if "episode_index" in options and "episode_id" in options:
        raise EnvConfigError(
            "both episode_index and episode_id name an episode", field="options", fix="pass one of them"
        )
    if "scene_id" in options and "episode_id" not in options:
        raise EnvConfigError(
            "scene_id names an episode only with episode_id",
            field="options['scene_id']",
            fix="pass {'episode_id': ..., 'scene_id': ...}",
        )
    for key, kinds in (("episode_id", (str, int, np.integer)), ("scene_id", (str,))):
        v = options.get(key)
        if key in options and (not isinstance(v, kinds) or isinstance(v, bool)):
            raise EnvConfigError(
                f"{key} must be a string, got {_show(v)}", field=f"options['{key}']", fix="pass e.g. '0'"
            )


def _env_rows(env_idx, num_envs: int) -> list[int]:
    """The sub-envs of ``env_idx`` (a list, array or tensor of distinct indices in range)."""
    values = env_idx.tolist() if isinstance(env_idx, (np.ndarray, torch.Tensor)) else env_idx
    rows = [values] if isinstance(values, (int, np.integer)) else values
    ok = isinstance(rows, (list, tuple)) and 0 < len(rows)
    ok = ok and all(
        isinstance(i, (int, np.integer)) and not isinstance(i, bool) and 0 <= i < num_envs for i in rows
    )
    if not ok or len({int(i) for i in rows}) != len(rows):
        raise EnvConfigError(
            f"env_idx must be distinct sub-env indices in [0, {num_envs}), got {_show(env_idx)}",
            field="options['env_idx']",
            fix="pass e.g. {'env_idx': [0]}",
        )
    return [int(i) for i in rows]
