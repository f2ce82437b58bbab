"""Wrappers that make a BioVLN ManiSkill env a plain gymnasium env for standard trainers, and the
training-only STOP settings (``StopShaping``).

``GymnasiumEnv`` is ManiSkill's ``CPUGymWrapper`` (numpy, unbatched; one env per process) that also
seeds gymnasium's ``np_random`` on ``reset(seed=...)`` (ManiSkill's ``BaseEnv.reset`` does not) and
reports the registered ``spec`` (gymnasium cannot re-describe ManiSkill's ``TimeLimitWrapper``), both
of which gymnasium's and Stable-Baselines3's ``check_env`` need.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import torch
from gymnasium.utils import seeding
from mani_skill.utils.wrappers.gymnasium import CPUGymWrapper

import biovln_ms  # noqa: F401
from biovln_ms.errors import BioVLNError
from biovln_ms.task_config import STOP
from biovln_ms.tasks.config_checks import check_seed
from biovln_ms.variants import RL_ENV


class GymnasiumEnv(CPUGymWrapper):
    @property
    def spec(self):
        """The registered spec (gymnasium cannot re-describe ManiSkill's TimeLimitWrapper)."""
        return self.unwrapped.spec

    def reset(self, *, seed=None, options=None):
        """ManiSkill's reset, with gymnasium's ``np_random`` seeded too; a bad seed is the env's one-line
        error (field 'seed'), checked before gymnasium's seeding would raise its own."""
        if seed is not None:
            checked = check_seed(seed, self.base_env.num_envs)
            first = checked[0] if isinstance(checked, list) else checked
            self.base_env._np_random, _ = seeding.np_random(first)
        return super().reset(seed=seed, options=options)


def make_gym_env(
    env_id: str = RL_ENV,
    single_thread: bool = True,
    stop_mask_steps: int = 0,
    stop_penalty: float = 0.0,
    **kwargs,
) -> gym.Env:
    """``gym.make`` on the CPU backends, wrapped for gymnasium / SB3 (with ``StopShaping`` when either STOP
    setting is on). Picklable through ``functools.partial``, so it serves as the env factory of
    ``AsyncVectorEnv`` / ``SubprocVecEnv`` (one env per process: ManiSkill refuses ``num_envs > 1`` on the
    CPU)."""

    if single_thread:  # with the simulator on one core, 2 torch threads per worker slow it many times over
        torch.set_num_threads(1)
    kwargs.setdefault("sim_backend", "physx_cpu")
    kwargs.setdefault("render_backend", "cpu")
    env = gym.make(env_id, **kwargs)
    if stop_mask_steps or stop_penalty:
        env = StopShaping(env, stop_mask_steps, stop_penalty)
    return GymnasiumEnv(env)


class StopShaping(gym.Wrapper):
    """Training-only STOP settings on a batched BioVLN env (``gym.make(..., num_envs=N)``, before
    ``GymnasiumEnv`` or ``ManiSkillVectorEnv``): STOP ends the episode, so a policy that draws it at random
    ends most episodes within a few steps and never sees the goal. Two remedies, both off by default:

    - ``mask_steps``: STOP is not allowed in an episode's first ``mask_steps`` steps. ``action_masks()``
      says which actions are allowed, (N, 4) bool, for a sampler that masks its logits; a discrete STOP
      drawn anyway is an error (there is no idle action to put in its place). In continuous control a
      masked STOP component is set to -1, so the forward and turn components still act.
    - ``penalty``: a STOP outside the success radius (``info["fail"]``) costs this much reward, once, in
      the units of Eq. 5 (a success earns ``success_bonus``, 10): divided by ``success_bonus`` as the
      env's reward is under the ``normalized_dense`` (ManiSkill's default) and ``sparse`` reward modes.

    Evaluation uses the env without this wrapper: the policy must have learnt when to stop.
    """

    def __init__(self, env: gym.Env, mask_steps: int = 0, penalty: float = 0.0) -> None:
        super().__init__(env)
        if mask_steps < 0 or penalty < 0:
            raise BioVLNError(
                f"mask_steps {mask_steps} and penalty {penalty} must be >= 0",
                field="stop_mask_steps" if mask_steps < 0 else "stop_penalty",
                fix="0 turns either off",
            )
        self.mask_steps = int(mask_steps)
        base = env.unwrapped
        self.discrete = base.control_mode == "discrete"
        self.set_penalty(penalty)  # in the env's units
        self._charged = torch.zeros(base.num_envs, dtype=torch.bool, device=base.device)

    def set_penalty(self, penalty: float) -> None:
        """A new penalty from the next step (a trainer that penalises only early in training)."""
        base = self.env.unwrapped
        self.penalty = float(penalty)
        self._cost = self.penalty if base.reward_mode == "dense" else self.penalty / base.cfg.success_bonus

    def action_masks(self) -> torch.Tensor:
        """(N, 4) bool: the actions allowed at the next step (STOP is column 0; discrete control)."""
        base = self.env.unwrapped
        mask = torch.ones(base.num_envs, 4, dtype=torch.bool, device=base.device)
        mask[:, STOP] = base.elapsed_steps >= self.mask_steps
        return mask

    def reset(self, *, seed=None, options=None):
        obs, info = self.env.reset(seed=seed, options=options)
        idx = (options or {}).get("env_idx")
        rows = slice(None) if idx is None else torch.as_tensor(idx, device=self._charged.device)
        self._charged[rows] = False
        return obs, info

    def step(self, action):
        base = self.env.unwrapped
        if self.mask_steps:
            masked = base.elapsed_steps < self.mask_steps
            if self.discrete:
                a = torch.as_tensor(np.asarray(action) if not torch.is_tensor(action) else action)
                if (a.reshape(-1).to(masked.device) == STOP)[masked].any():
                    raise BioVLNError(
                        f"STOP is masked for the first {self.mask_steps} steps of an episode",
                        field="action",
                        fix="sample with action_masks() (a masked policy), or set mask_steps 0",
                    )
            else:
                a = torch.as_tensor(action, dtype=torch.float32, device=base.device).reshape(-1, 3).clone()
                a[masked, 2] = -1.0
                action = a
        obs, reward, terminated, truncated, info = self.env.step(action)
        if self._cost:
            new = info["fail"].to(torch.bool) & ~self._charged
            reward = reward - self._cost * new.to(reward.dtype)
            self._charged |= new
        return obs, reward, terminated, truncated, info
