"""`biovln-ms dataset export habitat`: an ObjectNav-v1 dataset as habitat-lab reads it.

habitat-lab cannot be imported here: every release on the package index imports habitat-sim (``magnum``,
``habitat_sim``, not on the index) from ``import habitat``, and the ones before 0.3.3 also fail on
Python 3.11 in ``habitat.config.default_structured_configs``. So the export is read as habitat-lab 0.3.3's
``ObjectNavDatasetV1.from_json`` reads it, with the field names of its attrs classes (below).
"""

from __future__ import annotations

import gzip
import json
import math
import os
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from biovln_ms.cli import app
from biovln_ms.episodes.dataset import EpisodeDataset

# habitat-lab 0.3.3: habitat/core/dataset.py (Episode), habitat/tasks/nav/nav.py (NavigationEpisode,
# NavigationGoal), habitat/tasks/nav/object_nav_task.py (ObjectGoalNavEpisode, ObjectGoal,
# ObjectViewLocation), habitat/core/simulator.py (AgentState). Keys outside a class's fields are a
# TypeError there; the required ones have no default or a not-None validator.
EPISODE_FIELDS = {
    "episode_id", "scene_id", "scene_dataset_config", "additional_obj_config_paths", "start_position",
    "start_rotation", "info", "goals", "start_room", "shortest_paths", "object_category",
}  # fmt: skip
EPISODE_REQUIRED = {"episode_id", "scene_id", "start_position", "start_rotation", "goals"}
GOAL_FIELDS = {
    "position", "radius", "object_id", "object_name", "object_name_id", "object_category", "room_id",
    "room_name", "view_points",
}  # fmt: skip
GOAL_REQUIRED = {"position", "object_id"}
SCENE = ".scene_instance.json"
SCENE_FILES = (".glb", ".overhead.glb", ".semantic.glb", ".semantic.txt", ".stage_config.json",
               ".overhead.object_config.json", SCENE)  # fmt: skip
VIEW_POINT_FIELDS = {"agent_state", "iou"}  # both required (positional, no defaults)
AGENT_STATE_FIELDS = {"position", "rotation"}  # position required

SPLITS = {"one": {154: 5}, "two": {154: 4, 150: 7}}  # seed 150: two centrifuges


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> tuple[EpisodeDataset, Path]:
    from biovln_ms.splits import FOUR_CATEGORIES
    from biovln_ms.episodes.writer import SplitPlan, write_dataset
    from biovln_ms.scene.generator import generate_scene

    base = tmp_path_factory.mktemp("habitat")
    scenes = {s: generate_scene("single_room", s, required_categories=FOUR_CATEGORIES) for s in (150, 154)}
    plans = [SplitPlan(name, [(scenes[s], n, False) for s, n in eps.items()]) for name, eps in SPLITS.items()]
    write_dataset(base / "ds", plans, progress=False)
    for split in SPLITS:
        args = ["dataset", "export", "habitat", "--split", split, "-o", str(base / "out")]
        r = CliRunner().invoke(app, [*args, "--dataset", str(base / "ds")])
        assert r.exit_code == 0, r.output
    return EpisodeDataset(base / "ds"), base / "out"


def load_objectnav(path: Path, scenes_dir: Path) -> dict:
    """What habitat-lab's ObjectNavDatasetV1.from_json checks and builds, as plain dicts."""
    d = json.loads(gzip.decompress(path.read_bytes()))
    assert d["category_to_task_category_id"].keys() == d["category_to_scene_annotation_category_id"].keys()
    for goals in d["goals_by_category"].values():
        for g in goals:
            assert GOAL_REQUIRED <= g.keys() <= GOAL_FIELDS and g["object_id"] is not None
            for v in g["view_points"]:
                assert v.keys() == VIEW_POINT_FIELDS and v["agent_state"].keys() == AGENT_STATE_FIELDS
    for ep in d["episodes"]:
        assert EPISODE_REQUIRED <= ep.keys() <= EPISODE_FIELDS
        assert all(ep[k] is not None for k in EPISODE_REQUIRED)
        ep["scene_id"] = os.path.join(scenes_dir, ep["scene_id"])
        ep["goals"] = d["goals_by_category"][f"{os.path.basename(ep['scene_id'])}_{ep['object_category']}"]
    return d


def _rotate(q_xyzw, v) -> np.ndarray:
    """``v`` turned by the unit quaternion ``q`` ([x, y, z, w])."""
    u, w = np.asarray(q_xyzw[:3]), q_xyzw[3]
    return v + 2 * np.cross(u, np.cross(u, v) + w * np.asarray(v))


def _check_position(ours: list[float], theirs: list[float]) -> None:
    """Our Z-up (x, y, z) is habitat's Y-up (x, z, -y), within 1e-6."""
    x, y, z = ours
    assert np.allclose(theirs, [x, z, -y], rtol=0, atol=1e-6)


def _check_rotation(ours: list[float], theirs: list[float]) -> None:
    """Our yaw ([w, x, y, z] about +z, forward +x) is habitat's unit [x, y, z, w] about +y, forward -z (both
    rounded to 6 decimals: headings agree within 5e-6)."""
    assert theirs[0] == theirs[2] == 0.0 and theirs[3] >= 0 and abs(math.hypot(*theirs) - 1) < 2e-6
    yaw = 2 * math.atan2(ours[3], ours[0])
    forward = _rotate(theirs, np.array([0.0, 0.0, -1.0]))
    forward /= np.linalg.norm(forward)
    assert np.allclose(forward, [math.cos(yaw), 0.0, -math.sin(yaw)], rtol=0, atol=5e-6)


def test_layout(exported):
    _, out = exported
    scenes = [f"scenes/lab_s{s}_v0{suffix}" for s in (150, 154) for suffix in SCENE_FILES]
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()) == sorted(
        ["objectnav/one/one.json.gz", "objectnav/two/two.json.gz", "scenes/biovln.scene_dataset_config.json"]
        + scenes
    )
    config = json.loads((out / "scenes/biovln.scene_dataset_config.json").read_text())
    assert config["stages"]["paths"] == {".json": ["*.stage_config.json"]}
    assert config["stages"]["default_attributes"]["up"] == [0, 1, 0]
    assert config["scene_instances"]["paths"] == {".json": ["*.scene_instance.json"]}
    semantic = config["semantic_scene_descriptor_instances"]
    assert semantic == {f"lab_s{s}_v0": f"lab_s{s}_v0.semantic.txt" for s in (150, 154)}
    for name in scenes:
        path = out / name
        assert path.read_bytes()[:4] == b"glTF" if name.endswith(".glb") else path.stat().st_size > 0
    instance = json.loads((out / "scenes/lab_s154_v0.scene_instance.json").read_text())
    assert instance["stage_instance"]["template_name"] == "lab_s154_v0.stage_config.json"
    assert instance["semantic_scene_instance"] in semantic
    (overhead,) = instance["object_instances"]
    assert overhead["motion_type"] == "STATIC" and overhead["translation_origin"] == "asset_local"
    stage = json.loads((out / "scenes/lab_s154_v0.stage_config.json").read_text())
    for key in ("render_asset", "semantic_asset", "semantic_descriptor_filename"):
        assert (out / "scenes" / stage[key]).is_file()


@pytest.mark.parametrize("split", SPLITS)
def test_episodes_goals_and_poses_match_ours(exported, split, catalog):
    ds, out = exported
    data = load_objectnav(out / "objectnav" / split / f"{split}.json.gz", out / "scenes")
    ours = list(ds.episodes(split))
    assert len(data["episodes"]) == len(ours) == sum(SPLITS[split].values())
    assert data["category_to_task_category_id"] == {c: i for i, c in enumerate(catalog.goal_categories())}
    # goals per category: every instrument of the category in the scene (all of them are targeted here)
    want = defaultdict(list)
    for scene in ds.split_info(split)["scenes"]:
        for o in ds.spec(scene).goal_objects():
            want[f"{scene}{SCENE}_{o.category}"].append(o.id)
    got = {k: [g["object_name"] for g in v] for k, v in data["goals_by_category"].items()}
    assert got == {k: sorted(v) for k, v in want.items()}
    assert split != "two" or len(got["lab_s150_v0.scene_instance.json_centrifuge"]) == 2
    config = (out / "scenes" / "biovln.scene_dataset_config.json").as_posix()
    for mine, ep in zip(ours, data["episodes"]):
        assert ep["scene_id"] == str(out / "scenes" / f"{mine['scene_id']}{SCENE}")
        assert ep["scene_dataset_config"] == config
        assert (ep["episode_id"], ep["object_category"]) == (mine["episode_id"], mine["object_category"])
        assert ep["info"] == {**mine["info"], "target_object_id": mine["object_id"]}
        _check_position(mine["start_position"], ep["start_position"])
        _check_rotation(mine["start_rotation"], ep["start_rotation"])
        target = mine["goals"][0]
        goal = next(g for g in ep["goals"] if g["object_name"] == target["object_id"])
        assert goal["object_category"] == target["object_category"] and goal["radius"] == target["radius"]
        assert isinstance(goal["object_id"], int)
        # position: the object's centre (inside its footprint, above the floor); view point 0: our goal
        o = ds.spec(mine["scene_id"]).get(target["object_id"])
        x, y, z = goal["position"]
        assert (
            abs(x - o.position[0]) < o.size[0] + o.size[1] and abs(-z - o.position[1]) < o.size[0] + o.size[1]
        )
        assert 0 < y < 3
        _check_position(target["position"], goal["view_points"][0]["agent_state"]["position"])
        assert len(goal["view_points"]) == len(target["view_points"])
        for v_ours, v in zip(target["view_points"], goal["view_points"]):
            _check_position(v_ours["agent_state"]["position"], v["agent_state"]["position"])
            _check_rotation(v_ours["agent_state"]["rotation"], v["agent_state"]["rotation"])


def test_export_is_deterministic(exported):
    from biovln_ms.bridges.habitat import export_habitat

    ds, out = exported
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}  # the CLI's
    files = [p for split in SPLITS for p in export_habitat(ds, split, out)]
    assert set(files) == set(before) and {p: p.read_bytes() for p in files} == before


def test_unknown_format_and_split_are_one_line_errors(exported, tmp_path):
    from biovln_ms.cli import user_error_line

    ds, _ = exported
    for fmt, split, expected in (
        ("habitatt", "one", "unknown export format 'habitatt' (fix: use one of: habitat)"),
        ("habitat", "nope", "unknown split 'nope' (fix: use one of: one, two)"),
    ):
        args = ["dataset", "export", fmt, "--split", split, "-o", str(tmp_path), "--dataset", str(ds.root)]
        r = CliRunner().invoke(app, args)
        line = user_error_line(r.exception)
        assert expected in line and "\n" not in line
    assert not any(tmp_path.iterdir())


def _glb(path: Path) -> tuple[dict, bytes]:
    from biovln_ms.scene.export_glb import _chunks

    gltf, binary = _chunks(path.read_bytes())
    return gltf, bytes(binary)


def _triangles(path: Path, skip: str = "") -> np.ndarray:
    """Every triangle of a GLB (``[n, 3, 3]``, world Y-up, in the file's winding), nodes under ``skip``
    left out."""
    import trimesh

    scene = trimesh.load(path, force="scene")
    tris = [
        trimesh.transform_points(scene.geometry[geom].vertices, tf)[scene.geometry[geom].faces]
        for node in scene.graph.nodes_geometry
        if not (skip and node.startswith(skip))
        for tf, geom in [scene.graph[node]]
    ]
    return np.concatenate(tris)


def _keys(tris: np.ndarray) -> set:
    """Triangles as orientation-free keys: their corners, rounded and sorted."""
    return {tuple(sorted(map(tuple, t))) for t in np.round(tris, 4)}


def test_stage_has_no_walkable_surface_above_the_floor(exported):
    """Recast (habitat-sim's navmesh) walks a triangle whose winding normal is within 45 degrees of up.
    In the stage none lies above 0.1 m (no roof, no bench or instrument top) while the floor, walls and
    furniture stay; the overhead object renders the ceiling and, with their upward winding, exactly the
    tops the stage reversed."""
    from biovln_ms.bridges.habitat_scene import WALKABLE_HEIGHT, walkable_tops

    _, out = exported
    for scene in ("lab_s150_v0", "lab_s154_v0"):
        stage = _triangles(out / "scenes" / f"{scene}.glb")
        flat = stage.reshape(-1, 3)
        faces = np.arange(len(flat)).reshape(-1, 3)
        assert not walkable_tops(flat, faces).any()
        normal = np.cross(stage[:, 1] - stage[:, 0], stage[:, 2] - stage[:, 0])
        floor = (normal[:, 1] > 0) & (np.abs(stage[:, :, 1]).max(axis=1) < 1e-6)
        assert np.linalg.norm(normal[floor], axis=1).sum() / 2 > 20  # the 8 x 6 m room's floor
        assert stage[:, :, 1].max() > 2  # walls and tall furniture are still there
        assert "ceiling" not in {n["name"] for n in _glb(out / "scenes" / f"{scene}.glb")[0]["nodes"]}

        overhead = out / "scenes" / f"{scene}.overhead.glb"
        assert "ceiling" in {n["name"] for n in _glb(overhead)[0]["nodes"]}
        tops = _triangles(overhead, skip="ceiling/")
        flat = tops.reshape(-1, 3)
        assert len(tops) and walkable_tops(flat, np.arange(len(flat)).reshape(-1, 3)).all()
        assert tops[:, :, 1].min() > WALKABLE_HEIGHT
        reversed_in_stage = stage[(normal[:, 1] < 0) & (stage[:, :, 1].max(axis=1) > WALKABLE_HEIGHT)]
        assert _keys(tops) <= _keys(reversed_in_stage)


def _semantic_rows(path: Path) -> dict[int, tuple[int, str, int]]:
    """An HM3D-format descriptor as ``{instance id: (colour, category, region)}``."""
    lines = path.read_text().splitlines()
    assert lines[0] == "HM3D Semantic Annotations"
    rows = {}
    for line in lines[1:]:
        head, category, region = line.split('"')
        iid, color = head.rstrip(",").split(",")
        rows[int(iid)] = (int(color, 16), category, int(region.lstrip(",")))
    return rows


def test_semantics_are_habitat_instance_annotations(exported, catalog):
    """The descriptor lists every instance (ids 1..N, distinct non-black colours); each semantic-mesh
    instance's float vertex colour, converted to sRGB as habitat-sim does (Magnum's toSrgb, then packed
    to 8 bits), is its descriptor colour; goal object_ids are those instances; the annotation category
    ids are the order of the written GLB's semantic_colors."""
    from biovln_ms.bridges.habitat_scene import instance_color

    ds, out = exported
    data = load_objectnav(out / "objectnav/two/two.json.gz", out / "scenes")
    for scene in ("lab_s150_v0", "lab_s154_v0"):
        rows = _semantic_rows(out / "scenes" / f"{scene}.semantic.txt")
        colors = [c for c, _, _ in rows.values()]
        assert sorted(rows) == list(range(1, len(rows) + 1)) and len(set(colors)) == len(rows)
        assert 0 not in colors
        gltf, binary = _glb(out / "scenes" / f"{scene}.semantic.glb")
        assert len(gltf["nodes"]) == len(rows)
        for iid, node in enumerate(gltf["nodes"], start=1):
            acc = gltf["accessors"][gltf["meshes"][node["mesh"]]["primitives"][0]["attributes"]["COLOR_0"]]
            assert (acc["componentType"], acc["type"]) == (5126, "VEC3")
            view = gltf["bufferViews"][acc["bufferView"]]
            lin = np.frombuffer(binary, np.float32, acc["count"] * 3, view["byteOffset"]).reshape(-1, 3)
            srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin.astype(float) ** (1 / 2.4) - 0.055)
            packed = {tuple(c) for c in np.round(srgb * 255).astype(int)}
            assert packed == {instance_color(iid)}
            c = rows[iid][0]
            assert instance_color(iid) == ((c >> 16) & 255, (c >> 8) & 255, c & 255)
        objects = {o.id: o for o in ds.spec(scene).objects()}
        for name, o in objects.items():
            iid = next(i for i, n in enumerate(gltf["nodes"], start=1) if n["name"] == name)
            assert rows[iid][1] == o.category
        for key, goals in data["goals_by_category"].items():
            for g in goals if key.startswith(scene) else ():
                assert gltf["nodes"][g["object_id"] - 1]["name"] == g["object_name"]
                assert rows[g["object_id"]][1] == g["object_category"]
    order = list(_glb(out / "scenes/lab_s154_v0.glb")[0]["asset"]["extras"]["semantic_colors"])
    assert order == sorted(order)  # the GLB's JSON is written with sorted keys
    want = {c: order.index(c) for c in catalog.goal_categories()}
    assert data["category_to_scene_annotation_category_id"] == want


def test_habitat_lab_reads_the_export(exported):
    """scripts/check_habitat_export.py with habitat-lab: in this Python when it has habitat-lab, else with
    the Python ``$HABITAT_LAB_PYTHON`` names (a separate venv, as the script's docstring sets up); skipped
    when neither has it (habitat-lab is not a dependency)."""
    import importlib.util
    import subprocess
    import sys

    _, out = exported
    script = Path(__file__).parents[1] / "scripts" / "check_habitat_export.py"
    if importlib.util.find_spec("habitat") is not None:
        python = sys.executable
    elif os.environ.get("HABITAT_LAB_PYTHON"):
        python = os.environ["HABITAT_LAB_PYTHON"]
    else:
        pytest.skip("habitat-lab is not installed here and $HABITAT_LAB_PYTHON is not set")
    r = subprocess.run([python, str(script), str(out)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    lines = r.stdout.splitlines()
    assert [line.split(":")[0] for line in lines] == list(SPLITS) and all(": ok (" in line for line in lines)
