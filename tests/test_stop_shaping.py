"""The training-only STOP settings (``biovln_ms.wrappers.StopShaping``): STOP masked in an episode's first
steps, a failed STOP penalised, and the env unchanged without them (evaluation's env)."""

import gymnasium as gym
import numpy as np
import pytest
import torch

from biovln_ms.errors import BioVLNError
from biovln_ms.task_config import FORWARD, STOP, TURN_LEFT
from biovln_ms.variants import RL_ENV
from biovln_ms.wrappers import GymnasiumEnv, StopShaping, make_gym_env


@pytest.fixture(scope="module")
def dataset(held_out_dataset):
    return held_out_dataset(train=4, ms_val=3)


def batched(dataset, control_mode="discrete", reward_mode=None):
    return gym.make(
        RL_ENV,
        reward_mode=reward_mode,
        num_envs=1,
        sim_backend="physx_cpu",
        render_backend="cpu",
        obs_mode="state",
        control_mode=control_mode,
        dataset=dataset,
        split="train",
    )


def wrapper_chain(env) -> list[type]:
    chain = []
    while isinstance(env, gym.Wrapper):
        chain.append(type(env))
        env = env.env
    return chain


@pytest.mark.parametrize("reward_mode, units", [("dense", 1.0), ("normalized_dense", 10.0)])
def test_stop_is_masked_for_the_first_steps_and_a_failed_stop_costs_the_penalty(dataset, reward_mode, units):
    """The penalty is in Eq. 5's units: divided by the success bonus (10) as the normalised reward is."""
    moves = [TURN_LEFT, FORWARD, TURN_LEFT]
    plain = batched(dataset, reward_mode=reward_mode)
    shaped = StopShaping(batched(dataset, reward_mode=reward_mode), mask_steps=3, penalty=2.5)
    try:
        rewards = {}
        for name, env in (("plain", plain), ("shaped", shaped)):
            env.reset(seed=0)
            out = []
            for k, a in enumerate(moves):
                if name == "shaped":
                    assert shaped.action_masks().tolist() == [[False, True, True, True]], k
                    if k == 0:  # a masked STOP is refused, and the episode goes on untouched
                        with pytest.raises(BioVLNError, match="STOP is masked for the first 3 steps"):
                            env.step(torch.tensor([STOP]))
                out.append(float(env.step(torch.tensor([a]))[1][0]))
            if name == "shaped":
                assert shaped.action_masks().tolist() == [[True, True, True, True]]
            _, r, term, _, info = env.step(torch.tensor([STOP]))
            assert bool(term[0]) and bool(info["fail"][0])  # a STOP near the start (1.8 m or more away)
            rewards[name] = out + [float(r[0])]
            # the ended episode holds still until reset (as under ignore_terminations): no reward, and
            # the penalty is not charged again
            assert float(env.step(torch.tensor([FORWARD]))[1][0]) == 0.0
        # the moves earn what they earn without the wrapper; the failed STOP costs 2.5 more (in Eq. 5)
        assert rewards["shaped"][:3] == rewards["plain"][:3]
        assert rewards["shaped"][3] == pytest.approx(rewards["plain"][3] - 2.5 / units)
        # a reset starts the count of masked steps again
        shaped.reset()
        assert shaped.action_masks()[0, STOP].item() is False
        assert not shaped._charged.any()
    finally:
        plain.close()
        shaped.close()


def test_a_masked_continuous_stop_still_moves_and_turns(dataset):
    env = StopShaping(batched(dataset, "continuous"), mask_steps=2)
    try:
        env.reset(seed=0)
        before = env.unwrapped.agent.controller.planar_pose().copy()
        _, _, term, _, info = env.step(np.array([1.0, 0.5, 1.0], np.float32))  # forward, turn, STOP
        assert not bool(term[0]) and not bool(info["stopped"][0])
        assert not np.allclose(env.unwrapped.agent.controller.planar_pose(), before)
        env.step(np.array([-1.0, 0.0, -1.0], np.float32))
        _, _, term, _, info = env.step(np.array([-1.0, 0.0, 1.0], np.float32))  # the third step may STOP
        assert bool(term[0]) and bool(info["stopped"][0])
    finally:
        env.close()


def test_the_env_is_unchanged_without_stop_settings(dataset):
    """Evaluation's env (and training's by default) has no StopShaping; the settings are checked."""
    env = make_gym_env(RL_ENV, dataset=dataset, split="train")
    shaped = make_gym_env(RL_ENV, stop_penalty=1.0, dataset=dataset, split="train")
    try:
        assert StopShaping not in wrapper_chain(env) and isinstance(env, GymnasiumEnv)
        assert StopShaping in wrapper_chain(shaped)
        env.reset(seed=0)
        _, _, term, _, info = env.step(STOP)  # STOP at once ends the episode, as registered
        assert term and info["fail"]
    finally:
        env.close()
        shaped.close()
    with pytest.raises(BioVLNError, match="must be >= 0"):
        StopShaping(batched(dataset), penalty=-1.0)


def test_sb3_training_applies_the_penalty_and_can_end_it_early(dataset):
    from stable_baselines3 import PPO

    from biovln_ms.learning.rl import EndStopPenalty, RLConfig, make_vec_env

    venv = make_vec_env(RLConfig(n_envs=1, dataset=dataset, stop_penalty=10.0, scene_visit_episodes=2))
    plain = make_vec_env(RLConfig(n_envs=1, dataset=dataset))
    try:
        assert venv.env_is_wrapped(StopShaping) == [True] and venv.get_attr("penalty") == [10.0]
        assert plain.env_is_wrapped(StopShaping) == [False]
        # the config's scene visits reach the env (its cursor), the default leaves them out
        assert [c.scene_visit_episodes for c in venv.get_attr("cfg")] == [2]
        assert [c.scene_visit_episodes for c in plain.get_attr("cfg")] == [0]
        model = PPO("MlpPolicy", venv, n_steps=32, batch_size=32, n_epochs=1, device="cpu")
        model.learn(64, callback=EndStopPenalty(40))  # penalised early only: off from the 40th step
        assert venv.get_attr("penalty") == [0.0]
    finally:
        venv.close()
        plain.close()
