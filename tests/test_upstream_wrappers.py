"""ManiSkill 3.0.1 wrappers that fail on every task, each reproduced beside the alternative the envs guide
names for it (its page "ManiSkill wrappers and tools"). A reproduction that stops failing means ManiSkill
fixed it: update that page."""

from __future__ import annotations

import gymnasium as gym
import pytest

import biovln_ms  # noqa: F401
from biovln_ms.sim.maniskill_compat import maniskill_task_id
from biovln_ms.wrappers import GymnasiumEnv, make_gym_env

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")


def test_flatten_observation_wrapper_fails_and_gymnasiums_flattens():
    from mani_skill.utils.wrappers import FlattenObservationWrapper

    env = gym.make("BioVLN-OpFace-v0", obs_mode="state_dict", **CPU)
    try:
        with pytest.raises(AttributeError, match="nelement"):  # it flattens the NumPy initial obs as torch
            FlattenObservationWrapper(env)
    finally:
        env.close()
    flat = gym.wrappers.FlattenObservation(make_gym_env("BioVLN-OpFace-v0", obs_mode="state_dict"))
    try:
        obs, _ = flat.reset(seed=0)
        assert obs.ndim == 1 and flat.observation_space.contains(obs)
        obs, *_ = flat.step(1)
        assert obs.ndim == 1 and flat.observation_space.contains(obs)
    finally:
        flat.close()


@pytest.mark.render
@pytest.mark.slow
def test_flatten_rgbd_wrapper_works():
    """ManiSkill's image flattener, the alternative for RGB-D: state, RGB and depth, each one array."""
    from mani_skill.utils.wrappers import FlattenRGBDObservationWrapper

    env = gym.make("BioVLN-OpFace-v0", obs_mode="rgbd", camera_width=64, camera_height=48, **CPU)
    try:
        flat = FlattenRGBDObservationWrapper(env)
        flat.reset(seed=0)
        obs, *_ = flat.step(1)
        assert tuple(obs["rgb"].shape) == (1, 48, 64, 3) and tuple(obs["depth"].shape) == (1, 48, 64, 1)
        assert obs["state"].ndim == 2 and obs["rgb"].float().std() > 0
    finally:
        env.close()


def test_cpu_gym_wrapper_fails_check_env_and_gymnasium_env_passes(held_out_dataset):
    from gymnasium.utils.env_checker import check_env
    from mani_skill.utils.wrappers import CPUGymWrapper

    env = gym.make("BioVLN-OpFace-RL-v0", dataset=held_out_dataset(ms_val=2), split="ms_val", **CPU)
    try:
        with pytest.raises(AssertionError, match="random number generator"):  # reset(seed) never seeds
            check_env(CPUGymWrapper(env), skip_render_check=True)
        check_env(GymnasiumEnv(env), skip_render_check=True)
    finally:
        env.close()


def test_default_make_vec_fails_on_maniskills_registration():
    """ManiSkill registers a vector entry point beside an additional wrapper, which gymnasium refuses;
    a BioVLN id's ``gym.make_vec`` works (``tests/test_no_hang.py``)."""
    with pytest.raises(gym.error.Error, match="additional_wrappers"):
        gym.make_vec(maniskill_task_id("PickCube"), num_envs=2)  # registers ManiSkill's own tasks
    assert gym.spec("BioVLN-OpFace-v0").vector_entry_point is None  # so gymnasium's default is sync
