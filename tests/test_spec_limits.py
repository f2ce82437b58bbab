"""Non-finite, degenerate and oversized scene specs are refused with one clear line.

Each bad spec is a valid generated spec's JSON with one edit."""

from __future__ import annotations

import copy
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from biovln_ms.errors import BioVLNError
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.loading import load_spec, parse_spec
from biovln_ms.scene.rules import validate_spec
from biovln_ms.scene.spec import (
    MAX_COORDINATE,
    MAX_FILE_BYTES,
    MAX_JSON_DEPTH,
    MAX_OBJECTS,
    MAX_WALLS,
    SceneSpecError,
    json_depth,
)

NAN, INF = float("nan"), float("inf")


@pytest.fixture(scope="module")
def valid() -> dict:
    """A two-room spec (rooms, walls, openings, furniture, instruments) as a JSON object."""
    return json.loads(generate_scene("two_room", 4).to_json())


def _edited(valid: dict, edit) -> dict:
    obj = copy.deepcopy(valid)
    edit(obj)
    return obj


def _set(path: tuple, value):
    def edit(obj: dict) -> None:
        node = obj
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value

    return edit


def _zero_length_wall(obj: dict) -> None:
    w = obj["walls"][0]
    obj["walls"].insert(0, {**w, "id": "wall_zero", "end": list(w["start"])})  # an extra, degenerate wall


def _many_walls(obj: dict) -> None:
    w = obj["walls"][0]
    obj["walls"] = [{**w, "id": f"wall_{i}"} for i in range(10_000)]


# (name, edit, field named in the error): inputs fuzzing found, each to be refused naming that field
FINDINGS = [
    ("nan success_radius", _set(("instruments", 0, "success_radius"), NAN), "instruments[0].success_radius"),
    ("inf room height", _set(("rooms", 0, "height"), INF), "rooms[0].height"),
    ("inf wall height", _set(("walls", 0, "height"), INF), "walls[0].height"),
    ("zero-length wall", _zero_length_wall, "walls[0].end"),
    ("nan opening", _set(("openings", 0, "center", 0), NAN), "openings[0].center[0]"),
    ("nan yaw", _set(("instruments", 0, "yaw"), NAN), "instruments[0].yaw"),
    ("nan face", _set(("instruments", 0, "face"), [NAN, NAN]), "instruments[0].face[0]"),
    ("coordinate beyond 10 km", _set(("walls", 0, "start", 0), 2 * MAX_COORDINATE), "walls[0].start[0]"),
    ("zero interior normal", _set(("walls", 0, "interior"), [0.0, 0.0]), "walls[0].interior"),
    ("self-crossing room", _set(("rooms", 0, "polygon", 1), [0.0, 5.0]), "rooms[0].polygon"),
    ("negative size", _set(("instruments", 0, "size", 0), -0.5), "instruments[0].size[0]"),
]


@pytest.mark.parametrize("name, edit, field", FINDINGS, ids=[f[0] for f in FINDINGS])
def test_bad_values_are_refused_naming_the_field(valid, name, edit, field, tmp_path):
    obj = _edited(valid, edit)
    with pytest.raises(SceneSpecError) as e:
        validate_spec(parse_spec(obj, "edited"), "edited")
    assert e.value.field == field, str(e.value)
    p = tmp_path / "edited.json"
    p.write_text(json.dumps(obj))  # Python writes NaN / Infinity, which json.loads reads back
    with pytest.raises(SceneSpecError) as e:
        validate_spec(load_spec(p), str(p))
    assert str(p) in str(e.value) and f"field '{field}'" in str(e.value)


def test_ten_thousand_walls_are_refused_quickly(valid, tmp_path):
    obj = _edited(valid, _many_walls)
    t0 = time.perf_counter()
    with pytest.raises(SceneSpecError, match=f"limit of {MAX_WALLS}") as e:
        parse_spec(obj, "edited")
    assert e.value.field == "walls"
    p = tmp_path / "walls.json"
    p.write_text(json.dumps(obj))
    with pytest.raises(SceneSpecError, match=f"limit of {MAX_WALLS}"):
        load_spec(p)
    assert time.perf_counter() - t0 < 2.0


def test_too_many_objects_are_refused(valid):
    inst = valid["instruments"][0]
    obj = _edited(valid, _set(("instruments",), [{**inst, "id": f"i{k}"} for k in range(MAX_OBJECTS + 1)]))
    with pytest.raises(SceneSpecError, match=f"limit of {MAX_OBJECTS}"):
        parse_spec(obj)


def test_deep_nesting_is_one_clear_error(tmp_path):
    p = tmp_path / "deep.json"
    p.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(SceneSpecError, match=f"more than the limit of {MAX_JSON_DEPTH}") as e:
        load_spec(p)
    assert e.value.field == "file" and e.value.fix and str(p) in str(e.value)


def test_json_depth_skips_brackets_in_strings():
    assert json_depth(b'{"a": [[1], {"b": "[[[[\\"{{"}]}') == 3
    assert json_depth(b"[]") == 1 and json_depth(b"3") == 0


def test_non_utf8_file_is_one_clear_error(valid, tmp_path):
    p = tmp_path / "latin1.json"
    p.write_bytes(json.dumps({**valid, "name": "labor_\xfc"}, ensure_ascii=False).encode("latin-1"))
    with pytest.raises(SceneSpecError, match="not UTF-8") as e:
        load_spec(p)
    assert e.value.field == "file" and "UTF-8" in e.value.fix and str(p) in str(e.value)


@pytest.mark.parametrize("text", ['{"schema_version": 1,', "{'single': 1}", "9" * 5000])
def test_invalid_json_is_one_clear_error(text, tmp_path):
    p = tmp_path / "broken.json"
    p.write_text(text)
    with pytest.raises(SceneSpecError, match="not valid JSON") as e:
        load_spec(p)
    assert e.value.field == "file" and e.value.fix and str(p) in str(e.value)


def test_oversized_file_is_refused(valid, tmp_path):
    p = tmp_path / "big.json"
    text = json.dumps(valid)
    p.write_text(text + " " * (MAX_FILE_BYTES + 1 - len(text)))
    with pytest.raises(SceneSpecError, match="larger than the limit") as e:
        load_spec(p)
    assert e.value.field == "file"


def test_limits_match_the_gltf_reader():
    from biovln_ms.lsat import gltf

    assert MAX_COORDINATE == gltf.MAX_COORDINATE and MAX_JSON_DEPTH == gltf.Limits().max_depth


def test_cli_validate_refuses_with_one_line(valid, tmp_path):
    files = {
        "nan.json": json.dumps(_edited(valid, _set(("instruments", 0, "success_radius"), NAN))).encode(),
        "walls.json": json.dumps(_edited(valid, _many_walls)).encode(),
        "deep.json": b"[" * 100_000 + b"]" * 100_000,
        "latin1.json": b'{"name": "labor_\xfc"}',
        "broken.json": b'{"schema_version": 1,',
    }
    for name, data in files.items():
        p = tmp_path / name
        p.write_bytes(data)
        r = subprocess.run(
            [sys.executable, "-m", "biovln_ms.cli", "scene", "validate", str(p)],
            capture_output=True,
            text=True,
            env={**os.environ, "COLUMNS": "80"},
        )
        assert r.returncode == 2, (name, r.stdout, r.stderr)
        err = r.stderr.strip()
        assert len(err.splitlines()) == 1 and "Traceback" not in err, (name, err)
        assert err.startswith("error:") and name in err and "fix:" in err, (name, err)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # numpy on the inf wall, before the guard
def test_export_refuses_non_finite_geometry(tmp_path):
    from biovln_ms.scene.export_glb import export_scene_glb

    spec = generate_scene("single_room", 3)
    wall = spec.walls[0].model_copy(update={"height": INF})  # model_copy skips validation
    bad = spec.model_copy(update={"walls": [wall, *spec.walls[1:]]})
    out = tmp_path / "bad.glb"
    with pytest.raises(SceneSpecError, match="non-finite"):
        export_scene_glb(bad, out)
    assert not out.exists()


# ---- fuzz: random mutations of a valid spec are parsed to finite numbers or refused cleanly ----

MUTANT_NUMBERS = [NAN, INF, -INF, 0.0, 0, -1.0, -1e-9, 1e300, -1e300, 1e6, 10**30]
MUTANT_VALUES = ["x", "", None, True, [], {}, [1.0], {"a": 1}, 1, 2.5]


def _nodes(obj, path: tuple = ()):
    """(path, value) of every node below the root."""
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    for k, v in items:
        yield path + (k,), v
        yield from _nodes(v, path + (k,))


def _floats(obj):
    if isinstance(obj, float):
        yield obj
    elif isinstance(obj, dict):
        for v in obj.values():
            yield from _floats(v)
    elif isinstance(obj, (list, tuple)):
        for v in obj:
            yield from _floats(v)


@st.composite
def mutated_specs(draw, base: dict) -> dict:
    obj = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, 3))):
        nodes = list(_nodes(obj))
        numeric = [p for p, v in nodes if isinstance(v, (int, float)) and not isinstance(v, bool)]
        keyed = [p for p, _ in nodes if isinstance(p[-1], str)]
        kind = draw(st.sampled_from(["number", "delete", "type"]))
        pool = {"number": numeric, "delete": keyed, "type": [p for p, _ in nodes]}[kind] or [
            p for p, _ in nodes
        ]
        path = draw(st.sampled_from(pool))
        parent = obj
        for key in path[:-1]:
            parent = parent[key]
        if kind == "delete" and isinstance(parent, dict):
            del parent[path[-1]]
        elif kind == "number":
            parent[path[-1]] = draw(st.sampled_from(MUTANT_NUMBERS))
        else:
            parent[path[-1]] = draw(st.sampled_from(MUTANT_VALUES))
    return obj


_BASE = json.loads(generate_scene("two_room", 4).to_json())


@settings(max_examples=int(os.environ.get("BIOVLN_FUZZ_EXAMPLES", 150)))
@given(mutated_specs(_BASE))
def test_mutated_specs_parse_finite_or_raise_biovln_error(obj):
    try:
        spec = validate_spec(parse_spec(obj, "fuzz"), "fuzz")
    except BioVLNError:
        return
    assert all(math.isfinite(x) for x in _floats(spec.model_dump()))
    json.loads(spec.to_json(), parse_constant=lambda c: pytest.fail(f"{c} in the canonical JSON"))


def test_valid_specs_still_load(tmp_path: Path):
    for template, seed in (("single_room", 3), ("suite", 2), ("open_plan", 1)):
        spec = generate_scene(template, seed)
        p = tmp_path / f"{spec.name}.json"
        p.write_text(spec.to_json())
        assert validate_spec(load_spec(p)).to_json() == spec.to_json()
