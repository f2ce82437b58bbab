"""RL with Stable-Baselines3: the training command's outputs, evaluation through the harness, Ray envs."""

import time

import gymnasium as gym
import numpy as np
import pytest

from biovln_ms.errors import BioVLNError
from biovln_ms.eval.harness import EvalConfig, evaluate
from biovln_ms.eval.learned import train_and_evaluate
from biovln_ms.learning.rl import RLConfig, train_rl


@pytest.fixture(scope="module")
def dataset(held_out_dataset):
    return held_out_dataset(train=4, ms_val=3)


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_train_writes_logs_checkpoints_curve_and_evaluates(dataset, tmp_path, algo):
    hp = {"n_steps": 64, "batch_size": 32} if algo == "ppo" else {"learning_starts": 32, "batch_size": 32}
    cfg = RLConfig(
        algo=algo,
        timesteps=128,
        n_envs=1,
        dataset=dataset,
        checkpoint_every=64,
        eval_episodes=2,
        hyperparams=hp,
    )
    r = train_and_evaluate(cfg, tmp_path, echo=lambda s: None, progress=False)
    assert r.timesteps >= 128 and r.model.is_file()
    assert any((tmp_path / "tb").rglob("events.out.tfevents.*"))
    assert {p.name for p in (tmp_path / "checkpoints").glob("*.zip")} >= {f"{algo}_64.zip", f"{algo}_128.zip"}
    assert (tmp_path / "learning_curve.png").read_bytes()[:4] == b"\x89PNG"
    assert r.eval_summary["overall"]["episodes"] == 2  # through the harness, on the RL variant
    assert (tmp_path / "eval" / f"{algo}@opface-rl" / "ms_val" / "episodes.jsonl").is_file()


def test_on_policy_training_says_it_runs_whole_rollouts(dataset, tmp_path):
    said = []
    cfg = RLConfig(
        timesteps=100,
        n_envs=1,
        dataset=dataset,
        eval_split=None,
        hyperparams={"n_steps": 64, "batch_size": 32},
    )
    r = train_rl(cfg, tmp_path, echo=said.append, progress=False)
    assert r.timesteps == 128  # what SB3 runs for 100: two rollouts of 64, told up front
    assert any(
        "whole rollouts of 64 steps over its 1 env(s): training 128 timesteps, not 100" in s for s in said
    )


def test_learned_method_errors(dataset, tmp_path):
    with pytest.raises(BioVLNError, match="needs a checkpoint"):
        evaluate(EvalConfig("ppo", "ms_val", str(tmp_path), dataset, workers=1), progress=False)
    (tmp_path / "x.zip").write_bytes(b"junk")
    from biovln_ms.baselines.sb3_policy import SB3Policy

    with pytest.raises(BioVLNError, match="not a Stable-Baselines3 PPO model"):
        SB3Policy(str(tmp_path / "x.zip"), "ppo")
    with pytest.raises(BioVLNError, match="unknown algorithm"):
        train_rl(RLConfig(algo="dqn2"), tmp_path)


@pytest.mark.slow
def test_ray_vec_env_trains_sb3_on_a_local_ray_instance(dataset):
    """Beyond one machine: the same env factories in Ray actors (here a local Ray instance)."""
    pytest.importorskip("ray")
    from functools import partial

    from stable_baselines3 import PPO

    from biovln_ms.learning.ray_vec_env import RayVecEnv
    from biovln_ms.wrappers import make_gym_env

    venv = RayVecEnv(
        [partial(make_gym_env, "BioVLN-OpFace-RL-v0", split="train", dataset=dataset)] * 2, address="local"
    )
    try:
        venv.seed(3)
        obs = venv.reset()
        assert obs.shape == (2, *venv.observation_space.shape)
        obs, rew, done, infos = venv.step(np.array([1, 2]))
        assert rew.shape == (2,) and len(infos) == 2 and "clearance" in infos[0]
        assert venv.get_attr("spec")[0].id == "biovln_ms:BioVLN-OpFace-RL-v0"  # gym.make-able anywhere
        model = PPO("MlpPolicy", venv, n_steps=32, batch_size=32, n_epochs=1, device="cpu")
        model.learn(64)
        assert model.num_timesteps >= 64
    finally:
        venv.close()
    assert isinstance(venv.action_space, gym.spaces.Discrete)


def test_batched_vec_env_resets_finished_sub_envs_in_place_and_trains_sb3(dataset):
    """One batched env for SB3 (``RLConfig.sim_backend``: N sub-envs on physx_cuda; here 1 on the CPU)."""
    from stable_baselines3 import PPO

    from biovln_ms.learning.batched_vec_env import BatchedVecEnv
    from biovln_ms.learning.rl import make_vec_env

    venv = make_vec_env(RLConfig(sim_backend="physx_cpu", n_envs=1, dataset=dataset))
    try:
        assert isinstance(venv.venv, BatchedVecEnv)
        obs = venv.reset()
        assert obs.shape == (1, *venv.observation_space.shape) and obs.dtype == np.float32
        obs, rew, done, infos = venv.step(np.array([1]))  # FORWARD: the episode goes on, no info
        assert not done[0] and infos == [{}] and rew.dtype == np.float32
        # STOP ends it: reported once (VecMonitor's episode, the task's success, the terminal observation),
        # and the sub-env is reset in place by a partial reset with NumPy indices, as SB3 wrappers pass
        obs, rew, done, infos = venv.step(np.array([0]))
        assert done[0] and infos[0]["episode"]["l"] == 2 and infos[0]["success"] in (0.0, 1.0)
        assert infos[0]["terminal_observation"].shape == obs.shape[1:]
        assert not np.array_equal(infos[0]["terminal_observation"], obs[0])  # a new episode's first view
        with pytest.raises(BioVLNError, match="whole batched env"):
            venv.env_method("reset", indices=[0, 0])
        model = PPO("MlpPolicy", venv, n_steps=32, batch_size=32, n_epochs=1, device="cpu")
        model.learn(64)
        assert model.num_timesteps >= 64
    finally:
        venv.close()


def test_one_batched_sub_env_trains_the_same_model_as_one_env_in_process(dataset, tmp_path):
    """On physx_cpu the batched path (one sub-env) steps exactly as the one-env path (DummyVecEnv, in
    process), and takes one torch thread as it does: the same model, bit for bit."""
    import gc

    import torch

    from biovln_ms.learning.sb3_safe import load_sb3_model

    threads = torch.get_num_threads()
    torch.set_num_threads(2)  # the batched path must set one thread itself (it runs first)
    weights = []
    for backend in ("physx_cpu", None):
        cfg = RLConfig(
            timesteps=256,
            n_envs=1,
            dataset=dataset,
            eval_split=None,
            sim_backend=backend,
            hyperparams={"n_steps": 128, "batch_size": 64},
        )
        r = train_rl(cfg, tmp_path / str(backend), echo=lambda s: None, progress=False)
        assert gc.get_freeze_count() == 0  # what training froze (FreezeAtStart) is collectable again
        policy = load_sb3_model(r.model, "ppo").policy
        weights.append(torch.cat([p.detach().flatten() for p in policy.parameters()]))
    torch.set_num_threads(threads)
    assert torch.equal(weights[0], weights[1])
    with pytest.raises(BioVLNError, match="not on Ray actors"):
        train_rl(RLConfig(sim_backend="physx_cuda", ray_address="local"), tmp_path)


def test_batched_vec_env_rotates_all_sub_envs_on_through_the_split(dataset):
    """``rotate_every``: every running episode ends as truncated; all sub-envs move to the next episodes."""
    from stable_baselines3.common.vec_env import VecMonitor

    from biovln_ms.learning.batched_vec_env import BatchedVecEnv

    env = gym.make("BioVLN-OpFace-RL-v0", num_envs=1, obs_mode="state", split="train", dataset=dataset)
    venv = VecMonitor(BatchedVecEnv(env, rotate_every=3), info_keywords=("success",))
    try:
        venv.reset()
        first = env.unwrapped._episode_index[0]
        for _ in range(2):
            _, _, done, _ = venv.step(np.array([2]))  # TURN_LEFT: the episode goes on
            assert not done[0]
        _, _, done, infos = venv.step(np.array([2]))
        assert done[0] and infos[0]["TimeLimit.truncated"] and infos[0]["episode"]["l"] == 3
        assert env.unwrapped._episode_index[0] != first
    finally:
        venv.close()


def test_steps_in_process_tells_the_trainers_process_from_workers():
    """``train_rl`` freezes the trainer's objects only when the envs step in its process: one env
    (DummyVecEnv) or a batched env, under any stack of SB3's vector-env wrappers."""
    from stable_baselines3.common.vec_env import (
        DummyVecEnv,
        SubprocVecEnv,
        VecFrameStack,
        VecMonitor,
        VecNormalize,
    )

    from biovln_ms.learning.batched_vec_env import BatchedVecEnv
    from biovln_ms.learning.grouped_vec_env import GroupedSubprocVecEnv
    from biovln_ms.learning.ray_vec_env import RayVecEnv
    from biovln_ms.learning.rl import steps_in_process

    dummy = DummyVecEnv([lambda: gym.make("CartPole-v1")])
    assert steps_in_process(VecMonitor(dummy))
    assert steps_in_process(VecMonitor(VecNormalize(dummy))) and steps_in_process(VecFrameStack(dummy, 2))

    def shell(cls):  # the class is all that counts: no processes, actors or envs are started
        venv = cls.__new__(cls)
        venv.num_envs, venv.observation_space = dummy.num_envs, dummy.observation_space
        venv.action_space = dummy.action_space
        return venv

    assert steps_in_process(VecMonitor(shell(BatchedVecEnv)))
    for cls in (SubprocVecEnv, GroupedSubprocVecEnv, RayVecEnv):
        assert not steps_in_process(VecMonitor(shell(cls))), cls


@pytest.mark.parametrize("grouped", [False, True])
def test_an_interrupted_step_still_ends_the_env_processes(grouped):
    """A kill or ^C between two workers' replies (one read, ``waiting`` still set, as inside SB3's
    ``step_wait``): SB3's ``close`` would wait for the reply already read; ``end_env_processes`` ends
    the workers at once, and ``close`` afterwards returns."""
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecMonitor

    from biovln_ms.learning.grouped_vec_env import GroupedSubprocVecEnv
    from biovln_ms.cluster import end_env_processes

    fns = [lambda: gym.make("CartPole-v1")] * 2
    base = GroupedSubprocVecEnv(fns, processes=2) if grouped else SubprocVecEnv(fns, start_method="spawn")
    venv = VecMonitor(base)
    venv.reset()
    venv.step_async(np.zeros(2, dtype=np.int64))
    base.remotes[0].recv()  # the first worker's reply read, the second's not: where a signal can land
    t0 = time.monotonic()
    end_env_processes(venv)
    venv.close()
    assert time.monotonic() - t0 < 30
    assert base.closed and not any(p.is_alive() for p in base.processes)


def test_an_interrupted_ray_step_ends_the_actors():
    """The same on Ray: a step in flight, ``end_env_processes`` kills the actors without their ``close``
    and shuts down the local Ray instance it started."""
    ray = pytest.importorskip("ray")
    from biovln_ms.cluster import end_env_processes
    from biovln_ms.learning.ray_vec_env import RayVecEnv

    venv = RayVecEnv([lambda: gym.make("CartPole-v1")] * 2, address="local")
    try:
        venv.reset()
        venv.step_async(np.zeros(2, dtype=np.int64))
        end_env_processes(venv)
        assert venv.closed and not ray.is_initialized()
        venv.close()  # nothing left to close
    finally:
        if ray.is_initialized():
            ray.shutdown()


def test_train_rl_interrupted_mid_step_ends_its_env_processes(monkeypatch, tmp_path):
    """``train_rl`` itself: a ^C that lands between two workers' replies propagates at once, and no env
    process is left (SB3's own close would wait for ever)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecMonitor

    import biovln_ms.learning.rl as rl

    made = []

    def two_cartpoles(cfg, n_envs=None):
        made.append(SubprocVecEnv([lambda: gym.make("CartPole-v1")] * 2, start_method="spawn"))
        return VecMonitor(made[-1])

    def interrupted_learn(self, *args, **kwargs):
        self.env.reset()
        self.env.step_async(np.zeros(2, dtype=np.int64))
        made[-1].remotes[0].recv()  # one reply read, the other not
        raise KeyboardInterrupt

    monkeypatch.setattr(rl, "make_vec_env", two_cartpoles)
    monkeypatch.setattr(PPO, "learn", interrupted_learn)
    with pytest.raises(KeyboardInterrupt):
        train_rl(RLConfig(timesteps=64, n_envs=2, eval_split=None), tmp_path / "run", progress=False)
    assert made[-1].closed and not any(p.is_alive() for p in made[-1].processes)


def test_closing_vec_env_ends_the_workers_only_when_the_block_raises(monkeypatch):
    from biovln_ms import cluster

    calls, ended = [], []

    class Fake:
        def close(self):
            calls.append("close")

    monkeypatch.setattr(cluster, "end_env_processes", ended.append)
    venv = Fake()
    with cluster.closing_vec_env(venv) as v:
        assert v is venv
    assert (calls, ended) == (["close"], [])
    with pytest.raises(KeyboardInterrupt):
        with cluster.closing_vec_env(venv):
            raise KeyboardInterrupt
    assert (calls, ended) == (["close", "close"], [venv])
