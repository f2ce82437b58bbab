"""Noise presets (biovln_ms.noise): configuration errors, the LoCoBot actuation model's statistics, and the
env under noise: sensors without GPS+compass, deterministic noise that replays from a saved state, and
moves that do not slide along walls."""

import hashlib
import math

import gymnasium as gym
import numpy as np
import pytest
import shapely
import torch

import biovln_ms  # noqa: F401
from biovln_ms.errors import BioVLNError
from biovln_ms.eval.rollout import rollout
from biovln_ms.noise import (
    LOCOBOT_FORWARD,
    LOCOBOT_TURN,
    PRESETS,
    NoiseConfig,
    NoiseConfigError,
    TruncatedGaussian,
    actuation_errors,
    actuation_uniforms,
    resolve_noise,
)

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")


def test_presets_and_overrides():
    assert resolve_noise(None) == resolve_noise("ideal") == NoiseConfig()
    real = resolve_noise("realistic")
    assert (real.actuation, real.rgb, real.depth, real.gps_compass, real.sliding) == (
        0.5,
        0.1,
        True,
        False,
        False,
    )
    assert real.name == "realistic" and NoiseConfig(actuation=2.0).name == "custom"
    mixed = resolve_noise({"preset": "realistic", "actuation": 1, "gps_compass": True})
    assert mixed.actuation == 1 and mixed.gps_compass and not mixed.sliding
    assert resolve_noise(PRESETS["ideal"]) == PRESETS["ideal"]


@pytest.mark.parametrize(
    "bad, field",
    [
        ("noisy", "noise"),
        ({"preset": "loud"}, "noise"),
        ({"actuaton": 0.5}, "noise.actuaton"),
        ({"sliding": "no"}, "noise.sliding"),
        ({"rgb": -0.1}, "noise.rgb"),
        ({"actuation": float("nan")}, "noise.actuation"),
        ({"actuation": True}, "noise.actuation"),
        (3, "noise"),
    ],
)
def test_bad_noise_config_is_one_line(bad, field):
    with pytest.raises(NoiseConfigError) as e:
        resolve_noise(bad)
    msg = str(e.value)
    assert "\n" not in msg and f"field '{field}'" in msg and "fix:" in msg


def test_the_rl_state_vector_needs_gps_compass_as_a_state_observation():
    """The RL variant's state is the robot's pose: without GPS+compass a flat state observation is refused
    in one line (depth observations are fine: PPO then keeps its own
    estimate, biovln_ms.baselines.sb3_policy)."""
    with pytest.raises(BioVLNError, match="rl_state is the robot's pose") as e:
        gym.make("BioVLN-OpFace-RL-v0", noise="realistic", **CPU)
    assert "obs_mode='depth'" in str(e.value) and "\n" not in str(e.value)


def test_truncated_gaussian_statistics():
    g = TruncatedGaussian((0.5, -1.0), (0.04, 0.25))
    x = g.sample(np.random.default_rng(0), 200_000)
    sigma = np.sqrt(g.variance)
    assert np.all(np.abs(x - g.mean) <= 3 * sigma + 1e-12)
    np.testing.assert_allclose(x.mean(0), g.mean, atol=0.01)
    # truncation at 3 sigma keeps 97.3 % of the variance
    np.testing.assert_allclose(x.var(0), np.asarray(g.variance) * 0.9733, rtol=0.02)


def test_actuation_errors_follow_the_commanded_move():
    u = actuation_uniforms(1, 0, 60_000)  # one episode's draws, step after step: three sets of moves
    fwd = np.array([actuation_errors(x, 0.25, 0.0, 1.0) for x in u[:20_000]])
    np.testing.assert_allclose(fwd.mean(0), [0.017, 0.042, 0.031], atol=0.004)
    right = np.array([actuation_errors(x, 0.0, -0.5, 1.0) for x in u[20_000:40_000]])
    np.testing.assert_allclose(right.mean(0), [0.001, 0.005, -0.043], atol=0.004)
    half = np.array([actuation_errors(x, 0.0, 0.5, 0.5) for x in u[40_000:]])
    np.testing.assert_allclose(half.std(0), 0.5 * right.std(0), rtol=0.05)
    assert LOCOBOT_FORWARD.heading.variance == (0.026,) and LOCOBOT_TURN.position.mean == (0.001, 0.005)


def test_actuation_noise_is_the_noise_of_earlier_versions():
    """A pinned digest of 40 moves' errors (recorded at commit c24c505): a seed's actuation noise is fixed."""
    u = actuation_uniforms(123456, 0, 40)
    moves = [(0.25, 0.0), (0.0, 0.5236), (0.0, -0.5236)]
    errors = [e for step in range(40) for e in actuation_errors(u[step], *moves[step % 3], 0.5)]
    digest = hashlib.sha256(np.array(errors).tobytes()).hexdigest()
    assert digest == "c510f8f78923971f6f9be0755121f2486739dab4ca67f458ba3e8cd152ffc5bb"


def test_actuation_uniforms_are_stateless_and_chunks_agree():
    """A step's draws depend on (episode seed, step) only: drawn alone, in a chunk or from another start."""
    whole = actuation_uniforms(5, 0, 40)
    assert actuation_uniforms(5, 17, 1)[0] == whole[17]
    assert actuation_uniforms(5, 32, 8) == whole[32:]
    assert actuation_uniforms(6, 17, 1)[0] != whole[17]
    lo, hi = min(min(x) for x in whole), max(max(x) for x in whole)
    assert 0.0013 < lo and hi < 0.9987  # inside the 3-sigma truncation


def _run(env, actions, seed=7, episode=0):
    env.reset(seed=seed, options={"episode_index": episode})
    poses, obs_all, infos = [], [], []
    for a in actions:
        obs, _, term, trunc, info = env.step(a)
        poses.append(info["agent_pose"][0].numpy().copy())
        obs_all.append(obs)
        infos.append(info)
        if bool(term) or bool(trunc):
            break
    return np.array(poses), obs_all, infos


@pytest.fixture(scope="module")
def realistic_env():
    env = gym.make("BioVLN-OpFace-v0", split="ms_val", obs_mode="state_dict", noise="realistic", **CPU)
    yield env
    env.close()


def test_realistic_sensors_have_no_gps_compass(realistic_env):
    obs, _ = realistic_env.reset(seed=0, options={"episode_index": 1})
    extra = obs["extra"]
    assert set(extra) == {"pointgoal", "objectgoal"} and not obs.get("agent")
    first = extra["pointgoal"].clone()
    for a in (1, 2, 1):
        obs, *_ = realistic_env.step(a)
    assert torch.equal(obs["extra"]["pointgoal"], first)  # told once, in the start frame
    spec = realistic_env.unwrapped.task_spec()
    assert spec.noise == PRESETS["realistic"]


def test_actuation_noise_is_deterministic_and_recorded(realistic_env):
    actions = [1, 1, 2, 1, 3, 1, 1]
    a, _, infos = _run(realistic_env, actions)
    b, _, _ = _run(realistic_env, actions)
    c, _, _ = _run(realistic_env, actions, seed=8)
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - c).max() > 1e-3
    err = np.array([i["actuation_error"][0].numpy() for i in infos])
    assert err.shape == (len(actions), 3) and np.all(err != 0)
    ideal = gym.make("BioVLN-OpFace-v0", split="ms_val", obs_mode="state_dict", **CPU)
    exact, _, ideal_infos = _run(ideal, actions)
    ideal.close()
    assert "actuation_error" not in ideal_infos[0]
    assert np.abs(a - exact).max() > 0.01  # the noise moved the robot


class _Scripted:
    """A fixed action sequence (a policy that ignores its observations)."""

    def reset(self, episode_info) -> None:
        self.actions = iter([1, 1, 2, 1, 3, 1, 1, 1, 0])

    def act(self, obs, info) -> int:
        return next(self.actions)


def test_an_episodes_noise_does_not_depend_on_the_episodes_before_it(realistic_env):
    """The harness's rollout seeds each episode by its identity: the same noise whichever episodes its
    worker ran before (ManiSkill's unseeded resets draw a new seed from an RNG every reset advances)."""

    def errors(episodes):
        out = []
        for k in episodes:
            out = [
                st.info["actuation_error"][0].numpy()
                for st in list(rollout(realistic_env, _Scripted(), k))[1:]
            ]
        return np.array(out)

    alone, after_two = errors([3]), errors([1, 0, 3])
    np.testing.assert_array_equal(alone, after_two)
    assert len(alone) == 9 and not np.array_equal(alone, errors([1]))


class _IntoWalls(_Scripted):
    """Long straight runs: the robot meets the room's walls (no sliding under ``realistic``)."""

    def reset(self, episode_info) -> None:
        self.actions = iter([1] * 14 + [2, 2] + [1] * 14 + [3] + [1] * 10 + [0])


def test_a_fresh_scene_rebuilds_the_scene_at_each_reset(realistic_env):
    """``fresh_scene``: every reset rebuilds the scene (PhysX keeps contact state across resets within one
    scene), and an episode that runs into walls gives the same poses after another episode as alone."""
    u = realistic_env.unwrapped

    def poses(episodes, fresh):
        for k in episodes:
            steps = list(rollout(realistic_env, _IntoWalls(), k, fresh_scene=fresh))
        return np.array([st.info["agent_pose"][0].numpy() for st in steps]), steps[-1].info

    alone, info = poses([3], True)
    scene = u.scene
    after, _ = poses([2, 3], True)
    assert u.scene is not scene and int(info["collisions"]) > 0
    np.testing.assert_array_equal(alone, after)
    scene = u.scene
    poses([3], False)
    assert u.scene is scene  # without it, a reset in the same scene keeps it


def test_noisy_episode_replays_from_a_saved_state(realistic_env):
    env = realistic_env
    env.reset(seed=3, options={"episode_index": 2})
    for a in (1, 2, 1):
        env.step(a)
    state = env.unwrapped.get_state_dict()
    later = [1, 1, 3, 1, 2, 1]
    first = [env.step(a)[4] for a in later]
    env.unwrapped.set_state_dict(state)
    second = [env.step(a)[4] for a in later]
    for x, y in zip(first, second):
        for k in ("agent_pose", "actuation_error", "path_length", "collisions"):
            assert torch.equal(x[k], y[k]), k


def _near_wall_pose(env) -> tuple[float, float, float]:
    """A free pose 0.3 m from the left wall of the episode's floor, facing it at 40 degrees."""
    u = env.unwrapped
    free = u.navs[0].free
    minx, miny, maxx, maxy = free.bounds
    for y in np.linspace(miny + 0.5, maxy - 0.5, 60):
        x = minx + 0.05
        if shapely.contains_xy(free, x, y) and shapely.contains_xy(free, x + 0.6, y):
            return x, float(y), math.pi - math.radians(40)
    raise AssertionError("no free pose by the wall")


@pytest.mark.parametrize("sliding", [True, False])
def test_sliding_along_walls_on_and_off(sliding):
    env = gym.make(
        "BioVLN-OpFace-v0", split="ms_val", obs_mode="state_dict", noise={"sliding": sliding}, **CPU
    )
    env.reset(seed=0, options={"episode_index": 0})
    u = env.unwrapped
    x, y, yaw = _near_wall_pose(env)
    u.agent.controller.put_back([0], np.array([[x, y, yaw]]))
    before = u._pose()[0]
    for _ in range(3):
        info = env.step(1)[4]
    after = info["agent_pose"][0].numpy()
    env.close()
    if sliding:
        assert abs(after[1] - before[1]) > 0.2  # slid along the wall
    else:
        np.testing.assert_allclose(after[:2], before[:2], atol=1e-4)  # blocked moves leave it in place
    assert int(info["collisions"][0]) >= 1


def test_image_noise_is_deterministic_and_applied_to_rgbd():
    frames = {}
    for noise, run in (("ideal", 0), ("realistic", 0), ("realistic", 1)):
        env = gym.make(
            "BioVLN-OpFace-v0",
            split="ms_val",
            obs_mode="rgbd",
            camera_width=128,
            camera_height=128,
            noise={"preset": noise, "actuation": 0.0},  # same poses, so the images differ by noise alone
            **CPU,
        )
        env.reset(seed=5, options={"episode_index": 0})
        head = env.step(2)[0]["sensor_data"]["head"]
        frames[(noise, run)] = (head["rgb"].clone(), head["depth"].clone())
        env.close()
    (rgb0, d0), (rgb1, d1), (rgb2, d2) = frames.values()
    assert rgb1.dtype == torch.uint8 and d1.dtype == torch.int16 and d1.shape == d0.shape
    assert torch.equal(rgb1, rgb2) and torch.equal(d1, d2)  # same seed and step: the same noise
    rgb_err = (rgb1.float() - rgb0.float())[rgb0.float().sub(127).abs() < 100]  # unclipped pixels
    assert 20 < float(rgb_err.std()) < 30  # sigma 0.1 of 255
    err = (d1.float() - d0.float())[d0 > 0]
    assert 0 < float(err.abs().median()) < 200  # millimetres: a few disparity steps at 1-5 m


def test_without_gps_the_camera_extrinsics_are_the_mount_not_the_pose():
    env = gym.make(
        "BioVLN-OpFace-v0",
        split="ms_val",
        obs_mode="rgbd",
        camera_width=64,
        camera_height=64,
        noise="realistic",
        **CPU,
    )
    obs, _ = env.reset(seed=0)
    first = {k: obs["sensor_param"]["head"][k].clone() for k in ("extrinsic_cv", "cam2world_gl")}
    for a in (1, 2, 1, 3):
        obs, *_ = env.step(a)
    env.close()
    for k, v in first.items():  # the robot moved; its camera did not, relative to the base
        assert torch.allclose(obs["sensor_param"]["head"][k], v, atol=1e-4), k
    mount = first["cam2world_gl"][0]
    assert float(mount[2, 3]) == pytest.approx(0.88, abs=1e-3) and float(mount[:2, 3].abs().max()) < 1e-4
