"""Zone 2's clearance epsilon_c (Eq. 2) comes from the catalog the instrument's dimensions came from."""

import json
import math

import numpy as np
import pytest

from biovln_ms.catalog import load_catalog
from biovln_ms.geometry.zones import (
    InstrumentArray,
    PlacedInstrument,
    default_zone2_clearance,
    eq2_axis_aligned,
    zone2_disjoint,
)
from biovln_ms.paths import CATALOG_PATH

WIDE = 0.40
NAMES = ["refrigerator", "centrifuge", "waste_bin", "lab_bench"]


@pytest.fixture
def wide_catalog(tmp_path):
    """The packaged catalog with zone2_clearance 0.40."""
    obj = json.loads(CATALOG_PATH.read_text())
    obj["zone2_clearance"] = WIDE
    path = tmp_path / "catalog.json"
    path.write_text(json.dumps(obj))
    return load_catalog(path)


def _side_by_side(cat, gap: float) -> tuple[PlacedInstrument, PlacedInstrument]:
    """Two waste bins of ``cat`` whose bodies are ``gap`` apart along x."""
    a = cat.get("waste_bin")
    sx = a.dimensions[0]
    return (
        PlacedInstrument.from_asset(a, (0.0, 0.0, 0.0), 0.0),
        PlacedInstrument.from_asset(a, (sx + gap, 0.0, 0.0), 0.0),
    )


@pytest.mark.parametrize("yaw", [0.0, math.pi / 2, 0.7])
@pytest.mark.parametrize("name", NAMES)
def test_zone2_is_zone1_grown_by_the_catalogs_clearance(wide_catalog, name, yaw):
    asset = wide_catalog.get(name)
    p = PlacedInstrument.from_asset(asset, (1.0, -2.0, 0.5), yaw)
    assert p.eps_c == WIDE
    z1, z2 = p.zone1(), p.zone2()
    grown = z1.buffer(WIDE, join_style="mitre")
    assert z2.area == pytest.approx(grown.area, rel=1e-9)
    assert z2.area == pytest.approx(
        (asset.dimensions[0] + 2 * WIDE) * (asset.dimensions[1] + 2 * WIDE), rel=1e-9
    )
    assert grown.symmetric_difference(z2).area < 1e-6


def test_zone2_violation_follows_the_catalog(wide_catalog, catalog):
    point = np.array([0.0, 0.0])
    for cat, inside in ((catalog, False), (wide_catalog, True)):
        a = cat.get("waste_bin")
        p = PlacedInstrument.from_asset(
            a, (a.dimensions[0] / 2 + 0.30, 0.0, 0.0), 0.0
        )  # body 0.30 m from the point
        assert InstrumentArray([p]).in_zone2(point) is inside


@pytest.mark.parametrize("gap", [0.45, 0.55, 0.79, 0.81])
def test_eq2_follows_the_catalog(wide_catalog, catalog, gap):
    for cat in (catalog, wide_catalog):
        a, b = _side_by_side(cat, gap)
        disjoint = gap >= 2 * cat.zone2_clearance
        assert zone2_disjoint(a, b) is disjoint
        assert eq2_axis_aligned(a, b) is disjoint


def test_default_catalog_still_gives_0_25(wide_catalog, catalog):
    assert load_catalog() is catalog  # the packaged catalog is loaded once and cached
    assert catalog.zone2_clearance == 0.25
    assert default_zone2_clearance() == 0.25  # loading another catalog leaves the packaged one alone
    assert wide_catalog.get("refrigerator").zone2_clearance == WIDE
    assert catalog.get("refrigerator").zone2_clearance == 0.25
    for name in NAMES:
        assert PlacedInstrument.from_asset(catalog.get(name), (0.0, 0.0, 0.0), 0.0).eps_c == 0.25
    assert PlacedInstrument((0.0, 0.0, 0.0), 0.0, (1.0, 1.0, 1.0), None).eps_c == 0.25


def test_scene_spec_geometry_uses_the_packaged_clearance(catalog):
    from biovln_ms.scene.generator import generate_scene

    spec = generate_scene("single_room", 150)
    assert spec.catalog_sha256 == catalog.sha256
    assert {o.placed().eps_c for o in spec.objects()} == {0.25}
