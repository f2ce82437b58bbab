"""Fetch in every navigation task (``robot_uids="fetch"``): its controller, footprint, head camera and tuck
pose, and datasets built per robot (physx_cpu, lavapipe)."""

import json
import math

import gymnasium as gym
import numpy as np
import pytest
import sapien
import torch
from typer.testing import CliRunner

import biovln_ms  # noqa: F401
from biovln_ms.splits import FOUR_CATEGORIES
from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset
from biovln_ms.episodes.writer import SplitPlan, write_dataset
from biovln_ms.errors import BioVLNError
from biovln_ms.robot_specs import DEFAULT_ROBOT, ROBOTS
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import scene_free_space
from biovln_ms.variants import VARIANTS

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
FETCH = ROBOTS["fetch"]


def pose(u) -> np.ndarray:
    return u.agent.planar_pose()[0].astype(np.float64)


def scene(robot: str, seed: int = 154):
    r = ROBOTS[robot].footprint_radius
    return generate_scene("single_room", seed, required_categories=FOUR_CATEGORIES, robot_radius=r)


@pytest.fixture(scope="module")
def fetch_dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("data") / "fetch"
    s = scene("fetch")
    write_dataset(
        root, [SplitPlan("ms_val", [(s, 4, False)]), SplitPlan("train", [(s, 3, False)])], False, "fetch"
    )
    return root


@pytest.fixture(scope="module")
def cylinder_dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("data") / "cylinder"
    write_dataset(root, [SplitPlan("ms_val", [(scene(DEFAULT_ROBOT), 2, False)])], progress=False)
    return root


@pytest.fixture(scope="module")
def env(fetch_dataset):
    e = gym.make("BioVLN-OpFace-v0", robot_uids="fetch", dataset=str(fetch_dataset), split="ms_val", **CPU)
    yield e
    e.close()


def held_joints(u) -> np.ndarray:
    return u.agent.robot.get_qpos()[0, 3:].numpy()


def test_fetch_is_the_robot_and_matches_its_row(env):
    from biovln_ms.agents.robots.fetch_nav import BASE_JOINTS, TUCK, FetchNav

    env.reset(options={"episode_index": 0})
    u = env.unwrapped
    assert isinstance(u.agent, FetchNav) and u.robot_id == "fetch" and u.robot_uids == "fetch_nav"
    assert u.agent.radius == FETCH.footprint_radius == u.scene_spec.robot_radius == u.navs[0].radius
    assert u.task_spec().robot_radius == FETCH.footprint_radius
    assert [j.name for j in u.agent.robot.active_joints] == [*BASE_JOINTS, *TUCK]
    assert np.abs(held_joints(u) - np.array(list(TUCK.values()))).max() < 1e-6
    # every collision shape, in the tuck pose, lies within the footprint radius (rounded up to the cm)
    base = u.agent.base_link._objs[0].entity_pose.inv()
    reach, floor = 0.0, []
    for link in u.agent.robot.links:
        body = link._objs[0]
        for shape in body.get_collision_shapes():
            t = (base * body.entity_pose * shape.local_pose).to_transformation_matrix()
            v = (shape.vertices * shape.scale) @ t[:3, :3].T + t[:3, 3]
            reach = max(reach, float(np.hypot(v[:, 0], v[:, 1]).max()))
            floor.append(float(v[:, 2].min()))
    assert reach <= FETCH.footprint_radius < reach + 0.01
    assert min(floor) > -0.01  # the wheels rest on the floor
    cam = u.agent.camera_link.pose.p[0].numpy()
    assert cam[2] == pytest.approx(FETCH.camera_height, abs=1e-3)
    # the camera looks along the heading, level
    rot = u.agent.camera_link.pose.to_transformation_matrix()[0, :3, 0].numpy()
    yaw = pose(u)[2]
    assert rot == pytest.approx([math.cos(yaw), math.sin(yaw), 0.0], abs=1e-4)


def test_the_cylinder_matches_its_row(cylinder_dataset):
    e = gym.make("BioVLN-OpFace-v0", dataset=str(cylinder_dataset), split="ms_val", obs_mode="none", **CPU)
    e.reset(seed=0)
    u, row = e.unwrapped, ROBOTS[DEFAULT_ROBOT]
    assert u.robot_id == u.robot_uids == DEFAULT_ROBOT and u.agent.radius == row.footprint_radius
    assert float(u.agent.camera_link.pose.p[0, 2]) == pytest.approx(row.camera_height, abs=1e-6)
    e.close()


def test_actions_move_and_turn_exactly(env):
    env.reset(options={"episode_index": 0})
    u = env.unwrapped
    assert env.action_space == gym.spaces.Discrete(4)
    u.agent.reset_planar(torch.tensor([[4.0, 2.6, 0.3]]))  # open floor in the middle of the room
    p0 = pose(u)
    env.step(1)
    p1 = pose(u)
    assert np.linalg.norm(p1[:2] - p0[:2]) == pytest.approx(0.25, abs=0.01)
    assert math.atan2(*(p1[1::-1] - p0[1::-1])) == pytest.approx(0.3, abs=0.01)
    assert p1[2] == pytest.approx(p0[2], abs=math.radians(0.5))
    env.step(2)
    assert math.degrees(pose(u)[2] - p1[2]) == pytest.approx(30.0, abs=0.5)
    env.step(3)
    env.step(3)
    assert math.degrees(pose(u)[2] - p1[2]) == pytest.approx(-30.0, abs=0.5)
    _, _, term, _, info = env.step(0)
    assert bool(term) and bool(info["stopped"])


def test_many_turns_one_way_stay_thirty_degrees_each(env):
    """The yaw joint is re-seated past 1.5 pi (as the cylinder's) without disturbing the held joints."""
    env.reset(options={"episode_index": 0})
    u = env.unwrapped
    for action, sign in ((3, -1), (2, 1)):
        prev = pose(u)[2]
        for _ in range(30):  # 900 degrees one way
            env.step(action)
            yaw = pose(u)[2]
            turn = math.degrees((yaw - prev + math.pi) % (2 * math.pi) - math.pi)
            assert turn == pytest.approx(sign * 30.0, abs=0.5)
            prev = yaw
    assert np.abs(held_joints(u) - u.agent.keyframes["rest"].qpos[3:]).max() < 0.02


def test_continuous_actions_drive_fetch(fetch_dataset):
    e = gym.make(
        "BioVLN-OpFace-v0",
        robot_uids="fetch",
        control_mode="continuous",
        dataset=str(fetch_dataset),
        split="ms_val",
        obs_mode="none",
        **CPU,
    )
    e.reset(options={"episode_index": 0})
    u = e.unwrapped
    assert e.action_space.shape == (3,)
    u.agent.reset_planar(torch.tensor([[4.0, 2.6, 0.0]]))
    e.step(np.array([0.0, 0.5, -1.0]))  # half a step forward, half a turn
    p = pose(u)
    assert p[0] - 4.0 == pytest.approx(0.125, abs=0.01)
    assert math.degrees(p[2]) == pytest.approx(15.0, abs=0.5)
    e.close()


def test_walls_and_instruments_stop_fetch_and_its_arm_stays_tucked(env):
    env.reset(options={"episode_index": 1})
    u = env.unwrapped
    # the base is not round: the footprint disc (0.29 m) encloses it, its sides are 0.264 m from the centre,
    # so side-on contact lets the centre come that close (a disc-shaped body would stop at the radius)
    spec, r = u.scene_spec, 0.264
    worst, collisions = 0.0, 0
    for heading in (0.0, math.pi / 2, math.pi, -math.pi / 2, 0.7):
        u.agent.reset_planar(torch.tensor([[4.0, 2.6, heading]]))
        for k in range(30):
            _, _, _, _, info = env.step(1 if k % 6 else 2)
            worst = max(worst, float(np.abs(held_joints(u) - u.agent.keyframes["rest"].qpos[3:]).max()))
        collisions += int(info["collisions"])
        p = pose(u)[:2]
        assert r - 0.01 <= p[0] <= 8.0 - r + 0.01 and r - 0.01 <= p[1] <= 6.0 - r + 0.01
        for o in spec.objects():
            assert o.placed().clearance(p) >= r - 0.01, (heading, o.id)
    assert collisions > 0
    assert worst < 0.02  # 150 steps, bumping into walls: every held joint within 0.02 rad (m) of the tuck


def fetch_rgbd(fetch_dataset, width: int, height: int):
    """Fetch on its MS VAL episodes with the head camera's RGB-D at ``width`` x ``height``."""
    return gym.make(
        "BioVLN-OpFace-v0",
        robot_uids="fetch",
        dataset=str(fetch_dataset),
        split="ms_val",
        obs_mode="rgbd",
        camera_width=width,
        camera_height=height,
        **CPU,
    )


def test_head_camera_rgbd(fetch_dataset):
    e = fetch_rgbd(fetch_dataset, 96, 72)
    obs, _ = e.reset(options={"episode_index": 0})
    assert set(obs["sensor_data"]) == {"head"}  # not ManiSkill's fetch_head / fetch_hand
    cam = obs["sensor_data"]["head"]
    assert cam["rgb"].shape == (1, 72, 96, 3) and cam["depth"].shape == (1, 72, 96, 1)
    assert (cam["depth"] > 0).float().mean() > 0.95
    assert obs["agent"]["qpos"].shape == (1, 15)  # odometry first: x, y, yaw
    assert obs["agent"]["qpos"][0, :3].numpy() == pytest.approx(pose(e.unwrapped), abs=1e-5)
    cam2world = obs["sensor_param"]["head"]["cam2world_gl"][0].numpy()
    assert cam2world[2, 3] == pytest.approx(FETCH.camera_height, abs=1e-3)
    e.close()


@pytest.mark.parametrize(
    "env_id", ["BioVLN-OpFace-v0", "BioVLN-Centroid-v0", "BioVLN-OpFace-Strict-v0", "BioVLN-OpFace-RL-v0"]
)
def test_every_variant_runs_fetch(fetch_dataset, env_id):
    assert env_id in VARIANTS
    e = gym.make(env_id, robot_uids="fetch", dataset=str(fetch_dataset), split="train", **CPU)
    e.reset(seed=0)
    _, _, _, _, info = e.step(1)
    assert e.unwrapped.agent.radius == FETCH.footprint_radius and int(info["steps"]) == 1
    e.close()


def test_generated_scene_episodes_use_fetchs_footprint():
    e = gym.make("BioVLN-OpFace-v0", robot_uids="fetch", obs_mode="none", **CPU)
    e.reset(seed=0)
    u = e.unwrapped
    assert u.scene_spec.robot_radius == FETCH.footprint_radius
    free = scene_free_space(u.scene_spec)
    from shapely.geometry import Point

    assert all(free.covers(Point(ep["start_position"][:2])) for ep in u.source.episodes)
    e.close()


def test_unknown_robot_is_one_line():
    with pytest.raises(BioVLNError, match="unknown robot 'panda'.*use one of: biovln_base, fetch") as err:
        gym.make("BioVLN-OpFace-v0", robot_uids="panda", **CPU)
    assert "\n" not in str(err.value) and err.value.field == "robot_uids"


def test_a_dataset_serves_only_its_robot(fetch_dataset, cylinder_dataset, tmp_path):
    with pytest.raises(DatasetError, match="built for robot 'biovln_base', not 'fetch'") as err:
        gym.make("BioVLN-OpFace-v0", robot_uids="fetch", dataset=str(cylinder_dataset), split="ms_val", **CPU)
    assert "biovln-ms dataset build --robot fetch --out DIR" in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(DatasetError, match="built for robot 'fetch', not 'biovln_base'.*--robot biovln_base"):
        gym.make("BioVLN-OpFace-v0", dataset=str(fetch_dataset), split="ms_val", **CPU)
    assert EpisodeDataset(fetch_dataset, robot="fetch").robot == "fetch"
    assert EpisodeDataset(fetch_dataset, robot=None).agent_radius == FETCH.footprint_radius  # any robot
    # a manifest from before the robot field is the default robot's
    old = json.loads((cylinder_dataset / "manifest.json").read_text())
    assert old.pop("robot") == DEFAULT_ROBOT
    root = tmp_path / "old"
    root.mkdir()
    for p in cylinder_dataset.rglob("*"):
        dest = root / p.relative_to(cylinder_dataset)
        if p.is_dir():
            dest.mkdir(exist_ok=True)
        else:
            dest.write_bytes(p.read_bytes())
    (root / "manifest.json").write_text(json.dumps(old))
    assert EpisodeDataset(root).robot == DEFAULT_ROBOT
    with pytest.raises(DatasetError, match="built for robot 'biovln_base', not 'fetch'"):
        EpisodeDataset(root, robot="fetch")
    with pytest.raises(DatasetError, match="checked for a 0.2 m robot, the dataset is for fetch"):
        write_dataset(
            tmp_path / "bad", [SplitPlan("ms_val", [(scene(DEFAULT_ROBOT), 2, False)])], False, "fetch"
        )


def test_cli_builds_for_a_robot(tmp_path, monkeypatch):
    """``dataset build --robot fetch`` generates the splits for Fetch and records it (a small split stands in
    for the paper's); an unknown robot is one line."""
    from biovln_ms import splits
    from biovln_ms.cli import app, user_error_line

    asked = []

    def small(robot):
        asked.append(robot)
        return [SplitPlan("ms_val", [(scene(robot), 3, False)])]

    monkeypatch.setattr(splits, "paper_splits", small)
    r = CliRunner().invoke(app, ["dataset", "build", "--robot", "fetch", "--out", str(tmp_path / "ds")])
    assert r.exit_code == 0, r.output
    ds = EpisodeDataset(tmp_path / "ds", robot="fetch")
    assert asked == ["fetch"] and ds.robot == "fetch" and ds.agent_radius == FETCH.footprint_radius
    assert len(list(ds.episodes("ms_val"))) == 3
    r = CliRunner().invoke(app, ["dataset", "build", "--robot", "spot", "--out", str(tmp_path / "x")])
    line = user_error_line(r.exception)  # what ``biovln-ms`` prints
    assert "field '--robot': unknown robot 'spot'" in line and "biovln_base, fetch" in line
    assert not (tmp_path / "x").exists()


@pytest.mark.slow
def test_fetch_builds_every_paper_split():
    """Every split of the paper's datasets builds for Fetch (its default dataset is that build), with the
    cylinder's scene and episode counts."""
    from biovln_ms.splits import ensure_default_dataset

    def counts(robot):
        m = EpisodeDataset(ensure_default_dataset(echo=lambda *_: None, robot=robot), robot=robot).manifest
        return m, {k: (len(v["scenes"]), v["episodes"]) for k, v in m["splits"].items()}

    m, fetch = counts("fetch")
    assert fetch == counts(DEFAULT_ROBOT)[1]
    assert m["robot"] == "fetch" and m["agent_radius"] == FETCH.footprint_radius


@pytest.fixture(scope="module")
def two_room_env(tmp_path_factory):
    root = tmp_path_factory.mktemp("data") / "fetch2"
    s = generate_scene("two_room", 200, robot_radius=FETCH.footprint_radius)
    write_dataset(root, [SplitPlan("two_room", [(s, 2, True)])], False, "fetch")
    e = gym.make(
        "BioVLN-OpFace-v0", robot_uids="fetch", dataset=str(root), split="two_room", obs_mode="none", **CPU
    )
    e.reset(options={"episode_index": 0})
    yield e
    e.close()


def _floor_shapes(u):
    shell = next(a for a in u.scene.actors.values() if a.name.endswith("room_shell"))
    body = shell._objs[0].find_component_by_type(sapien.physx.PhysxRigidStaticComponent)
    return [s for s in body.get_collision_shapes() if s.local_pose.p[2] < 0]


def _drive_through_the_corridor(env) -> list[float]:
    """FORWARD from room A along the corridor's centre line into room B; the length of each move."""
    u = env.unwrapped
    u.agent.reset_planar(torch.tensor([[5.0, 2.5, 0.0]]))
    moves, prev = [], pose(u)
    for _ in range(14):  # the base's centre from x = 5.0 to 8.5: over both rooms' floor seams (x = 6, 8)
        env.step(1)
        moves.append(float(np.linalg.norm(pose(u)[:2] - prev[:2])))
        prev = pose(u)
    return moves


def test_fetch_crosses_the_seams_between_rooms_floors(two_room_env):
    """Each room's floor is its own box. Fetch's wheel meshes reach below the floor (its base is carried by
    the planar joints), so the edge of the next room's floor box stopped them at Two-Room's corridor: the
    floor ignores Fetch's base and wheels (ManiSkill's collision bits, as its own grounds do)."""
    from shapely.geometry import LineString

    from biovln_ms.sim.sapien_builder import FLOOR_IGNORED_BITS

    u = two_room_env.unwrapped
    assert scene_free_space(u.scene_spec).covers(LineString([(5.0, 2.5), (8.5, 2.5)]))  # nothing in the way
    wheels = u.agent.robot.links_map["l_wheel_link"]._objs[0]
    low = 1.0
    for shape in wheels.get_collision_shapes():
        t = (wheels.entity_pose * shape.local_pose).to_transformation_matrix()
        low = min(low, float(((shape.vertices * shape.scale) @ t[:3, :3].T + t[:3, 3])[:, 2].min()))
    assert low < -0.003  # the cause: 5 mm into the floor
    floors = _floor_shapes(u)
    assert len(floors) == 3 and all(s.get_collision_groups()[2] & FLOOR_IGNORED_BITS for s in floors)
    moves = _drive_through_the_corridor(two_room_env)
    assert moves == pytest.approx([0.25] * 14, abs=0.01)
    for s in floors:  # without the bits the wheels catch on the seam at x = 6
        groups = s.get_collision_groups()
        groups[2] = 0
        s.set_collision_groups(groups)
    moves = _drive_through_the_corridor(two_room_env)
    assert min(moves) < 0.15 and pose(u)[0] < 6.1


def test_frontier_on_fetch_sees_its_footprint_and_explores(fetch_dataset):
    """Fetch's head camera is 0.16 m ahead of its turning centre, so no depth ray crosses the cells under
    its base: the frontier map frees them from the camera's offset (read from the observed extrinsics), else
    the robot's cell is cut off from what it sees and it STOPs at its first step."""
    from biovln_ms.baselines.frontier import FREE, FrontierPolicy
    from biovln_ms.eval.rollout import rollout

    e = fetch_rgbd(fetch_dataset, 320, 240)
    pol = FrontierPolicy()
    try:
        steps = list(rollout(e, pol, 0))
    finally:
        e.close()
    assert pol.camera_offset == pytest.approx([0.164, 0.0], abs=0.005)
    actions = [s.action for s in steps[1:]]
    assert actions[0] != 0 and len(actions) > 5
    dtg = [float(s.info["distance_to_goal"]) for s in steps]
    assert bool(steps[-1].info["success"]) or dtg[-1] < dtg[0] - 1.0  # it went a long way toward the goal
    rc = pol.map.cell(pol.pose[:2])
    assert pol.map.grid[rc[0], rc[1]] == FREE  # the ground under the base, which the camera never sees


def test_the_ground_under_the_base_is_free_but_no_frontier_for_a_camera_off_the_axis():
    """``camera_offset`` reads the camera's ground offset from extrinsics and a base pose (zero within 1 mm
    of the axis: the cylinder's float32 extrinsics). ``integrate(base_xy=...)`` frees the disc the camera
    circles about the turning centre, which no ray crosses; those cells are not ``seen``, so their edge is
    no frontier (else the nearest frontier lies under the robot and it turns to and fro)."""
    from biovln_ms.baselines.frontier import FREE, UNKNOWN, FrontierParams, OccupancyMap, camera_offset
    from biovln_ms.baselines.frontier.planner import FrontierPlanner, PlanField

    def extrinsic(cam_xy, yaw):  # a level camera looking along yaw, 1 m up (OpenCV: x right, y down, z ahead)
        c, s = math.cos(yaw), math.sin(yaw)
        r = np.array([[s, -c, 0.0], [0.0, 0.0, -1.0], [c, s, 0.0]])  # world -> camera
        return np.hstack([r, (-r @ np.array([*cam_xy, 1.0]))[:, None]])

    base = np.array([2.0, 1.0, 0.5])
    ahead = base[:2] + 0.164 * np.array([math.cos(0.5), math.sin(0.5)])
    assert camera_offset(extrinsic(ahead, 0.5), base) == pytest.approx([0.164, 0.0], abs=1e-9)
    assert not camera_offset(extrinsic(base[:2] + 2e-7, 0.5), base).any()
    depth = np.full((48, 64), 3.0, np.float32)  # a wall 3 m ahead
    k = np.array([[32.0, 0.0, 32.0], [0.0, 32.0, 24.0], [0.0, 0.0, 1.0]])
    params = FrontierParams(robot_radius=FETCH.footprint_radius)
    plain = OccupancyMap(base[:2], extent=10.0)
    plain.integrate(depth, k, extrinsic(ahead, 0.5), stride=4)
    rc = plain.cell(base[:2])
    assert plain.grid[rc[0], rc[1]] == UNKNOWN and plain.seen is None
    m = OccupancyMap(base[:2], extent=10.0)
    m.integrate(depth, k, extrinsic(ahead, 0.5), stride=4, base_xy=base[:2])
    disc = m.disc_cells(base[:2], 0.164)
    assert len(disc) > 30 and (m.grid[disc[:, 0], disc[:, 1]] == FREE).all()
    seen = m.cell(ahead + 1.0 * np.array([math.cos(0.5), math.sin(0.5)]))  # 1 m ahead of the camera
    assert not m.seen[rc[0], rc[1]] and m.seen[seen[0], seen[1]]

    def nearest_frontier(occ):
        field = PlanField.compute(occ, base[:2], params.inflate_cells)
        return min(c.path_length for c in FrontierPlanner(params, None).candidates(field))

    assert nearest_frontier(m) >= 0.15  # where the camera's view ends
    m.seen = None  # were the freed disc seen, its edge beside the base would be the nearest frontier
    assert nearest_frontier(m) < 0.15
