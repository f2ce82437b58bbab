"""Recording and vectorisation of the nav env (one env per process on the CPU)."""

import functools
import subprocess
import sys

import gymnasium as gym
import imageio.v2 as imageio
import numpy as np
import pytest

import biovln_ms  # noqa: F401
from biovln_ms.wrappers import make_gym_env

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")


@pytest.mark.slow
def test_record_cli_writes_mp4_with_ego_view_and_map(tmp_path):
    out = tmp_path / "ep.mp4"
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "biovln_ms.cli",
            "record",
            "--split",
            "ms_val",
            "--episode",
            "0",
            "--policy",
            "oracle",
            "-o",
            str(out),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    assert "success=True" in r.stdout  # the oracle reaches this episode's goal
    reader = imageio.get_reader(out)
    frame = reader.get_data(0)
    assert frame.shape == (480, 1280, 3)  # 640 x 480 egocentric view + map of the same height
    assert frame[:, :640].std() > 10 and frame[:, 640:].std() > 10


def test_maniskill_record_episode_wrapper(tmp_path):
    from mani_skill.utils.wrappers.record import RecordEpisode

    env = gym.make("BioVLN-OpFace-v0", obs_mode="state", render_mode="rgb_array", **CPU)
    env = RecordEpisode(
        env,
        output_dir=str(tmp_path),
        save_trajectory=True,
        save_video=True,
        video_fps=5,
        max_steps_per_video=20,
    )
    env.reset(seed=0)
    for a in (1, 2, 1, 3, 0):
        env.step(a)
    env.close()
    assert list(tmp_path.glob("*.h5")) and list(tmp_path.glob("*.json")) and list(tmp_path.glob("*.mp4"))


def test_gymnasium_async_vector_env():
    factory = functools.partial(make_gym_env, "BioVLN-OpFace-v0", obs_mode="state")
    venv = gym.vector.AsyncVectorEnv(
        [factory, factory], context="spawn"
    )  # fork deadlocks after SAPIEN/torch start
    try:
        obs, info = venv.reset(seed=[0, 1])
        assert obs.shape[0] == 2 and not np.array_equal(obs[0], obs[1])
        obs, rew, term, trunc, info = venv.step(np.array([1, 2]))
        assert rew.shape == (2,) and "distance_to_goal" in info
    finally:
        venv.close()


def test_sb3_subproc_vec_env():
    from stable_baselines3.common.vec_env import SubprocVecEnv

    factory = functools.partial(make_gym_env, "BioVLN-OpFace-RL-v0", split="ms_val")
    venv = SubprocVecEnv([factory, factory])
    try:
        obs = venv.reset()
        assert obs.shape[0] == 2 and obs.dtype == np.float32
        obs, rew, done, infos = venv.step(np.array([1, 0]))
        assert done[1]  # STOP ends the episode; SB3 resets it
        assert "success" in infos[1]
    finally:
        venv.close()


@pytest.mark.skipif(__import__("torch").cuda.is_available(), reason="checks the message shown without a GPU")
def test_gpu_parallel_without_gpu_is_a_clear_error():
    from biovln_ms.errors import BioVLNError

    with pytest.raises(BioVLNError, match="num_envs > 1 needs sim_backend='physx_cuda' and a CUDA GPU"):
        gym.make("BioVLN-OpFace-v0", num_envs=4, sim_backend="physx_cpu")
    with pytest.raises(BioVLNError, match="sim_backend='physx_cuda' needs a CUDA GPU and none is visible"):
        gym.make("BioVLN-OpFace-v0", num_envs=4, sim_backend="physx_cuda")
