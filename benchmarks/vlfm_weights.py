"""VLFM with other detector weights beside the shipped weights' published runs, split by split: does a
detector that finds more on held-out frames navigate better?

    biovln-ms eval -m vlfm -s SPLIT [--noise realistic] -o runs/w224 \\
        --detector trained:runs/det224f/detector.safetensors     # every split: runs/w224/vlfm[+realistic]
    python benchmarks/vlfm_weights.py runs/w224/vlfm runs/w224/vlfm+realistic --label "224x168, 9,600 frames"

Rows, per split and preset: the shipped weights' SR (the learned rows of
``docs/data/perception/vlfm_detectors.json``, from their own runs), the other weights' SR and each failure's
trace (``vlfm_detectors.outcome``), the difference and Fisher's exact p. The two are separate runs of the
same episodes whose records are not paired here, so the test is unpaired; a last row per preset pools its
splits. Each run folder must be of one weights file (its manifest's detector spec), named in the notes by
its SHA-256. Writes ``docs/data/perception/vlfm_weights.json``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
from collections import Counter
from pathlib import Path

from scipy.stats import fisher_exact

from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.eval.harness import episode_key
from biovln_ms.eval.stats import wilson_interval
from vlfm_detectors import (
    OUTCOMES,
    RunsError,
    outcome,
    runs_by_split,
    sr,
    sr_cell,
    uncounted_goals,
)  # the script beside this

PUBLISHED = docs_data_dir() / "perception" / "vlfm_detectors.json"
COLUMNS = ["split", "noise", "shipped weights: SR %", "n (shipped)", "these weights: SR %", "n (these)"]
COLUMNS += OUTCOMES[1:]
COLUMNS += ["difference (points)", "Fisher p"]


def published_rows(path: Path) -> dict[tuple[str, str], tuple[str, int, int]]:
    """(split, noise) -> (SR cell, successes, episodes) of the shipped weights' runs."""
    data = json.loads(path.read_text())
    cols = data["columns"]
    i_det, i_n, i_sr = cols.index("detector"), cols.index("n"), cols.index("SR %")
    out = {}
    for r in data["rows"]:
        if r[i_det] == "learned":
            n = int(r[i_n])
            out[(r[0], r[1])] = (r[i_sr], round(float(r[i_sr].split()[0]) * n / 100), n)
    return out


def weights_of(folder: Path) -> str:
    """The SHA-256 of the one weights file every split of a run folder used."""
    specs = {
        json.loads(m.read_text())["arguments"]["method_kwargs"].get("detector", "trained")
        for m in folder.glob("*/manifest.json")
    }
    if len(specs) != 1:
        raise RunsError(f"{folder}: its splits ran with {len(specs)} detector specs (give one run's folder)")
    spec = specs.pop()
    if not spec.startswith("trained:"):
        raise RunsError(f"{folder}: detector '{spec}' is not a weights file (use --detector trained:FILE)")
    return hashlib.sha256(Path(spec.removeprefix("trained:")).read_bytes()).hexdigest()


def row(split: str, noise: str, shipped: tuple[str, int, int], recs: list[dict], others: dict) -> list:
    """One split's (or the pooled splits') row: the shipped SR, these weights' SR and traces (``others``:
    ``uncounted_goals`` of the episodes), the difference and Fisher's exact p."""
    cell, k0, n0 = shipped
    k1, n1 = sum(r["success"] for r in recs), len(recs)
    counts = Counter(outcome(r, others.get(episode_key(r), ())) for r in recs)
    p = fisher_exact([[k0, n0 - k0], [k1, n1 - k1]]).pvalue
    diff = round(100 * (k1 / n1 - k0 / n0), 1)
    traces = [counts.get(o, 0) for o in OUTCOMES[1:]]
    return [split, noise, cell, n0, sr(recs), n1, *traces, diff, round(p, 3)]


def compare(folders: list[Path], published: dict) -> tuple[list[list], list[str]]:
    """A row per split of each folder, then one per preset over its splits."""
    rows, notes, pooled = [], [], {}
    for folder in folders:
        notes.append(f"{folder.name}: weights {weights_of(folder)[:16]}")
        for split, by_key in sorted(runs_by_split(folder).items()):
            recs = list(by_key.values())
            noise = recs[0].get("noise", "ideal")
            if (split, noise) not in published:
                raise RunsError(f"{folder}/{split}: no published run of the shipped weights to set it beside")
            n0 = published[(split, noise)][2]
            if len(recs) != n0:  # a run still going, or of other episodes
                raise RunsError(
                    f"{folder}/{split}: {len(recs)} episodes, the shipped weights' run {n0} "
                    "(finish the run: biovln-ms eval resumes it)"
                )
            others = uncounted_goals(folder / split) or {}
            rows.append(row(split, noise, published[(split, noise)], recs, others))
            pool = pooled.setdefault(noise, [0, 0, [], {}])
            pool[0] += published[(split, noise)][1]
            pool[1] += published[(split, noise)][2]
            pool[2] += recs
            pool[3].update(others)
    for noise, (k0, n0, recs, others) in pooled.items():
        lo, hi = wilson_interval(k0, n0)
        cell = sr_cell(100 * k0 / n0, 100 * lo, 100 * hi)
        rows.append(row("all splits", noise, (cell, k0, n0), recs, others))
    return rows, notes


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", type=Path, nargs="+", help="results folders of vlfm with --detector trained:FILE")
    ap.add_argument("--label", default="other weights", help="what the weights are, for the table's title")
    ap.add_argument("--published", type=Path, default=PUBLISHED)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "perception" / "vlfm_weights.json")
    a = ap.parse_args(argv)
    try:
        rows, notes = compare(a.runs, published_rows(a.published))
    except RunsError as e:
        raise SystemExit(f"error: {e}") from None
    notes.append(
        "Shipped weights: the learned rows of vlfm_detectors.json (their own runs, not these); the two are "
        "different draws of the same episodes, compared unpaired (Fisher's exact test)."
    )
    write_table(a.data_out, f"VLFM: the shipped detector weights against {a.label}", COLUMNS, rows, notes)


if __name__ == "__main__":
    main()
