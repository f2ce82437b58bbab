"""ManiSkill's trajectory tool, run as installed (``python -m mani_skill.trajectory.replay_trajectory`` in a
fresh interpreter that never imported this package), on ``RecordEpisode`` recordings of BioVLN envs.

The recording's JSON names the env ``biovln_ms:<id>`` (gymnasium's "module:id" form, which ``gym.make``
imports), and a recorded step's task state is arrays and Python numbers the tool can batch. The ManiSkill
page of the envs guide lists which of the tool's options work; the reproductions here of the ones that fail
upstream (a Discrete action with ``--save-traj``; the first saved state) break when ManiSkill fixes them:
then update that page.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import gymnasium as gym
import h5py
import numpy as np
import pytest
import torch

import biovln_ms  # noqa: F401
from biovln_ms.baselines.oracle import OraclePolicy
from biovln_ms.baselines.policy import FORWARD, STOP, TURN_LEFT, TURN_RIGHT
from biovln_ms.registration import ENV_IDS, register_variant
from biovln_ms.variants import VARIANTS

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
#: a discrete action as the continuous control mode's [forward, turn, stop] vector: the same move
VECTOR = {STOP: [-1, 0, 1], FORWARD: [1, 0, -1], TURN_LEFT: [-1, 1, -1], TURN_RIGHT: [-1, -1, -1]}
TOOL_TIMEOUT_S = 300


def record(out: Path, env_id: str, control_mode: str = "continuous", **kwargs) -> Path:
    """The oracle's episode of ``reset(seed=0)``, recorded by ManiSkill's ``RecordEpisode`` (state only)."""
    from mani_skill.utils.wrappers.record import RecordEpisode

    env = gym.make(env_id, obs_mode="none", control_mode=control_mode, **CPU, **kwargs)
    env = RecordEpisode(env, str(out), trajectory_name="demo", save_trajectory=True, save_video=False)
    try:
        env.reset(seed=0)
        oracle = OraclePolicy()
        oracle.reset(env.unwrapped.episode_info(0, privileged=True))
        done = False
        while not done:
            a = oracle.act(None, None)
            action = a if control_mode == "discrete" else np.array(VECTOR[a], np.float32)
            _, _, terminated, truncated, _ = env.step(action)
            done = bool(terminated) or bool(truncated)
    finally:
        env.close()
    return out / "demo.h5"


def replay(h5: Path, *options: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # nothing imports this package first
    return subprocess.run(
        [sys.executable, "-m", "mani_skill.trajectory.replay_trajectory", "--traj-path", str(h5), *options],
        cwd=h5.parent,
        env=env,
        capture_output=True,
        text=True,
        timeout=TOOL_TIMEOUT_S,
        check=False,
    )


def leaves(group: h5py.Group, prefix: str = "") -> dict[str, np.ndarray]:
    out = {}
    for k, v in group.items():
        if isinstance(v, h5py.Group):
            out.update(leaves(v, f"{prefix}{k}/"))
        else:
            out[prefix + k] = v[()]
    return out


def assert_same_episode(original: Path, replayed: Path, first_state_upstream: bool) -> dict[str, np.ndarray]:
    """The replayed trajectory has the recording's steps, actions, flags and env states; with
    ``first_state_upstream`` its first state is the recording's second (the tool stores the state after
    the first step in place of the one it set, ManiSkill 3.0.1). The replayed leaves."""
    with h5py.File(original) as f, h5py.File(replayed) as g:
        a, b = leaves(f["traj_0"]), leaves(g["traj_0"])
    steps = len(a["actions"])
    assert len(b["actions"]) == steps and np.array_equal(a["actions"], b["actions"])
    for k in ("success", "fail", "terminated", "truncated"):
        assert np.array_equal(a[k], b[k]), k
    states = [k for k in a if k.startswith("env_states/")]
    assert states and {k for k in b if k.startswith("env_states/")} == set(states)
    for k in states:  # within 1e-4: Fetch's held arm joints' velocities (PhysX keeps solver state of its own)
        assert len(b[k]) == steps + 1, k
        np.testing.assert_allclose(b[k][1:], a[k][1:], atol=1e-4, err_msg=k)
        np.testing.assert_allclose(b[k][0], a[k][1 if first_state_upstream else 0], atol=1e-4, err_msg=k)
    meta = [json.loads(p.with_suffix(".json").read_text()) for p in (original, replayed)]
    assert meta[0]["episodes"][0]["elapsed_steps"] == meta[1]["episodes"][0]["elapsed_steps"] == steps
    return b


# --- fast: the mechanism ----------------------------------------------------------------------------------
def test_shipped_ids_name_their_package_and_your_ids_stay_plain():
    for uid in ENV_IDS:
        assert gym.spec(uid).id == f"biovln_ms:{uid}", uid  # what RecordEpisode writes, and gym.make imports
    mine = replace(VARIANTS["BioVLN-OpFace-v0"], turn_deg=15)
    register_variant("MyLab-Replayed-v0", mine)
    assert gym.spec("MyLab-Replayed-v0").id == "MyLab-Replayed-v0"  # importing biovln_ms does not make it


def test_a_recorded_step_state_is_one_the_tool_can_batch_and_set():
    """A recorded step, as h5py hands it back (NumPy scalars for one-number leaves), goes through
    ManiSkill's ``common.batch`` as arrays, and ``set_state_dict`` takes it unbatched."""
    from mani_skill.utils import common

    env = gym.make("BioVLN-OpFace-v0", obs_mode="none", **CPU)
    try:
        env.reset(seed=0)
        u = env.unwrapped
        for a in (1, 2, 1):
            env.step(a)
        step = _tree(u.get_state_dict(), lambda v: v.cpu().numpy()[0])
        _tree(common.batch(step), lambda v: _assert_batched(v))
        later = [env.step(a)[4] for a in (1, 3, 1, 0)]
        u.set_state_dict(step)
        again = [env.step(a)[4] for a in (1, 3, 1, 0)]
        for x, y in zip(later, again):
            for k in ("agent_pose", "path_length", "steps", "spl", "success", "collisions"):
                assert torch.equal(x[k], y[k]), k
    finally:
        env.close()


def _tree(tree, fn):
    return {k: _tree(v, fn) for k, v in tree.items()} if isinstance(tree, dict) else fn(tree)


def _assert_batched(v) -> None:
    assert isinstance(v, np.ndarray) and v.ndim >= 2, type(v)  # the tool indexes it [-1, :]


# --- slow: the tool itself --------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("BioVLN-OpFace-v0", {}),
        ("BioVLN-OpFace-Strict-v0", {}),
        ("BioVLN-OpFace-v0", {"robot_uids": "fetch"}),
    ],
    ids=["opface", "strict", "fetch"],
)
def test_state_replay_converts_to_the_state_obs_mode(tmp_path, env_id, kwargs):
    h5 = record(tmp_path, env_id, **kwargs)
    assert json.loads(h5.with_suffix(".json").read_text())["env_info"]["env_id"] == f"biovln_ms:{env_id}"
    r = replay(h5, "--use-env-states", "--save-traj", "--allow-failure", "-o", "state")
    assert r.returncode == 0 and "1/1=100.00% demos saved" in r.stdout, r.stdout[-2000:] + r.stderr[-4000:]
    b = assert_same_episode(h5, tmp_path / "demo.state.continuous.physx_cpu.h5", first_state_upstream=True)
    assert b["obs"].shape[0] == len(b["actions"]) + 1 and np.isfinite(b["obs"]).all()


@pytest.mark.slow
@pytest.mark.render
def test_action_replay_converts_to_rgbd(tmp_path):
    h5 = record(tmp_path, "BioVLN-OpFace-v0", camera_width=32, camera_height=24)
    r = replay(h5, "--save-traj", "-o", "rgbd")
    assert r.returncode == 0 and "1/1=100.00% demos saved" in r.stdout, r.stdout[-2000:] + r.stderr[-4000:]
    b = assert_same_episode(h5, tmp_path / "demo.rgbd.continuous.physx_cpu.h5", first_state_upstream=False)
    assert bool(b["success"][-1])  # the oracle's STOP, replayed from its actions alone
    rgb, depth = b["obs/sensor_data/head/rgb"], b["obs/sensor_data/head/depth"]
    assert rgb.shape == (len(b["actions"]) + 1, 24, 32, 3) and rgb.std() > 0 and depth.max() > 0


@pytest.mark.slow
def test_discrete_recordings_replay_states_but_cannot_be_saved(tmp_path):
    """ManiSkill's RecordEpisode batches a Python number but not the NumPy scalar the tool reads from a
    Discrete recording's (T,) actions, so ``--save-traj`` fails there; a replay without it works."""
    h5 = record(tmp_path, "BioVLN-OpFace-v0", control_mode="discrete")
    r = replay(h5, "--use-env-states")
    assert r.returncode == 0 and "1/1=100.00%" in r.stdout, r.stdout[-2000:] + r.stderr[-4000:]
    r = replay(h5, "--use-env-states", "--save-traj", "-o", "state")
    assert r.returncode != 0 and "too many indices for array" in r.stderr, r.stderr[-4000:]
