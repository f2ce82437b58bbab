"""Protocol episodes and splits and the instruction vocabulary: every episode is a valid,
ordered visit of a shipped protocol whose instruction reads back to its goals; the splits are deterministic,
held out, and hold at least 300 episodes; stats report K, route lengths and relations."""

from __future__ import annotations

import gzip
import hashlib
import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from biovln_ms.splits import (
    FOUR_CATEGORIES,
    HARD_SPLITS,
    HELD_OUT,
    PROTOCOL_SEED_SCAN,
    PROTOCOL_SPLITS,
    TWO_ROOM_SEEDS,
    protocol_splits,
)
from biovln_ms.cli import app
from biovln_ms.constants import MAX_VISITS, MIN_VISITS
from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset
from biovln_ms.episodes.samplers import ProtocolEpisodes
from biovln_ms.episodes.writer import SplitPlan, write_dataset
from biovln_ms.episodes.generator import EpisodeError, keeps_start_rule
from biovln_ms.protocols import load_protocols
from biovln_ms.protocols.episodes import ProtocolSampler, drawable_objects, hosted_protocols
from biovln_ms.protocols.instructions import resolve
from biovln_ms.protocols.vocabulary import (
    PAD,
    UNK,
    InstructionTooLongError,
    build_vocabulary,
    decode_text,
    load_vocabulary,
    tokenize,
    vocabulary_path,
)
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import scene_navigation

LIBRARY = load_protocols(env=False)


# --- the vocabulary -------------------------------------------------------------------------------
def test_the_shipped_vocabulary_is_the_one_the_sources_build():
    shipped = load_vocabulary()
    assert shipped == build_vocabulary(), (
        "the grammar, templates, catalog or shipped protocols changed the vocabulary: write the next "
        "version (python -m biovln_ms.protocols.vocabulary N) and move VOCABULARY_VERSION to it"
    )
    assert shipped.tokens[:2] == (PAD, UNK) and list(shipped.tokens[2:]) == sorted(shipped.tokens[2:])
    obj = json.loads(vocabulary_path().read_text())
    assert obj["version"] == shipped.version and obj["max_tokens"] == shipped.max_tokens == 256
    assert obj["max_text_bytes"] == shipped.max_text_bytes == 1024 and "tokenizer" in obj


def test_encoding_is_padded_unknown_words_are_one_and_long_text_is_refused():
    v = load_vocabulary()
    text = "Then, go to the refrigerator in room B; finally visit the zeppelin."
    assert tokenize(text)[:4] == ["then", ",", "go", "to"]
    ids = v.encode(text)
    assert ids.shape == (v.max_tokens,) and ids.dtype == np.int32
    n = len(tokenize(text))
    assert ids[n:].tolist() == [0] * (v.max_tokens - n) and ids.tolist().count(1) == 1
    assert v.unknown(text) == ["zeppelin"] and v.decode(ids) == " ".join(tokenize(text)).replace(
        "zeppelin", UNK
    )
    assert decode_text(v.encode_text("Go to room B.")) == "Go to room B."
    for long in ("go " * (v.max_tokens + 1), "é" * v.max_text_bytes):
        with pytest.raises(InstructionTooLongError) as e:
            v.encode(long) if long.startswith("go") else v.encode_text(long)
        assert "field 'instruction'" in str(e.value) and "\n" not in str(e.value)


# --- episodes -------------------------------------------------------------------------------------
@cache
def _scene(template: str, seed: int):
    required = FOUR_CATEGORIES if template == "single_room" else ()
    return generate_scene(template, seed, required_categories=required)


def _check_episode(ep: dict, spec) -> None:
    """One protocol episode against its scene: ordered goals of an admissible visit order, goal objects
    only, the instruction reads back to them, the start rule for the first goal, the route's legs."""
    p, goals = ep["protocol"], ep["goals"]
    protocol = LIBRARY.get(p["id"])
    assert MIN_VISITS <= p["k"] == len(goals) == protocol.k <= MAX_VISITS
    cats = [g["object_category"] for g in goals]
    assert protocol.admits(cats), (p["id"], cats)
    assert all(spec.get(g["object_id"]).is_goal for g in goals)  # furniture that is no goal is never drawn
    assert resolve(p["instruction"], spec) == [g["object_id"] for g in goals]
    assert load_vocabulary().unknown(p["instruction"]) == []
    assert p["needs_relation"] == sum(r is not None for r in p["relations"])
    for g, rel in zip(goals, p["relations"]):
        assert (rel is not None) == (sum(o.category == g["object_category"] for o in spec.objects()) > 1)
    assert ep["object_id"] == goals[0]["object_id"] and ep["object_category"] == cats[0]
    start, first = np.asarray(ep["start_position"][:2]), np.asarray(goals[0]["position"][:2])
    assert keeps_start_rule(p["legs"][0], float(np.linalg.norm(first - start)), goals[0]["radius"])
    for g in goals:  # no goal's radius holds the start
        assert np.linalg.norm(np.asarray(g["position"][:2]) - start) > g["radius"]
    assert p["route_length"] == pytest.approx(sum(p["legs"]), abs=1e-5)
    assert ep["info"]["geodesic_distance"] == p["route_length"]


@pytest.mark.parametrize("template", ["single_room", "two_room", "suite", "open_plan"])
def test_episodes_are_ordered_valid_and_read_back(template):
    spec = _scene(template, 701)
    sampler = ProtocolSampler(spec)
    eps = sampler.protocol_episodes(12, seed=3, library=LIBRARY)
    assert [e["episode_id"] for e in eps] == [str(k) for k in range(12)]
    for ep in eps:
        _check_episode(ep, spec)
    nav = scene_navigation(spec)
    ep = eps[0]
    legs = [nav.geodesic_distance(ep["start_position"][:2], ep["goals"][0]["position"][:2])]
    legs += [
        nav.geodesic_distance(a["position"][:2], b["position"][:2])
        for a, b in zip(ep["goals"], ep["goals"][1:])
    ]
    assert ep["protocol"]["legs"] == pytest.approx(legs, abs=1e-5)
    hosted = {p.id for p in hosted_protocols(spec, LIBRARY)}
    used = {e["protocol"]["id"] for e in eps}  # 12 episodes cycle over the (at most 12) it can start
    assert used <= hosted and len(used) >= min(2, len(hosted))
    assert ProtocolSampler(spec).protocol_episodes(12, seed=3, library=LIBRARY) == eps  # same seed, same


def test_single_rooms_host_the_two_single_room_protocols_and_a_bare_scene_none():
    spec = _scene("single_room", 700)
    assert {p.id for p in hosted_protocols(spec, LIBRARY)} == {"cold_spin_down", "centrifuge_cleanup"}
    bare = next(
        s
        for s in (generate_scene("single_room", seed) for seed in range(700, 800))
        if not hosted_protocols(s, LIBRARY)
    )
    with pytest.raises(EpisodeError) as e:
        ProtocolSampler(bare).protocol_episodes(3, seed=0, library=LIBRARY)
    msg = str(e.value)
    assert "hosts no protocol" in msg and "required_categories" in msg and "\n" not in msg


def test_only_goal_objects_that_can_be_named_are_drawn():
    spec = _scene("two_room", 700)  # table_a is a lab table that is no goal; table_b is one
    pool = drawable_objects(spec)
    non_goals = {o.id for o in spec.objects() if not o.is_goal}
    assert non_goals and not non_goals & {i for ids in pool.values() for i in ids}
    eps = ProtocolSampler(spec).protocol_episodes(40, seed=1, library=LIBRARY)
    assert not non_goals & {g["object_id"] for e in eps for g in e["goals"]}


# --- splits and the dataset ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def protocol_dataset(tmp_path_factory) -> Path:
    """The default build's protocol splits (the other splits are tested elsewhere)."""
    root = tmp_path_factory.mktemp("data") / "protocols"
    write_dataset(root, protocol_splits(), progress=False)
    return root


def test_the_protocol_splits_hold_at_least_300_valid_episodes(protocol_dataset):
    ds = EpisodeDataset(protocol_dataset)
    counts = {name: ds.split_info(name)["episodes"] for name in PROTOCOL_SPLITS}
    assert counts["protocol_val"] + counts["protocol_test"] >= 300 and sum(counts.values()) >= 300
    templates = set()
    for name in PROTOCOL_SPLITS:
        for ep in ds.episodes(name):
            spec = ds.spec(ep["scene_id"])
            templates.add(spec.template)
            _check_episode(ep, spec)
    assert templates == {"single_room", "two_room", "suite", "open_plan"}
    scenes = {name: set(ds.split_info(name)["scenes"]) for name in PROTOCOL_SPLITS}
    assert not (scenes["protocol_train"] & scenes["protocol_val"]) and not (
        scenes["protocol_val"] & scenes["protocol_test"]
    )


def test_protocol_seeds_are_disjoint_from_every_other_split():
    taken = {("single_room", s) for seeds, _ in HELD_OUT.values() for s in seeds}
    taken |= {("two_room", s) for s in TWO_ROOM_SEEDS}
    taken |= {(t, s) for scenes in HARD_SPLITS.values() for t, s, _ in scenes}
    taken |= {("single_room", s) for s in range(0, 100)}  # ``full`` takes the first single rooms from 0 up
    ranges = [range(first, first + PROTOCOL_SEED_SCAN) for first, _ in PROTOCOL_SPLITS.values()]
    assert all(not set(a) & set(b) for i, a in enumerate(ranges) for b in ranges[i + 1 :])
    assert not {s for _, s in taken} & {s for r in ranges for s in r}


def test_stats_show_k_routes_and_relations(protocol_dataset):
    st = EpisodeDataset(protocol_dataset).stats("protocol_val")
    p = st["protocol"]
    assert sum(p["k"].values()) == st["episodes"] and set(p["k"]) <= set(range(MIN_VISITS, MAX_VISITS + 1))
    assert MIN_VISITS <= p["mean_k"] <= MAX_VISITS and p["protocols"] >= 2
    assert 0 < p["route_length"]["min"] <= p["route_length"]["mean"] <= p["route_length"]["max"]
    assert 0 < p["needs_relation"] < 100 and 0 < p["relation_visits"] <= p["needs_relation"]
    r = CliRunner().invoke(app, ["dataset", "stats", str(protocol_dataset)])
    out = " ".join(r.output.split())
    assert r.exit_code == 0 and "protocol splits" in out and "mean K" in out, r.output
    assert f"{p['mean_k']}" in out and "needing a relation" in out


def test_a_tampered_protocol_record_is_refused(tmp_path):
    root = tmp_path / "ds"
    write_dataset(
        root,
        [SplitPlan("p", [(_scene("two_room", 700), 2, False)], sampler=ProtocolEpisodes(LIBRARY))],
        progress=False,
    )
    manifest = json.loads((root / "manifest.json").read_text())
    entry = manifest["splits"]["p"]["files"]["two_room_s700_v0"]
    eps = json.loads(gzip.decompress((root / entry["file"]).read_bytes()))
    eps["episodes"][1]["protocol"]["k"] += 1 if eps["episodes"][1]["protocol"]["k"] < MAX_VISITS else -1
    blob = gzip.compress(json.dumps(eps).encode())
    (root / entry["file"]).write_bytes(blob)
    entry["sha256"] = hashlib.sha256(blob).hexdigest()
    (root / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(DatasetError) as e:
        list(EpisodeDataset(root).episodes("p"))
    assert "episodes[1].protocol.k" in str(e.value) and "\n" not in str(e.value)


def test_a_small_protocol_build_is_byte_identical(tmp_path):
    plan = [
        SplitPlan(
            "p",
            [(_scene("suite", 701), 6, False), (_scene("single_room", 701), 4, False)],
            sampler=ProtocolEpisodes(LIBRARY),
        )
    ]
    for out in ("a", "b"):
        write_dataset(tmp_path / out, plan, progress=False)
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    assert files and all(
        (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes() for f in files
    )


def test_the_protocol_splits_are_deterministic(protocol_dataset, tmp_path):
    write_dataset(tmp_path / "again", protocol_splits(), progress=False)
    a = {p.relative_to(protocol_dataset): p.read_bytes() for p in protocol_dataset.rglob("*") if p.is_file()}
    b = {
        p.relative_to(tmp_path / "again"): p.read_bytes()
        for p in (tmp_path / "again").rglob("*")
        if p.is_file()
    }
    assert a == b
