import json
import math

import numpy as np
import pytest
import shapely

from biovln_ms.splits import FOUR_CATEGORIES
from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset
from biovln_ms.episodes.writer import SplitPlan, write_dataset
from biovln_ms.episodes.dataset import EPISODE_GENERATOR_VERSION as VERSION
from biovln_ms.episodes.generator import EpisodeError, EpisodeSampler, difficulty
from biovln_ms.scene.rules import scene_navigation
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import floor_polygon


@pytest.fixture(scope="module")
def spec150():
    return generate_scene("single_room", 150, required_categories=FOUR_CATEGORIES)


def test_episode_fields_and_geometry(spec150):
    nav = scene_navigation(spec150)
    eps = EpisodeSampler(spec150, nav).episodes(40, seed=3)
    floor = floor_polygon(spec150)
    assert len({e["episode_id"] for e in eps}) == 40
    assert {e["object_category"] for e in eps} == set(FOUR_CATEGORIES)
    for e in eps:
        s = np.asarray(e["start_position"][:2])
        g = np.asarray(e["goals"][0]["position"][:2])
        o = spec150.get(e["object_id"])
        assert nav.is_navigable(s) and nav.is_navigable(g)
        clear = min(
            min(obj.placed().clearance(s) for obj in spec150.objects()),
            floor.exterior.distance(shapely.Point(s)),
        )
        assert clear >= e["info"]["start_clearance"] - 1e-6 and e["info"]["start_clearance"] == 1.0
        assert e["info"]["geodesic_distance"] == pytest.approx(nav.geodesic_distance(s, g), abs=1e-5)
        assert e["info"]["euclidean_distance"] == pytest.approx(np.linalg.norm(g - s), abs=1e-5)
        assert e["info"]["difficulty"] == difficulty(e["info"]["geodesic_distance"])
        assert np.linalg.norm(g - np.asarray(o.goal)) <= o.success_radius
        assert e["goals"][0]["radius"] == o.success_radius
        assert abs(np.linalg.norm(e["start_rotation"]) - 1) < 1e-6
        for vp in e["goals"][0]["view_points"]:
            p = np.asarray(vp["agent_state"]["position"][:2])
            assert nav.is_navigable(p)
            w, _, _, z = vp["agent_state"]["rotation"]
            yaw = 2 * math.atan2(z, w)
            to_obj = np.asarray(o.position[:2]) - p
            assert np.dot([math.cos(yaw), math.sin(yaw)], to_obj / np.linalg.norm(to_obj)) > 0.999


def test_difficulty_tiers():
    assert [difficulty(x) for x in (0.5, 2.999, 3.0, 6.0, 6.001)] == [
        "easy",
        "easy",
        "medium",
        "medium",
        "hard",
    ]


def test_cross_room_starts_in_the_other_room():
    spec = generate_scene("two_room", 200)
    eps = EpisodeSampler(spec).episodes(20, seed=0, cross_room=True)
    rooms = {r.id: shapely.Polygon(r.polygon) for r in spec.rooms}
    for e in eps:
        target_room = spec.get(e["object_id"]).room
        assert not rooms[target_room].contains(shapely.Point(e["start_position"][:2]))
    # Room B has no floor 1 m from every obstacle: the fallback is recorded on the episode.
    assert any(e["info"]["start_clearance_fallback"] and e["info"]["start_clearance"] < 1.0 for e in eps)


def test_unreachable_zone3_fails_loudly(spec150):
    nav = scene_navigation(spec150, radius=0.55)
    with pytest.raises(EpisodeError, match="Zone 3 of 'waste_bin_0'"):
        EpisodeSampler(spec150, nav)


def _small_splits():
    a = generate_scene("single_room", 150, required_categories=FOUR_CATEGORIES)
    b = generate_scene("single_room", 3)
    return [
        SplitPlan("full", [(a, 10, False), (b, 6, False)]),
        SplitPlan("train", [(b, 6, False)], view_of="full"),
        SplitPlan("ms_dev", [(a, 8, False)]),
        SplitPlan("lsat_target", [], missing="not built"),
    ]


def test_dataset_is_deterministic_and_loads(tmp_path):
    m1 = write_dataset(tmp_path / "a", _small_splits(), progress=False)
    m2 = write_dataset(tmp_path / "b", _small_splits(), progress=False)
    assert m1 == m2
    for f in (tmp_path / "a").rglob("*"):
        if f.is_file():
            assert f.read_bytes() == (tmp_path / "b" / f.relative_to(tmp_path / "a")).read_bytes(), f
    ds = EpisodeDataset(tmp_path / "a")
    assert len(list(ds.episodes("full"))) == 16 and len(list(ds.episodes("train"))) == 6
    assert ds.stats("ms_dev")["episodes"] == 8
    with pytest.raises(DatasetError, match="split 'lsat_target' is not built"):
        list(ds.episodes("lsat_target"))
    with pytest.raises(DatasetError, match="unknown split 'ms_devv'"):
        list(ds.episodes("ms_devv"))


def test_dataset_refuses_other_radius_catalog_and_tampering(tmp_path):
    root = tmp_path / "ds"
    write_dataset(root, _small_splits(), progress=False)
    with pytest.raises(DatasetError, match="built for a 0.2 m agent, not the 0.25 m agent"):
        EpisodeDataset(root, agent_radius=0.25)
    m = json.loads((root / "manifest.json").read_text())
    m["catalog_sha256"] = "0" * 64
    (root / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(DatasetError, match="another instrument catalog"):
        EpisodeDataset(root)
    write_dataset(root, _small_splits(), progress=False)  # rebuild over the old one
    m = json.loads((root / "manifest.json").read_text())
    m["scene_generator_version"] = 1
    (root / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(DatasetError, match="made by scene generator version 1"):
        EpisodeDataset(root)
    write_dataset(root, _small_splits(), progress=False)
    f = next((root / "ms_dev" / "content").glob("*.json.gz"))
    f.write_bytes(f.read_bytes()[:-3] + b"xyz")
    with pytest.raises(DatasetError, match="does not match its hash"):
        EpisodeDataset(root)


def test_killed_build_leaves_nothing_that_loads(tmp_path, monkeypatch):
    root = tmp_path / "ds"
    write_dataset(root, _small_splits(), progress=False)
    before = (root / "manifest.json").read_bytes()
    calls = {"n": 0}
    real = EpisodeSampler.episodes

    def dying(self, *a, **k):
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt("killed")
        return real(self, *a, **k)

    monkeypatch.setattr(EpisodeSampler, "episodes", dying)
    with pytest.raises(KeyboardInterrupt):
        write_dataset(root, _small_splits(), progress=False)
    assert (root / "manifest.json").read_bytes() == before  # the old dataset is untouched
    EpisodeDataset(root)
    new = tmp_path / "fresh"
    calls["n"] = 0
    with pytest.raises(KeyboardInterrupt):
        write_dataset(new, _small_splits(), progress=False)
    with pytest.raises(DatasetError, match="interrupted build"):
        EpisodeDataset(new)


def test_paper_splits_are_disjoint_and_counted():
    from biovln_ms.splits import paper_splits

    splits = {s.name: s for s in paper_splits()}
    full = splits["full"]
    assert len(full.scenes) == 47
    assert sum(n for _, n, _ in full.scenes) == 1669
    assert sum(n for s, n, _ in full.scenes if s.template == "single_room") == 1365
    bench = ["ms_dev", "ms_val", "ms_test", "two_room", "lsat_target"]
    names = {b: {s.name for s, _, _ in splits[b].scenes} for b in bench + ["train"]}
    for i, a in enumerate(bench + ["train"]):
        for b in (bench + ["train"])[i + 1 :]:
            assert not names[a] & names[b], (a, b)
    assert [sum(n for _, n, _ in splits[b].scenes) for b in bench] == [160, 50, 120, 50, 40]
    assert names["ms_dev"] == {f"lab_s{s}_v0" for s in (150, 151, 152, 153)}
    ((lsat, n, _),) = splits["lsat_target"].scenes
    assert lsat.template == "lsat" and n == 40 and len(lsat.goal_objects()) == 8  # 5 episodes per category


def test_cli_dataset_build_stats_show_and_map_overlay(tmp_path):
    import subprocess
    import sys

    root = tmp_path / "ds"
    write_dataset(root, _small_splits(), progress=False)
    exe = [sys.executable, "-m", "biovln_ms.cli"]
    r = subprocess.run([*exe, "dataset", "stats", str(root)], capture_output=True, text=True)
    assert r.returncode == 0 and "ms_dev" in r.stdout and "MISSING" in r.stdout, r.stderr
    r = subprocess.run(
        [
            *exe,
            "dataset",
            "show",
            str(root),
            "--split",
            "ms_dev",
            "--episode",
            "2",
            "-o",
            str(tmp_path / "e.png"),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    spec = root / "scenes" / "lab_s150_v0.json"
    r = subprocess.run(
        [
            *exe,
            "scene",
            "map",
            str(spec),
            "--dataset",
            str(root),
            "--split",
            "ms_dev",
            "--episode",
            "2",
            "--islands",
            "-o",
            str(tmp_path / "m.png"),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "m.png").stat().st_size > 20_000
    r = subprocess.run(
        [*exe, "dataset", "show", str(root), "--split", "ms_dev", "--episode", "999"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "no episode '999'" in r.stderr and "Traceback" not in r.stderr


def test_no_trivial_episodes_in_any_split_of_the_default_dataset():
    """No trivial episode: every start is outside its goal's success radius r and >= r + 1.0 m from it
    along the floor, by the stored geodesic and by one recomputed on the scene's navigation geometry."""
    from biovln_ms.splits import ensure_default_dataset
    from biovln_ms.episodes.generator import MIN_START_GEODESIC_MARGIN

    ds = EpisodeDataset(ensure_default_dataset(echo=lambda *_: None))
    navs: dict = {}
    assert {"ms_dev", "ms_val", "ms_test", "two_room", "lsat_target", "train", "full"} <= set(
        ds.split_names()
    )
    for split in ds.split_names():
        for e in ds.episodes(split):
            if e["scene_id"] not in navs:
                navs[e["scene_id"]] = scene_navigation(ds.spec(e["scene_id"]))
            where = (split, e["scene_id"], e["episode_id"])
            s = np.asarray(e["start_position"][:2])
            for goal in e["goals"]:  # the Hard track's episodes have every instance as a goal
                assert np.linalg.norm(np.asarray(goal["position"][:2]) - s) > goal["radius"], where
            nearest = e["goals"][0]  # nearest first
            g, r = np.asarray(nearest["position"][:2]), nearest["radius"]
            assert e["info"]["geodesic_distance"] >= r + MIN_START_GEODESIC_MARGIN, where
            assert navs[e["scene_id"]].geodesic_distance(s, g) >= r + MIN_START_GEODESIC_MARGIN, where


def test_hard_track_is_long_multi_instance_and_held_out():
    """The Hard track: >= 300 episodes on suite / open_plan / single_room held-out seeds, >= 40 % hard
    (geodesic > 6 m), several instances of a category as goals (any counts), nearest first."""
    from biovln_ms.splits import HARD_SPLITS, ensure_default_dataset

    ds = EpisodeDataset(ensure_default_dataset(echo=lambda *_: None))
    eps = [e for split in HARD_SPLITS for e in ds.episodes(split)]
    assert len(eps) >= 300
    assert sum(e["info"]["difficulty"] == "hard" for e in eps) >= 0.4 * len(eps)
    assert {ds.spec(e["scene_id"]).template for e in eps} == {"suite", "open_plan", "single_room"}
    multi = [e for e in eps if len(e["goals"]) > 1]
    assert len(multi) >= 100
    navs: dict = {}
    for e in multi[:40]:
        assert e["info"]["any_instance"] and e["info"]["instances"] == len(e["goals"])
        assert {g["object_category"] for g in e["goals"]} == {e["object_category"]}
        spec = ds.spec(e["scene_id"])
        same = {o.id for o in spec.goal_objects() if o.category == e["object_category"]}
        assert {g["object_id"] for g in e["goals"]} == same  # every instance of the category
        nav = navs.setdefault(e["scene_id"], scene_navigation(spec))
        s = np.asarray(e["start_position"][:2])
        geo = [nav.geodesic_distance(s, np.asarray(g["position"][:2])) for g in e["goals"]]
        assert geo == sorted(geo) and geo[0] == pytest.approx(e["info"]["geodesic_distance"], abs=1e-5)
    train = set(ds.manifest["splits"]["full"]["scenes"])
    assert not train & {e["scene_id"] for e in eps}  # held out from the paper's scenes (train included)


def test_episodes_of_an_older_generator_are_refused_with_the_rebuild_command(tmp_path):
    root = tmp_path / "ds"
    write_dataset(root, _small_splits(), progress=False)
    m = json.loads((root / "manifest.json").read_text())
    m["episode_generator_version"] = 1
    (root / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(DatasetError, match="made by episode generator version 1") as e:
        EpisodeDataset(root)
    assert "\n" not in str(e.value) and "biovln-ms dataset build --out" in str(e.value)


def test_a_stale_default_dataset_is_rebuilt(tmp_path, monkeypatch):
    from biovln_ms import splits

    root = tmp_path / "default"
    write_dataset(root, _small_splits(), progress=False)
    m = json.loads((root / "manifest.json").read_text())
    m["episode_generator_version"] = 1
    (root / "manifest.json").write_text(json.dumps(m))
    monkeypatch.setenv("BIOVLN_DATA_DIR", str(root))
    monkeypatch.setattr(splits, "paper_splits", lambda robot: _small_splits())
    said: list[str] = []
    assert splits.ensure_default_dataset(echo=said.append) == root
    assert "stale" in said[0] and EpisodeDataset(root).manifest["episode_generator_version"] == VERSION


def test_a_goal_no_start_can_keep_the_rule_for_fails_in_one_line(spec150):
    goal = EpisodeSampler(spec150).episodes(1, seed=0)[0]["goals"][0]
    far = dict(goal, radius=30.0)  # no floor is 31 m from it
    with pytest.raises(EpisodeError, match=f"31.00 m .* from the goal of '{goal['object_id']}'") as e:
        EpisodeSampler(spec150).start_region(far)
    assert "\n" not in str(e.value)


def test_dataset_build_keeps_an_up_to_date_folder_and_force_rebuilds_it(tmp_path, monkeypatch):
    """The paper's build is deterministic: a folder holding an up-to-date build is kept (one line says so);
    --force, a stale manifest or another split set rebuild it; --force with --template is one line."""
    from typer.testing import CliRunner

    from biovln_ms import splits
    from biovln_ms.cli import app, user_error_line

    builds: list[int] = []

    def small(robot):
        builds.append(1)
        return _small_splits()

    monkeypatch.setattr(splits, "paper_splits", small)
    monkeypatch.setattr(splits, "paper_split_names", lambda: [p.name for p in _small_splits()])
    out = tmp_path / "ds"

    def build(*extra):
        r = CliRunner().invoke(app, ["dataset", "build", "--out", str(out), *extra])
        assert r.exit_code == 0, r.output
        return r.output

    build()
    first = (out / "manifest.json").read_bytes()
    assert "is up to date for biovln_base" in build() and builds == [1]
    assert "up to date" not in build("--force") and builds == [1, 1]
    assert (out / "manifest.json").read_bytes() == first  # the same bytes
    m = json.loads(first)
    m["episode_generator_version"] = 1
    (out / "manifest.json").write_text(json.dumps(m))
    assert "up to date" not in build() and builds == [1, 1, 1]
    monkeypatch.setattr(splits, "paper_split_names", lambda: ["full", "train", "ms_dev", "ms_val"])
    assert splits.stale_paper_dataset(out) == "other splits"
    monkeypatch.setenv("BIOVLN_DATA_DIR", str(out))  # a user's own dataset as the default: never rebuilt
    assert splits.ensure_default_dataset(echo=lambda *_: None) == out and builds == [1, 1, 1]
    r = CliRunner().invoke(
        app,
        ["dataset", "build", "--template", "single_room", "--scenes", "1", "--episodes-per-scene", "1"]
        + ["-o", str(tmp_path / "t"), "--force"],
    )
    assert "field '--force'" in user_error_line(r.exception) and not (tmp_path / "t").exists()


def test_the_split_names_known_without_generating_are_the_built_ones():
    from biovln_ms.splits import ensure_default_dataset, paper_split_names

    m = EpisodeDataset(ensure_default_dataset(echo=lambda *_: None)).manifest
    assert sorted(m["splits"]) == sorted(paper_split_names())  # the manifest sorts its keys
