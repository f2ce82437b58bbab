"""Every non-privileged method runs from ``obs`` and ``info`` alone (README, "What each method may know").

Each policy runs an episode in an env whose private attributes raise when code of a policy module reads
them; policies never hold a reference to the env; non-privileged methods get no privileged view; the
oracles' view is read-only."""

import json
import sys
from dataclasses import FrozenInstanceError

import gymnasium as gym
import numpy as np
import pytest
import torch

import biovln_ms  # noqa: F401
from biovln_ms.eval.methods import METHODS
from biovln_ms.eval.rollout import rollout

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
STEPS = 12


def _is_policy_module(name: str) -> bool:
    return name.startswith(("biovln_ms.baselines", "biovln_ms.perception"))


@pytest.fixture
def guarded(monkeypatch):
    """Make private env attributes raise when read from policy code (the env's own code is unaffected)."""
    from mani_skill.envs.sapien_env import BaseEnv

    real = BaseEnv.__getattribute__

    def getattribute(self, name):
        if (
            name.startswith("_")
            and not name.startswith("__")
            and _is_policy_module(sys._getframe(1).f_globals.get("__name__", ""))
        ):
            raise AttributeError(f"policy code read the env's private attribute {name!r}")
        return real(self, name)

    monkeypatch.setattr(BaseEnv, "__getattribute__", getattribute)
    yield


def _holds_env(obj, seen=None, depth=0) -> bool:
    """Whether ``obj`` reaches a ManiSkill env through its attributes (containers included)."""
    from mani_skill.envs.sapien_env import BaseEnv

    seen = seen if seen is not None else set()
    if id(obj) in seen or depth > 6:
        return False
    seen.add(id(obj))
    if isinstance(obj, (BaseEnv, gym.Env)):
        return True
    if isinstance(obj, dict):
        return any(_holds_env(v, seen, depth + 1) for v in obj.values())
    if isinstance(obj, (list, tuple, set)):
        return any(_holds_env(v, seen, depth + 1) for v in obj)
    if isinstance(obj, (np.ndarray, torch.Tensor, torch.nn.Module, str, bytes, int, float)):
        return False
    d = getattr(obj, "__dict__", None)
    return d is not None and _holds_env(d, seen, depth + 1)


class _Answer:
    """An LLM client stand-in (the real client is tested against a loopback server in test_llm_frontier)."""

    def ask(self, system, user, validate):
        json.loads(user)
        return {"choice": 0} if validate({"choice": 0}) else None


def _policies(tmp_path, dataset):
    """Non-privileged policies with what they need: an untrained BC checkpoint and an untrained PPO."""
    from stable_baselines3 import PPO

    from biovln_ms.baselines.bc_policy import BCPolicy
    from biovln_ms.baselines.frontier import FrontierPolicy
    from biovln_ms.baselines.llm_frontier import LLMFrontierPolicy
    from biovln_ms.baselines.protocol.frontier import ProtocolFrontierPolicy
    from biovln_ms.baselines.protocol.language import ProtocolLanguagePolicy
    from biovln_ms.baselines.protocol.vlfm import ProtocolVLFMPolicy
    from biovln_ms.baselines.random_policy import RandomPolicy
    from biovln_ms.baselines.sb3_policy import SB3Policy
    from biovln_ms.baselines.vlfm import VLFMPolicy
    from biovln_ms.learning.bc import ARCH, BCConfig, BCNet
    from biovln_ms.wrappers import make_gym_env

    torch.manual_seed(0)
    bc = tmp_path / "bc.pt"
    torch.save(
        {
            "arch": ARCH,
            "config": json.dumps(BCConfig(image_size=32).__dict__),
            "meta": json.dumps({"frame_size": [96, 72]}),
            "state_dict": BCNet().state_dict(),
        },
        bc,
    )
    env = make_gym_env("BioVLN-OpFace-RL-v0", split="ms_val", dataset=str(dataset))
    PPO("MlpPolicy", env, n_steps=16, batch_size=16, device="cpu").save(tmp_path / "ppo.zip")
    env.close()
    return {
        "random": RandomPolicy(),
        "frontier": FrontierPolicy(),
        "llm_frontier": LLMFrontierPolicy(client=_Answer()),
        "vlfm": VLFMPolicy(),
        "vlfm_gt": VLFMPolicy(detector="gt"),
        "bc": BCPolicy(str(bc)),
        "ppo": SB3Policy(str(tmp_path / "ppo.zip")),
        "protocol_frontier": ProtocolFrontierPolicy(),
        "protocol_vlfm": ProtocolVLFMPolicy(),
        "protocol_vlfm_gt": ProtocolVLFMPolicy(detector="gt"),
        "protocol_language": ProtocolLanguagePolicy(),
    }


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """Two MS VAL episodes of the held-out scene of seed 154, and a protocol episode there."""
    from biovln_ms.splits import FOUR_CATEGORIES
    from biovln_ms.episodes.samplers import ProtocolEpisodes
    from biovln_ms.episodes.writer import SplitPlan, write_dataset
    from biovln_ms.protocols import load_protocols
    from biovln_ms.scene.generator import generate_scene

    root = tmp_path_factory.mktemp("data") / "ds"
    scene = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
    protocols = SplitPlan(
        "protocol_val", [(scene, 1, False)], sampler=ProtocolEpisodes(load_protocols(env=False))
    )
    write_dataset(root, [SplitPlan("ms_val", [(scene, 2, False)]), protocols], progress=False)
    return root


@pytest.mark.slow
def test_non_privileged_methods_run_from_observations_alone(tmp_path, dataset, guarded):
    policies = _policies(tmp_path, dataset)
    assert set(policies) | {"a2c", "sac"} == {m for m, s in METHODS.items() if not s.privileged}
    for name, policy in policies.items():
        spec = METHODS[name]
        assert policy.obs_mode == spec.obs_mode, f"{name}: the registry and the policy disagree on obs_mode"
        without = getattr(policy, "obs_mode_without_gps", None)
        assert without == spec.obs_mode_without_gps, f"{name}: they disagree on obs_mode without GPS"
        env = gym.make(
            spec.env_id or "BioVLN-OpFace-v0",
            split="protocol_val" if spec.env_id == "BioVLN-Protocol-v0" else "ms_val",
            dataset=str(dataset),
            obs_mode=spec.obs_mode,
            camera_width=96,
            camera_height=72,
            **spec.env_kwargs,
            **CPU,
        )
        try:
            steps = 0
            for st in rollout(env, policy, 0, privileged=spec.privileged):
                steps += 1
                if steps > STEPS:
                    break
            assert steps > 1, name
            assert not _holds_env(policy), f"{name} keeps a reference to the env"
        finally:
            env.close()


def test_ppo_without_gps_acts_on_its_own_pose_estimate(tmp_path, dataset, guarded):
    """Under ``realistic`` the RL variant gives no RL state vector (it is the pose): PPO builds it from its
    estimate, reading depth, the start-frame ``pointgoal`` and ``objectgoal`` only."""
    policy, spec = _policies(tmp_path, dataset)["ppo"], METHODS["ppo"]
    env = gym.make(
        spec.env_id,
        split="ms_val",
        dataset=str(dataset),
        obs_mode=spec.obs_mode_under(False),
        camera_width=96,
        camera_height=72,
        noise="realistic",
        **spec.env_kwargs,
        **CPU,
    )
    try:
        steps, keys = 0, set()
        for st in rollout(env, policy, 0):
            keys |= set(st.obs["extra"])
            steps += 1
            if steps > STEPS:
                break
        assert keys == {"pointgoal", "objectgoal"} and steps > 1
        stats = policy.episode_stats()
        assert len(stats["pose_estimates"]) == steps - 1 and not _holds_env(policy)
    finally:
        env.close()


def test_only_oracles_get_the_read_only_privileged_view(dataset):
    env = gym.make("BioVLN-OpFace-v0", split="ms_val", dataset=str(dataset), obs_mode="none", **CPU)
    try:
        env.reset(options={"episode_index": 0})
        u = env.unwrapped
        assert u.episode_info(0).privileged is None
        view = u.episode_info(0, privileged=True).privileged
        goal = view.goal
        goal += 100.0  # a copy: the env's goal is unchanged
        assert np.allclose(view.goal, u.episode_info(0, privileged=True).privileged.goal)
        with pytest.raises(AttributeError):
            view.goal = np.zeros(2)
        with pytest.raises(FrozenInstanceError):
            view.target.yaw = 1.0
        privileged = {m for m, s in METHODS.items() if s.privileged}
        assert privileged == {"oracle", "zone3_oracle", "protocol_oracle"}
    finally:
        env.close()


def test_the_guard_catches_a_policy_reading_env_internals(dataset, guarded):
    """A policy module that reads ``env._measures`` is stopped (so the guard above is real)."""
    ns = {"__name__": "biovln_ms.baselines.cheat"}
    exec("def peek(env):\n    return env._measures\n", ns)
    env = gym.make("BioVLN-OpFace-v0", split="ms_val", dataset=str(dataset), obs_mode="none", **CPU)
    try:
        env.reset(options={"episode_index": 0})
        with pytest.raises(AttributeError, match="private attribute '_measures'"):
            ns["peek"](env.unwrapped)
        assert env.unwrapped._measures is not None  # the test itself may look
    finally:
        env.close()
