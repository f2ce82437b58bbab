"""Every input from someone else is bounded: ids and names have one character set and length, paths built
from data or command-line names stay inside their folder, files are read only when regular and small,
nesting and counts have limits, and each refusal is one line naming the file or the option."""

from __future__ import annotations

import gzip
import hashlib
import json
import os
import shutil
import threading
import zipfile
from pathlib import Path

import pytest
import yaml
from pydantic import TypeAdapter, ValidationError
from typer.testing import CliRunner

from biovln_ms.bridges.nav2 import export_nav2
from biovln_ms.cli import app
from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset
from biovln_ms.errors import BioVLNError
from biovln_ms.eval.handoff import HandoffError, write_handoff
from biovln_ms.eval.harness import EvalConfig
from biovln_ms.io_utils import inside, parse_yaml
from biovln_ms.limits import MAX_ID_LENGTH, MAX_NAME_MAP_ENTRIES, MAX_PROTOCOL_FILES, Identifier
from biovln_ms.lsat.layout import LayoutError, load_request
from biovln_ms.lsat.name_map import NameMapError, load_name_map
from biovln_ms.protocols.library import ProtocolError, load_protocols
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.loading import load_spec, parse_spec
from biovln_ms.scene.spec import SceneSpecError

SPEC = generate_scene("single_room", 154)


def _one_line(e: BaseException) -> str:
    text = str(e)
    assert "\n" not in text and "\r" not in text and "Traceback" not in text, text
    return text


def _within(seconds: float, fn, fifo: Path | None = None):
    """``fn()`` run in a thread that must end within ``seconds`` (a blocked read of a FIFO would not: the
    FIFO is then opened for writing, which releases the reader, and the test fails)."""
    box: dict = {}

    def run():
        try:
            box["value"] = fn()
        except BaseException as e:  # noqa: BLE001 - handed to the test
            box["error"] = e

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(seconds)
    if t.is_alive():
        if fifo is not None:
            os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        pytest.fail(f"still running after {seconds} s (a blocked read)")
    if "error" in box:
        raise box["error"]
    return box.get("value")


# --- ids and paths ------------------------------------------------------------------------------------
@pytest.mark.parametrize("good", ["lab_s154_v0", "0", "a.b-c_D", "x" * MAX_ID_LENGTH])
def test_an_id_of_the_documented_characters_is_accepted(good):
    assert TypeAdapter(Identifier).validate_python(good) == good


@pytest.mark.parametrize(
    "bad", ["", "..", "../x", "a/b", ".hidden", "a b", "x\n", "-x", "x" * (MAX_ID_LENGTH + 1)]
)
def test_an_id_outside_the_documented_characters_is_refused(bad):
    with pytest.raises(ValidationError):
        TypeAdapter(Identifier).validate_python(bad)


def test_paths_built_from_data_stay_inside_their_root(tmp_path):
    assert inside(tmp_path, "run", "ms_val") == tmp_path / "run" / "ms_val"
    assert inside(tmp_path, "ms_val/content/x.json.gz", nested=True) == tmp_path / "ms_val/content/x.json.gz"
    (tmp_path / "out").symlink_to(tmp_path.parent)
    for parts in (("..",), ("a", "../../b"), ("/etc",), ("a/b",), ("",), ("a\x00",), ("out", "x")):
        with pytest.raises(BioVLNError) as e:
            inside(tmp_path, *parts)
        _one_line(e.value)


def _payload(scene_id: str, episode_id: str) -> dict:
    return {"split": "ms_val", "scene_id": scene_id, "episode_id": episode_id, "schema": "x"}


@pytest.mark.parametrize(
    "scene_id, episode_id", [("lab", "../../../../escaped"), ("../../../..", "escaped"), ("/tmp", "escaped")]
)
def test_a_crafted_episode_id_cannot_move_a_handoff_out_of_its_folder(tmp_path, scene_id, episode_id):
    root = tmp_path / "handoff"
    with pytest.raises(HandoffError) as e:
        write_handoff(root, "oracle", _payload(scene_id, episode_id))
    _one_line(e.value)
    assert not (tmp_path / "escaped.json").exists()
    assert write_handoff(root, "oracle", _payload("lab_s154_v0", "3")).is_relative_to(root)


@pytest.mark.parametrize(
    "options, field",
    [
        ({"name": "../.."}, "--name"),
        ({"name": "a/b"}, "--name"),
        ({"split": "../../x"}, "--split"),
        ({"max_episodes": 0}, "--max-episodes"),
        ({"max_episodes": -3}, "--max-episodes"),
        ({"workers": 0}, "--workers"),
        ({"record_dir": ""}, "--record"),
        ({"handoff_dir": ""}, "--export-handoff"),
        ({"out": " "}, "--out"),
    ],
)
def test_eval_options_no_run_can_use_are_refused(tmp_path, options, field):
    kw = {"method": "oracle", "split": "ms_val", "out": str(tmp_path / "out"), **options}
    with pytest.raises(BioVLNError) as e:
        EvalConfig(**kw).run_dir  # the folder the run would write: checked with the options
    assert e.value.field == field, _one_line(e.value)


@pytest.mark.parametrize(
    "option, value",
    [
        ("--max-episodes", "0"),
        ("--max-episodes", "-3"),
        ("--workers", "0"),
        ("--record", ""),
        ("--export-handoff", ""),
        ("--out", ""),
        ("--name", "../.."),
    ],
)
def test_eval_cli_refuses_them_before_writing_anything(tmp_path, option, value):
    out = tmp_path / "out"
    argv = ["eval", "-m", "oracle", "-s", "ms_val", "--dataset", str(tmp_path / "none"), "-o", str(out)]
    r = CliRunner().invoke(app, [*argv, option, value])
    if r.exit_code == 2:  # click's usage error, naming the option
        assert option in r.output, r.output
    else:  # a BioVLNError: biovln_ms.cli.main prints it as one line
        assert isinstance(r.exception, BioVLNError), r.output
        assert option in _one_line(r.exception)
    assert not out.exists() and not (tmp_path.parent / "ms_val").exists()


# --- scene specs and the Nav2 export --------------------------------------------------------------------
@pytest.mark.parametrize(
    "key, value",
    [
        ("name", "lab\nimage: evil.pgm"),
        ("name", "lab\r"),
        ("name", "lab\x00"),
        ("name", "x" * 5_000_000),
        ("template", "../x"),
    ],
)
def test_a_spec_name_outside_the_id_rule_is_refused(key, value):
    obj = json.loads(SPEC.to_json())
    obj[key] = value
    with pytest.raises(SceneSpecError) as e:
        parse_spec(obj, "crafted")
    assert e.value.field == key, _one_line(e.value)


def test_a_five_million_character_name_is_refused_from_the_file(tmp_path):
    obj = json.loads(SPEC.to_json())
    obj["instruments"][0]["room"] = "r" * 5_000_000
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(obj))
    with pytest.raises(SceneSpecError) as e:
        load_spec(path)
    assert e.value.field == "instruments[0].room" and "128" in _one_line(e.value)


def test_nav2_yaml_stays_one_map_whatever_the_name(tmp_path):
    """The exporter does not rely on the schema: a spec built without validation cannot inject keys."""
    spec = SPEC.model_copy(update={"name": "lab\nimage: evil.pgm\r\x00\u2028origin: [9, 9, 0]"})
    export_nav2(spec, tmp_path, resolution=0.1)
    for name, image in (("map.yaml", "map.pgm"), ("keepout_mask.yaml", "keepout_mask.pgm")):
        text = (tmp_path / name).read_text()
        meta = yaml.safe_load(text)
        assert meta["image"] == image and meta["origin"][:2] != [9, 9]
        assert list(meta) == [
            "image",
            "mode",
            "resolution",
            "origin",
            "negate",
            "occupied_thresh",
            "free_thresh",
        ]
        assert text.count("\n") == 8 and "\r" not in text and "\x00" not in text
    goals = yaml.safe_load((tmp_path / "goals.yaml").read_text())
    assert list(goals) == ["frame_id", "goals"]


# --- SB3 checkpoints ------------------------------------------------------------------------------------
def test_a_plain_json_checkpoint_of_a_huge_network_is_refused_before_building(tmp_path, monkeypatch):
    from fuzz_targets import _sb3_setup
    from stable_baselines3 import PPO

    from biovln_ms.learning.sb3_safe import MAX_PARAMETERS, load_sb3_model

    entries = _sb3_setup(tmp_path)  # a small PPO checkpoint's zip members
    data = json.loads(entries["data"])
    data["policy_kwargs"] = {"net_arch": [4096] * 32}  # plain JSON: nothing pickled
    entries["data"] = json.dumps(data).encode()
    huge = tmp_path / "huge.zip"
    with zipfile.ZipFile(huge, "w") as z:
        for n, blob in entries.items():
            z.writestr(n, blob)

    def built(self):
        raise AssertionError("the networks were built")

    monkeypatch.setattr(PPO, "_setup_model", built)
    with pytest.raises(BioVLNError) as e:
        load_sb3_model(huge, "ppo")
    assert f"{MAX_PARAMETERS:,}" in _one_line(e.value) and e.value.field == "data.policy_kwargs.net_arch"


# --- name maps, layout requests, protocol folders --------------------------------------------------------
DEEP = "a: " + "[" * 20_000 + "]" * 20_000 + "\n"


def _fifo(folder: Path, name: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    os.mkfifo(path)
    return path


def test_a_deeply_nested_name_map_is_one_line(tmp_path):
    path = tmp_path / "names.yaml"
    path.write_text(DEEP)
    with pytest.raises(NameMapError, match="nested more than 64 levels") as e:
        load_name_map(path)
    _one_line(e.value)


def test_a_fifo_name_map_is_refused_not_waited_on(tmp_path):
    fifo = _fifo(tmp_path, "names.yaml")
    with pytest.raises(NameMapError, match="not a regular file"):
        _within(10, lambda: load_name_map(fifo), fifo)


def test_name_map_entries_and_names_are_bounded(tmp_path):
    path = tmp_path / "names.yaml"
    path.write_text("".join(f"n{i}: null\n" for i in range(MAX_NAME_MAP_ENTRIES + 1)))
    with pytest.raises(NameMapError, match="more than the limit of 20,000"):
        load_name_map(path)
    path.write_text(json.dumps({"Bench\nincubator": "lab_bench"}))
    with pytest.raises(NameMapError, match="control character") as e:
        load_name_map(path)
    _one_line(e.value)


def test_a_deeply_nested_layout_request_is_one_line(tmp_path):
    path = tmp_path / "req.yaml"
    path.write_text(DEEP)
    with pytest.raises(LayoutError, match="nested more than 64 levels") as e:
        load_request(path)
    _one_line(e.value)


def test_a_fifo_layout_request_is_refused_not_waited_on(tmp_path):
    fifo = _fifo(tmp_path, "req.yaml")
    with pytest.raises(LayoutError, match="not a regular file"):
        _within(10, lambda: load_request(fifo), fifo)


def test_a_yaml_alias_is_refused_before_it_stands_for_a_billion_values(tmp_path):
    lines = ["Sterilgard:", "  - &l0 [x, x, x, x, x, x, x, x, x, x]"]
    lines += [f"  - &l{i} [{', '.join([f'*l{i - 1}'] * 10)}]" for i in range(1, 9)]
    path = tmp_path / "names.yaml"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(NameMapError, match="uses a YAML alias"):
        _within(20, lambda: load_name_map(path))


def test_yaml_of_many_values_is_refused_before_it_is_built():
    raw = ("[" + "0, " * 100_001 + "0]").encode()
    with pytest.raises(BioVLNError, match="more than 100,000 values"):
        parse_yaml(raw, "x.yaml", "file")


def _protocol(pid: str) -> str:
    steps = [{"category": "refrigerator", "purpose": "take"}, {"category": "pipette", "purpose": "dose"}]
    return json.dumps({"id": pid, "name": "n", "description": "d", "steps": steps})


def test_a_deeply_nested_protocol_is_one_line(tmp_path):
    (tmp_path / "deep.json").write_text('{"id": ' + "[" * 100_000 + "]" * 100_000 + "}")
    with pytest.raises(ProtocolError, match="nested 100001 levels deep, more than the limit of 64") as e:
        load_protocols(extra_dirs=[tmp_path], env=False)
    _one_line(e.value)


def test_a_fifo_in_a_protocol_folder_is_refused_not_waited_on(tmp_path):
    fifo = _fifo(tmp_path, "x.json")
    with pytest.raises(ProtocolError, match="not a regular file"):
        _within(10, lambda: load_protocols(extra_dirs=[tmp_path], env=False), fifo)


def test_protocol_files_are_counted_before_any_is_read(tmp_path):
    for i in range(MAX_PROTOCOL_FILES + 1):
        (tmp_path / f"p{i}.json").write_text(_protocol(f"p{i}"))
    with pytest.raises(ProtocolError, match="more than 1,000 protocol files") as e:
        load_protocols(extra_dirs=[tmp_path], env=False)
    _one_line(e.value)


# --- datasets -------------------------------------------------------------------------------------------
def _dataset_copy(held_out_dataset, tmp_path: Path) -> Path:
    return Path(shutil.copytree(held_out_dataset(ms_val=3), tmp_path / "ds"))


def _rehash(root: Path, rel: str, blob: bytes) -> None:
    """Write ``blob`` to ``rel`` and its hash into the manifest, as a re-hashed hand edit would."""
    (root / rel).write_bytes(blob)
    m = json.loads((root / "manifest.json").read_text())
    for split in m["splits"].values():
        for entry in split["files"].values():
            if entry["file"] == rel:
                entry["sha256"] = hashlib.sha256(blob).hexdigest()
    (root / "manifest.json").write_text(json.dumps(m))


def test_duplicate_episode_ids_are_refused_naming_the_file_and_the_id(held_out_dataset, tmp_path):
    root = _dataset_copy(held_out_dataset, tmp_path)
    rel = "ms_val/content/lab_s154_v0.json.gz"
    obj = json.loads(gzip.decompress((root / rel).read_bytes()))
    obj["episodes"][2]["episode_id"] = obj["episodes"][0]["episode_id"]
    _rehash(root, rel, gzip.compress(json.dumps(obj).encode()))
    with pytest.raises(DatasetError) as e:
        list(EpisodeDataset(root).episodes("ms_val"))
    text = _one_line(e.value)
    assert e.value.source == str(root / rel) and e.value.field == "episodes[2].episode_id"
    assert repr(obj["episodes"][0]["episode_id"]) in text


def test_a_scene_listed_twice_in_a_split_is_refused(held_out_dataset, tmp_path):
    root = _dataset_copy(held_out_dataset, tmp_path)
    m = json.loads((root / "manifest.json").read_text())
    split = m["splits"]["ms_val"]
    split["scenes"] *= 2  # its episodes twice, and a count that adds up
    split["episodes"] *= 2
    (root / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(DatasetError, match="listed twice") as e:
        EpisodeDataset(root)
    assert e.value.field == "splits.ms_val.scenes", _one_line(e.value)


@pytest.mark.parametrize("where", ["split", "scene"])
def test_manifest_split_and_scene_names_follow_the_id_rule(held_out_dataset, tmp_path, where):
    root = _dataset_copy(held_out_dataset, tmp_path)
    m = json.loads((root / "manifest.json").read_text())
    if where == "split":
        m["splits"]["../../x"] = m["splits"].pop("ms_val")
    else:
        m["scenes"]["../x"] = m["scenes"]["lab_s154_v0"]
    (root / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(DatasetError, match=r"is not an id \(letters, digits") as e:
        EpisodeDataset(root)
    _one_line(e.value)
