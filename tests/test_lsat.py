"""LSAT: names, the defensive GLB reader, import strategies 1 and 2, the shipped LSAT Target scene,
exporters (goal JSON, LSAT format, USD re-opened with pxr), and a fuzzed importer."""

import hashlib
import json
import math
import os
import struct

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from biovln_ms.errors import BioVLNError
from biovln_ms.lsat.designer_scene import LAYOUT, build_target_scene, target_glb_path, write_target_glb
from biovln_ms.lsat.gltf import GLTFError, read_gltf
from biovln_ms.lsat.importer import LSATImportError, import_glb
from biovln_ms.lsat.names import match_category, normalise
from biovln_ms.scene.loading import parse_spec
from biovln_ms.scene.rules import validate_spec


@pytest.mark.parametrize(
    "name, category",
    [
        ("target_refrigerater_2", "refrigerator"),
        ("target_centrifuge.001", "centrifuge"),
        ("Storage Cabinet.002", "cabinet"),
        ("waste-bin_3", "waste_bin"),
        ("target_minicentrifuge", "mini_centrifuge"),
        ("Lab Bench", "lab_bench"),
        ("target_Pipette Stand", "pipette"),
        ("INCUBATOR", "incubator"),
    ],
)
def test_fuzzy_names(name, category):
    m = match_category(name, "target_")
    assert m.category == category and m.distance <= 2


def test_unmatched_and_far_names_are_not_guessed():
    assert match_category("target_lamp", "target_").category is None
    assert match_category("target_refrgrtr", "target_").category is None  # distance 3
    assert normalise("Centrifuge.001") == "centrifuge" and normalise("fridge door-2") == "fridge_door"


@pytest.fixture(scope="module")
def imported():
    return import_glb(target_glb_path(), name="lsat_target")


def test_shipped_target_glb_is_regenerated_byte_for_byte(tmp_path):
    assert write_target_glb(tmp_path / "t.glb").read_bytes() == target_glb_path().read_bytes()


# sha256 of the LSAT Target import: the spec's JSON with its catalog_sha256 zeroed (a catalog edit such as
# new categories or interaction points changes only that field), and the
# report with the GLB's path written <glb>. Update only for an intended change of the importer, the
# catalog's numbers or the shipped GLB.
TARGET_SPEC_SHA256 = "d44ab29d11ca58463940a7d4b7ddcacd65498554916410132d9418f3fb669f30"
TARGET_REPORT_SHA256 = "ea8f8fe30a50f69d20116ba58057f0c7aa3ab54d2675918f4e45531218b75d82"


def test_target_import_is_byte_for_byte_unchanged(imported):
    spec, report = imported
    text = spec.to_json().replace(spec.catalog_sha256, "0" * 64)
    assert hashlib.sha256(text.encode()).hexdigest() == TARGET_SPEC_SHA256
    md = report.to_markdown().replace(str(target_glb_path()), "<glb>")
    assert hashlib.sha256(md.encode()).hexdigest() == TARGET_REPORT_SHA256


def test_import_recovers_the_designers_layout(imported):
    spec, report = imported
    c = report.coverage()
    assert (
        c["instruments_found"] == 8
        and c["goals_strategy1"] == 6
        and c["goals_strategy2"] == 2
        and not c["missing"]
    )
    assert {o.category for o in spec.goal_objects()} == {row[1] for row in LAYOUT}
    by_cat = {o.category: o for o in spec.objects()}
    for name, category, x, y, yaw_deg, marker, _ in LAYOUT:
        o = by_cat[category]
        assert o.position[:2] == pytest.approx((x, y), abs=1e-3), (
            name
        )  # Y-up -> Z-up and the footprint centre
        assert abs(math.remainder(o.yaw - math.radians(yaw_deg), 2 * math.pi)) < 1e-3, (
            name
        )  # face from geometry/rotation
        assert (o.goal_source == "marker") == (marker is not None)
    assert spec.template == "lsat"
    validate_spec(parse_spec(json.loads(spec.to_json())))  # the spec round-trips through validation


def test_import_cli_writes_spec_and_report(tmp_path):
    import subprocess
    import sys

    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "biovln_ms.cli",
            "lsat",
            "import",
            str(target_glb_path()),
            "-o",
            str(tmp_path / "lab.json"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert r.returncode == 0, r.stderr
    assert "from markers 6" in r.stdout and (tmp_path / "lab.report.md").read_text().count("strategy") >= 8


def test_exporters_goal_json_lsat_format_and_usd(imported, tmp_path):
    from pxr import Usd, UsdGeom

    from biovln_ms.lsat.exporters import goal_json, lsat_json, write_usd

    spec, report = imported
    g = goal_json(spec)
    assert len(g["goals"]) == 8 and {x["source"] for x in g["goals"]} == {"marker", "eq1"}
    lj = lsat_json(spec, report)
    fridge = next(o for o in lj["objects"] if o["category"] == "refrigerator")
    assert (
        fridge["node"] == "Refrigerator"
        and fridge["goal"]["strategy"] == 1
        and len(fridge["zones"]["zone3"]) == 4
    )
    path = write_usd(spec, tmp_path / "lab.usda")
    stage = Usd.Stage.Open(str(path))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    for o in spec.goal_objects():
        inst = stage.GetPrimAtPath(f"/World/Instruments/{o.id}")
        assert inst.IsValid() and inst.GetAttribute("biovln:category").Get() == o.category
        assert any(c.IsA(UsdGeom.Mesh) for c in inst.GetChildren())
        goal = stage.GetPrimAtPath(f"/World/Goals/{o.id}_goal")
        t = UsdGeom.Xformable(goal).ComputeLocalToWorldTransform(Usd.TimeCode.Default()).ExtractTranslation()
        assert (t[0], t[1]) == pytest.approx(o.goal, abs=1e-6)
        assert goal.GetAttribute("biovln:category").Get() == o.category


def test_harness_runs_on_the_lsat_target_split(tmp_path):
    from biovln_ms.splits import lsat_target_scene
    from biovln_ms.episodes.writer import SplitPlan, write_dataset
    from biovln_ms.eval.harness import EvalConfig, evaluate

    root = tmp_path / "ds"
    write_dataset(root, [SplitPlan("lsat_target", [(lsat_target_scene(), 8, False)])], progress=False)
    s = evaluate(
        EvalConfig("oracle", "lsat_target", str(tmp_path / "res"), str(root), workers=1), progress=False
    )
    assert s["overall"]["episodes"] == 8 and s["overall"]["sr"] > 50
    assert len(s["per_category"]) == 8


# --- bad and hostile input -------------------------------------------------------------------------
def _glb(doc: dict, binary: bytes = b"") -> bytes:
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    chunks = struct.pack("<II", len(js), 0x4E4F534A) + js
    if binary:
        binary += b"\0" * (-len(binary) % 4)
        chunks += struct.pack("<II", len(binary), 0x004E4942) + binary
    return struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks


def _mini_scene(**node_extra) -> dict:
    return {
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "target_fridge", **node_extra}],
    }


@pytest.mark.parametrize(
    "data, message",
    [
        (b"PK\x03\x04 not a glb at all", "not a GLB"),
        (_glb(_mini_scene())[:-3], "header says"),
        (
            struct.pack("<III", 0x46546C67, 2, 28) + struct.pack("<II", 8, 0x4E4F534A) + b"{bad jso",
            "malformed JSON chunk",
        ),
        (_glb({**_mini_scene(), "buffers": [{"uri": "../../etc/passwd", "byteLength": 10}]}), "external URI"),
        (
            _glb({**_mini_scene(), "buffers": [{"uri": "https://example.com/x.bin", "byteLength": 10}]}),
            "external URI",
        ),
        (_glb(_mini_scene(translation=[0, float("nan"), 0])), "malformed transform|non-finite"),
        (
            _glb(
                {
                    "asset": {"version": "2.0"},
                    "nodes": [{"name": "a", "children": [1]}, {"name": "b", "children": [0]}],
                    "scenes": [{"nodes": []}],
                }
            ),
            "cycle|two parents",
        ),
        (
            _glb(
                {"asset": {"version": "2.0"}, "nodes": [{"name": "a", "mesh": 7}], "scenes": [{"nodes": [0]}]}
            ),
            "missing mesh",
        ),
        (_glb({"asset": {"version": "1.0"}, "nodes": []}), "asset.version"),
        (
            struct.pack("<III", 0x46546C67, 2, 12 + 8 + 200_000)
            + struct.pack("<II", 200_000, 0x4E4F534A)
            + b"[" * 100_000
            + b"]" * 100_000,
            "nests deeper than 64",
        ),
    ],
)
def test_hostile_glbs_are_refused_clearly(tmp_path, data, message):
    path = tmp_path / "bad.glb"
    path.write_bytes(data)
    with pytest.raises(GLTFError, match=message):
        read_gltf(path)


def test_external_buffers_only_beside_the_file(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "outside.bin").write_bytes(b"\0" * 12)
    doc = {**_mini_scene(), "buffers": [{"uri": "../outside.bin", "byteLength": 12}]}
    (tmp_path / "sub" / "s.glb").write_bytes(_glb(doc))
    with pytest.raises(GLTFError, match="outside the scene's folder"):
        read_gltf(tmp_path / "sub" / "s.glb", allow_external=True)


def test_a_glb_without_floor_or_instruments_is_named(tmp_path):
    import trimesh

    s = trimesh.Scene()
    s.add_geometry(trimesh.creation.box((1, 1, 1)), node_name="Sofa")
    (tmp_path / "x.glb").write_bytes(s.export(file_type="glb"))
    with pytest.raises(LSATImportError, match="no floor"):
        import_glb(tmp_path / "x.glb")


def test_import_never_writes_anything(tmp_path, imported):
    before = sorted(p.name for p in target_glb_path().parent.iterdir())
    import_glb(target_glb_path())
    assert sorted(p.name for p in target_glb_path().parent.iterdir()) == before


@pytest.fixture(scope="module")
def seed_glb():
    """A small valid designer GLB (floor, one instrument with parts, one marker) to mutate."""
    scene = build_target_scene()
    keep = {"Floor", "Refrigerator", "target_refrigerator"}
    for node in list(scene.graph.nodes_geometry):
        if node.split("|")[0] not in keep:
            scene.delete_geometry(scene.graph[node][1])
    return scene.export(file_type="glb")


@settings(
    max_examples=int(os.environ.get("BIOVLN_FUZZ_EXAMPLES", "150")),
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(st.data())
def test_fuzzed_glbs_fail_only_with_clear_errors(tmp_path_factory, seed_glb, data):
    """Random byte flips, truncations and JSON-chunk edits: a BioVLNError (named file and problem) or a
    valid import, never another exception."""
    raw = bytearray(seed_glb)
    kind = data.draw(st.sampled_from(["flip", "truncate", "json"]))
    if kind == "flip":
        for _ in range(data.draw(st.integers(1, 8))):
            i = data.draw(st.integers(0, len(raw) - 1))
            raw[i] = data.draw(st.integers(0, 255))
    elif kind == "truncate":
        raw = raw[: data.draw(st.integers(0, len(raw) - 1))]
    else:
        jlen = struct.unpack_from("<I", raw, 12)[0]
        doc = json.loads(bytes(raw[20 : 20 + jlen]))
        node = data.draw(st.integers(0, len(doc["nodes"]) - 1))
        field = data.draw(st.sampled_from(["translation", "rotation", "scale", "mesh", "children", "matrix"]))
        value = data.draw(
            st.one_of(
                st.none(),
                st.integers(-5, 10**6),
                st.floats(allow_nan=True, allow_infinity=True),
                st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=17),
                st.text(max_size=5),
            )
        )
        doc["nodes"][node][field] = value
        raw = bytearray(_glb(doc, bytes(raw[28 + jlen :])))
    path = tmp_path_factory.mktemp("fuzz") / "f.glb"
    path.write_bytes(bytes(raw))
    try:
        spec, _ = import_glb(path)
    except BioVLNError as e:
        assert str(path) in str(e)  # names the file
    else:
        assert spec.instruments  # a mutation that kept the scene valid imports to a valid spec


def test_marker_helpers_of_the_blender_addon():
    from biovln_ms.lsat.markers import check_markers, suggested_marker

    name, xy = suggested_marker("Pipette Stand.001", (5.5, 2.78), math.pi)  # face -Y turned by 180 deg: +Y
    assert name == "target_pipette" and xy[0] == pytest.approx(5.5) and xy[1] > 2.78 + 0.159
    with pytest.raises(BioVLNError, match="matches no catalog category"):
        suggested_marker("Sofa", (0, 0), 0.0)
    rows = check_markers(["target_cabinet", "target_cabbage_xx", "Floor"])
    assert [r["status"] for r in rows] == ["ok", "unmatched"]


@pytest.mark.parametrize("template, seed", [("single_room", 150), ("two_room", 200)])
def test_exported_procedural_scene_imports_back(tmp_path, template, seed):
    """`scene export` writes Y-up glTF; importing it (strategy 2, names/extras) recovers every pose and
    goal."""
    from biovln_ms.scene.export_glb import export_scene_glb
    from biovln_ms.scene.generator import generate_scene

    spec = generate_scene(template, seed)
    back, report = import_glb(export_scene_glb(spec, tmp_path / "lab.glb"))
    assert report.coverage()["goals_strategy2"] == len(spec.goal_objects()) and not report.unmatched
    got = {o.id: o for o in back.objects()}
    for o in spec.objects():
        b = got[o.id]
        assert b.category == o.category and b.support == o.support
        assert b.position == pytest.approx(o.position, abs=2e-3), o.id
        assert abs(math.remainder(b.yaw - o.yaw, 2 * math.pi)) < 2e-3, o.id
        if o.is_goal:
            assert b.goal == pytest.approx(o.goal, abs=3e-3), o.id


def test_a_failing_import_lists_every_problem_and_still_writes_its_report(tmp_path):
    """A 3 m designer bench (the catalog's is 5.94 m, so it leaves the room), a table-top instrument on the
    floor and a bin beyond the floor: all three named with their coordinates, in the one-line error and
    in the report written beside the spec."""
    import subprocess
    import sys

    import trimesh

    from biovln_ms.geometry.frames import Z_UP_TO_Y_UP
    from biovln_ms.lsat.designer_scene import build_designer_scene

    kept = [row for row in LAYOUT if row[0] not in ("Lab Bench", "Mini Centrifuge", "Pipette Stand")]
    scene = build_designer_scene(kept)
    for name, size, centre in (
        ("Bench 3m", (3.0, 1.55, 0.76), (1.6, 2.2, 0.38)),
        ("Minifuge", (0.66, 0.5, 0.43), (2.6, 1.0, 0.215)),
        ("Bin outside", (0.38, 0.37, 0.51), (9.0, 1.0, 0.255)),
    ):
        scene.add_geometry(
            trimesh.creation.box(size),
            node_name=name,
            geom_name=name,
            transform=Z_UP_TO_Y_UP @ trimesh.transformations.translation_matrix(centre),
        )
    glb = tmp_path / "bench.glb"
    glb.write_bytes(scene.export(file_type="glb"))
    out = tmp_path / "lab.json"
    cmd = [sys.executable, "-m", "biovln_ms.cli", "lsat", "import", str(glb), "-o", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert r.returncode != 0 and not out.exists()
    expected = [
        "`Bin outside` at (9.00, 1.00): a waste_bin standing outside every floor",
        "`Minifuge` at (2.60, 1.00): a table-top mini_centrifuge standing on no bench or table",
        "`Bench 3m`: 'lab_bench_0' at (1.60, 2.20) is not inside the rooms' floor [rule: inside rooms]",
    ]
    error = r.stderr.strip()
    assert "3 problems: 1) " in error and all(e in error for e in expected) and "more)" not in error
    report = (tmp_path / "lab.report.md").read_text()
    assert "## The import failed: 3 problems" in report and all(e in report for e in expected)
    assert str(tmp_path / "lab.report.md") in error  # the error says where the report is
