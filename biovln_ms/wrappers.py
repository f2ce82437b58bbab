"""Wrappers that make a BioVLN ManiSkill env a plain gymnasium env for standard trainers.

``GymnasiumEnv`` is ManiSkill's ``CPUGymWrapper`` (numpy, unbatched; one env per process) that also
seeds gymnasium's ``np_random`` on ``reset(seed=...)`` (ManiSkill's ``BaseEnv.reset`` does not) and
reports the registered ``spec`` (gymnasium cannot re-describe ManiSkill's ``TimeLimitWrapper``), both
of which gymnasium's and Stable-Baselines3's ``check_env`` need.
"""

from __future__ import annotations

import gymnasium as gym
from gymnasium.utils import seeding
from mani_skill.utils.wrappers.gymnasium import CPUGymWrapper

import biovln_ms  # noqa: F401
from biovln_ms.variants import RL_ENV


class GymnasiumEnv(CPUGymWrapper):
    @property
    def spec(self):
        """The registered spec (gymnasium cannot re-describe ManiSkill's TimeLimitWrapper)."""
        return self.unwrapped.spec

    def reset(self, *, seed=None, options=None):
        if seed is not None:
            self.base_env._np_random, _ = seeding.np_random(seed)
        return super().reset(seed=seed, options=options)


def make_gym_env(env_id: str = RL_ENV, single_thread: bool = True, **kwargs) -> gym.Env:
    """``gym.make`` on the CPU backends, wrapped for gymnasium / SB3. Picklable through
    ``functools.partial``, so it serves as the env factory of ``AsyncVectorEnv`` / ``SubprocVecEnv``
    (one env per process: ManiSkill refuses ``num_envs > 1`` on the CPU)."""

    if single_thread:  # with the simulator on one core, 2 torch threads per worker slow it many times over
        import torch

        torch.set_num_threads(1)
    kwargs.setdefault("sim_backend", "physx_cpu")
    kwargs.setdefault("render_backend", "cpu")
    return GymnasiumEnv(gym.make(env_id, **kwargs))
