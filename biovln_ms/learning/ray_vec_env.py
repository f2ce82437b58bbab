"""``RayVecEnv``: a Stable-Baselines3 ``VecEnv`` whose sub-envs live in Ray actors.

The same env factories as ``SubprocVecEnv``, but each env runs in a Ray actor, which Ray may place on
any node of a cluster: ``address="local"`` starts a local instance (tests, one machine), ``"auto"`` or
``"ray://host:port"`` joins a running cluster. Steps are sent to all actors at once and gathered, with
the same auto-reset and ``terminal_observation`` convention as SB3's own vector envs, so any SB3
algorithm trains on it unchanged.
"""

from __future__ import annotations

from typing import Any, Callable, Sequence

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices

from biovln_ms.cluster import start_ray, stop_ray_work


class EnvActor:
    """One env in a Ray actor; ``step`` auto-resets like SB3's vector envs."""

    def __init__(self, factory: Callable[[], gym.Env]) -> None:
        self.env = factory()

    def spaces(self) -> tuple[gym.Space, gym.Space, dict]:
        return self.env.observation_space, self.env.action_space, dict(self.env.metadata or {})

    def reset(self, seed: int | None, options: dict | None) -> tuple[Any, dict]:
        return self.env.reset(seed=seed, **({"options": options} if options else {}))

    def step(self, action) -> tuple[Any, float, bool, dict, dict]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        done = bool(terminated or truncated)
        info["TimeLimit.truncated"] = bool(truncated and not terminated)
        reset_info: dict = {}
        if done:
            info["terminal_observation"] = obs
            obs, reset_info = self.env.reset()
        return obs, float(reward), done, info, reset_info

    def get_attr(self, name: str) -> Any:
        return self.env.get_wrapper_attr(name)

    def set_attr(self, name: str, value: Any) -> None:
        setattr(self.env, name, value)

    def call(self, name: str, args: tuple, kwargs: dict) -> Any:
        return self.env.get_wrapper_attr(name)(*args, **kwargs)

    def is_wrapped(self, wrapper_class: type) -> bool:
        from stable_baselines3.common.env_util import is_wrapped

        return is_wrapped(self.env, wrapper_class)

    def close(self) -> None:
        self.env.close()


def _stack(items: list):
    if isinstance(items[0], dict):
        return {k: np.stack([it[k] for it in items]) for k in items[0]}
    return np.stack(items)


class RayVecEnv(VecEnv):
    def __init__(
        self, env_fns: Sequence[Callable[[], gym.Env]], address: str = "local", num_cpus_per_env: float = 1.0
    ) -> None:
        ray, self._started = start_ray(address, num_cpus=int(np.ceil(len(env_fns) * num_cpus_per_env)))
        self._ray = ray
        actor = ray.remote(num_cpus=num_cpus_per_env)(EnvActor)
        self.actors = [actor.remote(fn) for fn in env_fns]
        obs_space, act_space, metadata = ray.get(self.actors[0].spaces.remote())
        super().__init__(len(env_fns), obs_space, act_space)
        self.metadata = metadata
        self._pending: list | None = None
        self.closed = False

    def _indices(self, indices: VecEnvIndices) -> list[int]:
        return list(self._get_indices(indices))

    def reset(self):
        results = self._ray.get(
            [a.reset.remote(self._seeds[i], self._options[i]) for i, a in enumerate(self.actors)]
        )
        self.reset_infos = [info for _, info in results]
        self._reset_seeds()
        self._reset_options()
        return _stack([obs for obs, _ in results])

    def step_async(self, actions: np.ndarray) -> None:
        self._pending = [a.step.remote(actions[i]) for i, a in enumerate(self.actors)]

    def step_wait(self):
        results = self._ray.get(self._pending)
        self._pending = None
        obs, rewards, dones, infos, reset_infos = zip(*results)
        for i, r in enumerate(reset_infos):
            if dones[i]:
                self.reset_infos[i] = r
        return _stack(list(obs)), np.array(rewards, np.float32), np.array(dones, bool), list(infos)

    def terminate(self) -> None:
        """End the actors at once, without their ``close`` (after ^C, SIGTERM or an error, an actor may be
        mid-step or never placed on a node, and ``close`` would wait for it)."""
        if self.closed:
            return
        try:
            stop_ray_work(self._ray, actors=self.actors)
            if self._started:
                self._ray.shutdown()
        finally:
            self.closed = True

    def close(self) -> None:
        if self.closed:
            return
        self._ray.get([a.close.remote() for a in self.actors])
        for a in self.actors:
            self._ray.kill(a)
        if self._started:
            self._ray.shutdown()
        self.closed = True

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return self._ray.get([self.actors[i].get_attr.remote(attr_name) for i in self._indices(indices)])

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        self._ray.get([self.actors[i].set_attr.remote(attr_name, value) for i in self._indices(indices)])

    def env_method(
        self, method_name: str, *method_args, indices: VecEnvIndices = None, **method_kwargs
    ) -> list[Any]:
        return self._ray.get(
            [
                self.actors[i].call.remote(method_name, method_args, method_kwargs)
                for i in self._indices(indices)
            ]
        )

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return self._ray.get(
            [self.actors[i].is_wrapped.remote(wrapper_class) for i in self._indices(indices)]
        )
