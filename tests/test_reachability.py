"""Reachability of the interaction points by Fetch: the catalog's points, the reach
check (IK on Fetch's URDF, collisions), the ``reachable`` / ``reach_success`` measures at STOP, their
aggregation and report, and the navigation-to-manipulation hand-off (physx_cpu)."""

from __future__ import annotations

import json
import math

import gymnasium as gym
import numpy as np
import pytest

import biovln_ms  # noqa: F401
from biovln_ms.catalog import load_catalog
from biovln_ms.errors import BioVLNError, CatalogError
from biovln_ms.paths import CATALOG_PATH
from biovln_ms.sim.reach import (
    APPROACH_TOLERANCE_DEG,
    POSITION_TOLERANCE,
    Box,
    FetchArm,
    ReachError,
    interaction_point,
    object_box,
    scene_boxes,
)

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
FACE_BACK = np.array([-1.0, 0.0])  # an instrument ahead (+x) whose face looks back at the robot


@pytest.fixture(scope="module")
def arm() -> FetchArm:
    return FetchArm.load()


def _approach(arm: FetchArm, q: np.ndarray, face: np.ndarray) -> float:
    axis = arm.tcp_pose(q).to_transformation_matrix()[:3, 0]
    inward = -np.array([face[0], face[1], 0.0]) / np.linalg.norm(face)
    return math.degrees(math.acos(float(np.clip(axis @ inward, -1, 1))))


def _within_limits(arm: FetchArm, q: np.ndarray) -> bool:
    lo, hi = np.array([b[0] for b in arm.bounds]), np.array([b[1] for b in arm.bounds])
    return bool(np.all(q[arm.free] >= lo - 1e-9) and np.all(q[arm.free] <= hi + 1e-9))


# --- the catalog's interaction points ---------------------------------------------------------------
def test_every_goal_category_has_an_interaction_point_inside_its_bounds_on_the_face_side(catalog):
    for name in catalog.goal_categories():
        a = catalog.get(name)
        assert a.interaction is not None, f"{name}: no interaction point"
        p = np.asarray(a.interaction.point)
        assert np.all(np.abs(p) <= np.asarray(a.dimensions) / 2 + 1e-9), name
        assert float(p[:2] @ a.face_vector) > 0, f"{name}: {p} is not on the {a.face} side"
        assert a.interaction.label and "\n" not in a.interaction.rationale


def _write(tmp_path, name, point):
    obj = json.loads(CATALOG_PATH.read_text())
    i = next(i for i, a in enumerate(obj["assets"]) if a["name"] == name)
    obj["assets"][i]["interaction"]["point"] = point
    path = tmp_path / "catalog.json"
    path.write_text(json.dumps(obj))
    return path, i


@pytest.mark.parametrize(
    "point, words",
    [([0.36, -0.6, 0.025], "outside the asset's bounds"), ([0.36, 0.3, 0.025], "is not on the -Y side")],
)
def test_a_misplaced_interaction_point_is_a_one_line_catalog_error(tmp_path, point, words):
    path, i = _write(tmp_path, "refrigerator", point)
    with pytest.raises(CatalogError) as e:
        load_catalog(path)
    msg = str(e.value)
    assert f"field 'assets[{i}].interaction'" in msg and words in msg and "\n" not in msg


def test_interaction_points_follow_the_instrument_into_the_world():
    from biovln_ms.scene.generator import generate_scene

    spec = generate_scene("single_room", 154, robot_radius=0.29)
    for o in spec.instruments:
        p = interaction_point(o)
        box = object_box(o)
        assert box.distance(p) < 1e-9, o.id  # inside its Zone-1 box
        local = np.asarray(load_catalog().get(o.category).interaction.point)
        assert math.isclose(p[2] - o.position[2], local[2], abs_tol=1e-9)
        assert float((p[:2] - np.asarray(o.position[:2])) @ np.asarray(o.face)) > 0  # on the face's side
    walls = [b for b in scene_boxes(spec) if b.name in {w.id for w in spec.walls}]
    assert len(walls) == len(spec.walls)


# --- the reach check -------------------------------------------------------------------------------
def test_ik_reaches_a_point_in_front_of_fetch_and_refuses_one_3_m_away(arm):
    point = np.array([0.75, 0.0, 0.9])
    r = arm.reach((0.0, 0.0, 0.0), point, FACE_BACK, [], "target")
    assert r.reachable and r.reason == "reached"
    assert np.linalg.norm(arm.tcp_pose(r.qpos).p - point) <= POSITION_TOLERANCE
    assert _approach(arm, r.qpos, FACE_BACK) <= APPROACH_TOLERANCE_DEG
    assert _within_limits(arm, r.qpos)
    assert np.allclose(r.qpos[:3], 0.0)  # the base stays where it stopped
    # the same point from a base turned and moved: the world frame is the planar joints'
    yaw = 2.0
    base = point[:2] - 0.75 * np.array([math.cos(yaw), math.sin(yaw)])
    face = -np.array([math.cos(yaw), math.sin(yaw)])
    moved = arm.reach((*base, yaw), point, face, [], "target")
    assert moved.reachable and np.linalg.norm(arm.tcp_pose(moved.qpos).p - point) <= POSITION_TOLERANCE
    far = arm.reach((0.0, 0.0, 0.0), np.array([3.0, 0.0, 0.9]), FACE_BACK, [], "target")
    assert not far.reachable and far.reason == "out of reach"
    high = arm.reach((0.0, 0.0, 0.0), np.array([0.6, 0.0, 2.4]), FACE_BACK, [], "target")
    assert not high.reachable and high.position_error > POSITION_TOLERANCE


def test_a_box_in_the_way_blocks_the_reach_and_the_target_may_be_touched(arm):
    point = np.array([0.75, 0.0, 0.9])
    screen = Box("screen", (0.55, 0.0, 0.75), 0.0, (0.02, 0.6, 0.75))  # a panel between robot and point
    r = arm.reach((0.0, 0.0, 0.0), point, FACE_BACK, [screen], "target")
    assert not r.reachable and r.reason == "collision" and r.blocked_by.startswith("screen")
    # the instrument itself, its face at the point: the gripper may touch it, nothing else does
    instrument = Box("target", (1.0, 0.0, 0.6), 0.0, (0.25, 0.4, 0.6))
    ok = arm.reach((0.0, 0.0, 0.0), point, FACE_BACK, [instrument], "target")
    assert ok.reachable
    assert arm.collision(ok.qpos, [instrument], "another")  # were it not the target, the gripper hits it


def test_self_and_floor_collisions_are_found(arm):
    def q(**joints):
        out = arm.seeds[0].copy()
        for name, v in joints.items():
            out[arm.joint_names.index(name)] = v
        return out

    assert arm.collision(arm.seeds[0], [], "") == ""  # the tuck pose is free
    folded = q(shoulder_pan_joint=0.0, shoulder_lift_joint=1.3, elbow_flex_joint=1.5, wrist_flex_joint=1.5)
    assert arm.collision(folded, [], "").startswith("self (")
    down = q(shoulder_pan_joint=0.0, shoulder_lift_joint=1.5, elbow_flex_joint=0.0, wrist_flex_joint=0.0)
    assert arm.collision(down, [], "").startswith("floor (")


def test_a_category_without_an_interaction_point_is_a_one_line_error(tmp_path, monkeypatch):
    import biovln_ms.sim.reach as reach
    from biovln_ms.scene.generator import generate_scene

    o = generate_scene("single_room", 154, robot_radius=0.29).instruments[0]
    obj = json.loads(CATALOG_PATH.read_text())
    next(a for a in obj["assets"] if a["name"] == o.category).pop("interaction")
    (tmp_path / "catalog.json").write_text(json.dumps(obj))
    monkeypatch.setattr(reach, "load_catalog", lambda: load_catalog(tmp_path / "catalog.json"))
    with pytest.raises(ReachError) as e:
        interaction_point(o)
    assert "field 'interaction'" in str(e.value) and "\n" not in str(e.value)


# --- the measures at STOP ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def fetch_data(tmp_path_factory):
    from biovln_ms.splits import FOUR_CATEGORIES
    from biovln_ms.episodes.writer import SplitPlan, write_dataset
    from biovln_ms.scene.generator import generate_scene

    root = tmp_path_factory.mktemp("data") / "fetch"
    s = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES, robot_radius=0.29)
    write_dataset(root, [SplitPlan("ms_val", [(s, 4, False)])], False, "fetch")
    return root


@pytest.fixture(scope="module")
def fetch_env(fetch_data):
    env = gym.make("BioVLN-OpFace-v0", robot_uids="fetch", dataset=str(fetch_data), split="ms_val", **CPU)
    yield env
    env.close()


def _oracle_episode(env, index: int) -> list[dict]:
    from biovln_ms.baselines.oracle import OraclePolicy
    from biovln_ms.eval.rollout import rollout

    return [st.info for st in rollout(env, OraclePolicy(), index, privileged=True)]


@pytest.mark.slow
def test_reachable_is_decided_at_stop_in_a_scripted_episode(fetch_env):
    u = fetch_env.unwrapped
    infos = _oracle_episode(fetch_env, 0)
    assert all(not bool(i["reachable"]) for i in infos[:-1])  # not before the STOP
    end = infos[-1]
    assert bool(end["stopped"]) and bool(end["success"])
    assert bool(end["reach_success"]) == (bool(end["success"]) and bool(end["reachable"]))
    q = u.reach_configuration()
    assert bool(end["reachable"]) == (q is not None)
    obj = u.scene_spec.get(u.current_episode["object_id"])
    if q is not None:  # the reaching configuration puts the TCP on the point, from the final base pose
        arm = FetchArm.load()
        assert np.linalg.norm(arm.tcp_pose(q).p - interaction_point(obj)) <= POSITION_TOLERANCE
        assert np.allclose(q[:3], end["agent_pose"][0].numpy(), atol=1e-4)
    # a STOP where the episode starts, meters from the instrument: not reachable, no reach success
    fetch_env.reset(options={"episode_index": 1})
    _, _, _, _, info = fetch_env.step(0)
    start = np.asarray(u.current_episode["start_position"][:2])
    if np.linalg.norm(start - interaction_point(u.scene_spec.get(u.current_episode["object_id"]))[:2]) > 1.5:
        assert not bool(info["reachable"]) and not bool(info["reach_success"])
    state = fetch_env.unwrapped.get_state_dict()  # the measure's state (verdict, configuration) replays
    assert "reachable" in state["task"]["measures"]


def test_the_cylinder_has_no_reach_measures(held_out_dataset):
    env = gym.make("BioVLN-OpFace-v0", dataset=held_out_dataset(ms_val=1), split="ms_val", **CPU)
    try:
        _, info = env.reset(options={"episode_index": 0})
        _, _, _, _, info = env.step(0)
        assert "reachable" not in info and "reach_success" not in info
        assert env.unwrapped.reach_configuration() is None
    finally:
        env.close()


# --- aggregation and report --------------------------------------------------------------------------
def _rec(cat: str, success: bool, reachable: bool | None) -> dict:
    r = dict(success=success, spl=0.5 * success, soft_spl=0.5, dtg=0.3, steps=10, mcr=0.6, vrt=0.1)
    r.update(strict_success=False, object_category=cat, difficulty="easy")
    if reachable is not None:
        r.update(reachable=reachable, reach_success=success and reachable)
    return r


def test_reach_sr_and_reachable_successes_are_aggregated_and_reported():
    from biovln_ms.eval.aggregate import aggregate
    from biovln_ms.eval.paper_tables import reach_table
    from biovln_ms.eval.report import summarize

    fetch = [_rec("cabinet", True, True), _rec("cabinet", True, False), _rec("refrigerator", False, True)]
    fetch.append({"error": "boom", "object_category": "cabinet"})
    a = aggregate(fetch)
    assert a["reach_successes"] == 1 and a["successes"] == 2 and a["episodes"] == 4
    assert a["reach_sr"] == 25.0 and a["reachable_of_successes"] == 50.0
    assert a["reach_sr_ci95"][0] < 25.0 < a["reach_sr_ci95"][1]
    cylinder = aggregate([_rec("cabinet", True, None)])
    assert cylinder["reach_successes"] is None and math.isnan(cylinder["reach_sr"])
    summ = summarize({("oracle-fetch", "ms_val"): fetch, ("oracle", "ms_val"): [_rec("cabinet", True, None)]})
    assert (
        "reach" in summ["runs"]["oracle-fetch"]["ms_val"] and "reach" not in summ["runs"]["oracle"]["ms_val"]
    )
    text = "\n".join(reach_table(summ))
    assert "oracle-fetch" in text and "| cabinet | 2 | 50.0" in text
    assert reach_table(summarize({("oracle", "ms_val"): [_rec("cabinet", True, None)]})) == []


def test_eval_config_takes_a_robot():
    from biovln_ms.eval.harness import EvalConfig

    cfg = EvalConfig("oracle", "ms_val", "out", robot="fetch")
    assert cfg.run_name == "oracle-fetch"
    assert EvalConfig("frontier", "ms_val", "out", robot="fetch", noise="realistic").run_name == (
        "frontier-fetch+realistic"
    )
    assert EvalConfig("oracle", "ms_val", "out").run_name == "oracle"
    with pytest.raises(BioVLNError, match="field 'robot': unknown robot 'panda'"):
        EvalConfig("oracle", "ms_val", "out", robot="panda")


# --- the hand-off ------------------------------------------------------------------------------------
@pytest.mark.slow
def test_handoff_is_exported_and_restored_in_a_fresh_env(fetch_data, tmp_path):
    from biovln_ms.eval.handoff import HANDOFF_SCHEMA, HandoffError, load_handoff, restore_handoff
    from biovln_ms.eval.harness import EvalConfig, evaluate, load_records

    cfg = EvalConfig(
        "oracle",
        "ms_val",
        str(tmp_path / "res"),
        dataset=str(fetch_data),
        workers=1,
        robot="fetch",
        handoff_dir=str(tmp_path / "handoff"),
    )
    summary = evaluate(cfg, progress=False)
    recs = load_records(cfg.run_dir / "episodes.jsonl")
    assert all("handoff" not in r and r["robot"] == "fetch" and "reachable" in r for r in recs)
    assert summary["overall"]["reach_successes"] == sum(r["reach_success"] for r in recs)
    files = sorted((tmp_path / "handoff" / "oracle-fetch" / "ms_val").glob("*/*.json"))
    assert len(files) == sum(r["success"] for r in recs) > 0
    assert not list((tmp_path / "handoff").rglob("*.tmp*"))  # written atomically: no leftovers
    h = load_handoff(files[0])
    assert h["schema"] == HANDOFF_SCHEMA and h["success"] and h["robot"] == "fetch"
    pose = h["base_pose_instrument"]
    assert math.isclose(
        math.hypot(pose["x"], pose["y"]),
        math.hypot(
            *(
                np.array([h["base_pose_world"]["x"], h["base_pose_world"]["y"]])
                - np.array(h["instrument"]["center"][:2])
            )
        ),
        abs_tol=1e-6,
    )
    assert len(h["joints"]["names"]) == len(h["joints"]["qpos"]) == 15

    env = gym.make("BioVLN-OpFace-v0", robot_uids="fetch", dataset=str(fetch_data), split="ms_val", **CPU)
    try:
        u = env.unwrapped
        restore_handoff(env, files[0])
        b = h["base_pose_world"]
        assert np.allclose(u.agent.planar_pose()[0], [b["x"], b["y"], b["yaw"]], atol=1e-4)
        assert np.allclose(u.agent.robot.get_qpos()[0].numpy(), h["joints"]["qpos"], atol=1e-4)
        # the reach from the restored pose, as the check at STOP found it
        result, _ = u._reach(0, np.array([b["x"], b["y"], b["yaw"]]))
        assert result.reachable == h["reachable"]
        if h["reach_qpos"] is not None:  # the reaching arm puts the simulator's gripper on the point
            restore_handoff(env, files[0], arm="reach")
            tcp = u.agent.robot.links_map["gripper_link"].pose.p[0].numpy()
            assert (
                np.linalg.norm(tcp - np.array(h["instrument"]["interaction_point_world"]))
                <= POSITION_TOLERANCE
            )
        with pytest.raises(HandoffError, match="unknown arm state"):
            restore_handoff(env, files[0], arm="up")
    finally:
        env.close()
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"schema": "other"}))
    with pytest.raises(HandoffError, match="field 'schema'"):
        load_handoff(bad)
