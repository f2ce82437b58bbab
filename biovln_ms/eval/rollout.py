"""One episode of a policy in an env, as a stream of steps (used by the harness, `record` and reports)."""

from __future__ import annotations

import zlib
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


def episode_seed(episode: dict) -> int:
    """The reset seed of a dataset episode: CRC-32 of ``"<scene_id>/<episode_id>"`` (31 bits).

    ManiSkill draws an unseeded reset's episode seed from the env's main RNG, which every reset advances,
    so an episode's noise (actuation, image noise) would depend on the episodes its worker ran before it.
    Seeded by its identity, an episode gets the same noise in any worker, order or run."""
    return zlib.crc32(f"{episode['scene_id']}/{episode['episode_id']}".encode()) & 0x7FFFFFFF


def rollout(
    env, policy, episode_index: int, privileged: bool = False, fresh_scene: bool = False
) -> Iterator[Step]:
    """Reset ``env`` to an episode (seeded by :func:`episode_seed`), reset ``policy`` with what it may know
    (``privileged``: the oracles' read-only view too), and run until STOP or the variant's step limit.

    ``fresh_scene``: rebuild the scene at the reset (ManiSkill's ``reconfigure``), so that the episode's
    contacts do not depend on the episodes the env ran before in the same scene (PhysX keeps state across
    resets; the noise presets guide), at the cost of a scene build per reset."""
    seed = episode_seed(env.unwrapped.source.episodes[episode_index])
    obs, info = env.reset(seed=seed, options={"episode_index": episode_index, "reconfigure": fresh_scene})
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
