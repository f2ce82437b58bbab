"""Robust evaluation: every episode counts in the metrics, errored ones as failures; one writer per
results folder; a killed run resumes with each episode exactly once; duplicates are repaired."""

from __future__ import annotations

import fcntl
import json
import math
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest

from biovln_ms.eval import harness
from biovln_ms.eval.harness import EvalConfig, episode_key, evaluate, load_records
from biovln_ms.eval.methods import METHODS


class _FailingPolicy:
    """Raises in the episodes it is told to (all by default), as an LLM returning non-string content did."""

    fail_ids: set[str] | None = None

    def reset(self, episode_info) -> None:
        if self.fail_ids is None or episode_info.episode_id in self.fail_ids:
            raise TypeError("the JSON object must be str, bytes or bytearray, not dict")

    def act(self, obs, info) -> int:
        return 0  # STOP


@pytest.fixture
def ds(held_out_dataset) -> str:
    return held_out_dataset(ms_val=4)


def _flaky_oracle(monkeypatch, fail_id: str = "1") -> None:
    from biovln_ms.baselines.oracle import OraclePolicy

    real = OraclePolicy.reset

    def flaky(self, info):
        if info.episode_id == fail_id:
            raise RuntimeError("planner exploded")
        return real(self, info)

    monkeypatch.setattr(OraclePolicy, "reset", flaky)


def _lines(path: Path) -> int:
    return path.read_bytes().count(b"\n") if path.exists() else 0


# --- metrics count every episode ------------------------------------------------------------------
def test_an_errored_episode_is_a_failure_in_sr_and_spl(ds, tmp_path, monkeypatch):
    _flaky_oracle(monkeypatch)
    s = evaluate(EvalConfig("oracle", "ms_val", str(tmp_path), ds, workers=1), progress=False)
    recs = load_records(tmp_path / "oracle" / "ms_val" / "episodes.jsonl")
    ran = [r for r in recs if not r.get("error")]
    assert len(recs) == 4 and len(ran) == 3
    o = s["overall"]
    assert o["episodes"] == 4 and o["errors"] == 1  # never dropped
    assert o["sr"] == pytest.approx(100 * sum(r["success"] for r in ran) / 4)
    assert o["spl"] == pytest.approx(sum(r["spl"] for r in ran) / 4)  # SPL 0 for the errored one
    assert o["soft_spl"] == pytest.approx(sum(r["soft_spl"] for r in ran) / 4)
    assert o["dtg"] == pytest.approx(sum(r["dtg"] for r in ran) / 3)  # DTG/MCR/VRT: over those that ran
    on_disk = json.loads((tmp_path / "oracle" / "ms_val" / "summary.json").read_text())
    assert on_disk["errors"] == 1 and on_disk["overall"]["episodes"] == 4
    assert on_disk["failed_episodes"] == [
        {"key": episode_key(recs[1]), "error": "RuntimeError: planner exploded"}
    ]
    # per category and tier too
    assert sum(a["episodes"] for a in s["per_category"].values()) == 4
    assert sum(a["errors"] for a in s["per_difficulty"].values()) == 1
    # running again retries the errored episode, whose new record replaces the error
    monkeypatch.undo()
    said: list[str] = []
    s = evaluate(
        EvalConfig("oracle", "ms_val", str(tmp_path), ds, workers=1), progress=False, echo=said.append
    )
    keys = [episode_key(r) for r in load_records(tmp_path / "oracle" / "ms_val" / "episodes.jsonl")]
    assert len(keys) == len(set(keys)) == 4 and s["overall"]["errors"] == 0 and s["failed_episodes"] == []
    assert any("3 done, 1 to go (1 that errored run again)" in line for line in said)


def test_a_nan_metric_is_an_error_of_its_record_not_a_gap_in_the_mean(ds, tmp_path, monkeypatch):
    from biovln_ms.eval.aggregate import aggregate

    real = harness.rollout

    def nan_spl(env, policy, index, privileged=False, fresh_scene=False):
        for st in real(env, policy, index, privileged, fresh_scene):
            if st.done and index == 2:
                st.info = {**st.info, "spl": float("nan")}
            yield st

    monkeypatch.setattr(harness, "rollout", nan_spl)
    s = evaluate(EvalConfig("random", "ms_val", str(tmp_path), ds, workers=1), progress=False)
    path = tmp_path / "random" / "ms_val" / "episodes.jsonl"
    assert "NaN" not in path.read_text()
    bad = load_records(path)[2]
    assert "spl" in bad["error"] and bad["spl"] is None
    assert s["overall"]["episodes"] == 4 and s["overall"]["errors"] == 1
    assert s["failed_episodes"][0]["key"] == episode_key(bad)
    # a NaN in an older file's record: the same, counted and shown, never skipped by a mean
    recs = [
        {"success": True, "spl": 1.0, "soft_spl": 1.0, "dtg": 0.1, "steps": 5, "mcr": 0.6, "vrt": 0.0},
        {"success": True, "spl": math.nan, "soft_spl": 1.0, "dtg": 0.1, "steps": 5, "mcr": 0.6, "vrt": 0.0},
    ]
    a = aggregate(recs)
    assert a["episodes"] == 2 and a["errors"] == 1 and a["sr"] == 50.0 and a["spl"] == 0.5
    from biovln_ms.eval.stats import mean_interval

    with pytest.raises(ValueError, match="non-finite"):
        mean_interval([1.0, math.nan, 2.0])


def test_cli_eval_exits_nonzero_when_episodes_error(ds, tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from biovln_ms.cli import app

    monkeypatch.setitem(METHODS, "failing", replace(METHODS["random"], factory=_FailingPolicy))
    args = ["eval", "-m", "failing", "-s", "ms_val", "--dataset", ds, "--workers", "1"]
    r = CliRunner().invoke(app, [*args, "-o", str(tmp_path / "all")])
    assert r.exit_code == 1, r.output
    assert "failing on ms_val: 4 episodes, SR 0.0%" in r.stdout and "errors: 4" in r.stdout
    results = tmp_path / "all" / "failing" / "ms_val" / "episodes.jsonl"
    msg = r.stderr.strip().splitlines()[-1]  # after the progress bar
    assert "4 of 4 episodes failed to run" in msg and str(results) in msg
    assert "episodes, SR nan" not in r.output
    # one of four errors: still exit status 1; none: 0
    monkeypatch.setattr(_FailingPolicy, "fail_ids", {"3"})
    r = CliRunner().invoke(app, [*args, "-o", str(tmp_path / "one")])
    assert r.exit_code == 1 and "errors: 1" in r.stdout and "1 of 4 episodes" in r.stderr
    monkeypatch.setattr(_FailingPolicy, "fail_ids", set())
    r = CliRunner().invoke(app, [*args, "-o", str(tmp_path / "none")])
    assert r.exit_code == 0 and "errors: 0" in r.stdout and "error:" not in r.stderr


def test_report_counts_errored_episodes_as_failures(ds, tmp_path, monkeypatch):
    from biovln_ms.eval.report import write_report

    _flaky_oracle(monkeypatch)
    res = tmp_path / "res"
    evaluate(EvalConfig("oracle", "ms_val", str(res), ds, workers=1), progress=False)
    evaluate(EvalConfig("random", "ms_val", str(res), ds, workers=1), progress=False)
    ran = [r for r in load_records(res / "oracle" / "ms_val" / "episodes.jsonl") if not r.get("error")]
    said: list[str] = []
    md = write_report(res, tmp_path / "rep", dataset=ds, videos=0, hard_figures=0, echo=said.append)
    text = md.read_text()
    assert "oracle on ms_val (4 episodes, 1 errored)" in text and "random on ms_val (4 episodes)" in text
    assert "Errored episodes: 1. An errored episode" in text and "counts as a failure" in text
    oracle_row = next(line for line in text.splitlines() if line.startswith("| Oracle |"))
    assert f"| {100 * sum(r['success'] for r in ran) / 4:.1f} [" in oracle_row
    assert "| 4, 1 errored |" in oracle_row  # the row's episodes, the errored one named
    assert any("oracle on ms_val: 1" in line for line in said)


# --- one writer per results folder ----------------------------------------------------------------
def test_a_second_writer_fails_at_once_and_a_dead_ones_lock_is_taken_over(ds, tmp_path):
    from biovln_ms.errors import BioVLNError

    run_dir = tmp_path / "random" / "ms_val"
    lock = run_dir / "eval.lock"
    script = tmp_path / "holder.py"
    script.write_text(
        "import sys, time\n"
        "from biovln_ms.io_utils import exclusive_lock\n"
        "with exclusive_lock(sys.argv[1]):\n"
        "    print('held', flush=True)\n"
        "    time.sleep(300)\n"
    )
    holder = subprocess.Popen([sys.executable, str(script), str(lock)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        cfg = EvalConfig("random", "ms_val", str(tmp_path), ds, workers=1)
        with pytest.raises(BioVLNError) as e:
            evaluate(cfg, progress=False)
        msg = str(e.value)
        assert f"pid {holder.pid}" in msg and "started" in msg and "holder.py" in msg
        assert f"kill {holder.pid}" in msg
        cli = [sys.executable, "-m", "biovln_ms.cli", "eval", "-m", "random", "-s", "ms_val"]
        r = subprocess.run(
            [*cli, "--dataset", ds, "-o", str(tmp_path), "--workers", "1"], capture_output=True, text=True
        )
        err = r.stderr.strip()
        assert r.returncode == 2 and "\n" not in err and f"pid {holder.pid}" in err and "fix:" in err
        assert not (run_dir / "episodes.jsonl").exists()  # nothing ran
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    s = evaluate(cfg, progress=False)  # the dead holder's lock is taken over
    assert s["overall"]["episodes"] == 4
    assert json.loads(lock.read_text())["pid"] == os.getpid()


def test_the_lock_is_held_while_the_driver_writes(ds, tmp_path, monkeypatch):
    seen: list = []

    class Probe(_FailingPolicy):
        fail_ids = set()

        def reset(self, episode_info) -> None:
            fd = os.open(tmp_path / "random" / "ms_val" / "eval.lock", os.O_RDWR)
            try:
                with pytest.raises(BlockingIOError):
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                seen.append(json.loads(os.pread(fd, 4096, 0))["pid"])
            finally:
                os.close(fd)

    monkeypatch.setitem(METHODS, "random", replace(METHODS["random"], factory=Probe))
    evaluate(EvalConfig("random", "ms_val", str(tmp_path), ds, workers=1), progress=False)
    assert seen == [os.getpid()] * 4


def test_a_killed_run_resumes_with_each_episode_exactly_once(held_out_dataset, tmp_path):
    n = 40
    data = held_out_dataset(ms_val=n)
    run_dir = tmp_path / "random" / "ms_val"
    path = run_dir / "episodes.jsonl"
    cmd = [sys.executable, "-m", "biovln_ms.cli", "eval", "-m", "random", "-s", "ms_val"]
    proc = subprocess.Popen(
        [*cmd, "--dataset", data, "-o", str(tmp_path), "--workers", "1"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 180
        while _lines(path) < 3 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.005)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    killed_after = _lines(path)
    assert 3 <= killed_after < n  # killed mid-run
    assert json.loads((run_dir / "eval.lock").read_text())["pid"] == proc.pid  # the dead run's lock
    said: list[str] = []
    s = evaluate(
        EvalConfig("random", "ms_val", str(tmp_path), data, workers=1), progress=False, echo=said.append
    )
    keys = [episode_key(r) for r in load_records(path)]
    assert len(keys) == len(set(keys)) == n and s["overall"]["episodes"] == n and s["errors"] == 0
    assert any("resuming" in line for line in said)


def _workers_of_group(pgid: int) -> list[int]:
    """The multiprocessing workers (``spawn_main``) alive in process group ``pgid`` (Linux /proc)."""
    found = []
    for entry in Path("/proc").iterdir():
        try:
            stat = (entry / "stat").read_text()
            cmd = (entry / "cmdline").read_bytes()
        except (OSError, ValueError):
            continue
        fields = stat.rsplit(")", 1)[1].split()  # after "pid (comm)": state, ppid, pgrp, ...
        if int(fields[2]) == pgid and fields[0] != "Z" and b"spawn_main" in cmd:
            found.append(int(entry.name))
    return found


def _terminated_leaves_no_workers(argv: list[str], ready) -> None:
    """Start ``biovln-ms argv`` in its own process group (its workers are in it too), wait until
    ``ready(proc)`` (at most 180 s), SIGTERM it: it exits as ^C does, and none of its workers is left."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "biovln_ms.cli", *argv],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 180
        while not ready(proc) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert proc.poll() is None and ready(proc)
        os.kill(proc.pid, signal.SIGTERM)
        proc.wait(timeout=60)
        assert _workers_of_group(proc.pid) == []  # ended before it exited
    finally:
        if proc.poll() is None:
            proc.kill()
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    assert proc.returncode == 128 + signal.SIGTERM


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process table from /proc")
def test_a_terminated_run_stops_its_workers(held_out_dataset, tmp_path):
    """``kill`` (SIGTERM) of a run with worker processes ends them too: none is left running on its own."""
    data = held_out_dataset(ms_val=40)
    path = tmp_path / "frontier" / "ms_val" / "episodes.jsonl"
    argv = [
        "eval",
        "-m",
        "frontier",
        "-s",
        "ms_val",
        "--dataset",
        data,
        "-o",
        str(tmp_path),
    ]
    # episodes of seconds: the workers are mid-episode once two have been written
    _terminated_leaves_no_workers([*argv, "--workers", "2"], lambda proc: _lines(path) >= 2)


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process table from /proc")
def test_a_terminated_training_stops_its_env_processes(held_out_dataset, tmp_path):
    """``kill`` of ``train ppo`` with two env processes (SB3's SubprocVecEnv) ends them too."""
    data = held_out_dataset(train=10)
    argv = ["train", "ppo", "--timesteps", "100000", "--n-envs", "2", "--dataset", data, "--eval-split", ""]

    def ready(proc) -> bool:  # SB3 makes tb/ once the envs are up
        return (tmp_path / "run" / "tb").exists() and len(_workers_of_group(proc.pid)) == 2

    _terminated_leaves_no_workers([*argv, "-o", str(tmp_path / "run")], ready)


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process table from /proc")
def test_a_terminated_dataset_build_stops_its_workers(tmp_path):
    """``kill`` of ``dataset build --workers 2`` (a process pool) ends its workers too."""
    argv = ["dataset", "build", "--template", "single_room", "--scenes", "400", "--episodes-per-scene", "2"]
    argv += ["--workers", "2", "-o", str(tmp_path / "ds")]
    _terminated_leaves_no_workers(argv, lambda proc: len(_workers_of_group(proc.pid)) == 2)


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process table from /proc")
def test_a_terminated_perception_dataset_stops_its_workers(tmp_path):
    """``kill`` of ``perception dataset --workers 2`` (a multiprocessing pool, rendering) ends its workers."""
    argv = ["perception", "dataset", "-o", str(tmp_path / "frames"), "--frames", "400", "--workers", "2"]
    _terminated_leaves_no_workers(argv, lambda proc: len(_workers_of_group(proc.pid)) == 2)


def test_duplicate_records_of_an_older_version_are_repaired_and_named(ds, tmp_path):
    from biovln_ms.eval.report import load_runs

    cfg = EvalConfig("random", "ms_val", str(tmp_path), ds, workers=1, max_episodes=3)
    evaluate(cfg, progress=False)
    path = tmp_path / "random" / "ms_val" / "episodes.jsonl"
    lines = path.read_text().splitlines(keepends=True)
    first = [json.loads(x) for x in lines]
    path.write_text("".join(lines + lines[:2]))  # two writers ran episodes 0 and 1 twice
    dup_keys = [episode_key(r) for r in first[:2]]
    said: list[str] = []
    cfg.max_episodes = None
    s = evaluate(cfg, progress=False, echo=said.append)
    repaired = next(line for line in said if "repaired" in line)
    assert all(k in repaired for k in dup_keys) and episode_key(first[2]) not in repaired
    recs = load_records(path)
    keys = [episode_key(r) for r in recs]
    assert len(keys) == len(set(keys)) == 4 and s["overall"]["episodes"] == 4
    assert recs[:3] == first  # the first record of each was kept
    # the report reads such a file with the first record of each, and names the duplicates
    path.write_text("".join(lines + lines[:2]))
    warned: list[str] = []
    assert len(load_runs(tmp_path, echo=warned.append)[("random", "ms_val")]) == 3
    assert len(warned) == 1 and all(k in warned[0] for k in dup_keys) and "fix:" in warned[0]
    from biovln_ms.eval.harness import unique_records

    # a retried episode (an error record, then its finished record) is one episode, not a duplicate
    err = {**{k: first[0][k] for k in ("scene_id", "episode_id")}, "error": "boom"}
    assert unique_records([err, first[0], first[1]]) == ([first[0], first[1]], [])
    assert unique_records([first[0], err]) == ([first[0]], [])
