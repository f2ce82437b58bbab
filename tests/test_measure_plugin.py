"""A measure declared outside the package reaches the records, summary.json and the report with no edit to
evaluation code: its :class:`Metric` is the only declaration."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np

from biovln_ms.eval.harness import EvalConfig, evaluate
from biovln_ms.eval.methods import METHODS
from biovln_ms.eval.aggregate import aggregate, record_error
from biovln_ms.eval.paper_tables import other_measures_table
from biovln_ms.eval.report import load_runs, summarize
from biovln_ms.metrics.measures import Aggregate, Measure, Metric, register_measure
from biovln_ms.task_config import NavTaskConfig


@register_measure
class Zone3Steps(Measure):
    """Steps that ended in a goal's Zone 3."""

    uuid = "test_zone3_steps"
    metric = Metric(
        "zone3_steps", aggregates=(Aggregate("zone3_steps", "Zone-3 steps", "steps per episode"),)
    )
    dtype = np.int64
    dependencies = ("in_zone3",)

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0

    def update(self, ctx, s, m, idx):
        self.value[idx] += m["in_zone3"][idx]


def test_a_registered_measure_reaches_records_summary_and_report(tmp_path, monkeypatch):
    measures = NavTaskConfig().measures + ("test_zone3_steps",)
    spec = replace(METHODS["oracle"], env_kwargs={"measures": measures}, label="Oracle + Zone-3 steps")
    monkeypatch.setitem(METHODS, "oracle_z3", spec)
    cfg = EvalConfig(method="oracle_z3", split="ms_val", out=str(tmp_path), max_episodes=2, workers=1)
    cfg.camera = (64, 48)
    summary = evaluate(cfg, progress=False, echo=lambda *_: None)

    records = [json.loads(line) for line in (cfg.run_dir / "episodes.jsonl").read_text().splitlines()]
    assert [record_error(r) for r in records] == [None, None]
    steps = [r["zone3_steps"] for r in records]
    assert all(
        isinstance(v, int) and 1 <= v <= r["steps"] for v, r in zip(steps, records)
    )  # oracle ends in it

    on_disk = json.loads((cfg.run_dir / "summary.json").read_text())
    assert on_disk["overall"]["zone3_steps"] == summary["overall"]["zone3_steps"] == np.mean(steps)
    assert on_disk["overall"]["zone3_steps_ci95"][0] <= np.mean(steps)
    assert aggregate(records)["zone3_steps"] == np.mean(steps)

    runs = load_runs(tmp_path)
    assert list(runs) == [("oracle_z3", "ms_val")]
    table = "\n".join(other_measures_table(summarize(runs)))
    assert "Zone-3 steps" in table and "Oracle + Zone-3 steps" in table


def test_a_run_says_who_it_is(tmp_path):
    cfg = EvalConfig(
        method="random", split="ms_val", out=str(tmp_path), max_episodes=1, workers=1, noise="realistic"
    )
    cfg.camera = (64, 48)
    evaluate(cfg, progress=False, echo=lambda *_: None)
    manifest = json.loads((cfg.run_dir / "manifest.json").read_text())
    assert {k: manifest[k] for k in ("method", "env_id", "robot", "noise", "split")} == {
        "method": "random",
        "env_id": "BioVLN-OpFace-v0",
        "robot": "biovln_base",
        "noise": "realistic",
        "split": "ms_val",
    }
    assert len(manifest["dataset_sha256"]) == 64 and manifest["arguments"]["max_episodes"] == 1
    # the report reads the manifest, not the folder: a renamed folder is still the same run
    (tmp_path / cfg.run_name).rename(tmp_path / "renamed")
    assert list(load_runs(tmp_path)) == [("random+realistic", "ms_val")]
