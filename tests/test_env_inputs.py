"""Every input of the navigation envs is bounded: ``gym.make`` arguments, ``reset`` seeds and options,
``step`` actions and ``set_state_dict`` states outside their documented limits (the envs guide's argument
table) are one line naming the argument and the fix, raised before anything is built; the rest runs."""

from __future__ import annotations

import inspect
import math

import gymnasium as gym
import numpy as np
import pytest
import torch

import biovln_ms  # noqa: F401
from biovln_ms.errors import BioVLNError

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
NAN, INF = float("nan"), float("inf")


def _one_line(err: BioVLNError, field: str) -> None:
    text = str(err)
    assert "\n" not in text and f"field '{field}" in text and "(fix: " in text, text


@pytest.fixture(scope="module")
def env():
    e = gym.make("BioVLN-OpFace-v0", obs_mode="none", reward_mode="dense", **CPU)
    yield e
    e.close()


@pytest.fixture(scope="module")
def box_env():
    e = gym.make("BioVLN-OpFace-v0", obs_mode="none", control_mode="continuous", **CPU)
    yield e
    e.close()


# --- gym.make -----------------------------------------------------------------------------------------------
BAD_ARGUMENTS = [
    ({"bogus": 1}, "bogus"),
    ({"forward_stp": 0.5}, "forward_stp"),
    ({"obs_mode": "bogus"}, "obs_mode"),
    ({"obs_mode": 3}, "obs_mode"),
    ({"obs_mode": "rgb+bogus"}, "obs_mode"),
    ({"reward_mode": "bogus"}, "reward_mode"),
    ({"render_mode": "bogus"}, "render_mode"),
    ({"shader_dir": "bogus"}, "shader_dir"),
    ({"enable_shadow": "yes"}, "enable_shadow"),
    ({"sensor_configs": 3}, "sensor_configs"),
    ({"sensor_configs": {"shader_pack": "bogus"}}, "sensor_configs"),
    ({"sensor_configs": {"width": 64}}, "sensor_configs"),  # the task's camera_width
    ({"sensor_configs": {"head": {"fov": 1.0}}}, "sensor_configs['head']"),
    ({"human_render_camera_configs": 3}, "human_render_camera_configs"),
    ({"human_render_camera_configs": {"width": "x"}}, "human_render_camera_configs['width']"),
    ({"human_render_camera_configs": {"follow": {"pose": [0, 0, NAN, 1, 0, 0, 0]}}}, "human_render"),
    ({"viewer_camera_configs": 3}, "viewer_camera_configs"),
    ({"sim_config": 3}, "sim_config"),
    ({"sim_config": {"sim_freq": 99}}, "sim_config"),
    ({"sim_config": {"sim_freq": 20}}, "sim_config"),  # one substep: the drive would not settle
    ({"sim_config": {"bogus": 1}}, "sim_config"),
    ({"sim_config": {"spacing": INF}}, "sim_config"),
    ({"reconfiguration_freq": "x"}, "reconfiguration_freq"),
    ({"reconfiguration_freq": -1}, "reconfiguration_freq"),
    ({"parallel_in_single_scene": True, "obs_mode": "rgb"}, "parallel_in_single_scene"),
    ({"enhanced_determinism": "x"}, "enhanced_determinism"),
    ({"num_envs": 2**40}, "num_envs"),
    ({"dataset": 3, "split": "ms_val"}, "dataset"),
    ({"episodes": 3}, "episodes"),
    ({"camera_far": "x"}, "camera_far"),
    ({"camera_far": 0.0}, "camera_far"),
    ({"camera_width": 64.5}, "camera_width"),
    ({"camera_width": 10**6}, "camera_width"),
    ({"camera_width": True}, "camera_width"),
    ({"camera_hfov_deg": 200}, "camera_hfov_deg"),
    ({"camera_hfov_deg": 180}, "camera_hfov_deg"),
    ({"forward_step": 100.0}, "forward_step"),
    ({"turn_deg": 400}, "turn_deg"),
    ({"strict_facing_deg": 200}, "strict_facing_deg"),
    ({"max_episode_steps": 2.5}, "max_episode_steps"),
    ({"success_bonus": NAN}, "success_bonus"),
    ({"success_bonus": 0}, "success_bonus"),
    ({"success_bonus": "x"}, "success_bonus"),
    ({"step_penalty": INF}, "step_penalty"),
    ({"safety_penalty": NAN}, "safety_penalty"),
    ({"safety_penalty": "x"}, "safety_penalty"),
    ({"position_scale": 0}, "position_scale"),
    ({"proportional_safety": "x"}, "proportional_safety"),
    ({"shuffle_episodes": "x"}, "shuffle_episodes"),
    ({"scene_visit_episodes": -1}, "scene_visit_episodes"),
    ({"scene_visit_episodes": 1.5}, "scene_visit_episodes"),
    ({"scene_visit_episodes": 2}, "scene_visit_episodes"),  # without shuffle_episodes
    ({"agent_obs": "x"}, "agent_obs"),
    ({"measures": ("bogus",)}, "measures"),
    ({"measures": "success"}, "measures"),
    ({"measures": ("subgoal_index",)}, "measures"),  # a protocol measure
    ({"measures": ("reach_success",)}, "measures"),  # needs Fetch's arm
    ({"reward_measure": "bogus"}, "reward_measure"),
    ({"reward_measure": "success"}, "reward_measure"),  # true or false, not a number
    ({"success_measure": "distance_to_goal"}, "success_measure"),
    ({"fail_measure": "bogus"}, "fail_measure"),
    ({"sensors": ("bogus",)}, "sensors"),
    ({"sensors": "gps"}, "sensors"),
    ({"sensors": ("instruction",)}, "sensors"),  # the protocol env's
    ({"default_split": 3}, "default_split"),
    ({"default_obs_mode": "bogus"}, "default_obs_mode"),
    ({"lighting": ["fast"]}, "lighting"),
    ({"goal_mode": []}, "goal_mode"),
]


@pytest.mark.parametrize("kwargs, field", BAD_ARGUMENTS, ids=[repr(k)[:60] for k, _ in BAD_ARGUMENTS])
def test_a_bad_make_argument_is_one_line(kwargs, field):
    with pytest.raises(BioVLNError) as e:
        gym.make("BioVLN-OpFace-v0", **{"obs_mode": "none", **CPU, **kwargs})
    _one_line(e.value, field)


def test_a_misspelt_argument_names_the_nearest():
    with pytest.raises(BioVLNError, match="unknown argument 'forward_stp'.*did you mean forward_step"):
        gym.make("BioVLN-OpFace-v0", forward_stp=0.5, **CPU)


@pytest.mark.parametrize("limit", [0, -1, 2.5, "5"])
def test_gym_makes_step_limit_is_checked_before_the_env_is_built(limit):
    with pytest.raises(BioVLNError) as e:
        gym.make("BioVLN-OpFace-v0", max_episode_steps=limit, obs_mode="none", **CPU)
    _one_line(e.value, "max_episode_steps")


def test_gym_makes_step_limit_is_the_envs():
    """gymnasium keeps ``max_episode_steps`` for its time limit; the env ends its episodes there too (its
    ``TaskSpec`` says so), not at the config's 500 while the wrapper truncates elsewhere."""
    e = gym.make("BioVLN-OpFace-v0", max_episode_steps=3, obs_mode="none", **CPU)
    try:
        u = e.unwrapped
        assert u.cfg.max_episode_steps == 3 and u.task_spec().max_episode_steps == 3
        e.reset(seed=0)
        truncated = [bool(e.step(2)[3]) for _ in range(3)]
        assert truncated == [False, False, True]
    finally:
        e.close()


def test_shader_dir_leaves_maniskills_defaults_alone():
    """ManiSkill's ``shader_dir`` merges into its default camera-config dicts, so one env's shader pack would
    become every later env's; the env hands ManiSkill fresh dicts."""
    from mani_skill.envs.sapien_env import BaseEnv

    defaults = inspect.signature(BaseEnv.__init__).parameters
    e = gym.make("BioVLN-OpFace-v0", shader_dir="minimal", obs_mode="none", **CPU)
    e.close()
    for name in ("sensor_configs", "human_render_camera_configs", "viewer_camera_configs"):
        assert defaults[name].default == {}, name


def test_accepted_arguments_build_and_step():
    """NumPy numbers, lists and ManiSkill's camera and physics settings within their limits are taken (as
    Python numbers and tuples) and run."""
    e = gym.make(
        "BioVLN-OpFace-v0",
        obs_mode="state",
        camera_width=np.int64(32),
        camera_height=24,
        camera_hfov_deg=np.float32(120.0),
        sensor_configs={"head": {"shader_pack": "minimal"}},
        human_render_camera_configs={"follow": {"width": 64, "height": 48, "fov": 1.0}},
        sim_config={"sim_freq": 200},
        reconfiguration_freq=0,
        measures=["success", "spl"],
        **CPU,
    )
    try:
        u = e.unwrapped
        assert type(u.cfg.camera_width) is int and u.cfg.measures == ("success", "spl")
        assert (u._sensors["head"].config.width, u._sensors["head"].config.height) == (32, 24)
        assert u._human_render_cameras["follow"].config.width == 64 and u.sim_freq == 200
        e.reset(seed=0)
        assert bool(torch.isfinite(e.step(1)[1]).all())
    finally:
        e.close()


def test_bad_protocol_arguments_are_one_line():
    for kwargs, field in (({"steps_per_goal": 10**9}, "steps_per_goal"), ({"wrong_stop": []}, "wrong_stop")):
        with pytest.raises(BioVLNError) as e:
            gym.make("BioVLN-Protocol-v0", obs_mode="none", **CPU, **kwargs)
        _one_line(e.value, field)


# --- reset --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "seed",
    [
        -1,
        2**32,
        2**70,
        1.5,
        "x",
        np.uint64(2**63),
        np.float64(2.0),
        True,
        [1, 2],
        [],
        float("nan"),
        {},
        [[1]],
    ],
    ids=repr,
)
def test_a_bad_seed_is_one_line(env, seed):
    with pytest.raises(BioVLNError) as e:
        env.reset(seed=seed)
    _one_line(e.value, "seed")


def test_seeds_of_numpy_and_torch_pick_the_same_episode(env):
    env.reset(seed=3)
    want = env.unwrapped.current_episode["episode_id"]
    for seed in (np.int64(3), np.array(3), np.array([3]), torch.tensor(3), [3], (3,)):
        env.reset(seed=seed)
        assert env.unwrapped.current_episode["episode_id"] == want, repr(seed)


@pytest.mark.parametrize(
    "options, field",
    [
        ({"bogus": 1}, "options"),
        ("x", "options"),
        ([1], "options"),
        ({"scene_id": "lab_s0_v0"}, "options['scene_id']"),
        ({"episode_id": "0", "episode_index": 0}, "options"),
        ({"episode_id": [0]}, "options['episode_id']"),
        ({"env_idx": [5]}, "options['env_idx']"),
        ({"env_idx": [-1]}, "options['env_idx']"),
        ({"env_idx": []}, "options['env_idx']"),
        ({"env_idx": "x"}, "options['env_idx']"),
        ({"env_idx": [0.5]}, "options['env_idx']"),
        ({"reconfigure": "x"}, "options['reconfigure']"),
        ({"reset_to_env_states": {"env_states": {}}}, "options['reset_to_env_states']"),
    ],
    ids=repr,
)
def test_a_bad_reset_option_is_one_line(env, options, field):
    u = env.unwrapped
    env.reset(options={"episode_index": 2})
    position = u.cursor.position
    with pytest.raises(BioVLNError) as e:
        env.reset(options=options)
    _one_line(e.value, field)
    assert u.cursor.position == position and u.current_episode is u.source.episodes[2]  # nothing moved


def test_an_unknown_reset_option_lists_the_known_ones(env):
    with pytest.raises(
        BioVLNError, match="unknown reset option 'episode'.*episode_index, episode_id, scene_id"
    ):
        env.reset(options={"episode": 1})


# --- step ---------------------------------------------------------------------------------------------------
BAD_DISCRETE = [
    "1",
    True,
    np.bool_(True),
    np.array([True]),
    torch.tensor(True),
    NAN,
    INF,
    -1,
    4,
    2**70,
    1.5,
    [1, 1],
    [],
    [[1]],
    np.array(["a"]),
    1 + 2j,
    b"1",
    object(),
    {"a": 1},
    {"control_mode": "continuous", "action": [0, 0, 0]},
    np.zeros(3),
    torch.tensor([0.5]),
]


def _action_id(action) -> str:
    """A test id that is the same in every process (pytest-xdist's workers compare them)."""
    return "object()" if type(action) is object else repr(action)


BAD_BOX = [
    1,
    [0, 0],
    np.array([NAN, 0, 0]),
    np.array([INF, 0, 0]),
    np.array([2.0, 0, 0]),
    np.zeros((2, 3)),
    np.zeros((3, 1)),
    np.array([True, False, True]),
    torch.tensor([0, 0, 0], dtype=torch.complex64),
    {"control_mode": "discrete", "action": 1},
    "x",
]


@pytest.mark.parametrize("action", BAD_DISCRETE, ids=_action_id)
def test_a_bad_discrete_action_is_one_line_and_changes_nothing(env, action):
    env.reset(options={"episode_index": 0})
    u = env.unwrapped
    before = u.agent.controller.planar_pose().copy()
    with pytest.raises(BioVLNError) as e:
        env.step(action)
    _one_line(e.value, "action")
    assert int(u.elapsed_steps[0]) == 0 and np.array_equal(u.agent.controller.planar_pose(), before)
    assert u.control_mode == "discrete" and u.agent.control_mode == "discrete"


@pytest.mark.parametrize("action", BAD_BOX, ids=repr)
def test_a_bad_continuous_action_is_one_line(box_env, action):
    box_env.reset(options={"episode_index": 0})
    with pytest.raises(BioVLNError) as e:
        box_env.step(action)
    _one_line(e.value, "action")
    assert box_env.unwrapped.agent.control_mode == "continuous"


def test_a_dict_action_of_the_envs_own_control_mode_is_its_action(env, box_env):
    env.reset(options={"episode_index": 0})
    yaw = env.unwrapped.agent.controller.planar_pose()[0, 2]
    env.step({"control_mode": "discrete", "action": 2})
    assert math.degrees(env.unwrapped.agent.controller.planar_pose()[0, 2] - yaw) == pytest.approx(
        30, abs=0.5
    )
    box_env.reset(options={"episode_index": 0})
    box_env.step({"control_mode": "continuous", "action": np.array([1.0, 0.0, -1.0], np.float32)})


def test_no_action_holds_the_pose_and_never_repeats_an_earlier_one(env):
    """``step(None)`` is ManiSkill's "no action": the robot stays, the step counts, nothing earlier carries
    over (a FORWARD just before, or the last move of the episode before a reset)."""
    u = env.unwrapped
    env.reset(options={"episode_index": 0})
    for _ in range(2):
        env.step(1)
    _, reward, terminated, _, info = env.step(None)
    pose = u.agent.controller.planar_pose().copy()
    assert int(info["steps"]) == 3 and not bool(terminated) and not bool(info["stopped"])
    penalty = u.cfg.step_penalty + u.cfg.safety_penalty * float(info["clearance"] < 0.5)
    assert float(reward) == pytest.approx(-penalty, abs=1e-3)
    length = float(info["path_length"])
    info = env.step(None)[4]
    assert float(info["path_length"]) == length and np.allclose(
        u.agent.controller.planar_pose(), pose, atol=1e-4
    )
    env.reset(options={"episode_index": 1})
    start = u.agent.controller.planar_pose().copy()
    info = env.step(None)[4]
    assert (
        np.allclose(u.agent.controller.planar_pose(), start, atol=1e-4) and float(info["path_length"]) == 0.0
    )


# --- set_state_dict -----------------------------------------------------------------------------------------
def test_a_bad_state_is_one_line_and_changes_nothing(env):
    env.reset(options={"episode_index": 0})
    env.step(1)
    u = env.unwrapped
    state = u.get_state_dict()
    pose = u.agent.controller.planar_pose().copy()
    bad_states = [
        3,
        {"bogus": 1},
        {"articulations": {"biovln_base": torch.zeros(1, 5)}},
        {"articulations": {"biovln_base": torch.full_like(state["articulations"]["biovln_base"], NAN)}},
        {**state, "task": {k: v for k, v in state["task"].items() if k != "start"}},
    ]
    for bad in bad_states:
        with pytest.raises(BioVLNError) as e:
            u.set_state_dict(bad)
        _one_line(e.value, "state")
        assert np.array_equal(u.agent.controller.planar_pose(), pose)
    u.set_state_dict(state)  # its own state is accepted
