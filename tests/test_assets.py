import shutil

import numpy as np
import pytest

from biovln_ms.assetgen.generate import (
    build_scene,
    generate_assets,
    load_glb,
    plans,
    verify_assets,
)
from biovln_ms.errors import AssetError
from biovln_ms.paths import ASSET_DIR, asset_glb


def test_shipped_assets_match_manifest(catalog):
    assert verify_assets(ASSET_DIR, catalog) == []


@pytest.mark.parametrize(
    "plan", plans(__import__("biovln_ms.catalog", fromlist=["x"]).load_catalog()), ids=lambda p: p.name
)
def test_glb_is_origin_centred_with_table2_bounds(plan):
    scene = load_glb(asset_glb(plan.name))
    lo, hi = scene.bounds
    assert np.abs((hi - lo) - np.array(plan.dimensions)).max() < 1e-6  # exactly, up to float32 storage
    assert np.abs((hi + lo) / 2).max() < 1e-6
    assert len(scene.geometry) >= 1


def test_instruments_are_detailed(catalog):
    # Doors/handles/panels/labels: several parts and several materials per instrument, textures on them.
    for a in catalog.assets():
        scene = load_glb(asset_glb(a.name))
        names = " ".join(scene.geometry)
        assert len(scene.geometry) >= 7, a.name
        assert any(k in names for k in ("label", "display", "keypad", "services")), a.name
        textured = [
            g
            for g in scene.geometry.values()
            if getattr(getattr(g.visual, "material", None), "baseColorTexture", None) is not None
        ]
        assert len(textured) >= 3, a.name


def test_operational_face_carries_the_controls(catalog):
    """The display/keypad/label decals sit on the operational-face side of the body."""
    for a in catalog.assets():
        if a.face is None:
            continue
        scene = load_glb(asset_glb(a.name))
        f = a.face_vector
        front = []
        for node in scene.graph.nodes_geometry:
            tf, geom = scene.graph[node]
            if any(
                k in geom
                for k in (
                    "display",
                    "keypad",
                    "control",
                    "door",
                    "pedal",
                    "console",
                    "drawer",
                    "volume",
                    "sash",
                )
            ):
                c = scene.geometry[geom].bounds.mean(axis=0) + tf[:3, 3]
                front.append(float(c[:2] @ f))
        assert front, a.name
        assert np.median(front) > 0, f"{a.name}: controls are not on the {a.face} side"


@pytest.mark.slow
def test_regeneration_is_bit_identical(tmp_path, catalog):
    # GLBs are regenerated; the coacd cache is reused when its input mesh is unchanged.
    out = tmp_path / "assets"
    shutil.copytree(ASSET_DIR / "collision", out / "collision")
    shutil.copy(ASSET_DIR / "manifest.json", out / "manifest.json")
    generate_assets(out, catalog, progress=False)
    for plan in plans(catalog):
        assert (out / f"{plan.name}.glb").read_bytes() == asset_glb(plan.name).read_bytes(), plan.name
    assert (out / "manifest.json").read_bytes() == (ASSET_DIR / "manifest.json").read_bytes()


@pytest.mark.slow
def test_coacd_decomposition_is_deterministic_and_cached(tmp_path, catalog):
    out = tmp_path / "assets"
    generate_assets(out, catalog, names=["waste_bin"], progress=False)  # no cache: runs coacd
    shipped = (ASSET_DIR / "collision" / "waste_bin.obj").read_bytes()
    assert (out / "collision" / "waste_bin.obj").read_bytes() == shipped
    assert shipped.count(b"\no hull_") >= 2


def test_collision_hulls_fit_inside_the_body(catalog):
    import trimesh

    for a in catalog.assets():
        if a.collision != "coacd":
            continue
        mesh = trimesh.load(ASSET_DIR / "collision" / f"{a.name}.obj", force="mesh", process=False)
        lo, hi = mesh.bounds
        assert np.all(hi - lo <= np.array(a.dimensions) + 0.02), a.name
        assert np.all(hi - lo >= 0.7 * np.array(a.dimensions)), a.name


def test_corrupt_or_missing_assets_are_reported(tmp_path, catalog):
    bad = tmp_path / "x.glb"
    bad.write_bytes(b"glTF\x02\x00\x00\x00garbage")
    with pytest.raises(AssetError, match=str(bad)):
        load_glb(bad)
    with pytest.raises(AssetError, match="missing"):
        load_glb(tmp_path / "absent.glb")
    copy = tmp_path / "assets"
    shutil.copytree(ASSET_DIR, copy, ignore=shutil.ignore_patterns("__pycache__"))
    (copy / "pipette.glb").write_bytes(b"tampered")
    (copy / "cabinet.glb").unlink()
    problems = verify_assets(copy, catalog)
    assert any("pipette.glb" in p and "does not match" in p for p in problems)
    assert any("cabinet.glb" in p and "missing" in p for p in problems)


def test_unknown_builder_is_a_clear_error():
    from biovln_ms.assetgen.generate import AssetPlan

    with pytest.raises(AssetError, match="no builder for asset 'flux_capacitor'"):
        build_scene(AssetPlan("flux_capacitor", (1, 1, 1), (0, -1), "box"))
