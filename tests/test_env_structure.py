"""The navigation env's layout: the env is handed an episode source (``gym.make`` resolves ``split=`` and the
like first), the protocol options belong to the protocol task's config type, and locomotion is the robot's
controller."""

from __future__ import annotations

import ast
from dataclasses import replace
from pathlib import Path

import gymnasium as gym
import pytest

import biovln_ms  # noqa: F401
from biovln_ms.errors import BioVLNError
from biovln_ms.task_config import NavTaskConfig, ProtocolTaskConfig
from biovln_ms.variants import VARIANTS

ROOT = Path(__file__).resolve().parents[1]
CPU = dict(sim_backend="physx_cpu", render_backend="cpu")


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
    return names


def test_the_env_module_builds_no_dataset():
    assert not any(m.startswith("biovln_ms.splits") for m in _imports(ROOT / "tasks" / "nav_env.py"))


def test_protocol_options_belong_to_the_protocol_config():
    assert not NavTaskConfig().protocol and ProtocolTaskConfig().protocol
    for uid, cfg in VARIANTS.items():
        assert isinstance(cfg, ProtocolTaskConfig) == cfg.protocol == uid.startswith("BioVLN-Protocol"), uid
    with pytest.raises(TypeError):
        replace(NavTaskConfig(), steps_per_goal=3)
    assert ProtocolTaskConfig(steps_per_goal=3).step_budget(4) == 12 and NavTaskConfig().step_budget(4) == 500


@pytest.mark.parametrize("name, value", [("wrong_stop", "miss"), ("steps_per_goal", 3)])
def test_a_protocol_option_for_a_single_goal_env_is_one_line(name, value):
    with pytest.raises(BioVLNError, match=f"field '{name}'") as e:
        gym.make("BioVLN-OpFace-v0", **{name: value}, **CPU)
    assert "\n" not in str(e.value)


def test_an_episode_source_and_a_split_together_are_refused():
    from biovln_ms.episodes.source import EpisodeSource

    with pytest.raises(BioVLNError, match="field 'split'.*episodes= was given with split="):
        gym.make("BioVLN-OpFace-v0", episodes=EpisodeSource(), split="ms_val", **CPU)


def test_an_env_made_with_an_episode_source_runs_it():
    from biovln_ms.episodes.source import GeneratedEpisodes

    source = GeneratedEpisodes("single_room", 3)
    e = gym.make("BioVLN-OpFace-v0", episodes=source, obs_mode="none", **CPU)
    try:
        e.reset(options={"episode_index": 1})
        u = e.unwrapped
        assert u.source is source and u.current_episode is source.episodes[1]
        info = e.step(0)[4]
        assert bool(info["stopped"]) and u.agent.controller.command.stop.all()
    finally:
        e.close()


#: ManiSkill's largest task file is 580 lines, its median 259; ours hold hooks and stay under this
MAX_TASK_FILE_LINES = 400
#: no module grows past this: a larger one holds more than one idea
MAX_MODULE_LINES = 800


def test_task_files_hold_hooks_and_stay_short():
    envs = [f for f in (ROOT / "tasks").glob("*_env.py")]
    assert envs, "no task files found"
    long = {f.name: n for f in envs if (n := len(f.read_text().splitlines())) > MAX_TASK_FILE_LINES}
    assert not long, f"task files over {MAX_TASK_FILE_LINES} lines: {long}"


def test_no_module_is_over_the_size_limit():
    files = [f for d in ("biovln_ms", "tasks", "agents") for f in (ROOT / d).rglob("*.py")]
    long = {
        str(f.relative_to(ROOT)): n
        for f in files
        if "__pycache__" not in f.parts and (n := len(f.read_text().splitlines())) >= MAX_MODULE_LINES
    }
    assert not long, f"modules of {MAX_MODULE_LINES} lines or more: {long}"
