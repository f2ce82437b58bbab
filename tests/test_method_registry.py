"""The method registry (``biovln_ms.eval.methods.METHODS``) is the one source the report, the paper
comparisons and the CLI read: a method added there, or a learned policy's results, reach the report."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from biovln_ms.splits import FOUR_CATEGORIES
from biovln_ms.episodes.dataset import EpisodeDataset
from biovln_ms.episodes.writer import SplitPlan, write_dataset
from biovln_ms.eval import paper
from biovln_ms.eval.harness import EvalConfig
from biovln_ms.eval.methods import METHODS, MethodSpec, method_spec, report_methods
from biovln_ms.variants import RL_ENV
from biovln_ms.eval.report import load_runs, tables, write_report
from biovln_ms.scene.generator import generate_scene


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> str:
    root = tmp_path_factory.mktemp("data") / "ds"
    scene = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
    write_dataset(root, [SplitPlan("ms_val", [(scene, 4, False)])], progress=False)
    return str(root)


def _record(ep: dict, index: int, method: str, env_id: str, split: str, success: bool) -> dict:
    """One finished episode as the harness writes it (``harness._run``)."""
    start, goal = ep["start_position"][:2], ep["goals"][0]["position"][:2]
    positions = [start, [(s + g) / 2 for s, g in zip(start, goal)], goal]
    return {
        "success": success,
        "spl": 0.8 * success,
        "soft_spl": 0.7,
        "dtg": 0.4 if success else 2.5,
        "steps": 2,
        "mcr": 0.6,
        "vrt": 0.1,
        "collisions": 0,
        "path_length": 0.5,
        "stopped": True,
        "truncated": False,
        "actions": [1, 0],
        "positions": positions,
        "headings": [0.0] * 3,
        "clearance": [0.6] * 3,
        "zone2": [False] * 3,
        "method": method,
        "env_id": env_id,
        "split": split,
        "index": index,
        "scene_id": ep["scene_id"],
        "episode_id": ep["episode_id"],
        "object_category": ep["object_category"],
        "object_id": ep["object_id"],
        "difficulty": ep["info"]["difficulty"],
        "geodesic_distance": ep["info"]["geodesic_distance"],
        "goal": goal,
        "start": start,
        "wall_time_s": 0.1,
    }


def _fake_run(
    dataset: str,
    results: Path,
    method: str,
    successes: list[bool],
    split: str = "ms_val",
    env_id: str | None = None,
) -> Path:
    """An episodes.jsonl where `biovln-ms eval` would write it (the harness names the folder)."""
    cfg = EvalConfig(method=method, split=split, out=str(results), dataset=dataset, env_id=env_id)
    cfg.run_dir.mkdir(parents=True, exist_ok=True)
    eps = list(EpisodeDataset(dataset).episodes(split))
    lines = [
        json.dumps(_record(eps[i], i, method, cfg.env_id, split, ok), separators=(",", ":"))
        for i, ok in enumerate(successes)
    ]
    (cfg.run_dir / "episodes.jsonl").write_text("\n".join(lines) + "\n")
    return cfg.run_dir


def _section(md: str, heading: str) -> str:
    """The Markdown section whose heading contains ``heading``."""
    return md.split(heading, 1)[1].split("\n## ", 1)[0]


def test_registry_fields_are_consistent():
    assert report_methods()[:3] == ["random", "oracle", "frontier"]
    assert len({s.report_order for s in METHODS.values()}) == len(METHODS)
    assert len({s.label for s in METHODS.values()}) == len(METHODS)
    assert {m for m, s in METHODS.items() if s.privileged} == {"oracle", "zone3_oracle", "protocol_oracle"}
    assert METHODS["vlfm"].label == "VLFM (learned detector)" and METHODS["vlfm"].paper_key == "VLFM"
    assert METHODS["vlfm_gt"].label == "VLFM (GT detector)" and METHODS["vlfm_gt"].paper_key is None
    assert [METHODS[m].paper_key for m in ("ppo", "a2c", "sac")] == [None, None, None]
    # every row of the paper's tables belongs to a registered method, and no two methods claim one row
    keys = [s.paper_key for s in METHODS.values() if s.paper_key]
    assert len(keys) == len(set(keys))
    rows = {
        *paper.TABLE5,
        *paper.TABLE10,
        *paper.TABLE6,
        *paper.TABLE9,
        *paper.TABLE11,
        *paper.TABLE17,
        *(k for a, b, _ in paper.TABLE16 for k in (a, b)),
    }
    assert rows <= set(keys)
    # the privileged methods' obs_mode (the others': tests/test_observation_boundary.py builds them)
    from biovln_ms.baselines.oracle import OraclePolicy
    from biovln_ms.baselines.protocol.oracle import ProtocolOraclePolicy
    from biovln_ms.baselines.zone3_oracle import Zone3OraclePolicy

    for name, cls in (
        ("oracle", OraclePolicy),
        ("zone3_oracle", Zone3OraclePolicy),
        ("protocol_oracle", ProtocolOraclePolicy),
    ):
        assert METHODS[name].obs_mode == cls().obs_mode, name


def test_a_registered_method_reaches_the_reports_tables(dataset, tmp_path, monkeypatch):
    dummy = MethodSpec(
        lambda **_: None, "none", "walks straight to the goal", label="Dummy Walker", report_order=15
    )
    monkeypatch.setitem(METHODS, "dummy", dummy)
    assert method_spec("dummy") is dummy and report_methods()[:3] == ["random", "dummy", "oracle"]
    _fake_run(dataset, tmp_path / "res", "dummy", [True, False, True, True])
    md = write_report(
        tmp_path / "res", tmp_path / "rep", dataset=dataset, videos=0, hard_figures=0, echo=lambda *_: None
    ).read_text()
    t5 = _section(md, "(Table 5 layout)")
    # the dataset's MS VAL holds 4 episodes: a whole run, n = 4; no strict_success in these records: –
    assert "| Dummy Walker | 4 | 75.0 [30.1, 95.4] | – | 0.600 [" in t5
    assert t5.index("| Random |") < t5.index("| Dummy Walker |") < t5.index("| Oracle |")  # report_order 15
    t10 = _section(md, "(Table 10 layout)")
    assert "| Dummy Walker | 4 | 75.0 [30.1, 95.4] | – | 0.92 [" in t10 and "| 2.0; n=3 |" in t10
    assert (tmp_path / "rep" / "figures" / "trajectories_dummy_ms_val.png").exists()

    from biovln_ms.cli import _methods_help

    assert "dummy         Dummy Walker — walks straight to the goal" in _methods_help()


def test_paper_numbers_follow_the_paper_key_not_the_name_or_label(dataset, tmp_path, monkeypatch):
    monkeypatch.setitem(METHODS, "oracle", dataclasses.replace(METHODS["oracle"], label="Geodesic Oracle"))
    _fake_run(dataset, tmp_path, "oracle", [True, True, False, True])
    md = "\n".join(line for block in tables(load_runs(tmp_path)) for line in block)
    # no dataset given: MS VAL's full 50 episodes, so 4 of them is a partial run
    assert "| Geodesic Oracle | partial (4/50) | 75.0 [30.1, 95.4] (76.0) | – | 0.600 [" in md
    assert "Not compared with the paper (partial runs" in md and "Geodesic Oracle on MS VAL: partial" in md
    assert "| Oracle |" not in md


def test_learned_policies_appear_in_the_report_when_their_results_exist(dataset, tmp_path):
    res = tmp_path / "res"
    for algo, ok in (("ppo", [True, False, False, True]), ("a2c", [False] * 4), ("sac", [True] * 4)):
        run_dir = _fake_run(dataset, res, algo, ok)
        assert run_dir.parent.name == f"{algo}@opface-rl"  # the RL variant's folder, not one named `algo`
    _fake_run(dataset, res, "frontier", [True, True, True, False])
    _fake_run(dataset, res, "frontier", [False, True, True, False], env_id="BioVLN-Centroid-v0")
    assert {r["env_id"] for r in load_runs(res)[("ppo", "ms_val")]} == {RL_ENV}
    md = write_report(
        res, tmp_path / "rep", dataset=dataset, videos=0, hard_figures=0, echo=lambda *_: None
    ).read_text()
    assert "ppo on ms_val (4 episodes)" in md and "frontier@centroid on ms_val (4 episodes)" in md
    t5, t10 = _section(md, "(Table 5 layout)"), _section(md, "(Table 10 layout)")
    for label, sr in (
        ("PPO", "50.0 [15.0, 85.0]"),
        ("A2C", "0.0 [0.0, 49.0]"),
        ("SAC", "100.0 [51.0, 100.0]"),
    ):
        assert f"| {label} | 4 | {sr} |" in t5
        assert f"| {label} | 4 | {sr} |" in t10
    order = [t5.index(f"| {label} |") for label in ("VLFM (learned detector)", "PPO", "A2C", "SAC")]
    assert order == sorted(order)  # report_order
    mc = _section(md, "Pairwise McNemar")
    for pair in (
        "| Frontier | PPO | MS VAL | 4 |",
        "| PPO | A2C | MS VAL | 4 |",
        "| A2C | SAC | MS VAL | 4 |",
    ):
        assert pair in mc, pair
    t9 = _section(md, "(Table 9 layout)")
    assert (
        "| MS VAL (4) | 50.0 [15.0, 85.0] | 75.0 [30.1, 95.4] | -25.0 | 1.000 | 1.000 | no |" in t9
    )  # centroid: a run of its own
    figs = {p.name for p in (tmp_path / "rep" / "figures").iterdir()}
    assert {f"trajectories_{algo}_ms_val.png" for algo in ("ppo", "a2c", "sac")} <= figs
