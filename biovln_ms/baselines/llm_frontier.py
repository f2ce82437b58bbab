"""LLM-Frontier: Frontier exploration that asks an LLM to pick among near-equidistant frontiers.

When the nearest frontiers lie within 1.0 m (path length) of each other, the top 3 are described to
the LLM with the target instrument and the agent's position; its JSON answer picks one. Any failure
(endpoint down, timeout, garbage, out-of-range choice) falls back to the nearest frontier and is
counted. The LLM's output is data: only an index is read from it.
"""

from __future__ import annotations

import json

import numpy as np

from biovln_ms.baselines.frontier import FrontierParams, FrontierPolicy
from biovln_ms.baselines.frontier.planner import Candidate
from biovln_ms.baselines.policy import EpisodeInfo
from biovln_ms.llm.client import JSONChatClient, default_cache_path

SYSTEM = (
    "You guide a mobile robot exploring a biomedical laboratory to reach an instrument. Answer with a "
    'JSON object {"choice": k} where k is the index of the frontier to explore next.'
)


class LLMFrontierPolicy(FrontierPolicy):
    name = "llm_frontier"

    def __init__(
        self,
        client=None,
        equidistance_threshold: float = 1.0,
        top_k: int = 3,
        params: FrontierParams | None = None,
    ) -> None:
        super().__init__(params)
        if client is None:  # as `eval` builds it: the endpoint from the environment, the persistent cache
            client = JSONChatClient(cache_path=default_cache_path())
        self.client = client
        self.threshold, self.top_k = equidistance_threshold, top_k
        self.consulted = 0
        self.fallbacks = 0

    def reset(self, episode_info: EpisodeInfo) -> None:
        super().reset(episode_info)
        self.category = episode_info.object_category
        self.consulted = self.fallbacks = 0

    def episode_stats(self) -> dict:
        """LLM use in the current episode, and the frontier baseline's pose estimates (recorded per
        episode by the harness)."""
        return {"llm_consulted": self.consulted, "llm_fallbacks": self.fallbacks, **super().episode_stats()}

    def choose(self, candidates: list[Candidate], pose: np.ndarray) -> np.ndarray:
        """The LLM's pick among the nearest frontiers within the threshold of the nearest (the nearest
        when there is one, or on any failure)."""
        ranked = sorted(candidates, key=lambda c: c.path_length)
        near = [c for c in ranked if c.path_length - ranked[0].path_length <= self.threshold][: self.top_k]
        if len(near) < 2:
            return ranked[0].position
        self.consulted += 1
        prompt = json.dumps(
            {
                "target_instrument": self.category.replace("_", " "),
                "agent_position_m": [round(float(pose[0]), 2), round(float(pose[1]), 2)],
                "agent_heading_rad": round(float(pose[2]), 2),
                "frontiers": [
                    {
                        "index": i,
                        "position_m": [round(float(x), 2) for x in c.position[:2]],
                        "path_length_m": round(float(c.path_length), 2),
                        "size_cells": int(c.cells),
                    }
                    for i, c in enumerate(near)
                ],
            }
        )
        try:
            answer = self.client.ask(
                SYSTEM,
                prompt,
                validate=lambda o: (
                    isinstance(o.get("choice"), int)
                    and not isinstance(o.get("choice"), bool)
                    and 0 <= o["choice"] < len(near)
                ),
            )
        except Exception:  # the client counts its failures and returns None; anything else falls back too
            answer = None
        if answer is None:
            self.fallbacks += 1
            return ranked[0].position
        return near[answer["choice"]].position
