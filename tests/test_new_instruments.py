"""The molecular-biology instruments: seven goal categories beyond the paper's, with real dimensions,
their assets, the molecular_biology template and its splits, and the paper's datasets unchanged."""

import hashlib
import json

import numpy as np
import pytest

from biovln_ms.assetgen.generate import plans
from biovln_ms.catalog import PAPER_GOAL_CATEGORIES, load_catalog
from biovln_ms.episodes.samplers import AnyInstanceEpisodes
from biovln_ms.paths import asset_glb
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import check_consistency, check_layout
from biovln_ms.scene.loading import load_spec
from biovln_ms.scene.spec import save_spec
from biovln_ms.scene.templates import get_template

NEW = ("fume_hood", "ultra_low_freezer", "autoclave", "thermal_cycler", "microscope", "water_bath", "shaker")
#: name -> (dimensions, placement, face, d_half, delta, r): typical models' sizes (see each rationale)
EXPECTED = {
    "fume_hood": ((1.22, 0.81, 2.41), "wall", "-Y", 0.405, 0.7, 1.15),
    "ultra_low_freezer": ((0.87, 0.95, 1.99), "wall", "-Y", 0.475, 0.9, 1.0),
    "autoclave": ((0.66, 0.70, 1.05), "wall", "-Y", 0.35, 0.6, 0.9),
    "thermal_cycler": ((0.33, 0.46, 0.24), "table_top", "-Y", 0.23, 0.6, 0.8),
    "microscope": ((0.25, 0.40, 0.43), "table_top", "-Y", 0.20, 0.6, 0.8),
    "water_bath": ((0.60, 0.36, 0.30), "table_top", "-Y", 0.18, 0.6, 0.85),
    "shaker": ((0.68, 0.62, 0.52), "table_top", "-Y", 0.31, 0.7, 0.9),
}
PAPER_TEMPLATES = ("single_room", "two_room", "suite", "open_plan")
#: sha256 over the specs of PAPER_TEMPLATES x seeds 0-11 (catalog_sha256 left out), generated with the
#: paper's ten-category catalog: the paper's templates keep their layouts bit for bit
PAPER_TEMPLATE_SCENES = "642435dd29d3477bb3b7de9ae28ab7e5bcf93e7519ba7340d12d0e2f0e09ecf5"
#: sha256 over {split: {scene: episode file sha256}} of the paper's splits and the Hard track in the default
#: dataset, built with the paper's ten-category catalog
PAPER_SPLIT_EPISODES = "8b8a8eca943b723289e43d83d13162c29768af349683964a6b42d29257377e7c"
PAPER_SPLITS = (
    "full",
    "train",
    "ms_dev",
    "ms_val",
    "ms_test",
    "two_room",
    "lsat_target",
    "hard_val",
    "hard_test",
)


def test_at_least_fourteen_goal_categories_the_papers_first():
    goals = load_catalog().goal_categories()
    assert len(goals) >= 14
    assert tuple(goals[: len(PAPER_GOAL_CATEGORIES)]) == PAPER_GOAL_CATEGORIES  # one-hot indices 0-9 kept
    assert set(NEW) <= set(goals[len(PAPER_GOAL_CATEGORIES) :])


@pytest.mark.parametrize("name", NEW)
def test_new_category_numbers_and_the_documented_rule(name):
    a = load_catalog().get(name)
    dims, placement, face, d_half, delta, r = EXPECTED[name]
    assert (a.dimensions, a.placement, a.face, a.d_half) == (dims, placement, face, d_half)
    assert (a.approach_distance, a.success_radius) == (delta, r)
    assert r == pytest.approx(min(max(round((0.55 + a.face_width / 2) / 0.05) * 0.05, 0.8), 1.3))
    assert 0.5 <= delta <= 0.9 and a.goal_category
    assert "Not in the paper" in a.rationale and "delta" in a.rationale and " m " in a.rationale
    if placement == "table_top":  # the goal clears the support's edge (0.05 m back) by more than Fetch's body
        assert delta - 0.05 > 0.29


@pytest.mark.parametrize("name", NEW)
def test_new_asset_bounds_equal_the_catalog_dimensions(name):
    from biovln_ms.assetgen.generate import load_glb

    (plan,) = [p for p in plans(load_catalog()) if p.name == name]
    lo, hi = load_glb(asset_glb(name)).bounds
    assert np.abs((hi - lo) - np.array(plan.dimensions)).max() < 1e-6
    assert np.abs((hi + lo) / 2).max() < 1e-6


def test_existing_templates_do_not_offer_the_new_categories():
    for t in PAPER_TEMPLATES:
        assert not get_template(t).categories() & set(NEW), t
    assert set(NEW) <= get_template("molecular_biology").categories()


def test_existing_templates_keep_their_layouts():
    digests = {}
    for t in PAPER_TEMPLATES:
        for seed in range(12):
            s = json.loads(generate_scene(t, seed).to_json())
            s.pop("catalog_sha256")
            digests[f"{t}/{seed}"] = hashlib.sha256(json.dumps(s, sort_keys=True).encode()).hexdigest()
    assert hashlib.sha256(json.dumps(digests, sort_keys=True).encode()).hexdigest() == PAPER_TEMPLATE_SCENES


def test_molecular_biology_scenes_are_valid_and_place_every_new_category(tmp_path):
    seen = set()
    for seed in range(16):
        s = generate_scene("molecular_biology", seed)
        assert (
            s.name == f"molbio_s{seed}_v0"
            and s.to_json() == generate_scene("molecular_biology", seed).to_json()
        )
        assert check_layout(s) == [] and check_consistency(s) == []
        assert load_spec(save_spec(s, tmp_path / f"{s.name}.json")).to_json() == s.to_json()
        seen |= {o.category for o in s.goal_objects()}
    assert set(NEW) <= seen


def test_molecular_biology_builds_for_fetch():
    for seed in range(4):
        s = generate_scene("molecular_biology", seed, robot_radius=0.29)
        assert check_layout(s) == []


def test_molbio_splits_hold_every_new_category_on_seeds_no_other_split_uses():
    from biovln_ms import splits as b

    splits = b.molbio_splits()
    assert [s.name for s in splits] == ["molbio_val", "molbio_test"]
    used = {seed for seeds, _ in b.HELD_OUT.values() for seed in seeds} | set(b.TWO_ROOM_SEEDS)
    used |= {seed for scenes in b.HARD_SPLITS.values() for _, seed, _ in scenes}
    used |= {
        seed for first, _ in b.PROTOCOL_SPLITS.values() for seed in range(first, first + b.PROTOCOL_SEED_SCAN)
    }
    molbio = [spec.seed for s in splits for spec, _, _ in s.scenes]
    assert len(set(molbio)) == len(molbio) and not set(molbio) & used
    for s in splits:
        assert s.sampler == AnyInstanceEpisodes(hard_share=0.0)  # any instance counts, starts drawn as usual
        held = {o.category for spec, _, _ in s.scenes for o in spec.goal_objects()}
        assert set(NEW) <= held, s.name
        assert all(spec.template == "molecular_biology" for spec, _, _ in s.scenes)


def test_an_rl_checkpoint_of_the_ten_long_one_hot_is_refused_in_one_line():
    from types import SimpleNamespace

    from gymnasium import spaces

    from biovln_ms.baselines.sb3_policy import SB3Policy
    from biovln_ms.errors import BioVLNError

    policy = object.__new__(SB3Policy)
    policy.name = "ppo"
    old = 9 + len(PAPER_GOAL_CATEGORIES)  # rl_state + the paper's one-hot
    policy.model = SimpleNamespace(observation_space=spaces.Box(-1, 1, (old,)))
    obs = np.zeros((1, 9 + len(load_catalog().goal_categories())), np.float32)
    with pytest.raises(BioVLNError) as e:
        policy.act(obs, {})
    msg = str(e.value)
    assert "\n" not in msg and "retrain it" in msg and f"({old},)" in msg


def test_semantic_colours_of_the_paper_categories_are_unchanged():
    from biovln_ms.scene.export_glb import ROOM_CATEGORY, semantic_colors

    rng = np.random.default_rng(7)  # the colours drawn for the paper's ten and the room alone
    before = rng.integers(40, 256, size=(len(PAPER_GOAL_CATEGORIES) + 1, 3))
    colors = semantic_colors()
    for name, c in zip([*PAPER_GOAL_CATEGORIES, ROOM_CATEGORY], before):
        assert colors[name][:3] == tuple(int(v) for v in c), name
    assert len(set(colors.values())) == len(colors) and set(NEW) <= set(colors)


@pytest.mark.slow
def test_the_papers_splits_keep_their_episodes():
    """The default dataset (built on first use): every episode file of the paper's splits and the Hard
    track is the pinned one, built from the paper's ten categories; the molecular-biology splits are there."""
    from biovln_ms.splits import ensure_default_dataset
    from biovln_ms.episodes.dataset import EpisodeDataset

    ds = EpisodeDataset(ensure_default_dataset(lambda *_: None))
    files = {
        s: {scene: f["sha256"] for scene, f in e["files"].items()}
        for s, e in ds.manifest["splits"].items()
        if s in PAPER_SPLITS
    }
    assert hashlib.sha256(json.dumps(files, sort_keys=True).encode()).hexdigest() == PAPER_SPLIT_EPISODES
    assert {"molbio_val", "molbio_test", "hard_dressed_test"} <= set(ds.split_names())
    for split in PAPER_SPLITS:
        assert not {e["object_category"] for e in ds.episodes(split)} & set(NEW), split
    assert {e["object_category"] for e in ds.episodes("molbio_test")} >= set(NEW)
