"""The benchmark's whole evaluation from one command (``biovln-ms benchmark``): every method on every
benchmark split under every noise preset, the runs the paper's table layouts need (MS DEV, the centroid
ablation), the lab-protocol methods on the protocol splits (ideal preset only), the same with people in the
lab (the single-goal methods on the busy splits under every preset, the protocol methods with people), the
learned methods' training when no checkpoint is given, then the report.

Each (method, split, preset) is one harness run (:func:`biovln_ms.eval.harness.evaluate`), so a killed
suite resumes where it stopped: finished episodes are never run again, a finished run costs a file read,
and a learned method's checkpoint is trained once. ``<out>/suite.json`` keeps every run's status and wall
time (the time of a resumed run adds up over its sessions; a run whose results were deleted starts its
time afresh); ``<out>/suite.md`` is that as a table.

Runs that cannot be made are skipped with their reason in both files, never silently: LLM-Frontier
without an endpoint (``BIOVLN_LLM_API_KEY`` unset).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from biovln_ms.variants import BENCHMARK_ENV, CENTROID_ENV, PROTOCOL_ENV, WITH_PEOPLE
from biovln_ms.errors import BioVLNError
from biovln_ms.eval.harness import EvalConfig, evaluate
from biovln_ms.eval.methods import METHODS, method_spec
from biovln_ms.io_utils import atomic_write_text
from biovln_ms.noise import resolve_noise
from biovln_ms.episodes.dataset import EpisodeDataset
from biovln_ms.splits import BUSY_SPLITS, dataset_root

#: the benchmark splits: the paper's MS VAL / TEST, Two-Room and LSAT, and the Hard track
SUITE_SPLITS = ("ms_val", "ms_test", "two_room", "lsat_target", "hard_val", "hard_test")
SUITE_NOISE = ("ideal", "realistic")
#: geometric methods first (the suite's time budget is theirs), then the slower and the learned ones
GEOMETRIC = ("oracle", "zone3_oracle", "frontier", "random")  # the methods of the 60-minute budget
SUITE_METHODS = (*GEOMETRIC, "llm_frontier", "ppo", "vlfm", "vlfm_gt", "bc")
LEARNED = ("ppo", "bc")
PPO_TIMESTEPS = 300_000  # benchmarks/rl_learning.py's budget
BC_EPISODES = 200  # frontier recordings of the train split for BC
BC_MINUTES = 35.0  # BC's wall-clock budget (the learning guide's measured run)
BC_IMAGE_SIZE = 128


#: lab protocols: the protocol methods run on these splits under the ideal preset only, whatever
#: the splits and presets asked for the others (a new task: its baselines are compared with one another)
PROTOCOL_SPLITS = ("protocol_val", "protocol_test")
PROTOCOL_METHODS = (
    "protocol_oracle",
    "protocol_frontier",
    "protocol_vlfm",
    "protocol_vlfm_gt",
    "protocol_language",
)

#: the paper's tables also need MS DEV (Tables 5, 6, 10, 11) and the centroid ablation (Table 9, frontier)
PAPER_SPLIT = "ms_dev"
CENTROID = ("frontier", CENTROID_ENV, ("ms_dev", "ms_val", "ms_test"))


@dataclass(frozen=True)
class SuiteRun:
    method: str
    split: str
    noise: str
    skip: str | None = None  # why this run is not made
    env_id: str | None = None  # None: the method's own env

    @property
    def key(self) -> str:
        env = "" if self.env_id is None else "@" + self.env_id
        return f"{self.method}{env}/{self.split}/{self.noise}"


def skip_reason(method: str) -> str | None:
    """Why ``method`` cannot run here (None: it can): its preflight's error (the learned methods' is their
    checkpoint, which the suite trains)."""
    spec = method_spec(method)
    if spec.preflight is not None and method not in LEARNED:
        try:
            spec.preflight()
        except BioVLNError as e:
            return e.message
    return None


def plan(
    methods: Sequence[str],
    splits: Sequence[str],
    noises: Sequence[str],
    paper_tables: bool = True,
    people: bool = True,
) -> list[SuiteRun]:
    """Every (method, split, preset), a method's ideal runs first; with ``paper_tables`` also each method
    on MS DEV (ideal) and the centroid ablation, for the paper's table layouts; with ``people`` each
    single-goal method on the busy splits, on its variant's counterpart with people (``WITH_PEOPLE``), under
    every preset, and each protocol method on the protocol splits with people (ideal)."""
    for m in methods:
        method_spec(m)
    for n in noises:
        resolve_noise(n)
    runs = []
    for m in methods:  # a method's runs together, so the cheap methods finish first
        why = skip_reason(m)
        if METHODS[m].env_id == PROTOCOL_ENV:  # lab protocols: the protocol splits, ideal only
            runs += [SuiteRun(m, s, "ideal", why) for s in PROTOCOL_SPLITS]
            if people:
                runs += [SuiteRun(m, s, "ideal", why, WITH_PEOPLE[PROTOCOL_ENV]) for s in PROTOCOL_SPLITS]
            continue
        runs += [SuiteRun(m, s, n, why) for n in noises for s in splits]
        busy = WITH_PEOPLE.get(METHODS[m].env_id or BENCHMARK_ENV)  # its variant with people
        if people and busy:
            runs += [SuiteRun(m, s, n, why, busy) for n in noises for s in BUSY_SPLITS]
        if paper_tables:
            runs.append(SuiteRun(m, PAPER_SPLIT, "ideal", why))
            method, env, paper_splits = CENTROID
            if m == method:
                runs += [SuiteRun(method, s, "ideal", env_id=env) for s in paper_splits]
    return list(dict.fromkeys(runs))


class Suite:
    """One suite folder: its runs' log (``suite.json``), the learned checkpoints, the harness results."""

    def __init__(self, out: str | Path, workers: int | None = None, dataset: str | None = None, echo=print):
        self.out = Path(out)
        self.workers = workers
        self.dataset = dataset
        self.echo = echo
        self.log_path = self.out / "suite.json"
        self.log = json.loads(self.log_path.read_text()) if self.log_path.exists() else {"runs": {}}

    def _save(self) -> None:
        atomic_write_text(self.log_path, json.dumps(self.log, indent=1, sort_keys=True) + "\n")
        atomic_write_text(self.out / "suite.md", "\n".join(self.table()) + "\n")

    def _note(self, key: str, **fields) -> None:
        entry = self.log["runs"].setdefault(key, {"seconds": 0.0})
        if fields.get("status", entry.get("status")) != entry.get("status"):
            for stale in set(entry) - {"seconds"}:  # a skip's reason, a run's SR: not beyond their status
                del entry[stale]
        seconds = fields.pop("seconds", 0.0)
        entry.update(fields, seconds=round(entry["seconds"] + seconds, 1))
        self._save()

    # --- learned methods ------------------------------------------------------------------------------
    def checkpoint(self, method: str, given: dict[str, str], progress: bool) -> str:
        """The checkpoint of a learned method: ``given``, else the suite's own, trained once here."""
        if method in given:
            return given[method]
        if method == "ppo":
            return self._train_ppo(progress)
        return self._train_bc(progress)

    def _train_ppo(self, progress: bool) -> str:
        from biovln_ms.learning.rl import RLConfig, train_rl

        path = self.out / "checkpoints" / "ppo"
        if not (path / "model.zip").exists():
            self.echo(f"training PPO ({PPO_TIMESTEPS} timesteps) -> {path}")
            t = time.perf_counter()
            cfg = RLConfig(timesteps=PPO_TIMESTEPS, dataset=self.dataset, eval_split=None)
            train_rl(cfg, path, echo=self.echo, progress=progress)
            self._note("train/ppo", status="done", seconds=time.perf_counter() - t)
        return str(path / "model.zip")

    def _train_bc(self, progress: bool) -> str:
        from biovln_ms.learning.bc import BCConfig, train_bc

        path = self.out / "checkpoints" / "bc"
        if not (path / "bc.pt").exists():
            recordings = path / "recordings"
            self.echo(f"recording frontier on {BC_EPISODES} train episodes for BC -> {recordings}")
            t = time.perf_counter()
            evaluate(
                EvalConfig(
                    "frontier",
                    "train",
                    str(path / "recording_runs"),
                    self.dataset,
                    workers=self.workers,
                    max_episodes=BC_EPISODES,
                    record_dir=str(recordings),
                ),
                progress=progress,
                echo=self.echo,
            )
            cfg = BCConfig(image_size=BC_IMAGE_SIZE, max_minutes=BC_MINUTES)
            train_bc([recordings], path, cfg, echo=self.echo, progress=progress)
            self._note("train/bc", status="done", seconds=time.perf_counter() - t)
        return str(path / "bc.pt")

    # --- the runs -------------------------------------------------------------------------------------
    def _people_splits(self, runs: list[SuiteRun]) -> list[SuiteRun]:
        """The runs with people, skipped where the dataset lacks their split (a dataset of one's own)."""
        with_people = set(WITH_PEOPLE.values())
        if not any(r.env_id in with_people for r in runs):
            return runs
        known = set(EpisodeDataset(dataset_root(self.dataset)).split_names())
        why = "the dataset has no split '{}' (biovln-ms dataset build makes the paper's splits)"
        return [
            replace(r, skip=r.skip or why.format(r.split))
            if r.env_id in with_people and r.split not in known
            else r
            for r in runs
        ]

    def run(
        self, runs: list[SuiteRun], checkpoints: dict[str, str] | None = None, progress: bool = True
    ) -> dict:
        """Make (or resume) every run; returns the log."""
        given = dict(checkpoints or {})
        runs = self._people_splits(runs)
        todo = [r for r in runs if not r.skip]
        for method in dict.fromkeys(r.method for r in todo if r.method in given):
            spec = method_spec(method)
            if spec.preflight:  # a given checkpoint that cannot load fails now, not after the runs before it
                spec.preflight(checkpoint=given[method])
        for r in runs:
            if r.skip:
                self._note(r.key, status="skipped", reason=r.skip)
        for i, r in enumerate(todo, 1):
            env = f" ({r.env_id})" if r.env_id else ""
            self.echo(f"[{i}/{len(todo)}] {r.method}{env} on {r.split}, noise {r.noise}")
            kwargs = {}
            if r.method in LEARNED:
                kwargs["checkpoint"] = self.checkpoint(r.method, given, progress)
            cfg = EvalConfig(
                r.method,
                r.split,
                str(self.out / "results"),
                self.dataset,
                r.env_id,
                workers=self.workers,
                method_kwargs=kwargs,
                noise=r.noise,
            )
            if not (cfg.run_dir / "episodes.jsonl").exists():  # a fresh start: earlier sessions' time goes
                self.log["runs"].pop(r.key, None)
            t = time.perf_counter()
            summary = evaluate(cfg, progress=progress, echo=self.echo)
            overall = summary["overall"]
            self._note(
                r.key,
                status="done",
                episodes=overall["episodes"],
                errors=overall["errors"],
                sr=overall["sr"],
                seconds=time.perf_counter() - t,
            )
        return self.log

    def table(self) -> list[str]:
        """The log as a Markdown table, with the total wall time of the geometric methods and of all."""
        rows = ["| run | status | episodes | SR % | wall time |", "|---|---|---|---|---|"]
        for key, e in sorted(self.log["runs"].items(), key=lambda kv: self.order(kv[0])):
            status = e["status"] if e["status"] != "skipped" else f"skipped: {e['reason']}"
            sr = f"{e['sr']:.1f}" if e.get("sr") is not None else ""
            rows.append(
                f"| {key} | {status} | {e.get('episodes', '')} | {sr} | {e['seconds'] / 60:.1f} min |"
            )
        return [*rows, "", self.totals_line(self.log["runs"])]

    @classmethod
    def totals_line(cls, runs: dict) -> str:
        """The wall time of a log's runs: the geometric methods on the benchmark splits (the 60-minute
        budget), with the paper-table extras, and everything."""
        budgeted = geometric = total = 0.0
        for key, e in runs.items():
            total += e["seconds"]
            if cls.geometric(key):
                geometric += e["seconds"]
                budgeted += e["seconds"] if cls.benchmark_run(key) else 0.0
        return (
            f"Geometric methods on the benchmark splits under every preset (the 60-minute budget): "
            f"{budgeted / 60:.1f} min; with MS DEV and the centroid ablation (the paper's tables): "
            f"{geometric / 60:.1f} min; everything: {total / 60:.1f} min."
        )

    @staticmethod
    def benchmark_run(key: str) -> bool:
        """Whether a log key is a run on a benchmark split (``SUITE_SPLITS``) of a method's own env, not
        one of the paper-table extras (MS DEV, the centroid ablation's env)."""
        method, *rest = key.split("/")
        return "@" not in method and bool(rest) and rest[0] in SUITE_SPLITS

    @staticmethod
    def geometric(key: str) -> bool:
        """Whether a log key is a run of a geometric method (the 60-minute budget's)."""
        return key.split("/")[0].split("@")[0] in GEOMETRIC

    @staticmethod
    def order(key: str) -> tuple:
        """A log key's place in the table: by method (suite order), split, then the key."""
        method, *rest = key.split("/")
        method = method.split("@")[0]
        if method == "train":
            return (SUITE_METHODS.index(rest[0]) if rest[0] in SUITE_METHODS else 99, -1, "")
        split = rest[0] if rest else ""
        return (
            SUITE_METHODS.index(method) if method in SUITE_METHODS else len(METHODS),
            SUITE_SPLITS.index(split) if split in SUITE_SPLITS else 99,
            key,
        )


def run_suite(
    out: str | Path,
    methods: Sequence[str] = SUITE_METHODS + PROTOCOL_METHODS,
    splits: Sequence[str] = SUITE_SPLITS,
    noises: Sequence[str] = SUITE_NOISE,
    workers: int | None = None,
    dataset: str | None = None,
    checkpoints: dict[str, str] | None = None,
    report: str | Path | None = None,
    progress: bool = True,
    echo: Callable[[str], None] = print,
    paper_tables: bool = True,
    people: bool = True,
) -> dict:
    """Plan, run (or resume) and, with ``report``, write the report of ``<out>/results``."""
    suite = Suite(out, workers, dataset, echo)
    log = suite.run(plan(methods, splits, noises, paper_tables, people), checkpoints, progress)
    for line in suite.table():
        echo(line)
    if report is not None:
        from biovln_ms.eval.report import write_report

        write_report(suite.out / "results", Path(report), dataset, echo=echo)
    return log
