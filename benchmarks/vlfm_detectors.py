"""VLFM with the trained detector beside VLFM with the GT detector (the simulator's segmentation), on the
same episodes, and where the difference comes from.

    biovln-ms eval -m vlfm -s ms_test --name vlfm@gt -o runs/vlfm_detectors
    biovln-ms eval -m vlfm -s ms_test --detector trained --name vlfm@trained -o runs/vlfm_detectors
    python benchmarks/vlfm_detectors.py runs/vlfm_detectors/vlfm@gt runs/vlfm_detectors/vlfm@trained \
        [GT_RUN TRAINED_RUN ...]        # more pairs, e.g. the same under --noise realistic

Any splits the two run folders share are compared, episode by episode (McNemar's test on the episodes
both played). Each episode of the trained-detector run is traced to one outcome:

| outcome | rule |
|---|---|
| success | the episode succeeded |
| never detected | failed, and no detection of the target's category (right or wrong) ever gave |
|  | ``min_object_points`` points |
| STOP far from the target | failed after a detection, stopped more than ``FAR`` m from the goal: it went |
|  | to something it took for the target (a false positive) |
| STOP near the target | failed after a detection, stopped within ``FAR`` m: seen, but not reached |
| step limit | failed after a detection without stopping |

Writes ``docs/data/perception/vlfm_detectors.json`` (the table; its notes count the episodes whose outcome
differs, by target category) and beside it ``vlfm_detectors_episodes.json`` (each such episode: category,
both outcomes, both distances to the goal, both step counts, the trained run's detections);
``--data-out`` elsewhere.
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

import numpy as np

from biovln_ms.eval.harness import episode_key, load_records
from biovln_ms.eval.stats import mcnemar, wilson_interval
from biovln_ms.io_utils import atomic_write_text
from biovln_ms.measured import docs_data_dir, write_table

#: a failed STOP further than this (m) from the goal went to another object
FAR = 1.5
#: each episode's trace, success first (:func:`outcome`)
OUTCOMES = ("success", "never detected", "STOP far from the target", "STOP near the target", "step limit")


def outcome(rec: dict) -> str:
    """One episode's trace (:data:`OUTCOMES`)."""
    if rec["success"]:
        return "success"
    if not rec.get("policy_stats", {}).get("object_seen", False):
        return "never detected"
    if not rec["stopped"]:
        return "step limit"
    return "STOP far from the target" if rec["dtg"] > FAR else "STOP near the target"


class RunsError(ValueError):
    """A results folder that cannot be compared (one line: the folder and the fix)."""


def runs_by_split(folder: Path) -> dict[str, dict[str, dict]]:
    """{split: {episode key: record}} of a results folder (one subfolder per split)."""
    if not folder.is_dir():
        raise RunsError(f"{folder}: no such results folder (give biovln-ms eval's -o DIR/RUN_NAME)")
    out = {}
    for sub in sorted(p for p in folder.iterdir() if (p / "episodes.jsonl").is_file()):
        out[sub.name] = {episode_key(r): r for r in load_records(sub / "episodes.jsonl")}
    return out


def sr(recs: list[dict]) -> str:
    """Success rate in % with its Wilson 95 % interval."""
    k, n = sum(r["success"] for r in recs), len(recs)
    lo, hi = wilson_interval(k, n)
    return f"{100 * k / n:.1f} [{100 * lo:.1f}, {100 * hi:.1f}]"


def compare(gt_dir: Path, learned_dir: Path) -> tuple[list[str], list[list], dict]:
    """Columns and rows (per shared split: the GT run, then the trained run with McNemar's p and the median
    step ratio of the episodes both solved), and the episodes whose outcome differs."""
    gt, learned = runs_by_split(gt_dir), runs_by_split(learned_dir)
    columns = ["split", "noise", "detector", "n", "SR %", *OUTCOMES[1:], "McNemar p"]
    columns += ["steps / GT's (median)"]
    rows, traces = [], {}
    for split in sorted(set(gt) & set(learned)):
        keys = sorted(set(gt[split]) & set(learned[split]))
        if not keys:
            continue
        a, b = [gt[split][k] for k in keys], [learned[split][k] for k in keys]
        p = mcnemar([r["success"] for r in a], [r["success"] for r in b]).p_value
        both = [(x["steps"], y["steps"]) for x, y in zip(a, b) if x["success"] and y["success"]]
        ratio = round(float(np.median([y / x for x, y in both])), 2) if both else None
        noise = b[0].get("noise", "ideal")
        if a[0].get("noise", "ideal") != noise:
            raise RunsError(f"{gt_dir} ran under {a[0].get('noise')!r}, {learned_dir} under {noise!r}")
        for name, recs, extra in (("GT", a, [None, None]), ("trained", b, [round(p, 4), ratio])):
            counts = Counter(outcome(r) for r in recs)
            row = [split, noise, name, len(keys), sr(recs), *[counts.get(o, 0) for o in OUTCOMES[1:]]]
            rows.append(row + extra)
        traces[f"{split} ({noise})"] = {
            k: {
                "category": y["object_category"],
                "gt": outcome(x),
                "trained": outcome(y),
                "dtg": [round(x["dtg"], 2), round(y["dtg"], 2)],
                "steps": [x["steps"], y["steps"]],
                "trained_detections": y.get("policy_stats", {}).get("detections"),
            }
            for k, x, y in zip(keys, a, b)
            if outcome(x) != outcome(y)
        }
    return columns, rows, traces


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "runs",
        type=Path,
        nargs="+",
        help="results folders in pairs: VLFM with the GT detector, then with "
        "the trained detector (one pair per noise preset)",
    )
    ap.add_argument("--data-out", type=Path, help="default: docs/data/perception/vlfm_detectors.json")
    args = ap.parse_args(argv)
    if len(args.runs) % 2:
        ap.error("give the results folders in pairs: GT_RUN TRAINED_RUN [GT_RUN TRAINED_RUN ...]")
    rows, traces = [], {}
    for gt, learned in zip(args.runs[::2], args.runs[1::2]):
        try:
            columns, more, more_traces = compare(gt, learned)
        except RunsError as e:
            ap.error(str(e))
        if not more:
            ap.error(f"{gt} and {learned} share no episodes")
        rows += more
        traces.update(more_traces)
    for r in rows:
        print("  ".join(map(str, r)))
    notes = [
        "Each pair of runs: the same episodes and noise; SR with Wilson 95 % intervals; McNemar's test on "
        "the paired outcomes. The outcome columns trace each run's failures: never detected; a STOP more "
        f"than {FAR} m from the goal after a detection (a false positive it went to); a STOP nearer (seen, "
        "not reached); the step limit.",
    ]
    for key, differs in traces.items():
        changed = Counter(t["category"] for t in differs.values())
        notes.append(
            f"{key}: episodes whose outcome differs, by target category: "
            + ", ".join(f"{c} {n}" for c, n in changed.most_common())
        )
    out = args.data_out or docs_data_dir() / "perception" / "vlfm_detectors.json"
    write_table(out, "VLFM: the GT detector against the trained detector", columns, rows, notes=notes)
    episodes = out.with_name(out.stem + "_episodes.json")
    atomic_write_text(episodes, json.dumps(traces, indent=1, sort_keys=True) + "\n")
    print(f"wrote {episodes}")


if __name__ == "__main__":
    main()
