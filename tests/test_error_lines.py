"""Bad input gets one clear line: CLI error lines keep their text, BC checkpoints without a
config, unknown backends and a closed env."""

import json
import subprocess
import sys

import gymnasium as gym
import pytest
import torch

import biovln_ms  # noqa: F401
from biovln_ms.errors import BioVLNError

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")


def test_cli_error_lines_keep_square_brackets(tmp_path):
    """Error lines keep ``[...]``, which rich markup would eat (e.g. the Eq. 1 message's expected goal)."""
    code = (
        "import sys; from biovln_ms import cli; from biovln_ms.errors import BioVLNError\n"
        "def boom():\n"
        "    raise BioVLNError('goal [1.0, 2.0], expected [3.0, 4.0]', field='goals[0]', fix='use [3, 4]')\n"
        "cli.app = boom\ncli.main()\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert r.returncode == 2
    line = (r.stdout + r.stderr).strip()
    assert "[1.0, 2.0]" in line and "[3.0, 4.0]" in line and "(fix: use [3, 4])" in line, line
    assert len(line.splitlines()) == 1


def test_bc_checkpoint_without_config_is_refused(tmp_path):
    from biovln_ms.learning.bc import ARCH, BCNet, CheckpointError, load_bc

    path = tmp_path / "bc.pt"
    torch.save({"arch": ARCH, "state_dict": BCNet().state_dict()}, path)
    with pytest.raises(CheckpointError, match="has no config, meta"):
        load_bc(path)
    torch.save({"arch": ARCH, "state_dict": BCNet().state_dict(), "config": "{not json", "meta": "{}"}, path)
    with pytest.raises(CheckpointError, match="unreadable training config"):
        load_bc(path)
    torch.save({"arch": ARCH, "state_dict": {}, "config": json.dumps({"bogus": 1}), "meta": "{}"}, path)
    with pytest.raises(CheckpointError, match="unreadable training config"):
        load_bc(path)


@pytest.mark.parametrize(
    "kw, field",
    [
        ({"sim_backend": "bogus"}, "sim_backend"),
        ({"render_backend": "vulkan9"}, "render_backend"),
        ({"num_envs": 0}, "num_envs"),
        ({"camera_width": 0}, "camera_width"),
        ({"forward_step": -0.25}, "forward_step"),
        ({"goal_mode": "bogus"}, "goal_mode"),
    ],
)
def test_bad_env_arguments_are_one_line(kw, field):
    with pytest.raises(BioVLNError, match=f"field '{field}'"):
        gym.make("BioVLN-OpFace-v0", obs_mode="none", **{**CPU, **kw})


def test_a_closed_env_says_so():
    env = gym.make("BioVLN-OpFace-v0", obs_mode="none", **CPU)
    env.reset(seed=0)
    env.close()
    with pytest.raises(BioVLNError, match="the env is closed"):
        env.step(1)
    with pytest.raises(BioVLNError, match="the env is closed"):
        env.reset(seed=0)
