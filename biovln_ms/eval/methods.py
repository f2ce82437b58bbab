"""The baselines by name, with what each needs from the env."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from biovln_ms.errors import BioVLNError


@dataclass(frozen=True)
class MethodSpec:
    factory: Callable
    obs_mode: str  # what the policy reads: "none" for privileged oracles, "rgbd" for mapping methods
    description: str
    preflight: Callable[[], None] | None = None  # raises a clear error when the method cannot run here


def _llm_preflight() -> None:
    from biovln_ms.llm.client import LLMConfig

    LLMConfig.from_env()


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


METHODS: dict[str, MethodSpec] = {
    "random": MethodSpec(_random, "none", "uniform forward/left/right, 5 % stop per step"),
    "oracle": MethodSpec(_oracle, "none", "exact geodesic path to the snapped goal"),
    "zone3_oracle": MethodSpec(_zone3, "none", "up to 8 Zone-3 approach points, centroid fallback"),
    "frontier": MethodSpec(_frontier, "rgbd", "depth-only occupancy grid, nearest-frontier exploration"),
    "llm_frontier": MethodSpec(_llm_frontier, "rgbd", "frontier + LLM choice among near-equidistant frontiers",
                               _llm_preflight),
}


def method_spec(name: str) -> MethodSpec:
    if name not in METHODS:
        raise BioVLNError(f"unknown method '{name}'", field="method", fix=f"use one of: {', '.join(METHODS)}")
    return METHODS[name]
