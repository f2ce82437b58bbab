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


def rollout(env, policy, episode_index: int, max_steps: int = 500) -> Iterator[Step]:
    """Reset ``env`` to an episode, reset ``policy`` with it, and run until STOP or truncation."""
    obs, info = env.reset(options={"episode_index": episode_index})
    u = env.unwrapped
    policy.reset({"env": u, "episode": u.current_episode})
    yield Step(None, None, None, obs, info)
    for _ in range(max_steps):
        a = policy.act(obs, info)  # an int (Discrete(4)), or an array in continuous control
        a = int(a) if np.ndim(a) == 0 else np.asarray(a, np.float32)
        before, before_info = obs, info
        obs, _, term, trunc, info = env.step(a)
        done = bool(term) or bool(trunc)
        yield Step(a, before, before_info, obs, info, done, bool(trunc))
        if done:
            return
