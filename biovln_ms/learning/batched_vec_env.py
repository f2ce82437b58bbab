"""``BatchedVecEnv``: a Stable-Baselines3 ``VecEnv`` over one batched ManiSkill env.

ManiSkill simulates ``num_envs`` sub-envs in one process (thousands on ``physx_cuda``); SB3 wants NumPy
arrays and one ``info`` dict per sub-env. This adapter steps the whole batch at once, resets the finished
sub-envs in place (``reset(options={"env_idx": ...})``, a partial reset) and follows SB3's vector-env
convention: ``terminal_observation`` and ``TimeLimit.truncated`` in the finished sub-env's ``info``, with
the task's ``success``; wrap it in ``VecMonitor`` for episode returns and lengths.

A partial reset keeps each sub-env's scene (one sub-env's scene cannot be rebuilt alone), and a reset of
all sub-envs gives them consecutive episodes of the split, so without more the sub-envs would train in the
scenes of the first reset only (8 of the train split's 39 at N = 256). ``rotate_every`` plays the part of
ManiSkill's ``reconfiguration_freq``: after that many batched steps every unfinished episode ends as
truncated (SB3 bootstraps its value) and all sub-envs reset, moving on to the split's next episodes and
scenes.

ManiSkill's own ``ManiSkillSB3VectorEnv`` (3.0.1, marked TODO there) does not fit: it puts an ``episode``
entry in every sub-env's ``info`` at every step, holding the whole batch's running sums as views that its
partial reset then zeroes, and it drops ``success``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch
from mani_skill.utils.common import to_numpy
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices

from biovln_ms.errors import BioVLNError


class BatchedVecEnv(VecEnv):
    """``env``: ``gym.make(env_id, num_envs=N, ...)`` of a ManiSkill task (its wrappers included);
    ``rotate_every``: batched steps between resets of all sub-envs (None: never)."""

    def __init__(self, env: gym.Env, rotate_every: int | None = None) -> None:
        self.env = env
        self.base = env.unwrapped
        super().__init__(
            self.base.num_envs, self.base.single_observation_space, self.base.single_action_space
        )
        self.rotate_every = rotate_every
        self._steps = 0
        self._seed: int | None = None
        self._actions: np.ndarray | None = None

    def reset(self) -> np.ndarray:
        obs, _ = self.env.reset(seed=self._seed)
        self._seed = None  # a seed places the episode cursor once, as SB3's seed() promises
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return to_numpy(obs)

    def seed(self, seed: int | None = None) -> list[int | None]:
        self._seed = seed
        return [seed] * self.num_envs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        actions = torch.as_tensor(self._actions, device=self.base.device)
        obs, reward, terminated, truncated, info = self.env.step(actions)
        obs = to_numpy(obs).copy()
        terminated, truncated = to_numpy(terminated, bool), to_numpy(truncated, bool)
        self._steps += 1
        rotate = bool(self.rotate_every) and self._steps % self.rotate_every == 0
        if rotate:
            truncated = truncated | ~terminated  # every episode ends here: the running ones as truncated
        done = terminated | truncated
        success = to_numpy(info["success"]) if "success" in info else np.zeros(self.num_envs, bool)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        finished = np.flatnonzero(done)
        for i in finished:
            infos[i] = {
                "success": float(success[i]),
                "terminal_observation": obs[i].copy(),
                "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
            }
        if rotate:
            obs = to_numpy(self.env.reset()[0]).copy()  # the split's next episodes and scenes
        elif finished.size:
            fresh, _ = self.env.reset(options={"env_idx": finished})
            obs[finished] = to_numpy(fresh)[finished]
        return obs, to_numpy(reward, np.float32), done, infos

    def close(self) -> None:
        self.env.close()

    def _count(self, indices: VecEnvIndices) -> int:
        return len(list(self._get_indices(indices)))

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The batched env's attribute, once per requested sub-env (they share one env object)."""
        return [getattr(self.base, attr_name)] * self._count(indices)

    def _whole_batch(self, indices: VecEnvIndices, what: str) -> None:
        if self._count(indices) != self.num_envs:
            raise BioVLNError(
                f"{what} acts on the whole batched env, not on sub-envs {list(self._get_indices(indices))}",
                field="indices",
                fix="call it without indices, or on the env itself (BatchedVecEnv.env)",
            )

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Sets it on the batched env, which all sub-envs share."""
        self._whole_batch(indices, "set_attr")
        setattr(self.base, attr_name, value)

    def env_method(
        self, method_name: str, *method_args, indices: VecEnvIndices = None, **method_kwargs
    ) -> list[Any]:
        """Calls it once on the batched env (a wrapper's method first, as SB3's vector envs do); its result
        stands for every sub-env."""
        self._whole_batch(indices, "env_method")
        result = self.env.get_wrapper_attr(method_name)(*method_args, **method_kwargs)
        return [result] * self.num_envs

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        wrapped, env = False, self.env
        while isinstance(env, gym.Wrapper):
            wrapped = wrapped or isinstance(env, wrapper_class)
            env = env.env
        return [wrapped] * self._count(indices)
