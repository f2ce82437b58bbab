"""BioVLN-OpFace-v0 and its variants on the CPU (physx_cpu, lavapipe)."""

import math
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
import torch

import biovln_ms  # noqa: F401
from biovln_ms.splits import FOUR_CATEGORIES
from biovln_ms.episodes.writer import SplitPlan, write_dataset
from biovln_ms.errors import BioVLNError
from biovln_ms.scene.generator import generate_scene

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")


def pose(u) -> np.ndarray:
    """The robot's planar pose from its base joints (tests may look inside the env; policies may not)."""
    return u.agent.planar_pose()[0].astype(np.float64)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("data") / "ds"
    a = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
    b = generate_scene("single_room", 155, required_categories=FOUR_CATEGORIES)
    write_dataset(
        root,
        [SplitPlan("ms_val", [(a, 6, False), (b, 4, False)]), SplitPlan("train", [(a, 5, False)])],
        progress=False,
    )
    return root


@pytest.fixture(scope="module")
def env(dataset):
    e = gym.make(
        "BioVLN-OpFace-v0", dataset=str(dataset), split="ms_val", obs_mode="state", reward_mode="dense", **CPU
    )
    yield e
    e.close()


def test_registered_on_import_and_by_module_prefix():
    assert {"BioVLN-OpFace-v0", "BioVLN-Centroid-v0", "BioVLN-OpFace-RL-v0"} <= set(gym.registry)
    code = (
        "import gymnasium as gym; e = gym.make('biovln_ms:BioVLN-OpFace-v0', obs_mode='state', "
        "sim_backend='physx_cpu', render_backend='cpu'); print(e.action_space)"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0 and "Discrete(4)" in r.stdout, r.stderr
    import biovln_ms.tasks  # noqa: F401  (what the first gym.make imports)
    from mani_skill.agents.registration import REGISTERED_AGENTS
    from mani_skill.utils.registration import REGISTERED_ENVS

    assert "biovln_base" in REGISTERED_AGENTS
    assert {"BioVLN-OpFace-v0", "BioVLN-Centroid-v0", "BioVLN-OpFace-RL-v0", "BioVLN-LabScene-v0"} <= set(
        REGISTERED_ENVS
    )


def test_actions_are_exact_and_stop_terminates(env):
    env.reset(options={"episode_index": 0})
    u = env.unwrapped
    assert env.action_space == gym.spaces.Discrete(4)
    u.agent.reset(torch.tensor([[4.0, 2.6, 0.3]]))  # open floor in the middle of the room
    p0 = pose(u)
    env.step(1)
    p1 = pose(u)
    assert np.linalg.norm(p1[:2] - p0[:2]) == pytest.approx(0.25, abs=0.01)
    assert p1[2] == pytest.approx(p0[2], abs=math.radians(0.5))
    env.step(2)
    assert math.degrees(pose(u)[2] - p1[2]) == pytest.approx(30.0, abs=0.5)
    env.step(3)
    env.step(3)
    assert math.degrees(pose(u)[2] - p1[2]) == pytest.approx(-30.0, abs=0.5)
    _, _, term, trunc, info = env.step(0)
    assert bool(term) and not bool(trunc) and bool(info["stopped"])


def test_walls_and_instruments_block_the_robot(env):
    env.reset(options={"episode_index": 1})
    u = env.unwrapped
    spec = u.scene_spec
    for heading in (0.0, math.pi / 2, math.pi, -math.pi / 2, 0.7):
        u.agent.reset(torch.tensor([[4.0, 2.6, heading]]))
        for _ in range(40):
            _, _, _, _, info = env.step(1)
        p = pose(u)[:2]
        assert 0.19 <= p[0] <= 7.81 and 0.19 <= p[1] <= 5.81
        for o in spec.objects():
            assert o.placed().clearance(p) >= 0.19, (heading, o.id)
    assert int(info["collisions"]) > 0


def test_success_only_within_the_radius(env):
    env.reset(options={"episode_index": 2})
    u = env.unwrapped
    ep = u.current_episode
    g = np.asarray(ep["goals"][0]["position"][:2])
    u.agent.reset(torch.tensor([[g[0], g[1], 0.0]]))
    _, r, term, _, info = env.step(0)
    assert bool(info["success"]) and bool(term) and float(info["distance_to_goal"]) < 1e-3
    assert float(r) > 9.0  # Eq. 5 success bonus of 10
    env.reset(options={"episode_index": 2})
    _, r, term, _, info = env.step(0)
    d = float(info["distance_to_goal"])
    assert bool(info["success"]) == (d <= ep["goals"][0]["radius"])
    assert bool(info["fail"]) == (not bool(info["success"]))


def test_a_scene_met_again_reuses_its_geometry_and_gives_the_same_values(env):
    from functools import lru_cache

    u = env.unwrapped

    def visit() -> list[dict]:
        _, info = env.reset(options={"episode_index": 0})  # scene a (episodes 0-5)
        return [info] + [env.step(a)[4] for a in (1, 2, 1)]

    env.reset(options={"episode_index": 6})  # scene b
    first = visit()
    nav, ctx = u.navs[0], u._ctx.episode(0)
    env.reset(options={"episode_index": 7})
    assert u.navs[0] is not nav
    again = visit()
    assert u.navs[0] is nav and u._ctx.episode(0) is ctx  # kept, not rebuilt
    # one scene kept: scene a is built again, its contexts with it
    kept, u._scene = u._scene, lru_cache(1)(u._scene.__wrapped__)
    try:
        env.reset(options={"episode_index": 7})
        rebuilt = visit()
        assert u.navs[0] is not nav and u._ctx.episode(0) is not ctx
    finally:
        u._scene = kept
    for other in (again, rebuilt):
        for a, b in zip(first, other):
            assert a.keys() == b.keys()
            for k in a.keys() - {"reconfigure"}:
                np.testing.assert_array_equal(np.asarray(a[k]), np.asarray(b[k]), err_msg=k)


def test_truncated_after_500_steps(dataset):
    e = gym.make("BioVLN-OpFace-v0", dataset=str(dataset), split="ms_val", obs_mode="none", **CPU)
    e.reset(options={"episode_index": 0})
    for k in range(500):
        _, _, term, trunc, info = e.step(2)
        assert not bool(term)
    assert bool(trunc) and int(info["steps"]) == 500
    e.close()


def test_episode_selection_and_scene_rebuilds(env):
    u = env.unwrapped
    env.reset(options={"episode_id": "3", "scene_id": "lab_s154_v0"})
    assert u.current_episode["episode_id"] == "3" and u.current_episode["scene_id"] == "lab_s154_v0"
    builds = []
    real = u._load_scene
    u._load_scene = lambda options: (builds.append(1), real(options))
    env.reset(options={"episode_id": "4", "scene_id": "lab_s154_v0"})
    assert builds == []  # same scene: no rebuild
    env.reset(options={"episode_id": "0", "scene_id": "lab_s155_v0"})
    assert builds == [1] and u.scene_spec.name == "lab_s155_v0"
    u._load_scene = real


def test_info_has_every_metric(env):
    _, info = env.reset(options={"episode_index": 0})
    _, _, _, _, info = env.step(1)
    for key in (
        "success",
        "distance_to_goal",
        "geodesic_distance_to_goal",
        "clearance",
        "zone2_violation",
        "in_zone3",
        "facing_instrument",
        "collisions",
        "spl",
        "soft_spl",
        "mcr",
        "vrt",
        "steps",
    ):
        assert key in info, key
    assert float(info["geodesic_distance_to_goal"]) >= float(info["distance_to_goal"]) - 1e-6


def test_bad_input_is_named(dataset, env):
    with pytest.raises(BioVLNError, match="unknown split 'ms_vall'"):
        gym.make("BioVLN-OpFace-v0", dataset=str(dataset), split="ms_vall", **CPU)
    with pytest.raises(BioVLNError, match="unknown control mode 'teleport'.*discrete, continuous"):
        gym.make("BioVLN-OpFace-v0", control_mode="teleport", **CPU)
    with pytest.raises(BioVLNError, match="no episode '77'"):
        env.reset(options={"episode_id": "77"})
    env.reset(options={"episode_index": 0})
    with pytest.raises(BioVLNError, match="outside Discrete\\(4\\).*0=STOP"):
        env.step(7)
    with pytest.raises(BioVLNError, match="num_envs > 1 needs sim_backend='physx_cuda'"):
        gym.make("BioVLN-OpFace-v0", num_envs=2, **CPU)


def test_rgbd_and_segmentation_observations(dataset):
    e = gym.make(
        "BioVLN-OpFace-v0",
        dataset=str(dataset),
        split="ms_val",
        obs_mode="rgb+depth+segmentation",
        camera_width=96,
        camera_height=72,
        **CPU,
    )
    obs, _ = e.reset(options={"episode_index": 0})
    cam = obs["sensor_data"]["head"]
    assert cam["rgb"].shape == (1, 72, 96, 3) and cam["depth"].shape == (1, 72, 96, 1)
    assert (cam["depth"] > 0).float().mean() > 0.95  # the ceiling closes the room: depth everywhere
    extra = obs["extra"]
    assert extra["pointgoal_with_gps_compass"].shape == (1, 2) and extra["objectgoal"].sum() == 1
    assert (
        extra["gps"].abs().max() < 1e-5 and extra["compass"].abs().max() < 1e-5
    )  # the episode frame starts at 0
    # the semantic sensor: 1 + goal-category index where a goal-category object is seen, 0 elsewhere
    u = e.unwrapped
    sem, seg = extra["semantic_category"][0, ..., 0], cam["segmentation"][0, ..., 0]
    ids = u.scene_builder.segmentation_ids(0)
    for sid, oid in ids.items():
        cat = u.scene_spec.get(oid).category
        want = u.category_names.index(cat) + 1 if cat in u.category_names else 0
        assert bool((sem[seg == sid] == want).all()), oid
    assert bool((sem[~torch.isin(seg, torch.tensor(list(ids)))] == 0).all())
    e.close()


def test_centroid_variant_targets_the_bbox_centre(dataset):
    e = gym.make("BioVLN-Centroid-v0", dataset=str(dataset), split="ms_val", obs_mode="none", **CPU)
    e.reset(options={"episode_index": 0})
    u = e.unwrapped
    target = u.scene_spec.get(u.current_episode["object_id"])
    _, info = e.reset(options={"episode_index": 0})
    assert np.allclose(info["goal_position"][0].numpy(), target.position[:2])
    e.close()


def test_rl_variant_and_conformance(dataset):
    from gymnasium.utils.env_checker import check_env as gym_check
    from stable_baselines3.common.env_checker import check_env as sb3_check

    from biovln_ms.wrappers import GymnasiumEnv

    e = gym.make("BioVLN-OpFace-RL-v0", dataset=str(dataset), **CPU)
    u = e.unwrapped
    assert u.cfg.turn_deg == 10.0 and u.cfg.proportional_safety
    w = GymnasiumEnv(e)
    obs, _ = w.reset(seed=0)
    assert obs.dtype == np.float32 and obs.ndim == 1
    p = pose(u)
    assert obs[0] == pytest.approx(p[0] / 4.0, abs=1e-5) and obs[2] ** 2 + obs[3] ** 2 == pytest.approx(
        1.0, abs=1e-5
    )
    u.agent.reset(torch.tensor([[4.0, 2.6, 0.0]]))
    w.step(2)
    assert math.degrees(pose(u)[2]) == pytest.approx(10.0, abs=0.5)
    gym_check(w, skip_render_check=True)
    sb3_check(w, warn=True)
    e.close()


def test_user_variant_example_registers_and_runs(dataset):
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "tasks" / "examples" / "facing_variant.py"
    spec = importlib.util.spec_from_file_location("facing_variant", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    e = gym.make("MyLab-OpFaceFacing-v0", dataset=str(dataset), split="ms_val", obs_mode="none", **CPU)
    e.reset(options={"episode_index": 2})
    u = e.unwrapped
    g = np.asarray(u.current_episode["goals"][0]["position"][:2])
    target = u.scene_spec.get(u.current_episode["object_id"])
    away = math.atan2(g[1] - target.position[1], g[0] - target.position[0])  # facing away from the instrument
    u.agent.reset(torch.tensor([[g[0], g[1], away]]))
    _, _, term, _, info = e.step(0)
    assert bool(term) and not bool(info["success"]) and not bool(info["facing_instrument"])
    e.reset(options={"episode_index": 2})
    u.agent.reset(torch.tensor([[g[0], g[1], away + math.pi]]))
    _, _, _, _, info = e.step(0)
    assert bool(info["success"]) and bool(info["facing_success"])
    e.close()


def test_pointcloud_obs_mode():
    e = gym.make("BioVLN-OpFace-v0", obs_mode="pointcloud", camera_width=64, camera_height=48, **CPU)
    obs, _ = e.reset(seed=0)
    assert obs["pointcloud"]["xyzw"].shape == (1, 64 * 48, 4)
    e.step(1)
    e.close()


def test_control_mode_is_the_robots_controller(dataset):
    e = gym.make(
        "BioVLN-OpFace-v0",
        dataset=str(dataset),
        split="ms_val",
        obs_mode="none",
        control_mode="continuous",
        **CPU,
    )
    u = e.unwrapped
    assert u.control_mode == "continuous" and u.agent.control_mode == "continuous"
    assert e.action_space == gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
    e.reset(options={"episode_index": 0})
    u.agent.reset(torch.tensor([[4.0, 2.6, 0.0]]))
    p0 = pose(u)
    e.step(np.array([0.0, 0.5, -1.0], np.float32))  # half a step forward, half a turn left
    p1 = pose(u)
    assert np.linalg.norm(p1[:2] - p0[:2]) == pytest.approx(0.125, abs=0.01)
    assert math.degrees(p1[2] - p0[2]) == pytest.approx(15.0, abs=0.5)
    with pytest.raises(BioVLNError, match="outside Box"):
        e.step(np.array([2.0, 0.0, 0.0]))
    e.close()


def test_every_action_form_is_accepted(env):
    env.reset(options={"episode_index": 0})
    u = env.unwrapped
    for a in (2, np.int64(2), np.array(2), np.array([2]), torch.tensor(2), torch.tensor([2]), [2]):
        before = pose(u)[2]
        env.step(a)
        assert math.degrees(pose(u)[2] - before) == pytest.approx(30.0, abs=0.5), repr(a)
    with pytest.raises(BioVLNError, match="not 1 integer"):
        env.step(np.array([1.5]))


@pytest.mark.parametrize("obs_mode", ["depth+rgb", "rgb+normal", "rgb+depth", "state_dict", "sensor_data"])
def test_maniskill_obs_modes(dataset, obs_mode):
    e = gym.make(
        "BioVLN-OpFace-v0",
        dataset=str(dataset),
        split="ms_val",
        obs_mode=obs_mode,
        camera_width=32,
        camera_height=24,
        **CPU,
    )
    obs, _ = e.reset(options={"episode_index": 0})
    e.step(1)
    if "normal" in obs_mode:
        assert obs["sensor_data"]["head"]["normal"].shape == (1, 24, 32, 3)
    e.close()


def test_evaluate_is_a_pure_query(env):
    env.reset(options={"episode_index": 0})
    u = env.unwrapped
    env.step(1)
    a, b = u.evaluate(), u.evaluate()
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    obs1, obs2 = u.get_obs(a), u.get_obs(b)
    assert torch.equal(obs1, obs2)
    _, _, _, _, info = env.step(1)
    assert int(info["steps"]) == 2  # the extra evaluate() calls counted nothing


def test_state_dict_replay_gives_the_same_rewards_and_infos(env):
    env.reset(options={"episode_index": 1})
    u = env.unwrapped
    actions = [1, 1, 2, 1, 1, 3, 1, 1, 1, 2, 1, 1, 0]
    for a in actions[:5]:
        env.step(a)
    state = u.get_state_dict()
    first = [env.step(a) for a in actions[5:]]
    env.reset(options={"episode_index": 1})
    for a in (2, 2, 1):  # wander off, then restore the mid-episode state
        env.step(a)
    u.set_state_dict(state)
    again = [env.step(a) for a in actions[5:]]
    for (o1, r1, t1, tr1, i1), (o2, r2, t2, tr2, i2) in zip(first, again):
        assert torch.equal(r1, r2) and torch.equal(t1, t2) and torch.equal(tr1, tr2) and torch.equal(o1, o2)
        assert i1.keys() == i2.keys() and all(
            torch.equal(torch.as_tensor(i1[k]), torch.as_tensor(i2[k])) for k in i1
        )
    env.reset(options={"episode_index": 2})
    with pytest.raises(BioVLNError, match="another episode"):
        u.set_state_dict(state)


def test_normalized_and_sparse_rewards(dataset):
    rewards = {}
    for mode in ("dense", "normalized_dense", "sparse"):
        e = gym.make(
            "BioVLN-OpFace-v0", dataset=str(dataset), split="ms_val", obs_mode="none", reward_mode=mode, **CPU
        )
        e.reset(options={"episode_index": 2})
        g = np.asarray(e.unwrapped.current_episode["goals"][0]["position"][:2])
        rewards[mode] = [float(e.step(1)[1])]
        e.unwrapped.agent.reset(torch.tensor([[g[0], g[1], 0.0]]))
        rewards[mode].append(float(e.step(0)[1]))
        e.close()
    assert rewards["normalized_dense"] == pytest.approx([r / 10.0 for r in rewards["dense"]], abs=1e-6)
    assert rewards["sparse"] == [0.0, 1.0]


def test_gpu_backend_without_cuda_is_one_line(dataset):
    with pytest.raises(BioVLNError, match="needs a CUDA GPU"):
        gym.make("BioVLN-OpFace-v0", dataset=str(dataset), split="ms_val", sim_backend="gpu")


def test_render_shows_the_room_and_the_robot(dataset):
    """The follow camera sits inside the room with the ceiling hidden: the frame is the lit floor, walls and
    robot, not the grey underside of the ceiling box (the bug: one colour over the whole frame)."""
    e = gym.make(
        "BioVLN-OpFace-v0",
        dataset=str(dataset),
        split="ms_val",
        obs_mode="none",
        render_mode="rgb_array",
        **CPU,
    )
    e.reset(options={"episode_index": 0})
    frame = e.render()[0].cpu().numpy()
    assert frame.shape == (720, 960, 3)
    colours = len(np.unique(frame.reshape(-1, 3)[::7], axis=0))
    assert colours > 2000 and frame.std() > 20, (colours, frame.std())
    e.close()


def test_no_cuda_fallback_warning_on_a_cpu_machine(dataset):
    code = (
        "import gymnasium as gym, biovln_ms; e = gym.make('BioVLN-OpFace-v0', dataset=%r, split='ms_val', "
        "obs_mode='state'); e.reset(); e.step(1); print('ok')" % str(dataset)
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert r.returncode == 0 and "ok" in r.stdout, r.stderr[-2000:]
    if not torch.cuda.is_available():
        assert "Falling back" not in r.stderr and "sapien_cuda" not in r.stderr, r.stderr[-2000:]


def test_robot_radius_is_one_fact(env):
    """The robot's radius comes from its URDF collision cylinder; the navigation geometry, the episodes and
    the task spec policies get all use the same number."""
    from biovln_ms.constants import ROBOT_RADIUS

    u = env.unwrapped
    env.reset(options={"episode_index": 0})
    assert u.agent.radius == ROBOT_RADIUS == u.scene_spec.robot_radius == u.navs[0].radius
    assert u.task_spec().robot_radius == u.agent.radius


def test_nothing_happens_after_the_episode_ends(env):
    """Stepping after STOP (or truncation) moves nothing, changes no metric and pays nothing (Habitat's rule:
    an ended episode waits for reset); a second STOP does not pay the success bonus again."""
    env.reset(options={"episode_index": 2})
    u = env.unwrapped
    g = np.asarray(u.current_episode["goals"][0]["position"][:2])
    u.agent.reset(torch.tensor([[g[0], g[1], 0.0]]))
    _, r, term, _, info = env.step(0)
    assert bool(info["success"]) and bool(term) and float(r) > 9.0
    p = pose(u)
    for a in (1, 1, 2, 0, 0):
        _, r2, term2, _, info2 = env.step(a)
        assert float(r2) == 0.0 and bool(term2)
        assert np.allclose(pose(u), p, atol=1e-5)
        for k in ("success", "spl", "steps", "path_length", "collisions", "mcr", "vrt"):
            assert torch.equal(info2[k], info[k]), k
    env.reset(options={"episode_index": 2})
    _, _, _, _, info = env.step(1)
    assert int(info["steps"]) == 1  # a reset starts counting again


def test_no_tunnelling_at_any_step_size(dataset):
    """Large forward steps (up to 2 m, through 0.1 m walls and thin instruments) and random continuous actions
    never take the body more than ALLOWANCE (8 cm) into a wall or an instrument's collision footprint.
    ``BIOVLN_MOTION_RUNS`` runs per step size (episodes cycle); README gives a longer campaign's count."""
    import os

    import shapely

    from biovln_ms.geometry.motion import ALLOWANCE
    from biovln_ms.scene.rules import floor_polygon
    from biovln_ms.sim.footprints import collision_footprints

    rng = np.random.default_rng(0)
    for step, mode in ((0.5, "discrete"), (1.0, "discrete"), (2.0, "discrete"), (1.5, "continuous")):
        e = gym.make(
            "BioVLN-OpFace-v0",
            dataset=str(dataset),
            split="ms_val",
            obs_mode="none",
            forward_step=step,
            control_mode=mode,
            **CPU,
        )
        u = e.unwrapped
        for run in range(int(os.environ.get("BIOVLN_MOTION_RUNS", 4))):
            ep = run % len(u.source)
            e.reset(options={"episode_index": ep})
            room = floor_polygon(u.scene_spec).buffer(-(0.2 - ALLOWANCE))
            bodies = shapely.union_all(collision_footprints(u.scene_spec)).buffer(
                0.2 - ALLOWANCE, quad_segs=8
            )
            for _ in range(60):
                if mode == "discrete":
                    a = int(rng.choice([1, 1, 1, 2, 3]))
                else:
                    a = rng.uniform(-1, 1, 3) * [1, 1, 0]
                _, _, _, _, info = e.step(a)
                x, y = pose(u)[:2]
                assert room.contains(shapely.Point(x, y)), (step, mode, ep, x, y)
                assert not bodies.contains(shapely.Point(x, y)), (step, mode, ep, x, y)
            assert int(info["collisions"]) > 0, (step, mode, ep)
        e.close()


def test_many_turns_one_way_stay_thirty_degrees_each():
    """PhysX keeps the yaw joint within +-2 pi; a drive target past it would spin the robot the long way
    round (+131 deg for one right turn), so the controller re-seats the joint first."""
    env = gym.make("BioVLN-OpFace-v0", split="ms_val", obs_mode="state", max_episode_steps=100, **CPU)
    env.reset(options={"episode_index": 0})
    for action, sign in ((3, -1), (2, 1)):
        prev = float(env.unwrapped._pose()[0, 2])
        for _ in range(30):  # 900 degrees one way
            yaw = float(env.step(action)[4]["agent_pose"][0, 2])
            turn = math.degrees((yaw - prev + math.pi) % (2 * math.pi) - math.pi)
            assert turn == pytest.approx(sign * 30.0, abs=0.5)
            assert abs(yaw) <= 1.5 * math.pi + math.radians(30)
            prev = yaw
    env.close()


def test_any_instance_counts_on_the_hard_track():
    """A Hard-track episode lists every instance of its category; STOP at the farther one succeeds."""
    env = gym.make("BioVLN-OpFace-v0", split="hard_val", obs_mode="state", **CPU)
    u = env.unwrapped
    index = next(i for i, e in enumerate(u.source.episodes) if len(e["goals"]) > 1)
    env.reset(options={"episode_index": index})
    ep = u.current_episode
    assert float(env.step(2)[4]["distance_to_goal"]) == pytest.approx(ep["info"]["geodesic_distance"], abs=3)
    far = ep["goals"][-1]
    face = u.scene_specs[0].get(far["object_id"]).placed().face
    x, y = far["view_points"][0]["agent_state"]["position"][:2]  # in Zone 3, within r
    u.agent.controller.put_back([0], np.array([[x, y, math.atan2(-face[1], -face[0])]]))
    info = env.step(0)[4]
    assert bool(info["success"]) and bool(info["strict_success"]) and bool(info["in_zone3"])
    d = math.dist((x, y), far["position"][:2])
    assert float(info["distance_to_goal"]) == pytest.approx(d, abs=1e-4)  # the nearest goal is now this one
    env.close()
