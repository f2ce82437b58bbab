"""GroupedSubprocVecEnv: several envs per worker process give SB3's DummyVecEnv's transitions (auto-reset,
terminal observations, seeds), route attribute and method calls by env index, and turn a worker's
failure into a one-line error instead of a hang."""

from __future__ import annotations

from functools import partial

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv

from biovln_ms.errors import BioVLNError
from biovln_ms.learning.grouped_vec_env import GroupedSubprocVecEnv


class Tagged(gym.Env):
    """A counter with a tag; action 9 raises (a failing env)."""

    observation_space = gym.spaces.Box(-np.inf, np.inf, (2,), np.float64)
    action_space = gym.spaces.Discrete(10)

    def __init__(self, tag: int) -> None:
        self.tag, self.t = tag, 0

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = int(self.np_random.integers(0, 3))
        return np.array([self.tag, self.t], float), {"start": self.t}

    def step(self, action):
        if action == 9:
            raise RuntimeError("action 9 breaks this env")
        self.t += 1
        return np.array([self.tag, self.t], float), float(action), self.t >= 4, False, {}

    def double(self, k: int = 1) -> int:
        return 2 * self.tag * k


def _cartpole():
    return gym.make("CartPole-v1", max_episode_steps=30)


def _run(venv, n: int, steps: int):
    venv.seed(3)
    out = [venv.reset()]
    rng = np.random.default_rng(0)
    rewards, dones, finals = [], [], []
    for _ in range(steps):
        obs, r, d, infos = venv.step(rng.integers(0, 2, n))
        out.append(obs)
        rewards.append(r)
        dones.append(d)
        finals += [(k, i["terminal_observation"]) for k, i in enumerate(infos) if "terminal_observation" in i]
    venv.close()
    return np.array(out), np.array(rewards), np.array(dones), finals


def test_grouped_envs_give_the_dummy_vec_envs_transitions():
    n = 5
    grouped = GroupedSubprocVecEnv([_cartpole] * n, processes=2)
    assert grouped.groups == [(0, 3), (3, 5)] and grouped.num_envs == n
    obs_a, rew_a, done_a, fin_a = _run(grouped, n, 80)
    obs_b, rew_b, done_b, fin_b = _run(DummyVecEnv([_cartpole] * n), n, 80)
    assert np.array_equal(obs_a, obs_b) and np.array_equal(rew_a, rew_b) and np.array_equal(done_a, done_b)
    assert done_a.sum() > n  # episodes ended and were reset within the run
    assert [k for k, _ in fin_a] == [k for k, _ in fin_b]
    assert all(np.array_equal(x, y) for (_, x), (_, y) in zip(fin_a, fin_b))


def test_attributes_and_methods_go_to_the_envs_named():
    venv = GroupedSubprocVecEnv([partial(Tagged, k) for k in range(5)], processes=2)
    try:
        assert venv.get_attr("tag") == [0, 1, 2, 3, 4]
        assert venv.get_attr("tag", indices=[4, 0, 3]) == [4, 0, 3]
        assert venv.get_attr("tag", indices=[-1]) == [4]  # from the end, as SubprocVecEnv
        with pytest.raises(IndexError, match="env index 5 out of range"):
            venv.get_attr("tag", indices=[5])
        with pytest.raises(AttributeError):  # as DummyVecEnv raises it; the worker lives on
            venv.get_attr("no_such_attribute", indices=[3])
        assert venv.get_attr("tag", indices=[3]) == [3] and not venv.has_attr("no_such_attribute")
        venv.set_attr("tag", 7, indices=[1, 3])
        assert venv.get_attr("tag") == [0, 7, 2, 7, 4]
        assert venv.env_method("double", 3, indices=[2, 4]) == [12, 24]
        assert venv.env_is_wrapped(gym.Wrapper) == [False] * 5 and venv.has_attr("tag")
        venv.seed(10)
        venv.reset()
        assert [i["start"] for i in venv.reset_infos] == [
            int(np.random.default_rng(10 + k).integers(0, 3)) for k in range(5)
        ]  # env k seeded 10 + k, as SubprocVecEnv does
    finally:
        venv.close()


def test_a_failing_env_is_a_one_line_error_not_a_hang(capfd):
    venv = GroupedSubprocVecEnv([partial(Tagged, k) for k in range(4)], processes=2)
    venv.reset()
    with pytest.raises(BioVLNError, match=r"env process 1 \(envs 2\.\.3\) failed: RuntimeError: action 9"):
        venv.step(np.array([1, 1, 9, 1]))
    venv.close()  # the healthy worker ends too
    assert not any(p.is_alive() for p in venv.processes)
    assert "Traceback" in capfd.readouterr().err
    with pytest.raises(ValueError, match="processes must be in 1..4"):
        GroupedSubprocVecEnv([partial(Tagged, k) for k in range(4)], processes=5)
