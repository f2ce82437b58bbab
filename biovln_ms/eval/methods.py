"""The baselines by name, with what each needs from the env."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from biovln_ms.errors import BioVLNError

RL_ENV = "BioVLN-OpFace-RL-v0"  # the variant learned policies train and evaluate on
# Stable-Baselines3 algorithms and the env control mode each needs: SAC acts in a continuous Box
# ([forward, turn, stop] in [-1, 1]), PPO and A2C in Discrete(4)
SB3_CONTROL_MODES = {"ppo": "discrete", "a2c": "discrete", "sac": "continuous"}


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


def _lazy(module: str, cls: str, **fixed) -> Callable:
    """A factory of ``biovln_ms.agents.<module>.<cls>``, imported only when a worker builds the policy
    (so the driver never loads torch, SB3 or the perception models)."""

    def factory(**kw):
        import importlib

        return getattr(importlib.import_module(f"biovln_ms.agents.{module}"), cls)(**fixed, **kw)

    return factory


def _sb3_preflight(checkpoint: str | None = None, **_) -> None:
    if not checkpoint:
        raise BioVLNError("a learned method needs a checkpoint", field="checkpoint",
                          fix="pass --checkpoint DIR/model.zip (train one with `biovln-ms train ppo`)")


def _sb3_spec(algo: str, control_mode: str) -> MethodSpec:
    return MethodSpec(_lazy("sb3_policy", "SB3Policy", algo=algo), "state",
                      f"Stable-Baselines3 {algo.upper()} on the RL variant (--checkpoint)", _sb3_preflight,
                      ("checkpoint", "deterministic"), RL_ENV, {"control_mode": control_mode})


METHODS: dict[str, MethodSpec] = {
    "random": MethodSpec(_lazy("random_policy", "RandomPolicy"), "none", "uniform forward/left/right, 5 % stop per step"),
    "oracle": MethodSpec(_lazy("oracle", "OraclePolicy"), "none", "exact geodesic path to the snapped goal"),
    "zone3_oracle": MethodSpec(_lazy("zone3_oracle", "Zone3OraclePolicy"), "none", "up to 8 Zone-3 approach points, centroid fallback"),
    "frontier": MethodSpec(_lazy("frontier", "FrontierPolicy"), "rgbd", "depth-only occupancy grid, nearest-frontier exploration"),
    "llm_frontier": MethodSpec(_lazy("llm_frontier", "LLMFrontierPolicy"), "rgbd",
                               "frontier + LLM choice among near-equidistant frontiers", _llm_preflight),
    "vlfm": MethodSpec(_lazy("vlfm", "VLFMPolicy"), "rgb+depth+segmentation", "VLFM: frontier + image-text value map + detector "
                       "(default: GT segmentation, 'VLFM (GT detector)')", None,
                       ("detector", "scorer", "detect_every", "score_every")),
    "bc": MethodSpec(_lazy("bc_policy", "BCPolicy"), "rgb", "behavioural cloning: ResNet-18 + 4-d goal vector (--checkpoint)", _bc_preflight,
                     ("checkpoint", "sample", "seed")),
    **{algo: _sb3_spec(algo, mode) for algo, mode in SB3_CONTROL_MODES.items()},
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
