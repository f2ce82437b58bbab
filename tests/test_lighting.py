"""Lighting presets: ``fast`` is the default, unshadowed lighting; ``quality`` casts shadows."""

import gymnasium as gym
import numpy as np
import pytest
import shapely

import biovln_ms  # noqa: F401
from biovln_ms.render.lighting import LIGHTING, LightingError, fixture_positions, lighting_preset
from biovln_ms.scene.generator import generate_scene
from biovln_ms.sim.footprints import collision_footprints
from biovln_ms.tasks.config_checks import EnvConfigError


def test_presets_and_one_line_error():
    assert set(LIGHTING) == {"fast", "quality"}
    fast = LIGHTING["fast"]
    assert fast.ambient == (0.45, 0.45, 0.45) and not fast.shadows and fast.fixture_spacing is None
    assert LIGHTING["quality"].shadows
    with pytest.raises(LightingError) as e:
        lighting_preset("studio")
    assert "\n" not in str(e.value) and "fast, quality" in str(e.value)


def test_quality_fixtures_are_a_grid_under_the_ceiling():
    spec = generate_scene("single_room", 0)
    room = next(r for r in spec.rooms if r.kind == "room")
    (one,) = fixture_positions(room, LIGHTING["fast"])
    grid = fixture_positions(room, LIGHTING["quality"])
    assert len(grid) > 1 and all(abs(z - (room.height - 0.3)) < 1e-9 for *_, z in grid)
    assert np.allclose(np.mean([p[:2] for p in grid], 0), one[:2], atol=0.5)


def test_unknown_preset_is_rejected_by_the_env():
    with pytest.raises(
        EnvConfigError, match="field .lighting.: unknown lighting .studio.*use one of: fast, quality"
    ):
        gym.make("BioVLN-OpFace-v0", lighting="studio")


def _floor_shading(lighting: str) -> tuple[float, np.ndarray]:
    """Mean brightness of the floor under furniture over that of open floor, and the head camera's RGB."""
    env = gym.make(
        "BioVLN-OpFace-v0", obs_mode="pointcloud", camera_width=160, camera_height=120, lighting=lighting
    )
    try:
        obs, _ = env.reset(seed=0)
        spec = env.unwrapped.scene_spec
        pc = obs["pointcloud"]
        xyz = pc["xyzw"][0, :, :3].cpu().numpy()
        rgb = pc["rgb"][0].cpu().numpy()
    finally:
        env.close()
    lum = rgb.astype(float).mean(1)
    floor = np.abs(xyz[:, 2]) < 0.01
    footprints = shapely.union_all(collision_footprints(spec))
    pts = shapely.points(xyz[:, :2])
    under = floor & shapely.contains(footprints, pts)
    open_floor = floor & (shapely.distance(footprints, pts) > 0.5)
    assert under.sum() > 100 and open_floor.sum() > 100  # the start view sees floor under the bench
    return lum[under].mean() / lum[open_floor].mean(), rgb


@pytest.mark.slow
@pytest.mark.render
def test_quality_shadows_the_floor_under_furniture():
    fast, fast_rgb = _floor_shading("fast")
    quality, quality_rgb = _floor_shading("quality")
    assert np.abs(fast_rgb.astype(int) - quality_rgb.astype(int)).mean() > 5
    # without shadows the floor under a bench is lit like open floor; with them it is darker
    assert quality < fast - 0.04, (fast, quality)


@pytest.mark.render
def test_contact_sheet_and_scene_views_under_quality(tmp_path):
    """The pictures people look at render under ``quality``: an asset under its one shadowed fixture
    (SAPIEN's default shader pack would refuse it), a lit robot's-eye view and a view from above."""
    from PIL import Image

    from biovln_ms.assetgen.generate import plans
    from biovln_ms.catalog import load_catalog
    from biovln_ms.render.asset_preview import AssetRenderer
    from biovln_ms.render.scene_view import render_robot_and_top_views

    plan = next(p for p in plans(load_catalog()) if p.name == "waste_bin")
    r = AssetRenderer(96, lighting="quality").render(plan)
    assert r.front.shape == (96, 96, 3) and r.front.std() > 5 and r.front_colors > 200
    spec = generate_scene("single_room", 0)
    robot, top = render_robot_and_top_views(spec, tmp_path, "quality", eye_size=(96, 72), top_width=96)
    for png in (robot, top):
        rgb = np.asarray(Image.open(png))
        assert rgb.mean() > 40 and rgb.std() > 5, png.name  # lit, not one flat colour
    assert np.asarray(Image.open(top)).shape[:2] == (72, 96)  # the 8 x 6 m room's aspect
