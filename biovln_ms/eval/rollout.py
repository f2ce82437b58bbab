"""One episode of a policy in an env, as a stream of steps (used by the harness, `record` and reports)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterator

import numpy as np


@dataclass
class Step:
    """``action`` is None for the start. ``obs_before``/``info_before`` are what the policy acted on;
    ``obs``/``info`` come after the action; ``done`` ends the episode (terminated or truncated)."""

    action: int | np.ndarray | None
    obs_before: Any
    info_before: dict | None
    obs: Any
    info: dict
    done: bool = False
    truncated: bool = False


def rollout(env, policy, episode_index: int, privileged: bool = False) -> Iterator[Step]:
    """Reset ``env`` to an episode, reset ``policy`` with what it may know (``privileged``: the oracles'
    read-only view too), and run until STOP or the variant's step limit."""
    obs, info = env.reset(options={"episode_index": episode_index})
    episode_info = env.unwrapped.episode_info(0, privileged=privileged)
    policy.reset(episode_info)
    yield Step(None, None, None, obs, info)
    for _ in range(episode_info.task.max_episode_steps):
        a = policy.act(obs, info)  # an int (Discrete(4)), or an array in continuous control
        a = int(a) if np.ndim(a) == 0 else np.asarray(a, np.float32)
        before, before_info = obs, info
        obs, _, term, trunc, info = env.step(a)
        done = bool(term) or bool(trunc)
        yield Step(a, before, before_info, obs, info, done, bool(trunc))
        if done:
            return
