"""The ManiSkill adapter (``biovln_ms.sim.maniskill_compat``) on whichever ManiSkill is installed: the pinned
3.0.1 here, the nightly under scripts/check_maniskill_nightly.sh (this file is in its smoke set)."""

from __future__ import annotations

import inspect
from importlib import metadata
from pathlib import Path

import mani_skill
import pytest
import sapien
from mani_skill.envs.sapien_env import BaseEnv
from mani_skill.sensors.camera import CameraConfig
from mani_skill.utils.registration import REGISTERED_ENVS

import biovln_ms  # noqa: F401  (registers the envs)
from biovln_ms.errors import BioVLNError
from biovln_ms.sim.maniskill_compat import (
    DISTRIBUTIONS,
    STEREO_DEPTH_CAMERA,
    maniskill_distribution,
    maniskill_task_id,
    parse_sensor_configs,
    update_sensor_configs_from_dict,
)
from biovln_ms.tasks.config_checks import (
    SENSOR_CONFIG_KEYS,
    SIM_FREQUENCIES,
    VIEW_CONFIG_KEYS,
    EnvConfigError,
    check_camera_configs,
)


def test_the_distribution_is_the_one_whose_files_import():
    dist, version = maniskill_distribution()
    assert dist in DISTRIBUTIONS
    assert version == metadata.version(dist)
    located = metadata.distribution(dist).locate_file("mani_skill/__init__.py")
    assert Path(located).resolve() == Path(mani_skill.__file__).resolve()


def _camera(uid: str) -> CameraConfig:
    return CameraConfig(uid, sapien.Pose(), 32, 24, 1.0, 0.05, 10.0)


def test_sensor_config_helpers_take_every_setting_the_env_lets_through():
    """What ``check_camera_configs`` accepts, ManiSkill's updater (renamed in the nightly) applies."""
    configs = parse_sensor_configs([_camera("follow"), _camera("head")])
    assert list(configs) == ["follow", "head"]
    assert parse_sensor_configs(_camera("head")).keys() == {"head"}
    values = dict(
        shader_pack="minimal", width=64, height=48, fov=0.9, near=0.1, far=20.0, pose=[0, 0, 1, 1, 0, 0, 0]
    )
    assert set(VIEW_CONFIG_KEYS) <= set(values) and set(SENSOR_CONFIG_KEYS) <= set(values)
    checked = check_camera_configs(
        "human_render_camera_configs", {"follow": values}, ("follow",), VIEW_CONFIG_KEYS
    )
    update_sensor_configs_from_dict(configs, checked)
    follow = configs["follow"]
    assert (follow.width, follow.height, follow.fov, follow.near, follow.far) == (64, 48, 0.9, 0.1, 20.0)
    assert follow.shader_pack == "minimal" and follow.pose.p.reshape(-1).tolist() == [0, 0, 1]
    assert configs["head"].width == 32  # a camera's own settings reach that camera only
    update_sensor_configs_from_dict(configs, {"shader_pack": "default"})  # settings for every camera
    assert {c.shader_pack for c in configs.values()} == {"default"}


def test_stereo_depth_is_never_asked_for():
    """The nightly refuses ``StereoDepthCamera`` sensors; the env's checks refuse the setting on any build."""
    assert isinstance(STEREO_DEPTH_CAMERA, bool)
    with pytest.raises(EnvConfigError, match="use_stereo_depth"):
        check_camera_configs("sensor_configs", {"use_stereo_depth": True}, ("head",), SENSOR_CONFIG_KEYS)


def test_maniskill_task_ids_resolve_to_the_registered_version():
    uid = maniskill_task_id("PickCube")
    assert uid in REGISTERED_ENVS and uid.startswith("PickCube-v")
    assert maniskill_task_id(uid) == uid
    with pytest.raises(BioVLNError, match="no task 'PickCub'") as err:
        maniskill_task_id("PickCub")
    assert err.value.field == "name" and "PickCube" in err.value.fix


def test_every_env_sets_the_task_physics_rates():
    """ManiSkill 4 announces a new default physics rate: no env of the package may inherit the default."""
    ours = {uid: s.cls for uid, s in REGISTERED_ENVS.items() if s.cls.__module__.startswith("biovln_ms")}
    assert len(ours) >= 3
    for uid, cls in ours.items():
        prop = inspect.getattr_static(cls, "_default_sim_config")
        assert prop is not inspect.getattr_static(BaseEnv, "_default_sim_config"), uid
        cfg = prop.fget(None)
        assert (cfg.sim_freq, cfg.control_freq) == (
            SIM_FREQUENCIES["sim_freq"],
            SIM_FREQUENCIES["control_freq"],
        )
