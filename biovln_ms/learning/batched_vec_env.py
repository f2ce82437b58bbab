"""``BatchedVecEnv``: a Stable-Baselines3 ``VecEnv`` over one batched ManiSkill env.

ManiSkill simulates ``num_envs`` sub-envs in one process (thousands on ``physx_cuda``); SB3 wants NumPy
arrays and one ``info`` dict per sub-env. This adapter steps the whole batch at once, resets the finished
sub-envs in place (``reset(options={"env_idx": ...})``, a partial reset) and follows SB3's vector-env
convention: ``terminal_observation`` and ``TimeLimit.truncated`` in the finished sub-env's ``info``, with
the task's ``success``; wrap it in ``VecMonitor`` for episode returns and lengths.

ManiSkill's own ``ManiSkillSB3VectorEnv`` (3.0.1, marked TODO there) does not fit: it puts an ``episode``
entry in every sub-env's ``info`` at every step, holding the whole batch's running sums as views that its
partial reset then zeroes, and it drops ``success``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices


def _numpy(x) -> np.ndarray:
    return x.detach().cpu().numpy() if isinstance(x, torch.Tensor) else np.asarray(x)


class BatchedVecEnv(VecEnv):
    """``env``: ``gym.make(env_id, num_envs=N, ...)`` of a ManiSkill task (its wrappers included)."""

    def __init__(self, env: gym.Env) -> None:
        self.env = env
        self.base = env.unwrapped
        super().__init__(
            self.base.num_envs, self.base.single_observation_space, self.base.single_action_space
        )
        self._seed: int | None = None
        self._actions: np.ndarray | None = None

    def reset(self) -> np.ndarray:
        obs, _ = self.env.reset(seed=self._seed)
        self._seed = None  # a seed places the episode cursor once, as SB3's seed() promises
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return _numpy(obs)

    def seed(self, seed: int | None = None) -> list[int | None]:
        self._seed = seed
        return [seed] * self.num_envs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        actions = torch.as_tensor(self._actions, device=self.base.device)
        obs, reward, terminated, truncated, info = self.env.step(actions)
        obs = _numpy(obs).copy()
        terminated, truncated = _numpy(terminated).astype(bool), _numpy(truncated).astype(bool)
        done = terminated | truncated
        success = _numpy(info["success"]) if "success" in info else np.zeros(self.num_envs, bool)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        finished = np.flatnonzero(done)
        for i in finished:
            infos[i] = {
                "success": float(success[i]),
                "terminal_observation": obs[i].copy(),
                "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
            }
        if finished.size:
            fresh, _ = self.env.reset(options={"env_idx": finished})
            obs[finished] = _numpy(fresh)[finished]
        return obs, _numpy(reward).astype(np.float32), done, infos

    def close(self) -> None:
        self.env.close()

    def _count(self, indices: VecEnvIndices) -> int:
        return len(list(self._get_indices(indices)))

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The batched env's attribute, once per requested sub-env (they share one env object)."""
        return [getattr(self.base, attr_name)] * self._count(indices)

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Sets it on the batched env: for every sub-env, whatever ``indices`` asks."""
        setattr(self.base, attr_name, value)

    def env_method(
        self, method_name: str, *method_args, indices: VecEnvIndices = None, **method_kwargs
    ) -> list[Any]:
        result = getattr(self.base, method_name)(*method_args, **method_kwargs)
        return [result] * self._count(indices)

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        wrapped, env = False, self.env
        while isinstance(env, gym.Wrapper):
            wrapped = wrapped or isinstance(env, wrapper_class)
            env = env.env
        return [wrapped] * self._count(indices)
