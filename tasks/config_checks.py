"""The navigation env's argument checks: one-line errors (field and fix) for arguments ManiSkill would reject
with a traceback, or accept silently, and for episodes of the other task kind.

:func:`task_config` turns an env's keyword arguments into its :class:`~biovln_ms.task_config.NavTaskConfig`
(the config's fields may be passed as keyword arguments, paper §3.2's parameters among them).
"""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np
import torch

from biovln_ms.agents.robots.locomotion import CONTROL_MODES
from biovln_ms.episodes.source import EpisodeSource
from biovln_ms.errors import BioVLNError
from biovln_ms.metrics.protocol_measures import check_protocol_options
from biovln_ms.noise import NoiseConfig, resolve_noise
from biovln_ms.render.lighting import lighting_preset
from biovln_ms.task_config import NavTaskConfig, ProtocolTaskConfig

GOAL_MODES = ("opface", "centroid")
SIM_BACKENDS = ("auto", "cpu", "physx_cpu", "gpu", "cuda", "physx_cuda")  # ManiSkill's names
RENDER_BACKENDS = ("auto", "cpu", "sapien_cpu", "gpu", "cuda", "sapien_cuda", "none")
#: the config fields of the protocol task only
PROTOCOL_FIELDS = tuple(
    sorted({f.name for f in fields(ProtocolTaskConfig)} - {f.name for f in fields(NavTaskConfig)})
)


class EnvConfigError(BioVLNError):
    """Invalid env arguments (split, episode, obs mode, control mode, action)."""


def task_config(base: NavTaskConfig, control_mode: str, kwargs: dict) -> NavTaskConfig:
    """``base`` with the config fields of ``kwargs`` (taken out of it) and its noise resolved, checked; the
    ManiSkill defaults that follow from it are set in ``kwargs`` (the obs mode, a CPU renderer without a
    GPU)."""
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
    cfg = replace(base, **{f.name: kwargs.pop(f.name) for f in fields(base) if f.name in kwargs})
    kwargs.setdefault("obs_mode", cfg.default_obs_mode)
    noise = resolve_noise(cfg.noise)
    check_pose_state(cfg, noise, kwargs["obs_mode"])
    cfg = cfg.with_noise(noise)
    if not torch.cuda.is_available():  # ManiSkill's default asks for "sapien_cuda" and warns each make
        kwargs.setdefault("render_backend", "cpu")
    check_arguments(cfg, control_mode, kwargs)
    return cfg


def check_episode_kind(cfg: NavTaskConfig, source: EpisodeSource) -> None:
    """Protocol (multi-goal) episodes run only in the protocol env, and single-goal ones only elsewhere: a
    protocol episode's goals read as any-instance goals would be a silently wrong task."""
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
    if cfg.protocol:
        check_protocol_options(cfg.wrong_stop, cfg.subgoal_rule, cfg.steps_per_goal)
    for name in (
        "forward_step",
        "turn_deg",
        "camera_width",
        "camera_height",
        "camera_hfov_deg",
        "strict_facing_deg",
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
