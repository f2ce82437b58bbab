"""`biovln-ms report`: Markdown tables in the paper's layouts with its numbers beside ours, PNG plots,
top-down trajectory renders, episode MP4s and hard-episode figures, and ``measured.json``: the data the
tables are made from (``summarize``), which the documentation's reproduction page renders with the same
table functions (copied to ``docs/data/reproduction.json``).

Which methods appear, in what order, under which label and beside which of the paper's rows comes from the
method registry (``biovln_ms.eval.methods.METHODS``). The tables are drawn in
``biovln_ms.eval.paper_tables``, the figures in ``biovln_ms.eval.figures``; this module reads the runs,
summarizes them and writes the report."""

from __future__ import annotations

import json
import math
from datetime import date
from itertools import combinations
from pathlib import Path
from typing import Callable

import numpy as np

from biovln_ms.episode_video import record_episode
from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset
from biovln_ms.errors import BioVLNError
from biovln_ms.eval.aggregate import (
    INTERVALS,
    PROTOCOL_UNITS,
    UNITS,
    aggregate,
    aggregate_all,
    kind_metrics,
    record_error,
    succeeded,
)
from biovln_ms.eval.figures import (
    hard_episode_figure,
    hard_episodes,
    plot_protocol_stages,
    plot_safety,
    plot_sr,
    plot_trajectories,
)
from biovln_ms.eval.harness import episode_key, load_records, read_manifest, run_name, unique_records
from biovln_ms.eval.methods import METHODS, report_methods
from biovln_ms.eval.paper_tables import (
    ALPHA,
    BENCH_SPLITS,
    CENTROID_ENV,
    PRESETS,
    SPLIT_EPISODES,
    SPLITS,
    _partial,
    _preset_run,
    _ran,
    _run_name,
    benchmark_table,
    differences,
    mcnemar_table,
    other_measures_table,
    people_table,
    protocol_table,
    reach_table,
    table5,
    table6,
    table9,
    table10,
    table11,
    table17,
)
from biovln_ms.eval.stats import holm, mcnemar, wilson_interval
from biovln_ms.eval.tables import BREAKDOWN_MEASURES, PROTOCOL_BREAKDOWN_MEASURES, REACH_MEASURES, table_keys
from biovln_ms.io_utils import atomic_write_text
from biovln_ms.measured import machine
from biovln_ms.robot_specs import DEFAULT_ROBOT
from biovln_ms.splits import dataset_root, ensure_default_dataset


def load_runs(results: Path, echo: Callable[[str], None] = print) -> dict[tuple[str, str], list[dict]]:
    """Episode records by (run, split), one per episode, errored ones included (they count as failures).
    Who a run is comes from its manifest (:func:`run_key`); only records of an older version that name no
    method or split fall back on the folder names. A file with more than one finished record of an episode
    (two writers of an older version) is read with the first of each, and named (``biovln-ms eval`` on that
    run repairs the file)."""
    runs = {}
    for f in sorted(Path(results).glob("*/*/episodes.jsonl")):
        recs, dups = unique_records(load_records(f, repair=False))
        if dups:
            echo(
                f"warning: {f} has more than one record of {len(dups)} episodes ({', '.join(dups[:5])}"
                f"{', ...' if len(dups) > 5 else ''}); the first of each is used (fix: run `biovln-ms "
                "eval` again on that run: it repairs the file)"
            )
        if recs:
            who = read_manifest(f.parent, recs)
            run = run_key(who) if who.get("method") in METHODS else f.parent.parent.name
            split = who.get("split") or f.parent.name
            if (run, split) in runs:
                echo(f"warning: {f.parent} is a second run of {run} on {split}; it is left out")
                continue
            runs[(run, split)] = recs
    return runs


def run_key(who: dict) -> str:
    """A run's name in the report, from its manifest: the method's name for its own env, robot and the
    ``ideal`` preset; else the name ``biovln-ms eval`` gives such a run (``frontier+realistic``,
    ``frontier@centroid``)."""
    name = run_name(who["method"], who["env_id"], who["robot"], who["noise"])
    return who["method"] if name == _run_name(who["method"]) else name


SCHEMA = 2  # measured.json: 2 = intervals, strict SR, split sizes, Holm-adjusted McNemar tests


SIGNIFICANCE = (
    f"McNemar p-values adjusted by Holm's step-down method over every test of the report (the pairwise "
    f"table and Table 9 together); significant: adjusted p < {ALPHA}"
)


def _plain(value):
    """JSON-safe: a non-finite number (no episode to average) as None, through lists and dicts."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


def _overall_keys(agg: dict) -> tuple[str, ...]:
    """Every aggregate of a run's overall row but its timing (a new measure's included)."""
    return tuple(k for k in agg if k != "wall_time_s")


def _keep(agg: dict, keys: tuple[str, ...]) -> dict:
    return {k: _plain(agg[k]) for k in keys}


def summarize(runs, split_sizes: dict[str, int] | None = None) -> dict:
    """What the report's tables show, as plain data: per run and split the overall metrics, by category
    and by difficulty tier, each with its 95 % interval, the split's full size and whether the run is
    partial (fewer episodes than the split: ``split_sizes``, default the benchmark's ``SPLIT_EPISODES``),
    and the pairwise McNemar tests (every pair of methods on a split, and each ``method@centroid`` run
    against its method) with each SR's Wilson interval and Holm-adjusted p-values. Units (``units``):
    SR, strict SR and VRT in %, SPL in [0, 1]. ``write_report`` saves it as ``measured.json``; the tables
    below are made from it alone, so the documentation renders the same tables from a copy
    (``docs/data/reproduction.json``)."""
    sizes = {**SPLIT_EPISODES, **(split_sizes or {})}
    out: dict = {
        "schema": SCHEMA,
        "units": dict(UNITS),
        "labels": {a.key: a.label for m, _ in kind_metrics(False).values() for a in m.aggregates},
        "intervals": INTERVALS,
        "significance": SIGNIFICANCE,
        "runs": {},
        "mcnemar": [],
    }
    for (run, split), recs in sorted(runs.items()):
        a = aggregate_all(recs)
        total = sizes.get(split)
        if "per_protocol" in a:  # lab protocols (BioVLN-Protocol-v0): their own metrics
            out.setdefault("protocol_units", dict(PROTOCOL_UNITS))
            out["runs"].setdefault(run, {})[split] = {
                "split_episodes": total,
                "partial": total is not None and a["overall"]["episodes"] < total,
                "protocol": True,
                "overall": _keep(a["overall"], _overall_keys(a["overall"])),
                "per_k": {
                    k: _keep(v, table_keys(PROTOCOL_BREAKDOWN_MEASURES)) for k, v in a["per_k"].items()
                },
            }
            continue
        out["runs"].setdefault(run, {})[split] = {
            "split_episodes": total,
            "partial": total is not None and a["overall"]["episodes"] < total,
            "overall": _keep(a["overall"], _overall_keys(a["overall"])),
            "per_category": {
                c: _keep(v, table_keys(BREAKDOWN_MEASURES)) for c, v in a["per_category"].items()
            },
            "per_difficulty": {
                d: _keep(v, table_keys(BREAKDOWN_MEASURES)) for d, v in a["per_difficulty"].items()
            },
        }
        if a["overall"].get("reach_successes") is not None:  # a Fetch run
            out["runs"][run][split]["reach"] = {
                "overall": _keep(a["overall"], table_keys(REACH_MEASURES)),
                "per_category": {
                    c: _keep(v, table_keys(REACH_MEASURES)) for c, v in a["per_category"].items()
                },
            }
    pairs = []
    for preset in PRESETS:  # every pair of methods under one preset, and each method across presets
        named = [_preset_run(m, preset) for m in report_methods()]
        pairs += list(combinations([r for r in named if any((r, s) in runs for s in BENCH_SPLITS)], 2))
    pairs += [(_preset_run(m, p), m) for m in report_methods() for p in PRESETS[1:]]
    pairs += [(_run_name(m, CENTROID_ENV), m) for m in report_methods()]
    for s in BENCH_SPLITS:
        for a, b in pairs:
            if (a, s) in runs and (b, s) in runs:
                x, y = _paired(runs[(a, s)], runs[(b, s)])
                r = mcnemar(x, y)
                out["mcnemar"].append(
                    {
                        "a": a,
                        "b": b,
                        "split": s,
                        "n": len(x),
                        "sr_a": 100 * float(np.mean(x)) if x else None,
                        "sr_a_ci95": _plain([100 * v for v in wilson_interval(sum(x), len(x))]),
                        "sr_b": 100 * float(np.mean(y)) if y else None,
                        "sr_b_ci95": _plain([100 * v for v in wilson_interval(sum(y), len(y))]),
                        "n01": r.n01,
                        "n10": r.n10,
                        "p": r.p_value,
                        "exact": r.exact,
                    }
                )
    adjust_mcnemar(out["mcnemar"])
    return out


def adjust_mcnemar(tests: list[dict]) -> list[dict]:
    """Holm-adjusted p-values (``p_holm``) and ``significant`` (adjusted p < ``ALPHA``) on every test, in
    place: one family, all the report's McNemar tests."""
    for t, p in zip(tests, holm([t["p"] for t in tests])):
        t["p_holm"] = p
        t["significant"] = p < ALPHA
    return tests


def _paired(a: list[dict], b: list[dict]):
    """Outcomes of the episodes both runs hold, errored ones as failures."""
    ka = {episode_key(r): succeeded(r) for r in a}
    kb = {episode_key(r): succeeded(r) for r in b}
    keys = sorted(set(ka) & set(kb))
    return [ka[k] for k in keys], [kb[k] for k in keys]


def runs_header(runs, results, summ: dict | None = None) -> list[str]:
    """The report's first lines: each run with its episodes, how many of them errored (when any) and
    whether it is partial (by ``summarize``'s ``summ``), what an errored episode counts as, the units
    and the intervals."""
    listed, errored, partial = [], 0, 0
    for (m, s), recs in sorted(runs.items()):
        a = aggregate(recs)
        errored += a["errors"]
        label = _partial(summ, m, s) if summ else ""
        partial += bool(label)
        listed.append(
            f"{m} on {s} ({a['episodes']} episodes"
            + (f", {a['errors']} errored" if a["errors"] else "")
            + (f"; {label}" if label else "")
            + ")"
        )
    return [
        f"Results: `{results}`. Runs: " + ", ".join(listed) + ".",
        "",
        f"Errored episodes: {errored or 'none'}. An errored episode (it failed to run; its reason is the "
        "`error` field of `episodes.jsonl`) counts as a failure: in SR, and with SPL 0 in SPL. It has no "
        "trajectory, so DTG, steps, MCR and VRT are means over the episodes that ran.",
        "",
        (
            f"Partial runs: {partial} (fewer episodes than their split, marked partial (n/N) in the tables); "
            "their numbers are not comparable with the paper's, which are over whole splits."
            if partial
            else "Partial runs: none (every run covers its whole split)."
        ),
        "",
        "Units: SR, strict SR and VRT in %, SPL in [0, 1], DTG and MCR in m. " + INTERVALS + ".",
    ]


def tables(runs, split_sizes: dict[str, int] | None = None) -> list[list[str]]:
    """The report's Markdown sections, in order (one list of lines each)."""
    return tables_of(summarize(runs, split_sizes))


TABLES = {
    "table5": table5,
    "benchmark": benchmark_table,
    "table10": table10,
    "table6": table6,
    "table9": table9,
    "table11": table11,
    "table17": table17,
    "mcnemar": mcnemar_table,
    "reach": reach_table,
    "protocols": protocol_table,
    "people": people_table,
    "other": other_measures_table,
    "differences": differences,
}


def tables_of(summ: dict) -> list[list[str]]:
    """The report's Markdown sections made from ``summarize``'s data, in order."""
    return [make(summ) for make in TABLES.values()]


def split_sizes(ds) -> dict[str, int]:
    """Each split's episode count in the dataset ``ds`` (its manifest), for the partial-run labels."""

    out = {}
    for s in ds.split_names():
        try:
            out[s] = int(ds.split_info(s)["episodes"])
        except (DatasetError, KeyError, TypeError, ValueError):  # not built, or no count: no label
            continue
    return out


def write_report(
    results: Path, out: Path, dataset: str | None = None, videos: int = 1, hard_figures: int = 2, echo=print
) -> Path:

    runs = load_runs(Path(results), echo)
    if not runs:
        raise BioVLNError(
            f"no results under {results}", fix="run `biovln-ms eval --method M --split S --out DIR` first"
        )
    out = Path(out)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    ds = EpisodeDataset(dataset or ensure_default_dataset(echo))
    summ = summarize(runs, split_sizes(ds))
    lines = ["# BioVLN-MS evaluation report", "", *runs_header(runs, results, summ), ""]
    errored = {k: aggregate(r)["errors"] for k, r in sorted(runs.items())}
    if any(errored.values()):
        echo(
            "errored episodes (counted as failures): "
            + ", ".join(f"{m} on {s}: {n}" for (m, s), n in errored.items() if n)
        )
    meta = {
        "command": f"biovln-ms report {results}",
        "machine": machine(),
        "written": date.today().isoformat(),
    }
    atomic_write_text(
        out / "measured.json", json.dumps({**meta, **summ}, indent=1, ensure_ascii=False) + "\n"
    )
    for block in tables_of(summ):
        lines += block + [""]
    single = any(_ran(summ, m, s) for m in report_methods() for s in SPLITS)
    figs = [plot_sr(summ, out / "figures" / "sr_by_method.png")] if single else []
    figs.append(plot_safety(runs, out / "figures" / "safety.png"))
    stages = plot_protocol_stages(summ, out / "figures" / "protocol_stages.png")
    figs += [stages] if stages else []
    for (m, s), recs in sorted(runs.items()):
        if all(record_error(r) for r in recs):  # no trajectory to draw
            continue
        robot = recs[0].get("robot", DEFAULT_ROBOT)  # another robot's runs are in its own default dataset
        specs = (
            ds.spec
            if dataset or robot == DEFAULT_ROBOT
            else EpisodeDataset(dataset_root(None, robot), robot=robot).spec
        )
        figs.append(
            plot_trajectories(recs, specs, out / "figures" / f"trajectories_{m}_{s}.png", f"{m} on {s}")
        )
    lines += ["## Figures", ""] + [f"![{f.stem}](figures/{f.name})" for f in figs] + [""]
    ran = {k: [r for r in recs if record_error(r) is None] for k, recs in runs.items()}
    hard, any_hard = hard_episodes(runs, hard_figures)
    prefix = "hard" if any_hard else "longest"
    hard_files = [
        hard_episode_figure(r, dataset, out / "figures" / f"{prefix}_{r['scene_id']}_{r['episode_id']}.png")
        for r in hard
    ]
    if hard_files:
        heading = (
            "## Hard frontier episodes (geodesic > 6 m), longest first"
            if any_hard
            else "## Longest frontier episodes (no hard episode, geodesic > 6 m, in these runs)"
        )
        lines += [heading, ""] + [f"![{f.stem}](figures/{f.name})" for f in hard_files] + [""]
    if videos:
        (out / "videos").mkdir(exist_ok=True)
        vids = []
        for (m, s), recs in sorted(ran.items()):
            if len(vids) >= videos or m not in METHODS or not METHODS[m].recordable or not recs:
                continue
            r = recs[0]
            path = out / "videos" / f"{m}_{s}_{r['scene_id']}_{r['episode_id']}.mp4"
            record_episode(path, split=s, episode=r["index"], policy=m, dataset=dataset)
            vids.append(path)
        lines += ["## Videos", ""] + [f"- [`{v.name}`](videos/{v.name})" for v in vids] + [""]
    md = out / "report.md"
    md.write_text("\n".join(lines) + "\n")
    echo(f"wrote {md}")
    return md
