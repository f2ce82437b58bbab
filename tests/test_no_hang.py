"""First use never hangs: an evaluation whose workers cannot start stops with one line and exit status 2,
whatever the number of workers, and ``gym.make_vec(..., vectorization_mode="async")`` gives
``(num_envs, obs_dim)`` arrays without deadlocking. Each runs in a subprocess with a timeout, so a hang
fails the test instead of stalling the suite."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from biovln_ms.errors import BioVLNError


def _run(cmd: list[str], timeout: float) -> subprocess.CompletedProcess:
    """``cmd`` in a session of its own; past ``timeout`` the whole session (its workers too) is killed and
    the test fails as a hang."""
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"hung for {timeout:.0f} s: {' '.join(cmd)[:200]}\n{err[-2000:]}")
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def _eval(tmp_path: Path, *args: str, timeout: float) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "biovln_ms.cli", "eval", "--method", "ppo", "--out", str(tmp_path / "out")]
    return _run(cmd + list(args), timeout)


def _one_error_line(r: subprocess.CompletedProcess) -> str:
    assert r.returncode == 2, r.stderr[-2000:]
    assert "Traceback" not in r.stderr, r.stderr[-2000:]
    errors = [line for line in r.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, r.stderr[-2000:]
    return errors[0]


def test_a_missing_checkpoint_with_several_workers_is_one_line(tmp_path):
    """Refused in the driver, before a dataset is read or a worker started."""
    r = _eval(tmp_path, "--checkpoint", str(tmp_path / "nope.zip"), "--workers", "2", timeout=120)
    line = _one_error_line(r)
    assert "nope.zip" in line and "no such checkpoint" in line
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_workers_that_cannot_load_the_checkpoint_stop_the_run(tmp_path, held_out_dataset):
    """The file exists, so only the workers find it is no model: their error reaches the driver once."""
    bad = tmp_path / "model.zip"
    bad.write_text("not a model")
    args = ["--checkpoint", str(bad), "--dataset", held_out_dataset(ms_val=2), "--split", "ms_val"]
    r = _eval(tmp_path, *args, "--workers", "2", timeout=400)
    line = _one_error_line(r)
    assert "model.zip" in line and "not a Stable-Baselines3 PPO model" in line


def test_a_suite_checks_the_given_checkpoints_before_its_first_run(tmp_path, held_out_dataset):
    from biovln_ms.eval.suite import run_suite

    with pytest.raises(BioVLNError, match="no such checkpoint"):
        run_suite(
            tmp_path / "suite",
            methods=("random", "ppo"),
            splits=("ms_val",),
            noises=("ideal",),
            workers=1,
            dataset=held_out_dataset(ms_val=1),
            checkpoints={"ppo": str(tmp_path / "nope.zip")},
            progress=False,
            echo=lambda _: None,
            paper_tables=False,
        )
    assert not (tmp_path / "suite" / "results").exists()  # the random run before it never started


_MAKE_VEC = """
import json, sys
import gymnasium as gym
import numpy as np
import biovln_ms

mode = {} if sys.argv[1] == "default" else {"vectorization_mode": sys.argv[1]}
venv = gym.make_vec("BioVLN-OpFace-v0", num_envs=2, obs_mode="state", **mode)
try:
    obs, info = venv.reset(seed=[0, 1])
    shapes = [obs.shape]
    for action in ([1, 2], [2, 1], [1, 1]):
        obs, reward, terminated, truncated, info = venv.step(np.array(action))
        shapes.append(obs.shape)
    print(json.dumps({
        "single": venv.single_observation_space.shape,
        "shapes": shapes,
        "reward": reward.shape,
        "terminated": [terminated.shape, str(terminated.dtype)],
        "distance": np.asarray(info["distance_to_goal"]).shape,
        "differ": bool(not np.array_equal(obs[0], obs[1])),
        "kind": type(venv).__name__,
    }))
finally:
    venv.close()
"""


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["async", "default"])
def test_make_vec_gives_one_row_per_env(mode):
    """``async`` starts its workers after building a sub-env in this process (SAPIEN started): forked
    workers would deadlock. Every mode stacks NumPy sub-envs, not ManiSkill's ``(1, obs_dim)`` ones; the
    default mode is ``sync`` (ManiSkill's own default, its vector entry point, fails on every task)."""
    r = _run([sys.executable, "-c", _MAKE_VEC, mode], timeout=400)
    assert r.returncode == 0, r.stderr[-3000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    (dim,) = out["single"]
    assert out["shapes"] == [[2, dim]] * 4
    assert out["reward"] == [2] and out["terminated"] == [[2], "bool"] and out["distance"] == [2]
    assert out["differ"]  # two episodes, not one env twice
    assert out["kind"] == ("AsyncVectorEnv" if mode == "async" else "SyncVectorEnv")  # default: sync
