"""The baselines by name, with what each needs from the env."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from biovln_ms.errors import BioVLNError


@dataclass(frozen=True)
class MethodSpec:
    factory: Callable
    obs_mode: str  # what the policy reads: "none" for privileged oracles, "rgbd" for mapping methods
    description: str
    preflight: Callable[..., None] | None = None  # called with the method kwargs; raises when it cannot run here
    options: tuple[str, ...] = ()  # keyword arguments the method accepts (e.g. "checkpoint")
    env_id: str | None = None  # the env variant it must run on (None: the benchmark env)
    env_kwargs: dict = field(default_factory=dict)  # extra gym.make arguments (e.g. a control mode)


def _llm_preflight(**_) -> None:
    from biovln_ms.llm.client import LLMConfig

    LLMConfig.from_env()


def _bc_preflight(checkpoint: str | None = None, **_) -> None:
    from biovln_ms.learning.bc import CheckpointError, load_bc

    if not checkpoint:
        raise CheckpointError("the bc method needs a checkpoint", field="checkpoint",
                              fix="pass --checkpoint ckpt/bc.pt (train one with `biovln-ms train bc`)")
    load_bc(checkpoint)


def _random(**kw):
    from biovln_ms.agents.random_policy import RandomPolicy

    return RandomPolicy(**kw)


def _oracle(**kw):
    from biovln_ms.agents.oracle import OraclePolicy

    return OraclePolicy(**kw)


def _zone3(**kw):
    from biovln_ms.agents.zone3_oracle import Zone3OraclePolicy

    return Zone3OraclePolicy(**kw)


def _frontier(**kw):
    from biovln_ms.agents.frontier import FrontierPolicy

    return FrontierPolicy(**kw)


def _llm_frontier(**kw):
    from biovln_ms.agents.llm_frontier import LLMFrontierPolicy

    return LLMFrontierPolicy(**kw)  # raises LLMConfigError without a configured endpoint


def _vlfm(**kw):
    from biovln_ms.agents.vlfm import VLFMPolicy

    return VLFMPolicy(**kw)


def _bc(**kw):
    from biovln_ms.agents.bc_policy import BCPolicy

    return BCPolicy(**kw)


def _sb3(algo: str):
    def factory(**kw):
        from biovln_ms.agents.sb3_policy import SB3Policy

        return SB3Policy(algo=algo, **kw)

    return factory


def _sb3_preflight(checkpoint: str | None = None, **_) -> None:
    if not checkpoint:
        raise BioVLNError("a learned method needs a checkpoint", field="checkpoint",
                          fix="pass --checkpoint DIR/model.zip (train one with `biovln-ms train ppo`)")


def _sb3_spec(algo: str, control_mode: str) -> MethodSpec:
    return MethodSpec(_sb3(algo), "state", f"Stable-Baselines3 {algo.upper()} on the RL variant (--checkpoint)",
                      _sb3_preflight, ("checkpoint", "deterministic"), "BioVLN-OpFace-RL-v0",
                      {"control_mode": control_mode})


METHODS: dict[str, MethodSpec] = {
    "random": MethodSpec(_random, "none", "uniform forward/left/right, 5 % stop per step"),
    "oracle": MethodSpec(_oracle, "none", "exact geodesic path to the snapped goal"),
    "zone3_oracle": MethodSpec(_zone3, "none", "up to 8 Zone-3 approach points, centroid fallback"),
    "frontier": MethodSpec(_frontier, "rgbd", "depth-only occupancy grid, nearest-frontier exploration"),
    "llm_frontier": MethodSpec(_llm_frontier, "rgbd", "frontier + LLM choice among near-equidistant frontiers",
                               _llm_preflight),
    "vlfm": MethodSpec(_vlfm, "rgb+depth+segmentation", "VLFM: frontier + image-text value map + detector "
                       "(default: GT segmentation, 'VLFM (GT detector)')", None,
                       ("detector", "scorer", "detect_every", "score_every")),
    "bc": MethodSpec(_bc, "rgb", "behavioural cloning: ResNet-18 + 4-d goal vector (--checkpoint)", _bc_preflight,
                     ("checkpoint", "sample", "seed")),
    "ppo": _sb3_spec("ppo", "discrete"),
    "a2c": _sb3_spec("a2c", "discrete"),
    "sac": _sb3_spec("sac", "continuous"),
}


def method_spec(name: str, kwargs: dict | None = None) -> MethodSpec:
    """The method's spec; ``kwargs`` (if given) are checked against what it accepts."""
    if name not in METHODS:
        raise BioVLNError(f"unknown method '{name}'", field="method", fix=f"use one of: {', '.join(METHODS)}")
    spec = METHODS[name]
    extra = sorted(set(kwargs or {}) - set(spec.options))
    if extra:
        raise BioVLNError(f"method '{name}' takes no option {', '.join(extra)}", field=extra[0],
                          fix=f"it accepts: {', '.join(spec.options) or 'no options'}")
    return spec
