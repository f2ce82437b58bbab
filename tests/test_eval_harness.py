import json
import subprocess
import sys

import pytest

from biovln_ms.splits import FOUR_CATEGORIES
from biovln_ms.episodes.writer import SplitPlan, write_dataset
from biovln_ms.eval import harness
from biovln_ms.eval.harness import EvalConfig, ResultsError, evaluate, load_records
from biovln_ms.scene.generator import generate_scene


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("data") / "ds"
    a = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
    write_dataset(root, [SplitPlan("ms_val", [(a, 8, False)])], progress=False)
    return str(root)


def test_oracle_run_records_everything(dataset, tmp_path):
    s = evaluate(EvalConfig("oracle", "ms_val", str(tmp_path), dataset, workers=1), progress=False)
    recs = load_records(tmp_path / "oracle" / "ms_val" / "episodes.jsonl")
    assert len(recs) == 8 and s["overall"]["episodes"] == 8
    r = recs[0]
    for key in (
        "scene_id",
        "episode_id",
        "object_category",
        "difficulty",
        "geodesic_distance",
        "positions",
        "headings",
        "clearance",
        "zone2",
        "actions",
        "success",
        "spl",
        "dtg",
        "steps",
        "mcr",
        "vrt",
        "wall_time_s",
    ):
        assert key in r, key
    assert len(r["positions"]) == len(r["actions"]) + 1 == len(r["clearance"])
    assert r["mcr"] == pytest.approx(min(r["clearance"]), abs=1e-3)
    assert s["overall"]["sr"] >= 75.0
    assert (
        json.loads((tmp_path / "oracle" / "ms_val" / "summary.json").read_text())["overall"]["episodes"] == 8
    )


def test_resume_after_a_kill_loses_and_repeats_nothing(dataset, tmp_path):
    cfg = EvalConfig("random", "ms_val", str(tmp_path), dataset, workers=1, max_episodes=3)
    evaluate(cfg, progress=False)
    path = tmp_path / "random" / "ms_val" / "episodes.jsonl"
    with open(path, "a") as f:
        f.write('{"success": true, "scene_id": "lab_s1')  # killed mid-write
    cfg.max_episodes = None
    s = evaluate(cfg, progress=False)
    recs = load_records(path)
    keys = [(r["scene_id"], r["episode_id"]) for r in recs]
    assert len(keys) == len(set(keys)) == 8 and s["overall"]["episodes"] == 8
    # the random policy is seeded per episode: the resumed run equals a fresh one
    fresh = evaluate(
        EvalConfig("random", "ms_val", str(tmp_path / "fresh"), dataset, workers=2), progress=False
    )
    assert fresh["overall"]["sr"] == s["overall"]["sr"] and fresh["overall"]["spl"] == pytest.approx(
        s["overall"]["spl"]
    )


def test_a_complete_run_resumes_without_building_an_env(dataset, tmp_path, monkeypatch):
    cfg = EvalConfig("random", "ms_val", str(tmp_path), dataset, workers=1, max_episodes=2)
    first = evaluate(cfg, progress=False)

    def no_env(wcfg):
        raise AssertionError("a complete run built an env")

    monkeypatch.setattr(harness, "_init_worker", no_env)
    assert evaluate(cfg, progress=False)["overall"] == first["overall"]


def test_corrupt_results_file_is_named(dataset, tmp_path):
    path = tmp_path / "oracle" / "ms_val" / "episodes.jsonl"
    path.parent.mkdir(parents=True)
    path.write_text('{"a": 1}\nnot json\n{"b": 2}\n')
    with pytest.raises(ResultsError, match="line 2 is not valid JSON"):
        evaluate(EvalConfig("oracle", "ms_val", str(tmp_path), dataset, workers=1), progress=False)


def test_failing_episode_is_recorded_and_the_run_continues(dataset, tmp_path, monkeypatch):
    from biovln_ms.baselines.oracle import OraclePolicy

    real = OraclePolicy.reset

    def flaky(self, info):
        if info.episode_id == "2":  # EpisodeInfo (policies never get the episode dict)
            raise RuntimeError("planner exploded")
        return real(self, info)

    monkeypatch.setattr(OraclePolicy, "reset", flaky)
    s = evaluate(EvalConfig("oracle", "ms_val", str(tmp_path), dataset, workers=1), progress=False)
    assert s["overall"]["errors"] == 1 and s["overall"]["episodes"] == 8  # it counts, as a failure
    assert s["failed_episodes"][0]["error"] == "RuntimeError: planner exploded"


@pytest.mark.slow
def test_cli_eval_and_unknown_method(dataset, tmp_path):
    exe = [sys.executable, "-m", "biovln_ms.cli", "eval"]
    r = subprocess.run(
        [
            *exe,
            "--method",
            "zone3_oracle",
            "--split",
            "ms_val",
            "--dataset",
            dataset,
            "-o",
            str(tmp_path),
            "--workers",
            "2",
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    assert "zone3_oracle on ms_val: 8 episodes" in r.stdout
    r = subprocess.run(
        [*exe, "--method", "telepathy", "--dataset", dataset, "-o", str(tmp_path)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "unknown method 'telepathy'" in r.stderr and "random, oracle" in r.stderr


@pytest.mark.slow
def test_report_has_the_paper_tables_figures_and_a_video(dataset, tmp_path):
    from biovln_ms.eval.report import write_report

    for m in ("oracle", "random", "frontier"):
        evaluate(
            EvalConfig(m, "ms_val", str(tmp_path / "res"), dataset, workers=1, max_episodes=4), progress=False
        )
    evaluate(
        EvalConfig(
            "frontier",
            "ms_val",
            str(tmp_path / "res"),
            dataset,
            workers=1,
            max_episodes=4,
            env_id="BioVLN-Centroid-v0",
        ),
        progress=False,
    )
    md = write_report(
        tmp_path / "res", tmp_path / "rep", dataset=dataset, videos=1, hard_figures=1, echo=lambda *_: None
    )
    text = md.read_text()
    for heading in (
        "Table 5 layout",
        "Table 10 layout",
        "Table 6 layout",
        "Table 9 layout",
        "Table 11 layout",
        "Pairwise McNemar",
        "differ from the paper",
    ):
        assert heading in text, heading
    oracle = next(line for line in text.splitlines() if line.startswith("| Oracle | partial (4/8) | "))
    assert "] (76.0) |" in oracle  # ours [CI] (paper), a partial run labelled (4 of the split's 8)
    assert "Not compared with the paper (partial runs" in text
    figs = {p.name for p in (tmp_path / "rep" / "figures").iterdir()}
    assert {"sr_by_method.png", "safety.png", "trajectories_oracle_ms_val.png"} <= figs
    # MS VAL holds no hard episode: the figure is the longest one, and says so
    assert any(f.startswith("longest_") for f in figs) and not any(f.startswith("hard_") for f in figs)
    assert "## Longest frontier episodes (no hard episode, geodesic > 6 m, in these runs)" in text
    assert len(list((tmp_path / "rep" / "videos").glob("*.mp4"))) == 1
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "biovln_ms.cli",
            "report",
            str(tmp_path / "nothing"),
            "-o",
            str(tmp_path / "x"),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "no results under" in r.stderr


@pytest.mark.slow
def test_ray_local_instance_gives_the_pools_records(dataset, tmp_path):
    """Ray actors in place of the process pool (resuming is the driver's, the same for both)."""
    pytest.importorskip("ray")
    cfg = EvalConfig("oracle", "ms_val", str(tmp_path), dataset, workers=2, ray_address="local")
    s = evaluate(cfg, progress=False)
    recs = load_records(tmp_path / "oracle" / "ms_val" / "episodes.jsonl")
    keys = [(r["scene_id"], r["episode_id"]) for r in recs]
    assert len(keys) == len(set(keys)) == 8 and s["overall"]["episodes"] == 8
    pool = evaluate(
        EvalConfig("oracle", "ms_val", str(tmp_path / "pool"), dataset, workers=1), progress=False
    )
    assert pool["overall"]["sr"] == s["overall"]["sr"] and pool["overall"]["spl"] == pytest.approx(
        s["overall"]["spl"]
    )


def test_noise_preset_names_the_run_and_is_checked_first():
    from biovln_ms.eval.harness import EvalConfig
    from biovln_ms.noise import NoiseConfigError

    assert EvalConfig("frontier", "ms_val", "out", noise="realistic").run_name == "frontier+realistic"
    assert EvalConfig("frontier", "ms_val", "out").run_name == "frontier"
    with pytest.raises(NoiseConfigError, match="unknown noise preset 'loud'"):
        EvalConfig("frontier", "ms_val", "out", noise="loud")
