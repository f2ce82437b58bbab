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
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()) == [
        "objectnav/one/one.json.gz",
        "objectnav/two/two.json.gz",
        "scenes/biovln.scene_dataset_config.json",
        "scenes/lab_s150_v0.glb",
        "scenes/lab_s154_v0.glb",
    ]
    config = json.loads((out / "scenes/biovln.scene_dataset_config.json").read_text())
    assert config["stages"]["paths"] == {".glb": ["*.glb"]}
    assert config["stages"]["default_attributes"]["up"] == [0, 1, 0]
    assert (out / "scenes/lab_s154_v0.glb").read_bytes()[:4] == b"glTF"


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
            want[f"{scene}.glb_{o.category}"].append(o.id)
    got = {k: [g["object_id"] for g in v] for k, v in data["goals_by_category"].items()}
    assert got == {k: sorted(v) for k, v in want.items()}
    assert split != "two" or len(got["lab_s150_v0.glb_centrifuge"]) == 2
    config = (out / "scenes" / "biovln.scene_dataset_config.json").as_posix()
    for mine, ep in zip(ours, data["episodes"]):
        assert ep["scene_id"] == str(out / "scenes" / f"{mine['scene_id']}.glb")
        assert ep["scene_dataset_config"] == config
        assert (ep["episode_id"], ep["object_category"]) == (mine["episode_id"], mine["object_category"])
        assert ep["info"] == {**mine["info"], "target_object_id": mine["object_id"]}
        _check_position(mine["start_position"], ep["start_position"])
        _check_rotation(mine["start_rotation"], ep["start_rotation"])
        target = mine["goals"][0]
        goal = next(g for g in ep["goals"] if g["object_id"] == target["object_id"])
        assert goal["object_category"] == target["object_category"] and goal["radius"] == target["radius"]
        _check_position(target["position"], goal["position"])
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
