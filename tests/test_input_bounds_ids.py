"""Ids that become file names are ids: an episode's ids in a dataset, a recording's frame names, an
imported scene's name; each refusal is one line naming the field and the fix. The report's run names are
names only, never an evaluation config with an empty split or folder."""

from __future__ import annotations

import copy
import gzip
import hashlib
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from pydantic import ValidationError

from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset
from biovln_ms.episodes.schema import EPISODES
from biovln_ms.episodes.writer import SplitPlan, gz_json, write_dataset
from biovln_ms.errors import BioVLNError
from biovln_ms.limits import MAX_ID_LENGTH
from biovln_ms.scene.generator import generate_scene
from biovln_ms.splits import FOUR_CATEGORIES

GOAL = {
    "position": [2.0, 2.0, 0.0],
    "radius": 1.0,
    "object_id": "centrifuge_0",
    "object_category": "centrifuge",
    "eq1_goal": [2.0, 2.0],
    "view_points": [],
}
EPISODE = {
    "episode_id": "0",
    "scene_id": "lab_s154_v0",
    "start_position": [1.0, 1.0, 0.0],
    "start_rotation": [1.0, 0.0, 0.0, 0.0],
    "object_category": "centrifuge",
    "object_id": "centrifuge_0",
    "goals": [GOAL],
    "info": {
        "geodesic_distance": 1.0,
        "euclidean_distance": 1.0,
        "difficulty": "easy",
        "start_clearance": 0.5,
        "start_clearance_fallback": False,
        "cross_room": False,
    },
}
PROTOCOL = {
    "id": "sample_thaw_aliquot",
    "k": 2,
    "instruction": "thaw, then spin",
    "purposes": ["thaw", "spin"],
    "relations": [None, None],
    "needs_relation": 0,
    "legs": [1.0, 1.0],
    "route_length": 2.0,
}
NOT_IDS = ["../../x", "a/b", "a b", "", ".hidden", "x\n", "x" * (MAX_ID_LENGTH + 1)]


def _with(path: tuple, value) -> dict:
    ep = copy.deepcopy(EPISODE)
    ep["protocol"] = copy.deepcopy(PROTOCOL)
    obj = ep
    for key in path[:-1]:
        obj = obj[key]
    obj[path[-1]] = value
    return ep


ID_FIELDS = [
    ("episode_id",),
    ("scene_id",),
    ("object_id",),
    ("object_category",),
    ("goals", 0, "object_id"),
    ("goals", 0, "object_category"),
]


def test_the_reference_episode_is_valid():
    EPISODES.validate_python([_with(("episode_id",), "ms_val.0-a_1")])


@pytest.mark.parametrize("path", ID_FIELDS, ids=lambda p: ".".join(map(str, p)))
@pytest.mark.parametrize("bad", NOT_IDS, ids=repr)
def test_an_episode_id_field_is_an_id(path, bad):
    with pytest.raises(ValidationError):
        EPISODES.validate_python([_with(path, bad)])


def test_a_protocol_id_has_a_length_limit():
    EPISODES.validate_python([_with(("protocol", "id"), "a" * MAX_ID_LENGTH)])
    with pytest.raises(ValidationError):
        EPISODES.validate_python([_with(("protocol", "id"), "a" * (MAX_ID_LENGTH + 1))])


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("ids") / "ds"
    spec = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
    write_dataset(root, [SplitPlan("ms_val", [(spec, 2, False)])], progress=False)
    return root


@pytest.mark.parametrize("key", ["episode_id", "object_id"])
def test_a_dataset_episode_whose_id_leaves_a_folder_is_one_line(small_dataset, tmp_path, key):
    """A crafted episode id (``../..``) would put a hand-off or a recording outside its folder."""
    root = Path(shutil.copytree(small_dataset, tmp_path / "ds"))
    rel = "ms_val/content/lab_s154_v0.json.gz"
    obj = json.loads(gzip.decompress((root / rel).read_bytes()))
    obj["episodes"][1][key] = "../../outside"
    data = gz_json(obj)
    (root / rel).write_bytes(data)
    manifest = json.loads((root / "manifest.json").read_text())
    manifest["splits"]["ms_val"]["files"]["lab_s154_v0"]["sha256"] = hashlib.sha256(data).hexdigest()
    (root / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(DatasetError) as e:
        list(EpisodeDataset(root).episodes("ms_val"))
    text = str(e.value)
    assert "\n" not in text and f"field 'episodes[1].{key}'" in text and "is not an id" in text, text
    assert "'../../outside'" in text and "letters, digits" in text and "(fix: " in text


def test_a_built_dataset_loads_with_its_ids(small_dataset):
    """What the writer makes passes the id rule (the default datasets' ids are of the same kinds)."""
    eps = list(EpisodeDataset(small_dataset).episodes("ms_val"))
    assert [e["episode_id"] for e in eps] == ["0", "1"] and {e["scene_id"] for e in eps} == {"lab_s154_v0"}


# --- recordings ---------------------------------------------------------------------------------------------
def _episode(**ids) -> dict:
    return {**EPISODE, **ids}


def _obs() -> dict:
    return {"sensor_data": {"head": {"rgb": torch.zeros((1, 8, 8, 3), dtype=torch.uint8)}}}


@pytest.mark.parametrize(
    "ids, field",
    [
        ({"scene_id": "../.."}, "scene_id"),
        ({"scene_id": "/tmp"}, "scene_id"),
        ({"episode_id": "../../../x"}, "episode_id"),
        ({"episode_id": "a/b"}, "episode_id"),
        ({"episode_id": ""}, "episode_id"),
    ],
)
def test_a_recording_frame_name_stays_inside_its_folder(tmp_path, ids, field):
    from biovln_ms.learning.recorder import RecordingError, TrajectoryRecorder

    rec = TrajectoryRecorder(tmp_path / "rec", "full")
    with pytest.raises(RecordingError) as e:
        rec.start(_episode(**ids), (2.0, 2.0))
    text = str(e.value)
    assert "\n" not in text and f"field '{field}'" in text and "(fix: " in text, text
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["images", "rec"]  # nothing written anywhere
    TrajectoryRecorder(tmp_path / "trace", "trace").start(_episode(**ids), (2.0, 2.0))  # no file named


def test_a_recording_writes_its_frames_inside_images(tmp_path):
    from biovln_ms.learning.recorder import RecordingError, TrajectoryRecorder, read_recordings

    rec = TrajectoryRecorder(tmp_path, "full")
    rec.start(_episode(episode_id="7", scene_id="lab_s154_v0"), (2.0, 2.0))
    rec.step(0, 1, (1.0, 1.0, 0.0), (2.0, 2.0), 1.4, _obs())
    rec.finish(True)
    assert [p.name for p in (tmp_path / "images").iterdir()] == ["lab_s154_v0_7_0000.png"]
    (entry,) = read_recordings(rec.path)
    assert entry["steps"][0]["obs"]["rgb_path"] == "images/lab_s154_v0_7_0000.png"
    with pytest.raises(RecordingError, match="field 'image_format'"):
        TrajectoryRecorder(tmp_path, "full", image_format="png/../../x")


# --- LSAT: the scene name -----------------------------------------------------------------------------------
def test_a_glb_named_with_a_space_suggests_name(tmp_path):
    from biovln_ms.lsat.designer_scene import target_glb_path

    glb = tmp_path / "My Lab.glb"
    shutil.copyfile(target_glb_path(), glb)
    out = tmp_path / "lab.json"
    cmd = [sys.executable, "-m", "biovln_ms.cli", "lsat", "import", str(glb), "-o", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, check=False)
    err = r.stderr.strip()
    assert r.returncode == 2 and "\n" not in err and "Traceback" not in err, r.stderr
    assert "field '--name'" in err and "'My Lab'" in err and "--name My_Lab" in err, err
    assert "authoring tool" not in err  # not the node problems' hint
    assert not out.exists()
    assert "is not an id" in (tmp_path / "lab.report.md").read_text()  # the report is written all the same


@pytest.mark.parametrize(
    "stem, name, suggested",
    [("My Lab (v2)", None, "My_Lab_v2"), ("lab", "../lab", "lab"), ("lab", "a" * 200, "a" * MAX_ID_LENGTH)],
)
def test_a_scene_name_that_is_not_an_id_is_refused_before_the_glb_is_read(tmp_path, stem, name, suggested):
    from biovln_ms.lsat.importer import LSATImportError, import_glb

    glb = tmp_path / f"{stem}.glb"  # not even a GLB: the name is checked first
    glb.write_bytes(b"not a glb")
    with pytest.raises(LSATImportError) as e:
        import_glb(glb, name=name)
    text = str(e.value)
    assert "\n" not in text and "field '--name'" in text and f"pass --name {suggested} " in text, text


# --- the report's run names ---------------------------------------------------------------------------------
def test_run_names_build_no_eval_config(monkeypatch):
    """The report and its tables name runs as ``biovln-ms eval`` does, without an EvalConfig (whose empty
    split and folder would be invalid)."""
    from biovln_ms.eval import harness, paper_tables, report

    def refuse(self):
        raise AssertionError(f"an EvalConfig was built: {self}")

    monkeypatch.setattr(harness.EvalConfig, "__post_init__", refuse)
    assert paper_tables._run_name("frontier") == "frontier"
    assert paper_tables._run_name("frontier", "BioVLN-Centroid-v0") == "frontier@centroid"
    assert paper_tables._run_name("ppo") == "ppo@opface-rl"
    who = {"method": "frontier", "env_id": "BioVLN-OpFace-v0", "robot": "fetch", "noise": "realistic"}
    assert report.run_key(who) == "frontier-fetch+realistic"
    assert report.run_key({**who, "robot": "biovln_base", "noise": "ideal"}) == "frontier"


def test_run_name_is_eval_configs():
    from biovln_ms.eval.harness import EvalConfig, run_name

    cfg = EvalConfig(
        "frontier", "ms_val", "out", env_id="BioVLN-Centroid-v0", robot="fetch", noise="realistic"
    )
    assert cfg.run_name == run_name("frontier", "BioVLN-Centroid-v0", "fetch", "realistic")
    assert cfg.run_name == "frontier@centroid-fetch+realistic"
    assert EvalConfig("oracle", "ms_val", "out", name="mine").run_name == "mine"
    with pytest.raises(BioVLNError, match="field '--name'"):
        EvalConfig("oracle", "ms_val", "out", name="../..")
