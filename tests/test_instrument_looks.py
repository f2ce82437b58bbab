"""Instruments that look like themselves: PBR materials, readable decals, per-instance
variants, and meshes (so bounds and collision) exactly the first generator's."""

import hashlib

import numpy as np
import pytest

from biovln_ms.assetgen.generate import build_scene, load_glb, merged_mesh, plans
from biovln_ms.assetgen.instruments import LIVE_DECALS
from biovln_ms.assetgen.variation import HUE_JITTER, SHIPPED, VALUE_RANGE, WEAR_RANGE, restyle, variant_for
from biovln_ms.catalog import load_catalog
from biovln_ms.paths import asset_glb

#: sha256[:16] of each asset's merged mesh (float64 vertices, int64 faces) from the first generator, whose
#: meshes the coacd collision caches, the collision footprints and every dataset were computed from
FIRST_GENERATOR_MESHES = {
    "refrigerator": "b2e86dfdd06d2455",
    "incubator": "4dde8ac763fa3e65",
    "centrifuge": "f0f9e80b01393691",
    "mini_centrifuge": "682889d81e9b9f3b",
    "pipette": "a8e565f8c1c26718",
    "cabinet": "d5e4174fbcda3711",
    "waste_bin": "883d35eda81a1112",
    "biosafety_cabinet": "c14eac475d261649",
    "lab_bench": "466746806db205d9",
    "lab_table": "797e70de7135135d",
    "wall_panel": "59d86d5b82b7ef60",
    "floor_tile": "bf46764bc858e788",
    "ceiling_tile": "bf46764bc858e788",
    "door_frame": "9c99cdb24ca2c78c",
    # the molecular-biology instruments, pinned at their first generation
    "fume_hood": "215432c02b502584",
    "ultra_low_freezer": "be2de1ebfced241f",
    "autoclave": "67b5d18b8ffa57d2",
    "thermal_cycler": "599b0739d151341f",
    "microscope": "ad3bffd6b91b72d0",
    "water_bath": "f8a32d64db081c96",
    "shaker": "12b64f7881e173ee",
    # the lab dressing, pinned at its first generation
    "shelving_unit": "f67a0ba74436daa3",
    "lab_sink": "f74e282b134caeb4",
    "eyewash_station": "69cdf900020d5701",
    "fire_extinguisher": "9566ed9ed3722608",
    "safety_poster": "615b487c2e2a751a",
    "lab_stool": "8fbe3506e6b15cd9",
    "lab_trolley": "29b6101eb6a06fee",
    "glassware_rack": "24d16d98b839748d",
}
PLANS = plans(load_catalog())


def _materials(name: str) -> dict:
    scene = load_glb(asset_glb(name))
    return {g.visual.material.name: g.visual.material for g in scene.geometry.values()}


@pytest.mark.parametrize("plan", PLANS, ids=lambda p: p.name)
def test_meshes_are_the_first_generators(plan):
    m = merged_mesh(build_scene(plan))
    digest = hashlib.sha256(
        np.ascontiguousarray(m.vertices, dtype=np.float64).tobytes()
        + np.ascontiguousarray(m.faces, dtype=np.int64).tobytes()
    ).hexdigest()[:16]
    assert digest == FIRST_GENERATOR_MESHES[plan.name]


def test_instruments_have_physically_based_materials(catalog):
    for a in catalog.assets():
        mats = _materials(a.name)
        textured = [m for m in mats.values() if m.baseColorTexture is not None]
        assert len(textured) >= 5, a.name
        assert any(m.normalTexture is not None for m in mats.values()), f"{a.name}: no normal map"
        if a.name not in ("centrifuge", "pipette"):  # painted and moulded all over
            assert any((m.metallicFactor or 0) >= 0.8 for m in mats.values()), f"{a.name}: no steel"
        faces = [m for n, m in mats.items() if "_art_" in n]
        if a.name not in ("pipette", "lab_bench", "lab_table"):
            assert faces, f"{a.name}: no door or panel with its own picture"
    displays = {c for c, decals in LIVE_DECALS.items() for d in decals if "display" in d or "panel" in d}
    assert displays == {"refrigerator", "incubator", "centrifuge", "mini_centrifuge", "biosafety_cabinet"} | {
        "fume_hood",
        "ultra_low_freezer",
        "autoclave",
        "thermal_cycler",
        "water_bath",
        "shaker",
    }
    for c in displays:
        assert any(m.emissiveTexture is not None for m in _materials(c).values()), (
            f"{c}: display does not glow"
        )
    glass = _materials("biosafety_cabinet")["biosafety_cabinet_glass"]
    assert glass.alphaMode == "BLEND" and glass.baseColorTexture.mode == "RGBA"
    alpha = np.asarray(glass.baseColorTexture)[..., 3]
    assert 0.5 < alpha.mean() / 255 < 0.95  # see-through
    for c in ("centrifuge", "mini_centrifuge"):  # decals in the console's plane show through cut-outs
        console = _materials(c)[f"{c}_art_console"]
        assert console.alphaMode == "MASK"
        assert set(np.unique(np.asarray(console.baseColorTexture)[..., 3])) == {0, 255}


def test_every_live_decal_is_in_its_glb():
    for category, decals in LIVE_DECALS.items():
        names = _materials(category)
        for decal in decals:
            assert f"{category}_decal_{decal}" in names, (category, decal)


def test_variants_are_deterministic_distinct_and_plausible():
    a = variant_for("two_room_s0_v0", 0, "incubator_0")
    assert a == variant_for("two_room_s0_v0", 0, "incubator_0")
    others = [variant_for("two_room_s0_v0", 0, f"incubator_{i}") for i in range(1, 40)]
    others += [variant_for("two_room_s1_v0", 1, "incubator_0")]
    assert len({v.key for v in [a, *others]}) == len(others) + 1
    assert len({v.tag for v in [a, *others]}) == len(others) + 1
    assert len({(v.tint, v.wear) for v in others}) >= 4  # several paint looks in one lab
    for v in [a, *others]:
        t = np.asarray(v.tint)
        assert VALUE_RANGE[0] * (1 - HUE_JITTER) <= t.min() and t.max() <= VALUE_RANGE[1] * (1 + HUE_JITTER)
        assert WEAR_RANGE[0] <= v.wear <= WEAR_RANGE[1]


def test_live_decals_differ_between_instances():
    a, b = variant_for("lab", 0, "incubator_0"), variant_for("lab", 0, "incubator_1")
    for category, decals in LIVE_DECALS.items():
        for name, draw in decals.items():
            pa, pb, again = draw(a), draw(b), draw(a)
            pa, pb, again = (getattr(p, "albedo", p) for p in (pa, pb, again))
            assert np.array_equal(np.asarray(pa), np.asarray(again)), (category, name)
            assert not np.array_equal(np.asarray(pa), np.asarray(pb)), (category, name)


def test_restyle_stays_within_a_plausible_range():
    from PIL import Image

    img = Image.fromarray(np.full((64, 96, 3), 200, np.uint8))
    for v in (variant_for("lab", 0, f"x{i}") for i in range(12)):
        out = restyle(img, v.tint, v.wear, "body", face=True).astype(float)
        assert out.shape == (64, 96, 4) and (out[..., 3] == 255).all()
        change = out[..., :3].mean(axis=(0, 1)) / 200 - 1
        assert np.abs(change).max() < 0.12
    plain = restyle(img, SHIPPED.tint, 0.0, "body", face=False)
    assert (plain[..., :3] == 200).all()  # no tint, no wear: unchanged


def test_material_bounds_identify_materials():
    from biovln_ms.sim.instance_looks import asset_materials

    for category in LIVE_DECALS:
        found = asset_materials(asset_glb(category))
        assert len(found.names) == len(_materials(category)), f"{category}: two materials share bounds"
        assert found.paintwork, category


def test_benchmark_views_stand_within_the_success_radius():
    from biovln_ms.render.goal_views import goal_views
    from biovln_ms.scene.generator import generate_scene

    for o in generate_scene("two_room", 0).goal_objects():
        eyes = goal_views(o)
        assert np.allclose(eyes[0][:2], o.goal)
        for eye in eyes:
            assert np.hypot(*(eye[:2] - np.asarray(o.goal))) < o.success_radius, o.id
            assert np.hypot(*(eye[:2] - np.asarray(o.position[:2]))) == pytest.approx(
                np.hypot(*(np.asarray(o.goal) - np.asarray(o.position[:2])))
            )


@pytest.mark.render
def test_each_instance_gets_its_own_textures():
    from biovln_ms.render.sapien_utils import new_scene
    from biovln_ms.sim.instance_looks import apply_variant, variant_pictures

    scene = new_scene()
    for category in LIVE_DECALS:
        path = asset_glb(category)
        for i in range(2):
            b = scene.create_actor_builder()
            b.add_visual_from_file(str(path))
            actor = b.build_static(name=f"{category}_{i}")
            v = variant_for("lab", 0, f"{category}_{i}")
            assert apply_variant(actor, category, path, v) == len(variant_pictures(category, path, v)), (
                category
            )


@pytest.mark.render
def test_waste_bin_shows_ten_thousand_colours_from_its_goal():
    """Of the paper's categories the nearest the bar (10,000 colours from its Zone-3 goal, quality)."""
    from biovln_ms.render.goal_views import GoalViewRenderer, distinct_colours, goal_views
    from biovln_ms.scene.generator import generate_scene
    from biovln_ms.scene.templates import get_template

    offered = get_template("two_room").categories() - {"lab_bench", "lab_table"}
    instruments = [c for c in load_catalog().goal_categories() if c in offered]
    spec = generate_scene("two_room", 0, required_categories=instruments)  # the benchmark's scene
    bin_ = next(o for o in spec.instruments if o.category == "waste_bin")
    renderer = GoalViewRenderer(spec, "quality")
    rgb, mask = renderer.render(bin_, goal_views(bin_, (0.0,))[0])
    assert mask.sum() > 20_000
    assert distinct_colours(rgb, mask) >= 10_000


@pytest.mark.render
def test_microscope_shows_ten_thousand_colours_from_its_goal():
    """The smallest mask that holds 10,000 colours (the pipette stand's ~4,200 px cannot): the microscope
    in the benchmark's molecular-biology scene, from its Eq. 1 goal."""
    from biovln_ms.render.goal_views import GoalViewRenderer, distinct_colours, goal_views, showcase_scenes

    spec, objects = next(
        (s, o)
        for s, o in showcase_scenes(load_catalog().goal_categories())
        if s.template == "molecular_biology"
    )
    scope = next(o for o in objects if o.category == "microscope")
    rgb, mask = GoalViewRenderer(spec, "quality").render(scope, goal_views(scope, (0.0,))[0])
    assert 15_000 < mask.sum() < 25_000
    assert distinct_colours(rgb, mask) >= 10_000


def _builds_looks(**kwargs) -> bool:
    import gymnasium as gym

    env = gym.make("BioVLN-OpFace-v0", camera_width=64, camera_height=48, **kwargs)
    try:
        env.reset(seed=0)
        return env.unwrapped.scene_builder.variants
    finally:
        env.close()


def test_an_env_that_makes_no_picture_builds_no_looks():
    """Looks only show in a picture: a state-only env's scenes are built without them (faster)."""
    assert _builds_looks(obs_mode="state") is False


@pytest.mark.render
def test_an_image_observation_or_a_render_mode_keeps_the_looks():
    assert _builds_looks(obs_mode="rgb") is True
    assert _builds_looks(obs_mode="state", render_mode="rgb_array") is True
