"""``BioVLN-Protocol-v0``: a lab protocol as one episode, K = 2-5 ordered instrument goals.

The robot, actions, physics, sensors and safety measures are :class:`~biovln_ms.tasks.nav_env.BioVLNNavEnv`'s.
What differs: an episode's goals are visited in order, each an Eq. 1 goal with its success radius r; a STOP
(MultiON's FOUND) at the current goal moves on to the next, a STOP elsewhere ends the episode or misses the
goal (``wrong_stop``); the step budget is ``steps_per_goal`` x K (the options of its
:class:`~biovln_ms.task_config.ProtocolTaskConfig`). The rule and the metrics are measures
(:mod:`biovln_ms.metrics.protocol_measures`). The observation's goal sensors (``pointgoal_with_gps_compass``,
``pointgoal``, ``objectgoal``) and an oracle's privileged view follow the current goal; the observation also
carries the episode's English instruction: ``instruction`` (token ids of the versioned vocabulary,
:mod:`biovln_ms.protocols.vocabulary`, padded to its fixed length) and ``instruction_text`` (its UTF-8
bytes, padded with NUL; ``decode_text`` reads them).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from functools import partial

import numpy as np
import torch

from biovln_ms.constants import MAX_VISITS
from biovln_ms.episodes.samplers import ProtocolEpisodes
from biovln_ms.episodes.source import GeneratedEpisodes
from biovln_ms.metrics.protocol_measures import ProtocolBatchContext, ProtocolEpisodeContext
from biovln_ms.protocols.vocabulary import load_vocabulary
from biovln_ms.task_config import EpisodeInfo, ProtocolTaskConfig
from biovln_ms.tasks.nav_env import BioVLNNavEnv
from biovln_ms.tasks.sensors import SENSORS, SensorInputs, register_sensor
from biovln_ms.variants import PROTOCOL_ENV, VARIANTS


@dataclass
class ProtocolSensorInputs(SensorInputs):
    """:class:`SensorInputs` (``goal`` and ``objectgoal`` of the current goal) plus the instruction."""

    instruction: np.ndarray | None = None  # (N, max_tokens) int32 token ids
    instruction_text: np.ndarray | None = None  # (N, max_text_bytes) uint8 UTF-8 bytes


@register_sensor("instruction")
def instruction_tokens(x: ProtocolSensorInputs) -> np.ndarray:
    """The instruction's token ids (int32), padded with 0 to the vocabulary's ``max_tokens``."""
    return x.instruction.copy()


@register_sensor("instruction_text")
def instruction_text(x: ProtocolSensorInputs) -> np.ndarray:
    """The instruction's UTF-8 bytes (uint8), padded with NUL to the vocabulary's ``max_text_bytes``."""
    return x.instruction_text.copy()


class BioVLNProtocolEnv(BioVLNNavEnv):
    """Lab protocols: K ordered goals, a STOP at each. Episodes from a ``protocol_*`` split (of ``dataset``
    or the default dataset), or sampled in a scene generated from ``template`` (default ``two_room``, which
    hosts every shipped protocol) / ``scene_seed``. :class:`ProtocolTaskConfig` fields may be passed as
    keyword arguments (``wrong_stop``, ``subgoal_rule``, ``steps_per_goal`` among them)."""

    config: ProtocolTaskConfig = VARIANTS[PROTOCOL_ENV]
    generated_episodes = partial(GeneratedEpisodes, sampler=ProtocolEpisodes())
    default_template = "two_room"  # it hosts every shipped protocol

    def _after_reconfigure(self, options: dict):
        super()._after_reconfigure(options)
        n, vocab = self.num_envs, load_vocabulary()
        self._ctx = ProtocolBatchContext(n)
        self._instruction = np.zeros((n, vocab.max_tokens), np.int32)
        self._instruction_text = np.zeros((n, vocab.max_text_bytes), np.uint8)
        self._goal_category = np.zeros((n, MAX_VISITS), np.int64)  # catalog goal-category index per goal

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        vocab = load_vocabulary()
        for i in env_idx.cpu().numpy().tolist():
            ep = self._episodes[i]
            text = ep["protocol"]["instruction"]
            self._instruction[i] = vocab.encode(text)
            self._instruction_text[i] = vocab.encode_text(text)
            self._goal_category[i] = 0
            for j, g in enumerate(ep["goals"]):
                self._goal_category[i, j] = self.category_names.index(g["object_category"])
        super()._initialize_episode(env_idx, options)

    def _episode_context(self, i: int) -> ProtocolEpisodeContext:
        """The single-goal context of the episode's goals (in visit order), with the geodesic to each goal and
        the length L of the ordered route start -> g1 -> ... -> gK."""
        base, nav = super()._episode_context(i), self.navs[i]
        ends = [nav.snap(g) if self.cfg.goal_mode == "centroid" else g for g, _, _ in base.goals]
        geodesics = tuple(nav.distance_to(e) for e in ends)
        start = np.asarray(self._episodes[i]["start_position"][:2], float)
        route = geodesics[0](start) + sum(geodesics[j + 1](ends[j]) for j in range(len(ends) - 1))
        kept = {f.name: getattr(base, f.name) for f in fields(base) if f.init}
        kept.update(geodesic=geodesics[0], start_geodesic=float(geodesics[0](start)))
        return ProtocolEpisodeContext(**kept, goal_geodesics=geodesics, route_length=float(route))

    def _get_obs_extra(self, info: dict):
        n = self.num_envs
        col = np.minimum(self._measures["subgoal_index"], self._ctx.num_goals - 1)
        objectgoal = np.zeros((n, len(self.category_names)), np.float32)
        objectgoal[np.arange(n), self._goal_category[np.arange(n), col]] = 1.0
        x = ProtocolSensorInputs(
            self._measures["agent_pose"],
            self._start,
            self._measures["subgoal_position"],
            objectgoal,
            self._measures["clearance"],
            self.cfg,
            self._instruction,
            self._instruction_text,
        )
        return {name: torch.from_numpy(SENSORS[name](x)).to(self.device) for name in self.cfg.sensors}

    def episode_info(self, i: int = 0, privileged: bool = False) -> EpisodeInfo:
        """The single-goal env's (the first goal's category) with the episode's instruction; an oracle's
        view follows the current sub-goal (``info["subgoal_index"]``, the last goal once all are done)."""
        info = super().episode_info(i, privileged)
        if privileged:
            k = len(self._ctx.episode(i).goals)

            def current() -> int:
                return min(int(self._measures["subgoal_index"][i]), k - 1)

            info = replace(info, privileged=self._privileged_view(i, current))
        return replace(info, instruction=self._episodes[i]["protocol"]["instruction"])
