"""Designer names in the wild: words and catalog synonyms, the user's name map, and a
marker whose instrument's name says nothing — on a designer GLB written here."""

import json
import subprocess
import sys

import pytest
import trimesh

from biovln_ms.catalog import CatalogFile, load_catalog
from biovln_ms.errors import CatalogError
from biovln_ms.geometry.frames import Z_UP_TO_Y_UP
from biovln_ms.lsat.designer_scene import build_designer_scene
from biovln_ms.lsat.importer import MARKER_REACH, import_glb
from biovln_ms.lsat.name_map import NameMapError, load_name_map, parse_name_map
from biovln_ms.lsat.names import match_category


@pytest.mark.parametrize(
    "name, category",
    [
        ("Refrigerator_large", "refrigerator"),
        ("Fridge_02", "refrigerator"),
        ("Display Fridge", "refrigerator"),  # a part word before the phrase is a qualifier
        ("BSC-2", "biosafety_cabinet"),
        ("Biosafety Cabinet (Class II)", "biosafety_cabinet"),  # not the storage "cabinet" inside it
        ("TC Hood", "biosafety_cabinet"),
        ("Centrifuge 5424R", "centrifuge"),
        ("Mini Centrifuge", "mini_centrifuge"),  # not the "centrifuge" inside it
        ("waste-bin.003", "waste_bin"),
        ("WasteBin", "waste_bin"),  # camel case
        ("Storage Cabinet", "cabinet"),
        ("Bench_Island", "lab_bench"),
        ("CO2Incubator", "incubator"),
        ("target_Fridge_02", "refrigerator"),
        ("Fume Hood", "fume_hood"),  # a goal category of its own, not a biosafety cabinet
        ("ULT_Freezer_2", "ultra_low_freezer"),
        ("PCR Machine", "thermal_cycler"),
    ],
)
def test_designer_names_are_recognised_by_their_words(name, category):
    m = match_category(name, "target_" if name.startswith("target") else None)
    assert (m.category, m.how) == (category, "words")


@pytest.mark.parametrize(
    "name, how, candidates",
    [
        ("cabinet_door", "part", ()),  # a part word after the phrase: a part, and no biosafety cabinet
        ("Bin_Shelf", "part", ()),
        ("fridge door-2", "part", ()),
        ("Extract Hood", "", ()),  # "hood" alone is no synonym: a fume hood is not a biosafety cabinet
        ("Hood_01", "", ()),
        ("Binoculars", "", ()),  # words, not substrings: no "bin" in it (nor in "cabinet")
        ("Fridge_Incubator", "words", ("incubator", "refrigerator")),  # ambiguous: reported, not guessed
    ],
)
def test_names_that_are_parts_unknown_or_ambiguous_are_not_guessed(name, how, candidates):
    m = match_category(name)
    assert (m.category, m.how, m.candidates) == (None, how, candidates)


@pytest.mark.parametrize("name", ["BSC_cabinet", "Cabinet BSC.001", "target_BSC Cabinet"])
def test_the_more_specific_of_two_categories_in_a_name_wins(name):
    m = match_category(name, "target_" if name.startswith("target") else None)
    assert (m.category, m.how, m.set_aside) == ("biosafety_cabinet", "words", ("cabinet",))
    assert not m.ambiguous


@pytest.mark.parametrize(
    "name, candidates",
    [
        ("Fridge cabinet", ("cabinet", "refrigerator")),  # neither names the other: still ambiguous
        ("storage cabinet BSC", ("biosafety_cabinet", "cabinet")),  # "storage cabinet" is in no BSC phrase
    ],
)
def test_categories_neither_more_specific_stay_ambiguous(name, candidates):
    m = match_category(name)
    assert (m.category, m.candidates, m.set_aside) == (None, candidates, ())


def test_levenshtein_typos_still_match():
    m = match_category("target_refrigerater_2", "target_")
    assert (m.category, m.how, m.distance) == ("refrigerator", "fuzzy", 1)


def _catalog_obj() -> dict:
    return json.loads(load_catalog().source.read_text())


def test_catalog_synonyms_are_validated():
    obj = _catalog_obj()
    obj["assets"][1]["synonyms"] = ["fridge"]  # the incubator: "fridge" is the refrigerator's already
    with pytest.raises(ValueError, match=r"assets\[1\]\.synonyms.*'fridge' already names 'refrigerator'"):
        CatalogFile.model_validate(obj)
    obj = _catalog_obj()
    obj["assets"][0]["synonyms"] = ["Fridge 2"]
    with pytest.raises(ValueError, match="lower-case words"):
        CatalogFile.model_validate(obj)


def test_a_bad_catalog_synonym_is_one_line_naming_the_field(tmp_path):
    obj = _catalog_obj()
    obj["assets"][7]["synonyms"].append("bin")  # the biosafety cabinet claims the waste bin's word
    path = tmp_path / "catalog.json"
    path.write_text(json.dumps(obj))
    with pytest.raises(CatalogError) as e:
        load_catalog(path)
    assert str(path) in str(e.value) and "assets[7].synonyms" in str(e.value) and "\n" not in str(e.value)


def test_name_map_patterns_and_null():
    names = parse_name_map({"Sterilgard*": "biosafety_cabinet", "BSC-2": None, "Fridge_02": "incubator"}, "m")
    assert match_category("sterilgard III.001", names=names).category == "biosafety_cabinet"  # glob, any case
    assert (match_category("BSC-2", names=names).category, match_category("BSC-2", names=names).how) == (
        None,
        "name map",
    )
    assert match_category("Fridge_02", names=names).category == "incubator"  # the map wins over synonyms
    assert match_category("target_Sterilgard", "target_", names).category == "biosafety_cabinet"
    assert match_category("Fridge_03", names=names).category == "refrigerator"  # not in the map


@pytest.mark.parametrize(
    "text, field, fix",
    [
        ("Sterilgard: fridge\n", "Sterilgard", "did you mean 'refrigerator'?"),
        ("Sterilgard: [a, b]\n", "Sterilgard", "or null"),
        ("2: incubator\n", "2", "quote the name"),
        ("- a\n- b\n", None, "node name: category"),
        ("a: [\n", None, "node name: category"),
    ],
)
def test_a_bad_name_map_is_one_line_naming_file_key_and_fix(tmp_path, text, field, fix):
    path = tmp_path / "map.yaml"
    path.write_text(text)
    with pytest.raises(NameMapError) as e:
        load_name_map(path)
    msg = str(e.value)
    assert msg.startswith(str(path)) and fix in msg and "\n" not in msg
    assert (f"field '{field}'" in msg) if field else "field" not in msg


# ------------------------------------------------------------------------------------------------------
# A designer GLB with names as designers type them. The incubator is named after its model only; its
# marker's category tells what it is.
LAYOUT = [
    ("Bench_Island", "lab_bench", 4.0, 2.2, 90, None, None),
    ("Centrifuge 5424R", "centrifuge", 2.5, 2.62, -90, None, None),
    ("Refrigerator_large", "refrigerator", 4.2, 5.545, 0, "target_refrigerater", (0.5, -0.04)),
    ("Fridge_02", "refrigerator", 1.0, 5.545, 0, None, None),
    ("BSC-2", "biosafety_cabinet", 2.6, 5.6, 0, "target_bsc", (0.6, 0.0)),
    ("Biosafety Cabinet (Class II)", "biosafety_cabinet", 6.3, 5.6, 0, None, None),
    ("waste-bin.003", "waste_bin", 0.4, 0.6, 0, None, None),
    ("Heracell VIOS 160i", "incubator", 7.325, 3.9, 0, "target_incubator", (0.8, 0.0)),
]
LOOSE = {  # meshes no rule makes an instrument: name -> (centre x, y, z), size (x, y, z)
    "cabinet_door": ((7.6, 0.5, 0.85), (0.6, 0.03, 1.7)),
    "Bin_Shelf": ((7.6, 1.4, 0.5), (0.4, 0.3, 1.0)),
    "Extract Hood": ((2.5, 0.3, 1.0), (1.2, 0.5, 2.0)),
}
EXPECTED = {
    "Bench_Island": "lab_bench",
    "Centrifuge 5424R": "centrifuge",
    "Refrigerator_large": "refrigerator",
    "Fridge_02": "refrigerator",
    "BSC-2": "biosafety_cabinet",
    "Biosafety Cabinet (Class II)": "biosafety_cabinet",
    "waste-bin.003": "waste_bin",
    "Heracell VIOS 160i": "incubator",
}


@pytest.fixture(scope="module")
def designer_glb(tmp_path_factory):
    scene = build_designer_scene(LAYOUT)
    for name, (centre, size) in LOOSE.items():
        scene.add_geometry(
            trimesh.creation.box(size),
            node_name=name,
            geom_name=name,
            transform=Z_UP_TO_Y_UP @ trimesh.transformations.translation_matrix(centre),
        )
    path = tmp_path_factory.mktemp("designer") / "designer_lab.glb"
    path.write_bytes(scene.export(file_type="glb"))
    return path


def test_designer_glb_names_resolve_and_an_orphan_marker_keeps_its_goal(designer_glb):
    spec, report = import_glb(designer_glb)
    assert {r["node"]: r["category"] for r in report.instruments} == EXPECTED
    assert sorted(report.unmatched) == sorted(LOOSE) and not report.ambiguous
    (adopted,) = report.adopted
    assert adopted["marker"] == "target_incubator" and adopted["node"] == "Heracell VIOS 160i"
    assert adopted["category"] == "incubator" and adopted["distance"] < MARKER_REACH
    incubator = next(o for o in spec.instruments if o.category == "incubator")
    assert incubator.goal_source == "marker" and incubator.goal == pytest.approx(
        (7.325 - 0.673 - 0.8, 3.9), abs=0.01
    )
    markers = {m["node"]: m["assigned_to"] for m in report.markers}
    assert None not in markers.values() and set(markers) == {
        "target_refrigerater",
        "target_bsc",
        "target_incubator",
    }
    md = report.to_markdown()
    assert "recognised only by their marker" in md and "`Heracell VIOS 160i`" in md
    assert report.coverage()["instruments_from_markers"] == ["Heracell VIOS 160i"]


def test_ambiguous_names_beside_their_markers_keep_instrument_and_goal(tmp_path):
    """A biosafety cabinet named with both 'BSC' and 'cabinet', and a fridge named 'Fridge cabinet', each
    with its marker: the first is the more specific category, the second is the one its marker names."""
    renamed = {
        "BSC-2": ("BSC cabinet", "target_biosafety_cabinet"),
        "Fridge_02": ("Fridge cabinet", "target_refrigerator.001"),
    }
    layout = [
        (renamed[r[0]][0], r[1], r[2], r[3], r[4], renamed[r[0]][1], (0.55, 0.0)) if r[0] in renamed else r
        for r in LAYOUT
    ]
    path = tmp_path / "ambiguous.glb"
    path.write_bytes(build_designer_scene(layout).export(file_type="glb"))
    spec, report = import_glb(path)
    got = {r["node"]: (r["category"], r["goal_strategy"]) for r in report.instruments}
    assert got["BSC cabinet"] == ("biosafety_cabinet", 1) and got["Fridge cabinet"] == ("refrigerator", 1)
    assert not report.ambiguous and None not in {m["assigned_to"] for m in report.markers}
    assert [(r["node"], r["category"], r["by"].split(",")[0]) for r in report.settled] == [
        ("BSC cabinet", "biosafety_cabinet", "the more specific name"),
        ("Fridge cabinet", "refrigerator", "marker `target_refrigerator.001`"),
    ]
    md = report.to_markdown()
    assert "## Ambiguous names settled" in md and "`BSC cabinet`: biosafety_cabinet or cabinet" in md
    assert "Markers without an instrument" not in md


def test_name_map_wins_over_words_and_synonyms(designer_glb, tmp_path):
    path = tmp_path / "map.yaml"
    path.write_text(
        "# designer name or glob -> category (null: not an instrument)\n"
        "Centrifuge 5424R: mini_centrifuge\n"
        "'Heracell*': incubator\n"
        "Extract Hood: null\n"
    )
    spec, report = import_glb(designer_glb, names=load_name_map(path))
    got = {r["node"]: r["category"] for r in report.instruments}
    assert got == {**EXPECTED, "Centrifuge 5424R": "mini_centrifuge"}
    assert not report.adopted  # the map named the incubator: its marker is an ordinary one
    assert sorted(report.unmatched) == ["Bin_Shelf", "cabinet_door"]  # null: left out, unreported


def test_a_marker_with_no_mesh_in_reach_stays_unassigned(tmp_path):
    layout = [row for row in LAYOUT if row[0] != "Heracell VIOS 160i"]
    layout.append(
        ("Heracell VIOS 160i", "incubator", 7.325, 3.9, 0, "target_incubator", (MARKER_REACH + 0.4, 0))
    )
    path = tmp_path / "far.glb"
    path.write_bytes(build_designer_scene(layout).export(file_type="glb"))
    spec, report = import_glb(path)
    assert not report.adopted and report.coverage()["markers_unassigned"] == ["target_incubator"]
    assert "incubator" not in {o.category for o in spec.objects()}


def test_lsat_import_cli_names_option(designer_glb, tmp_path):
    from typer.testing import CliRunner

    from biovln_ms.cli import app

    good = tmp_path / "map.yaml"
    good.write_text("'Heracell*': incubator\n")
    out = tmp_path / "lab.json"
    r = CliRunner().invoke(app, ["lsat", "import", str(designer_glb), "-o", str(out), "--names", str(good)])
    assert r.exit_code == 0, r.output
    assert "Heracell VIOS 160i" in out.with_suffix(".report.md").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text("Heracell: fridge\n")
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "biovln_ms.cli",
            "lsat",
            "import",
            str(designer_glb),
            "-o",
            str(out),
            "--names",
            str(bad),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "Traceback" not in r.stderr
    line = " ".join(r.stderr.split())
    assert str(bad) in line and "field 'Heracell'" in line and "did you mean 'refrigerator'?" in line
