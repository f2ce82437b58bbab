import json

import pytest

from biovln_ms.catalog import load_catalog
from biovln_ms.errors import CatalogError
from biovln_ms.paths import CATALOG_PATH

# Paper Table 2, exactly as printed: name -> (dimensions, placement, face, d_half).
TABLE2 = {
    "refrigerator": ((0.89, 0.91, 1.78), "wall", "-Y", 0.455),
    "incubator": ((1.35, 0.85, 1.90), "wall", "-X", 0.673),
    "centrifuge": ((0.49, 0.42, 0.63), "table_top", "-X", 0.245),
    "mini_centrifuge": ((0.66, 0.50, 0.43), "table_top", "-X", 0.332),
    "pipette": ((0.04, 0.32, 0.28), "table_top", "-Y", 0.159),
    "cabinet": ((1.38, 0.57, 1.77), "wall", "+X", 0.692),
    "waste_bin": ((0.38, 0.37, 0.51), "floor", "+X", 0.183),
}


@pytest.mark.parametrize("name", sorted(TABLE2))
def test_table2_numbers_exact(catalog, name):
    dims, placement, face, d_half = TABLE2[name]
    a = catalog.get(name)
    assert a.dimensions == dims
    assert a.placement == placement
    assert a.face == face
    assert a.d_half == d_half


def test_infrastructure_and_extra_goal_categories(catalog):
    assert catalog.get("lab_bench").dimensions == (1.55, 5.94, 0.76)
    assert catalog.get("lab_table").dimensions == (2.40, 0.90, 1.10)
    assert catalog.support_heights == {"lab_bench": 0.76, "lab_table": 0.78}
    assert catalog.data.room_inner.dimensions == (8.0, 6.0, 3.24)
    assert catalog.zone2_clearance == 0.25
    goals = set(catalog.goal_categories())
    assert len(goals) >= 10  # the Two-Room template needs 10 goal categories
    assert {"biosafety_cabinet", "lab_bench", "lab_table"} <= goals


def test_approach_distance_and_success_radius_in_paper_ranges(catalog):
    for a in catalog.assets():
        if a.goal_category:
            assert 0.5 <= a.approach_distance <= 0.9, a.name
            assert 0.8 <= a.success_radius <= 1.3, a.name
            assert a.rationale, f"{a.name}: delta and r must be justified"


def test_success_radius_follows_the_documented_rule(catalog):
    # r = clip(0.55 + w/2, 0.8, 1.3) rounded to 0.05 (catalog.json "rules.success_radius").
    for a in catalog.assets():
        if a.goal_category:
            expected = min(max(round((0.55 + a.face_width / 2) / 0.05) * 0.05, 0.8), 1.3)
            assert a.success_radius == pytest.approx(expected, abs=1e-9), a.name


def test_unknown_name_lists_known_ones(catalog):
    with pytest.raises(CatalogError) as e:
        catalog.get("refrigerater")
    msg = str(e.value)
    assert "refrigerater" in msg and "refrigerator" in msg and "waste_bin" in msg
    assert "Did you mean 'refrigerator'" in msg


def test_json_list_has_the_documented_keys(catalog):
    rows = catalog.to_json_list()
    keys = {"name", "dimensions", "placement", "face", "d_half", "approach_distance", "success_radius"}
    for row in rows:
        assert keys <= set(row)
        assert len(row["dimensions"]) == 3
        assert row["placement"] in {"wall", "table_top", "floor", "furniture"}


def _write(tmp_path, mutate):
    obj = json.loads(CATALOG_PATH.read_text())
    mutate(obj)
    p = tmp_path / "bad_catalog.json"
    p.write_text(json.dumps(obj))
    return p


@pytest.mark.parametrize(
    "mutate, field",
    [
        (lambda o: o["assets"][0].update(approach_distance=2.0), "assets[0].approach_distance"),
        (lambda o: o["assets"][1].update(face="-Z"), "assets[1].face"),
        (lambda o: o["assets"][2].update(dimensions=[0.49, -0.42, 0.63]), "assets[2].dimensions"),
        (lambda o: o["assets"][3].update(d_half=0.9), "assets[3]"),
        (lambda o: o["assets"][4].pop("placement"), "assets[4].placement"),
        (lambda o: o["assets"].append(dict(o["assets"][0])), "assets"),
        (lambda o: o["assets"][0].update(colour="red"), "assets[0].colour"),
        (lambda o: o.update(zone2_clearance=0.0), "zone2_clearance"),
    ],
)
def test_malformed_catalog_names_file_and_field(tmp_path, mutate, field):
    path = _write(tmp_path, mutate)
    with pytest.raises(CatalogError) as e:
        load_catalog(path)
    msg = str(e.value)
    assert str(path) in msg
    assert f"field '{field}" in msg


def test_not_json_and_missing_file(tmp_path):
    p = tmp_path / "broken.json"
    p.write_text("{ not json")
    with pytest.raises(CatalogError, match="not valid JSON at line 1"):
        load_catalog(p)
    with pytest.raises(CatalogError, match="cannot read the catalog"):
        load_catalog(tmp_path / "absent.json")


def test_catalog_hash_is_stable(catalog):
    import hashlib

    assert catalog.sha256 == hashlib.sha256(CATALOG_PATH.read_bytes()).hexdigest()


def test_every_asset_carries_its_catalogs_zone2_clearance(tmp_path, catalog):
    from biovln_ms.catalog import AssetSpec

    assert {a.zone2_clearance for a in catalog.assets()} == {catalog.zone2_clearance}
    wide = load_catalog(_write(tmp_path, lambda o: o.update(zone2_clearance=0.4)))
    assert wide.zone2_clearance == 0.4
    assert {a.zone2_clearance for a in wide.assets()} == {0.4}
    assert {a.zone2_clearance for a in catalog.assets()} == {0.25}  # the packaged catalog is untouched
    raw = json.loads(CATALOG_PATH.read_text())["assets"][0]
    assert (
        AssetSpec.model_validate(raw).zone2_clearance == 0.25
    )  # a stand-alone asset: the packaged catalog's
