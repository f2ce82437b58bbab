"""The one-command evaluation (``biovln-ms benchmark``): plan, skips with reasons, resume, the log."""

import json
import shutil

import pytest

from biovln_ms.errors import BioVLNError
from biovln_ms.eval.harness import EvalConfig, load_records
from biovln_ms.eval.methods import method_spec
from biovln_ms.splits import BUSY_SPLITS
from biovln_ms.eval.suite import SUITE_METHODS, SUITE_SPLITS, Suite, plan, run_suite
from biovln_ms.io_utils import atomic_write_text
from biovln_ms.noise import NoiseConfigError, resolve_noise
from biovln_ms.variants import VARIANTS


def test_plan_covers_every_method_split_and_preset_and_names_each_skip(monkeypatch):
    monkeypatch.delenv("BIOVLN_LLM_API_KEY", raising=False)
    monkeypatch.delenv("DEEPSEEK_API_KEY", raising=False)
    runs = plan(SUITE_METHODS, SUITE_SPLITS, ("ideal", "realistic"), paper_tables=False, people=False)
    assert len(runs) == len(SUITE_METHODS) * len(SUITE_SPLITS) * 2
    assert {r.split for r in runs} == {
        "ms_val",
        "ms_test",
        "two_room",
        "lsat_target",
        "hard_val",
        "hard_test",
    }
    skipped = {(r.method, r.noise): r.skip for r in runs if r.skip}
    assert set(skipped) == {("llm_frontier", "ideal"), ("llm_frontier", "realistic")}
    assert "BIOVLN_LLM_API_KEY" in skipped[("llm_frontier", "ideal")]
    # bc and ppo estimate their pose from their commands and depth without GPS+compass
    # (biovln_ms.baselines.frontier.odometry)
    assert not any(r.skip for r in runs if r.method in ("bc", "ppo"))


def test_plan_adds_the_runs_of_the_papers_tables():
    runs = plan(["oracle", "frontier"], ["ms_val"], ["ideal"], people=False)
    assert [r.key for r in runs] == [
        "oracle/ms_val/ideal",
        "oracle/ms_dev/ideal",
        "frontier/ms_val/ideal",
        "frontier/ms_dev/ideal",
        "frontier@BioVLN-Centroid-v0/ms_dev/ideal",
        "frontier@BioVLN-Centroid-v0/ms_val/ideal",
        "frontier@BioVLN-Centroid-v0/ms_test/ideal",
    ]


def test_plan_adds_the_runs_with_people_on_each_methods_variant_with_people():
    runs = plan(
        ["frontier", "ppo", "protocol_oracle"], ["ms_val"], ["ideal", "realistic"], paper_tables=False
    )
    keys = [r.key for r in runs]
    busy = [f"frontier@BioVLN-OpFace-Busy-v0/{s}/{n}" for n in ("ideal", "realistic") for s in BUSY_SPLITS]
    assert keys[:2] == ["frontier/ms_val/ideal", "frontier/ms_val/realistic"] and keys[2:6] == busy
    rl_busy = [f"ppo@BioVLN-OpFace-RL-Busy-v0/{s}/{n}" for n in ("ideal", "realistic") for s in BUSY_SPLITS]
    assert [k for k in keys if k.startswith("ppo@")] == rl_busy
    assert "protocol_oracle@BioVLN-Protocol-Busy-v0/protocol_val/ideal" in keys


def test_plan_refuses_unknown_names():
    with pytest.raises(BioVLNError, match="unknown method 'nope'"):
        plan(["nope"], ["ms_val"], ["ideal"])
    with pytest.raises(NoiseConfigError, match="unknown noise preset"):
        plan(["oracle"], ["ms_val"], ["loud"])


def test_without_gps_the_rl_state_gives_way_to_pointgoal_and_ppo_reads_depth():
    """The RL state vector is the robot's pose: without GPS+compass the RL variant gives the start-frame
    ``pointgoal`` instead, and PPO runs on depth for its own pose estimate
    (biovln_ms.baselines.sb3_policy)."""
    cfg = VARIANTS["BioVLN-OpFace-RL-v0"].with_noise(resolve_noise("realistic"))
    assert cfg.sensors == ("pointgoal", "objectgoal")
    ppo = method_spec("ppo")
    assert (ppo.obs_mode_under(True), ppo.obs_mode_under(False)) == ("state", "depth")
    assert method_spec("frontier").obs_mode_under(False) == method_spec("frontier").obs_mode
    EvalConfig("ppo", "ms_val", "out", noise="realistic")  # accepted before any worker starts


def test_suite_runs_resumes_and_logs(held_out_dataset, tmp_path, monkeypatch):
    monkeypatch.delenv("BIOVLN_LLM_API_KEY", raising=False)
    monkeypatch.delenv("DEEPSEEK_API_KEY", raising=False)
    ds = held_out_dataset(ms_val=3)
    lines: list[str] = []
    args = dict(splits=["ms_val"], noises=["ideal", "realistic"], workers=1, dataset=ds, progress=False)
    args["paper_tables"] = False
    log = run_suite(tmp_path, ["oracle", "random", "llm_frontier"], echo=lines.append, **args)
    done = {k: v for k, v in log["runs"].items() if v["status"] == "done"}
    assert set(done) == {f"{m}/ms_val/{n}" for m in ("oracle", "random") for n in ("ideal", "realistic")}
    assert all(v["episodes"] == 3 and v["errors"] == 0 for v in done.values())
    assert done["oracle/ms_val/ideal"]["sr"] == 100.0
    assert log["runs"]["llm_frontier/ms_val/ideal"]["status"] == "skipped"
    busy = log["runs"]["oracle@BioVLN-OpFace-Busy-v0/busy_val/ideal"]  # this dataset has no busy splits
    assert busy["status"] == "skipped" and "no split 'busy_val'" in busy["reason"]
    recs = load_records(tmp_path / "results" / "oracle+realistic" / "ms_val" / "episodes.jsonl")
    assert len(recs) == 3 and all(r["noise"] == "realistic" for r in recs)
    table = (tmp_path / "suite.md").read_text()
    assert "| oracle/ms_val/ideal | done | 3 | 100.0 |" in table and "Geometric methods on the" in table
    assert Suite.benchmark_run("frontier/hard_val/realistic")
    assert not Suite.benchmark_run("oracle/ms_dev/ideal")
    assert not Suite.benchmark_run("frontier@BioVLN-Centroid-v0/ms_val/ideal")
    # a second call resumes: nothing runs again, the records stay, the time adds up
    before = json.loads((tmp_path / "suite.json").read_text())
    run_suite(tmp_path, ["oracle"], echo=lines.append, **args)
    after = Suite(tmp_path).log["runs"]
    assert len(load_records(tmp_path / "results" / "oracle" / "ms_val" / "episodes.jsonl")) == 3
    assert after["oracle/ms_val/ideal"]["seconds"] >= before["runs"]["oracle/ms_val/ideal"]["seconds"]
    # a run whose results were deleted starts afresh: its time is this call's only
    shutil.rmtree(tmp_path / "results" / "random" / "ms_val")
    log = Suite(tmp_path).log
    log["runs"]["random/ms_val/ideal"]["seconds"] = 1e6
    atomic_write_text(tmp_path / "suite.json", json.dumps(log))
    run_suite(tmp_path, ["random"], echo=lines.append, **args)
    assert Suite(tmp_path).log["runs"]["random/ms_val/ideal"]["seconds"] < 1e6
    # a run logged as skipped that runs now loses the skip's reason
    log = Suite(tmp_path).log
    log["runs"]["oracle/ms_val/ideal"].update(status="skipped", reason="refused then")
    atomic_write_text(tmp_path / "suite.json", json.dumps(log))
    run_suite(tmp_path, ["oracle"], echo=lines.append, **args)
    entry = Suite(tmp_path).log["runs"]["oracle/ms_val/ideal"]
    assert entry["status"] == "done" and "reason" not in entry
    # and a run made before that is skipped now keeps no SR of its own beside the skip
    suite = Suite(tmp_path)
    suite._note("oracle/ms_val/ideal", status="skipped", reason="refused now")
    entry = Suite(tmp_path).log["runs"]["oracle/ms_val/ideal"]
    assert entry["reason"] == "refused now" and not {"sr", "episodes", "errors"} & set(entry)


def test_cli_checkpoint_option_is_checked(tmp_path):
    from typer.testing import CliRunner

    from biovln_ms.cli import app

    r = CliRunner().invoke(app, ["benchmark", "-o", str(tmp_path), "--checkpoints", "ppo"])
    assert r.exit_code != 0
    assert "METHOD=PATH" in str(r.exception or r.output)
