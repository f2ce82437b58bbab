"""The LSAT importer's steps one at a time, on hand-built inputs: classify, place, assign markers, assemble
(``import_glb`` as a whole is tested in test_lsat)."""

import base64
import json

import numpy as np
import pytest

from biovln_ms.catalog import load_catalog
from biovln_ms.constants import ROBOT_RADIUS
from biovln_ms.geometry.zones import placement_z
from biovln_ms.lsat import importer
from biovln_ms.lsat.gltf import GLTFScene, Node, read_gltf
from biovln_ms.lsat.importer import (
    ImportReport,
    _assemble,
    _assign_markers,
    _classify,
    _adopt,
    _Marker,
    _place,
    _Placed,
    _rooms,
    _Shell,
)
from biovln_ms.lsat.names import Match, match_category
from biovln_ms.scene.generator import rooms_from_rects
from biovln_ms.scene.spec import ObjectSpec, make_object

FLOOR = {"name": "Floor", "box": (0, 0, -0.02, 6, 4, 0)}  # one 6 x 4 m room


def _scene(tmp_path, *nodes: dict) -> GLTFScene:
    """A glTF of hand-built nodes, read back. Each node: a name; optionally ``box`` (x0, y0, z0, x1, y1, z1),
    a mesh in BioVLN's Z-up world frame (m); ``at`` (x, y), an empty's position; ``parent`` (a node index);
    ``extras``."""
    doc: dict = {"asset": {"version": "2.0"}, "nodes": [], "meshes": [], "accessors": [], "bufferViews": []}
    blob = b""
    for nd in nodes:
        node = {"name": nd["name"], "extras": nd.get("extras", {})}
        if "box" in nd:
            x0, y0, z0, x1, y1, z1 = nd["box"]
            zup = [(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]
            corners = np.array([(x, z, -y) for x, y, z in zup], "<f4")  # glTF is Y-up
            doc["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": corners.nbytes})
            doc["accessors"].append(
                {
                    "bufferView": len(doc["accessors"]),
                    "componentType": 5126,
                    "type": "VEC3",
                    "count": len(corners),
                }
            )
            doc["meshes"].append({"primitives": [{"attributes": {"POSITION": len(doc["meshes"])}}]})
            node["mesh"] = len(doc["meshes"]) - 1
            blob += corners.tobytes()
        if "at" in nd:
            node["translation"] = [nd["at"][0], 0.0, -nd["at"][1]]
        doc["nodes"].append(node)
    for i, nd in enumerate(nodes):
        if "parent" in nd:
            doc["nodes"][nd["parent"]].setdefault("children", []).append(i)
    doc["buffers"] = [
        {
            "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
            "byteLength": len(blob),
        }
    ]
    (tmp_path / "hand.gltf").write_text(json.dumps(doc))
    return read_gltf(tmp_path / "hand.gltf")


def _object(obj_id: str, category: str, xy: tuple[float, float], yaw: float = 0.0) -> ObjectSpec:
    cat = load_catalog()
    a = cat.get(category)
    return make_object(
        cat,
        obj_id,
        category,
        xy,
        a.dimensions[2] / 2,
        yaw,
        a.placement,
        "room_0",
        None,
        None,
        a.goal_category,
    )


def _placed(*objects: ObjectSpec) -> _Placed:
    rows = {
        o.id: {
            "id": o.id,
            "node": o.id,
            "category": o.category,
            "is_goal": o.is_goal,
            "goal_strategy": None,
            "face_from": "node rotation (catalog face)",
        }
        for o in objects
    }
    return _Placed(
        [o for o in objects if o.placement == "furniture"],
        [o for o in objects if o.placement != "furniture"],
        rows,
    )


def _marker(name: str, category: str, xy: tuple[float, float]) -> _Marker:
    world = np.eye(4)
    world[:2, 3] = xy
    return _Marker(Node(0, name, world, None, None), category)


def test_classify_sorts_nodes_into_objects_markers_and_reported_names(tmp_path, monkeypatch):
    # no two catalog names are 2 edits apart
    def match(name: str, strip_prefix: str | None = None, names=None) -> Match:
        if "mystery" in name.lower():
            return Match(name, "mystery", None, 1, ("cabinet", "incubator"))
        return match_category(name, strip_prefix, names)

    monkeypatch.setattr(importer, "match_category", match)
    scene = _scene(
        tmp_path,
        FLOOR,
        {"name": "Wall_north", "box": (0, 4, 0, 6, 4.1, 3)},
        {"name": "Camera", "at": (3, 2)},
        {"name": "Refrigerator", "box": (0.1, 3.0, 0, 0.99, 3.91, 1.78)},
        {"name": "fridge door", "box": (0.1, 2.98, 0.1, 0.99, 3.0, 1.7), "parent": 3},  # a part
        {"name": "centrifuge.001", "box": (2, 2, 0.76, 2.49, 2.42, 1.39)},
        {"name": "Thing", "extras": {"category": "incubator"}, "box": (4, 3, 0, 5.35, 3.85, 1.9)},
        {"name": "target_refrigerator", "at": (0.5, 2.4)},
        {"name": "target_lamp", "at": (1, 1)},
        {"name": "Sofa", "box": (3, 0.5, 0, 4, 1, 0.5)},
        {"name": "Empty", "at": (1, 1)},  # no mesh, no category: silently left
        {"name": "cabinet", "at": (5, 1)},  # a category without mesh
        {"name": "Mystery Box", "box": (1, 1, 0, 1.5, 1.5, 0.5)},
        {"name": "mystery lid", "box": (1, 1, 0.5, 1.5, 1.5, 0.6), "parent": 12},
        {"name": "target_mystery", "at": (1, 0.5)},
    )
    report = ImportReport("hand")
    found, markers, loose, ambiguous = _classify(scene, report)
    assert [(f.node.name, f.category, len(f.points)) for f in found] == [
        ("Refrigerator", "refrigerator", 16),
        ("centrifuge.001", "centrifuge", 8),
        ("Thing", "incubator", 8),
    ]
    assert [(m.node.name, m.category) for m in markers] == [("target_refrigerator", "refrigerator")]
    assert report.unmatched == ["target_lamp", "Sofa"]  # "mystery lid" is claimed by its ambiguous parent
    assert [n.name for n in loose] == ["Sofa"]  # a node, not a marker, an instrument could be made of
    assert [a["node"] for a in report.ambiguous] == ["Mystery Box", "target_mystery"]
    assert [(a.node.name, a.candidates, len(a.points)) for a in ambiguous] == [
        ("Mystery Box", ("cabinet", "incubator"), 16)  # with its lid; a marker may settle it
    ]
    assert report.warnings == ["'cabinet' (cabinet) has no mesh: skipped"]


def test_adopt_gives_an_orphan_marker_the_nearest_loose_mesh_never_a_group_holding_an_instrument(tmp_path):
    scene = _scene(
        tmp_path,
        FLOOR,
        {"name": "Equipment"},  # a loose group: it holds a recognised fridge, so it is no candidate
        {"name": "Refrigerator", "box": (0.1, 3.0, 0, 0.99, 3.91, 1.78), "parent": 1},
        {"name": "Heracell", "box": (4, 3, 0, 5.35, 3.85, 1.9), "parent": 1},
        {"name": "Heracell door", "box": (3.98, 3.05, 0.1, 4.0, 3.8, 1.8), "parent": 3},
        {"name": "Sofa", "box": (0.2, 0.2, 0, 1.0, 0.6, 0.5)},
        {"name": "target_incubator", "at": (3.5, 3.4)},
        {"name": "target_refrigerator", "at": (0.5, 2.4)},
    )
    report = ImportReport("hand")
    found, markers = _adopt(scene, _classify(scene, report), report)
    assert [(f.node.name, f.category, len(f.points)) for f in found] == [
        ("Refrigerator", "refrigerator", 8),
        ("Heracell", "incubator", 16),  # with its part
    ]
    assert [(m.node.name, m.instrument) for m in markers] == [
        ("target_incubator", "Heracell"),
        ("target_refrigerator", None),  # its instrument is recognised: an ordinary marker
    ]
    assert report.unmatched == ["Equipment", "Sofa"]
    assert report.adopted == [
        {"marker": "target_incubator", "node": "Heracell", "category": "incubator", "distance": 0.48}
    ]  # to its door


def test_a_marker_settles_the_ambiguous_mesh_beside_it(tmp_path):
    scene = _scene(
        tmp_path,
        FLOOR,
        {"name": "Fridge cabinet", "box": (0.1, 3.0, 0, 0.99, 3.91, 1.78)},  # refrigerator or cabinet
        {"name": "target_refrigerator", "at": (0.5, 2.4)},
        {"name": "Fridge cabinet.001", "box": (4.0, 3.0, 0, 4.89, 3.91, 1.78)},  # no marker: stays ambiguous
        {
            "name": "BSC cabinet",
            "box": (2.0, 0.1, 0, 3.34, 0.9, 2.1),
        },  # the more specific: a biosafety cabinet
        {"name": "target_biosafety_cabinet", "at": (2.67, 1.6)},
    )
    report = ImportReport("hand")
    found, markers = _adopt(scene, _classify(scene, report), report)
    assert [(f.node.name, f.category) for f in found] == [
        ("BSC cabinet", "biosafety_cabinet"),
        ("Fridge cabinet", "refrigerator"),
    ]
    assert [(m.node.name, m.instrument) for m in markers] == [
        ("target_refrigerator", "Fridge cabinet"),
        ("target_biosafety_cabinet", None),  # its instrument is recognised by name
    ]
    assert report.ambiguous == [{"node": "Fridge cabinet.001", "candidates": ["cabinet", "refrigerator"]}]
    assert report.settled == [
        {
            "node": "BSC cabinet",
            "candidates": ["biosafety_cabinet", "cabinet"],
            "category": "biosafety_cabinet",
            "by": "the more specific name",
        },
        {
            "node": "Fridge cabinet",
            "candidates": ["cabinet", "refrigerator"],
            "category": "refrigerator",
            "by": "marker `target_refrigerator`, 0.60 m away",
        },
    ]
    assert not report.adopted and "Fridge cabinet" not in report.unmatched


def test_a_marker_nearer_a_recognised_instrument_settles_nothing(tmp_path):
    scene = _scene(
        tmp_path,
        FLOOR,
        {"name": "Refrigerator", "box": (0.1, 3.0, 0, 0.99, 3.91, 1.78)},
        {"name": "Fridge cabinet", "box": (1.5, 3.0, 0, 2.39, 3.91, 1.78)},
        {"name": "target_refrigerator", "at": (0.5, 2.6)},
    )
    report = ImportReport("hand")
    found, markers = _adopt(scene, _classify(scene, report), report)
    assert [f.node.name for f in found] == ["Refrigerator"] and markers[0].instrument is None
    assert [a["node"] for a in report.ambiguous] == ["Fridge cabinet"] and not report.settled


def test_place_snaps_a_table_top_instrument_onto_its_support(tmp_path):
    scene = _scene(
        tmp_path,
        FLOOR,
        {"name": "Lab Table", "box": (0.8, 1.5, 0, 3.2, 2.4, 0.78)},
        {"name": "Mini Centrifuge", "box": (1.67, 1.7, 0.83, 2.33, 2.2, 1.26)},  # 5 cm too high
        {"name": "display", "box": (2.33, 1.8, 0.9, 2.35, 2.1, 1.1), "parent": 2},
    )  # its +x side
    report = ImportReport("hand")
    rects, _ = _rooms(scene, report)
    placed = _place(scene, _classify(scene, report).found, rects, report)
    assert [o.id for o in placed.furniture] == ["lab_table_0"]
    (o,) = placed.instruments
    assert (o.id, o.room, o.support) == ("mini_centrifuge_0", "room_0", "lab_table_0")
    h = load_catalog().get("mini_centrifuge").dimensions[2]
    assert o.position == pytest.approx((2.01, 1.95, placement_z(0.78, 0.0, -h / 2)), abs=1e-6)  # Eq. 4
    assert o.face == pytest.approx((1.0, 0.0), abs=1e-9)  # towards its display
    row = placed.rows[o.id]
    assert row["face_from"] == "geometry (face parts)" and row["goal_strategy"] is None
    assert o.goal is not None and o.goal_source is None  # Eq. 1 until a marker says otherwise
    snapped = "'Mini Centrifuge': bottom at 0.830 m, its support's top at 0.780 m (snapped, Eq. 4)"
    assert report.warnings == [snapped]


def test_place_leaves_out_a_table_top_instrument_without_support_and_one_off_the_floor(tmp_path):
    scene = _scene(
        tmp_path,
        FLOOR,
        {"name": "Mini Centrifuge", "box": (1.67, 1.7, 0.78, 2.33, 2.2, 1.21)},
        {"name": "Waste Bin", "box": (6.81, 1.0, 0, 7.19, 1.37, 0.51)},  # beyond the floor's x = 6
        {"name": "Refrigerator", "box": (0.1, 3.0, 0, 0.99, 3.91, 1.78)},
    )
    report = ImportReport("hand")
    rects, _ = _rooms(scene, report)
    placed = _place(scene, _classify(scene, report).found, rects, report)
    assert [o.id for o in placed.instruments] == ["refrigerator_0"]  # the others are problems, not objects
    assert report.problem_lines() == [
        "`Mini Centrifuge` at (2.00, 1.95): a table-top mini_centrifuge standing on no bench or table "
        "(put it on a 'Lab Bench' or 'Lab Table' node)",
        "`Waste Bin` at (7.00, 1.19): a waste_bin standing outside every floor (move it onto a floor mesh, "
        "or add a floor under it)",
    ]


def test_assign_markers_strategy_1_nearest_of_the_category_strategy_2_for_the_rest():
    fridges = [_object(f"refrigerator_{i}", "refrigerator", (x, 3.5)) for i, x in enumerate((1.0, 4.0))]
    waste_bin = _object("waste_bin_0", "waste_bin", (5.0, 1.0))
    placed = _placed(*fridges, waste_bin)
    report = ImportReport("hand")
    out = _assign_markers(
        placed,
        [
            _marker("target_refrigerator", "refrigerator", (3.9, 2.9)),
            _marker("target_refrigerator.001", "refrigerator", (1.1, 2.8)),
        ],
        report,
    )
    got = {o.id: o for o in out.instruments}
    assert got["refrigerator_0"].goal == (1.1, 2.8) and got["refrigerator_1"].goal == (3.9, 2.9)
    assert got["refrigerator_0"].goal_source == "marker" and got["refrigerator_1"].goal_source == "marker"
    assert got["waste_bin_0"] == waste_bin  # no marker: its Eq. 1 goal
    assert [m["assigned_to"] for m in report.markers] == ["refrigerator_1", "refrigerator_0"]
    assert [r["goal_strategy"] for r in report.instruments] == [1, 1, 2]
    assert all(r["goal_strategy"] is None for r in placed.rows.values())  # the input is left as it was


def test_assign_markers_ignores_a_second_marker_and_one_without_instrument():
    fridge = _object("refrigerator_0", "refrigerator", (1.0, 3.5))
    report = ImportReport("hand")
    out = _assign_markers(
        _placed(fridge),
        [
            _marker("target_refrigerator", "refrigerator", (1.1, 2.8)),
            _marker("target_refrigerator.001", "refrigerator", (1.0, 2.9)),
            _marker("target_incubator", "incubator", (3.0, 2.0)),
        ],
        report,
    )
    assert out.instruments[0].goal == (1.1, 2.8)
    assert report.coverage()["markers_unassigned"] == ["target_refrigerator.001", "target_incubator"]
    ignored = "marker 'target_refrigerator.001': 'refrigerator_0' already has a marker; ignored"
    assert report.warnings == [ignored]


def test_assemble_reports_every_broken_designer_rule_with_node_and_coordinates():
    shell = _Shell(*rooms_from_rects([("room_0", "room", (0.0, 0.0, 6.0, 4.0))], 3.0))
    report = ImportReport("hand")
    inside = _assign_markers(_placed(_object("refrigerator_0", "refrigerator", (3.0, 3.5))), [], report)
    spec = _assemble("lab", shell, inside, ROBOT_RADIUS, report)
    assert (spec.name, spec.template, [o.id for o in spec.instruments]) == ("lab", "lsat", ["refrigerator_0"])
    assert not report.problems
    outside = _placed(
        _object("refrigerator_0", "refrigerator", (8.0, 2.0)), _object("waste_bin_0", "waste_bin", (7.0, 1.0))
    )
    report = ImportReport("hand")
    _assemble("lab", shell, outside, ROBOT_RADIUS, report)
    lines = report.problem_lines()
    for node, xy in (("refrigerator_0", "(8.00, 2.00)"), ("waste_bin_0", "(7.00, 1.00)")):
        line = f"`{node}`: '{node}' at {xy} is not inside the rooms' floor [rule: inside rooms]"
        assert line in lines
    assert len(lines) > 2  # their goals are off the floor too: every problem, not the first
    report = ImportReport("hand")
    assert _assemble("lab", shell, _placed(), ROBOT_RADIUS, report) is None
    assert report.problems[0]["message"].startswith("no instrument found")
