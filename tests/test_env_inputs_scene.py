"""The scene-only env's arguments, seeds and options, and ``GymnasiumEnv``'s seeds, get the navigation envs'
one-line errors; a process's first colour-camera env on a CPU renderer says so in one line, once, on a
terminal only."""

from __future__ import annotations

import logging
import sys

import gymnasium as gym
import pytest

import biovln_ms  # noqa: F401
from biovln_ms.errors import BioVLNError
from biovln_ms.render import progress
from biovln_ms.scene.generator import generate_scene

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
SCENE = "BioVLN-LabScene-v0"


def _one_line(err: BioVLNError, field: str) -> None:
    text = str(err)
    assert "\n" not in text and f"field '{field}" in text and "(fix: " in text, text


# --- BioVLN-LabScene-v0 -------------------------------------------------------------------------------------
BAD_SCENE_ARGUMENTS = [
    ({"specs": 3}, "specs"),
    ({"specs": []}, "specs"),
    ({"specs": [3]}, "specs"),
    ({"specs": "scene.json"}, "specs"),  # a string is not a list of files
    ({"template": 3}, "template"),
    ({"seed": -1}, "seed"),
    ({"seed": 2**40}, "seed"),
    ({"seed": 1.5}, "seed"),
    ({"seed": True}, "seed"),
    ({"ceiling": "yes"}, "ceiling"),
    ({"render_size": 5}, "render_size"),
    ({"render_size": (0, 10)}, "render_size"),
    ({"render_size": (10, 10_000)}, "render_size"),
    ({"lighting": "disco"}, "lighting"),
    ({"robot_uids": "panda"}, "robot_uids"),
    ({"reward_mode": "dense"}, "reward_mode"),
    ({"obs_mode": "pointcloud"}, "obs_mode"),
    ({"obs_mode": "bogus"}, "obs_mode"),
    ({"bogus": 1}, "bogus"),
    ({"sim_backend": "bogus"}, "sim_backend"),
    ({"render_backend": "vulkan9"}, "render_backend"),
    ({"num_envs": 0}, "num_envs"),
    ({"render_mode": "bogus"}, "render_mode"),
    ({"shader_dir": "bogus"}, "shader_dir"),
    ({"enable_shadow": "yes"}, "enable_shadow"),
    ({"sensor_configs": {"width": 64}}, "sensor_configs"),
    ({"human_render_camera_configs": {"width": "x"}}, "human_render_camera_configs['width']"),
    ({"human_render_camera_configs": {"follow": {"fov": 1.0}}}, "human_render_camera_configs"),
    ({"sim_config": 3}, "sim_config"),
    ({"reconfiguration_freq": -1}, "reconfiguration_freq"),
]


@pytest.mark.parametrize("kwargs, field", BAD_SCENE_ARGUMENTS, ids=lambda v: str(v)[:40])
def test_a_bad_scene_env_argument_is_one_line_before_anything_is_built(kwargs, field, monkeypatch):
    from biovln_ms.tasks import lab_scene_env

    def built(*args, **kw):
        raise AssertionError("a scene was generated before the arguments were checked")

    monkeypatch.setattr(lab_scene_env, "generate_scene", built)
    with pytest.raises(BioVLNError) as e:
        gym.make(SCENE, **{**CPU, **kwargs})
    _one_line(e.value, field)


def test_a_misspelt_scene_env_argument_names_the_nearest():
    with pytest.raises(BioVLNError, match="did you mean render_size"):
        gym.make(SCENE, render_sise=(64, 48), **CPU)


@pytest.fixture(scope="module")
def scene_env():
    env = gym.make(SCENE, specs=[generate_scene("single_room", 150)], obs_mode="none", **CPU)
    yield env
    env.close()


@pytest.mark.parametrize("seed", [-1, 2**33, 1.5, "0", True, [0, 1]])
def test_a_bad_scene_env_seed_is_one_line(scene_env, seed):
    with pytest.raises(BioVLNError) as e:
        scene_env.reset(seed=seed)
    _one_line(e.value, "seed")


@pytest.mark.parametrize(
    "options, field",
    [
        (3, "options"),
        ({"episode_index": 0}, "options"),  # no episodes in a scene-only env
        ({"bogus": 1}, "options"),
        ({"reconfigure": "yes"}, "options['reconfigure']"),
        ({"env_idx": [3]}, "options['env_idx']"),
    ],
)
def test_a_bad_scene_env_option_is_one_line(scene_env, options, field):
    with pytest.raises(BioVLNError) as e:
        scene_env.reset(seed=0, options=options)
    _one_line(e.value, field)


def test_a_scene_env_resets_with_good_seeds_and_options(scene_env):
    scene_env.reset(seed=3)
    scene_env.reset(seed=[4], options={"reconfigure": True})
    scene_env.reset(options={"env_idx": [0]})


# --- GymnasiumEnv -------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def gym_env():
    from biovln_ms.wrappers import make_gym_env

    env = make_gym_env("BioVLN-OpFace-v0", obs_mode="state", single_thread=False)  # a generated scene
    yield env
    env.close()


@pytest.mark.parametrize("seed", [-1, 2**33, 1.5, "0", [0, 1]])
def test_a_bad_seed_of_the_gymnasium_wrapper_is_the_envs_one_line(gym_env, seed):
    """Before gymnasium's seeding raises its own error (``seeding.np_random``: "Seed must be a python
    integer")."""
    with pytest.raises(BioVLNError) as e:
        gym_env.reset(seed=seed)
    _one_line(e.value, "seed")


def test_the_gymnasium_wrapper_seeds_as_before(gym_env):
    import numpy as np

    first, _ = gym_env.reset(seed=7)
    draw = gym_env.np_random.integers(1 << 30)
    again, _ = gym_env.reset(seed=np.int64(7))
    assert np.array_equal(first, again) and gym_env.np_random.integers(1 << 30) == draw


# --- the first colour camera --------------------------------------------------------------------------------
def _as_terminal(monkeypatch) -> None:
    """A fresh process's view: nothing said yet, no logging configuration, stderr a terminal (pytest's
    capture of it, read with capsys)."""
    monkeypatch.setattr(progress, "_said", set())
    monkeypatch.setattr(progress, "logging_configured", lambda: False)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)


def test_the_first_colour_camera_says_so_once_on_a_terminal(monkeypatch, capsys):
    _as_terminal(monkeypatch)
    assert not progress.first_camera_render("depth", software=True)  # a depth-only pack: quick
    assert not progress.first_camera_render("rgbd", software=False)  # a GPU renderer: quick
    assert progress.first_camera_render("rgbd", software=True)
    assert not progress.first_camera_render("rgb", software=True)  # once per process
    assert not progress.first_camera_render("sensor_data", software=True)
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("[biovln-ms] first colour camera in this process") and "once per process" in line


def test_the_first_colour_camera_line_is_silenced_by_the_logger_level(monkeypatch, capsys):
    _as_terminal(monkeypatch)
    monkeypatch.setattr(logging.getLogger("biovln_ms"), "level", logging.WARNING)
    assert not progress.first_camera_render("rgb", software=True)
    assert capsys.readouterr().err == ""


def test_the_first_colour_camera_line_stays_off_pipes(monkeypatch, capsys):
    _as_terminal(monkeypatch)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False)
    progress.first_camera_render("rgb", software=True)
    assert capsys.readouterr().err == ""


def test_the_first_colour_camera_line_goes_to_the_users_logging(caplog, monkeypatch, capsys):
    """With a logging configuration (pytest's is one), the line is a record there and nothing on stderr."""
    monkeypatch.setattr(progress, "_said", set())
    caplog.set_level(logging.INFO)
    assert progress.first_camera_render("rgb", software=True)
    (record,) = [r for r in caplog.records if r.name == "biovln_ms.progress"]
    assert record.levelno == logging.INFO and "first colour camera" in record.getMessage()
    assert capsys.readouterr().err == ""


def test_a_nav_env_says_it_before_the_env_is_built(monkeypatch):
    from biovln_ms.tasks import nav_env

    class Said(Exception):
        pass

    def first_camera_render(obs_mode, software):
        raise Said(obs_mode, software)

    monkeypatch.setattr(nav_env, "first_camera_render", first_camera_render)
    with pytest.raises(Said) as e:
        gym.make("BioVLN-OpFace-v0", obs_mode="rgb", camera_width=32, camera_height=24, **CPU)
    import torch

    assert e.value.args == ("rgb", not torch.cuda.is_available())
