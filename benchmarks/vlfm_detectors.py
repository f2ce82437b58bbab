"""VLFM with the learned detector (``vlfm``) beside VLFM with the GT detector (``vlfm_gt``, the
simulator's segmentation) and the paper's VLFM, split by split, and where the difference comes from.

    biovln-ms eval -m vlfm -s SPLIT [--noise realistic] -o runs      # every split: runs/vlfm[+realistic]
    biovln-ms eval -m vlfm_gt -s SPLIT [--noise realistic] -o runs   # where you can
    python benchmarks/vlfm_detectors.py --learned runs/vlfm runs/vlfm+realistic \
        --gt runs/vlfm_gt runs/vlfm_gt+realistic

Every split of a ``--learned`` folder is a row. Where a ``--gt`` folder holds the same split under the
same noise, the two are compared episode by episode (McNemar's test on the episodes both played);
elsewhere the GT detector's row is the published ``vlfm_gt`` run's SR (``docs/data/reproduction.json``),
another draw of the same episodes (contacts depend on what a worker ran before, the noise presets
guide), so SR only. The paper's VLFM SR (its Table 5) sits beside where the paper has the split. Each
failed episode is traced to one outcome:

| outcome | rule |
|---|---|
| success | the episode succeeded |
| never detected | failed, and no detection of the target's category (right or wrong) ever gave |
|  | ``min_object_points`` points |
| STOP at another instance | failed after a detection, stopped more than ``FAR`` m from the goal but within |
|  | ``FAR`` m of the Eq. 1 goal of an instance of the category the episode does not count (the paper's |
|  | splits name one instance; MS DEV's scenes hold two centrifuges or two refrigerators) |
| STOP far from the target | failed after a detection, stopped more than ``FAR`` m from every goal of the |
|  | category: it went to something it took for the target (a false positive) |
| STOP near the target | failed after a detection, stopped within ``FAR`` m: seen, but not reached |
| step limit | failed after a detection without stopping |

Writes ``docs/data/perception/vlfm_detectors.json`` (the table; its notes count, per paired split, the
episodes whose outcome differs by target category) and beside it ``vlfm_detectors_episodes.json`` (each
such episode: category, both outcomes, both distances to the goal, both step counts, the learned run's
detections); ``--data-out`` elsewhere.
"""

from __future__ import annotations

import argparse
import json
import math
from collections import Counter
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from biovln_ms.episodes.dataset import EpisodeDataset
from biovln_ms.errors import BioVLNError
from biovln_ms.eval import paper
from biovln_ms.eval.harness import dataset_digest, episode_key, load_records, run_name
from biovln_ms.eval.methods import METHODS
from biovln_ms.eval.stats import mcnemar, wilson_interval
from biovln_ms.io_utils import atomic_write_text
from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.robot_specs import DEFAULT_ROBOT

#: a failed STOP further than this (m) from the goal went to another object
FAR = 1.5
#: each episode's trace, success first (:func:`outcome`)
OUTCOMES = (
    "success",
    "never detected",
    "STOP at another instance",
    "STOP far from the target",
    "STOP near the target",
    "step limit",
)


def outcome(rec: dict, others: Sequence[Sequence[float]] = ()) -> str:
    """One episode's trace (:data:`OUTCOMES`); ``others``: the Eq. 1 goals (x, y) of the instances of its
    category that the episode does not count (:func:`uncounted_goals`)."""
    if rec["success"]:
        return "success"
    if not rec.get("policy_stats", {}).get("object_seen", False):
        return "never detected"
    if not rec["stopped"]:
        return "step limit"
    if rec["dtg"] <= FAR:
        return "STOP near the target"
    if any(math.dist(rec["positions"][-1][:2], g[:2]) <= FAR for g in others):
        return "STOP at another instance"
    return "STOP far from the target"


def uncounted_goals(run_split: Path) -> dict[str, list[list[float]]] | None:
    """{episode key: the Eq. 1 goals of the goal objects of its category that it does not count} for one
    split of a results folder, from the dataset its ``manifest.json`` names (checked against the digest the
    run recorded); None where no manifest names one (not checked: no STOP then reads as at another
    instance)."""
    try:
        manifest = json.loads((run_split / "manifest.json").read_text())
    except (OSError, ValueError):
        return None
    if not manifest.get("dataset"):
        return None
    root = Path(manifest["dataset"])
    if not root.is_absolute() or not (root / "manifest.json").is_file():
        raise RunsError(f"{run_split}: its manifest's dataset {str(root)!r} is not a dataset folder here "
                        "(trace the run where it ran, or rebuild that dataset at that path)")  # fmt: skip
    if manifest.get("dataset_sha256") not in (None, dataset_digest(root, run_split.name)):
        raise RunsError(f"{run_split}: {root} has changed since the run (its digest differs); trace the run "
                        "against the dataset it played")  # fmt: skip
    try:
        ds = EpisodeDataset(root, verify=False, robot=manifest.get("robot", DEFAULT_ROBOT))
    except BioVLNError as e:
        raise RunsError(f"{run_split}: its dataset does not read ({e})")
    if run_split.name not in ds.split_names():
        raise RunsError(f"{run_split}: {root} has no split {run_split.name!r} (a results folder's subfolders "
                        "are named by their split)")  # fmt: skip
    out = {}
    for ep in ds.episodes(run_split.name):
        spec = ds.spec(ep["scene_id"])  # cached by the dataset
        counted = {g["object_id"] for g in ep["goals"]}
        others = [
            list(o.goal)
            for o in spec.goal_objects()
            if o.category == ep["object_category"] and o.id not in counted
        ]
        if others:
            out[episode_key(ep)] = others
    return out


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


def sr_cell(sr: float, lo: float, hi: float) -> str:
    """A success rate and its 95 % interval, in %."""
    return f"{sr:.1f} [{lo:.1f}, {hi:.1f}]"


def sr(recs: list[dict]) -> str:
    """Success rate in % with its Wilson 95 % interval."""
    k, n = sum(r["success"] for r in recs), len(recs)
    lo, hi = wilson_interval(k, n)
    return sr_cell(100 * k / n, 100 * lo, 100 * hi)


#: the two methods compared
LEARNED, GT = "vlfm", "vlfm_gt"
COLUMNS = ["split", "noise", "detector", "n", "SR %", *OUTCOMES[1:], "McNemar p", "steps / GT's (median)"]
COLUMNS += ["paper SR %"]


def _noise(recs: list[dict]) -> str:
    return recs[0].get("noise", "ideal")


def _traced(split: str, noise: str, name: str, recs: list[dict], others: dict[str, list]) -> list:
    counts = Counter(outcome(r, others.get(episode_key(r), ())) for r in recs)
    return [split, noise, name, len(recs), sr(recs), *[counts.get(o, 0) for o in OUTCOMES[1:]]]


def compare(learned_dir: Path, gt_dirs: list[Path], published: dict) -> tuple[list[list], dict, dict]:
    """Rows (per split of ``learned_dir``: the GT detector's, then the learned one's), the episodes whose
    outcome differs where a GT run of the same split and noise is among ``gt_dirs``, and per split checked
    against its dataset the episodes that do not count an instance of their category ({split: (n, Counter
    of categories)});
    ``published``: the reproduction data's runs."""
    learned = runs_by_split(learned_dir)
    gts = [(d, runs_by_split(d)) for d in gt_dirs]
    paper_row = paper.TABLE5.get(METHODS[LEARNED].paper_key, {})
    rows, traces, twins = [], {}, {}
    for split in sorted(learned):
        b_all = list(learned[split].values())
        checked = uncounted_goals(learned_dir / split)
        others = checked or {}
        played = [k for k in others if k in learned[split]]
        if checked is not None:
            twins[split] = (len(played), Counter(learned[split][k]["object_category"] for k in played))
        noise = _noise(b_all)
        paper_sr = paper_row.get(split, {}).get("sr") if noise == "ideal" else None
        pair = next(
            ((d, g[split]) for d, g in gts if split in g and _noise(list(g[split].values())) == noise), None
        )
        if pair is None:  # the published run: its SR only
            o = published.get(run_name(GT, noise=noise), {}).get(split, {}).get("overall")
            if o:
                cell = sr_cell(o["sr"], *o["sr_ci95"])
                rows.append([split, noise, "GT (published run)", o["episodes"], cell, *[None] * 7, None])
            rows.append(_traced(split, noise, "learned", b_all, others) + [None, None, paper_sr])
            continue
        gt_dir, gt = pair
        keys = sorted(set(gt) & set(learned[split]))
        if not keys:
            raise RunsError(f"{gt_dir} and {learned_dir} share no episodes of {split}")
        a, b = [gt[k] for k in keys], [learned[split][k] for k in keys]
        p = mcnemar([r["success"] for r in a], [r["success"] for r in b]).p_value
        both = [(x["steps"], y["steps"]) for x, y in zip(a, b) if x["success"] and y["success"]]
        ratio = round(float(np.median([y / x for x, y in both])), 2) if both else None
        rows.append(_traced(split, noise, "GT", a, others) + [None, None, None])
        rows.append(_traced(split, noise, "learned", b, others) + [round(p, 4), ratio, paper_sr])
        traces[f"{split} ({noise})"] = {}
        for k, x, y in zip(keys, a, b):
            ox, oy = outcome(x, others.get(k, ())), outcome(y, others.get(k, ()))
            if ox != oy:
                traces[f"{split} ({noise})"][k] = {
                    "category": y["object_category"],
                    "gt": ox,
                    "learned": oy,
                    "dtg": [round(x["dtg"], 2), round(y["dtg"], 2)],
                    "steps": [x["steps"], y["steps"]],
                    "learned_detections": y.get("policy_stats", {}).get("detections"),
                }
    return rows, traces, twins


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--learned", type=Path, nargs="+", required=True, help="results folders of vlfm")
    ap.add_argument("--gt", type=Path, nargs="*", default=[], help="results folders of vlfm_gt")
    ap.add_argument("--published", type=Path, help="default: docs/data/reproduction.json")
    ap.add_argument("--data-out", type=Path, help="default: docs/data/perception/vlfm_detectors.json")
    args = ap.parse_args(argv)
    published_file = args.published or docs_data_dir() / "reproduction.json"
    try:
        published = json.loads(published_file.read_text())["runs"]
    except (OSError, ValueError, KeyError) as e:
        ap.error(f"{published_file}: not the reproduction data ({type(e).__name__}); give --published FILE")
    rows, traces, twins = [], {}, {}
    for learned in args.learned:
        try:
            more, more_traces, more_twins = compare(learned, args.gt, published)
        except RunsError as e:
            ap.error(str(e))
        if not more:
            ap.error(f"{learned} holds no split's episodes")
        rows += more
        traces.update(more_traces)
        for split, t in more_twins.items():  # each preset's run of a split plays the same episodes
            if twins.setdefault(split, t) != t:
                ap.error(f"{learned}/{split}: other episodes than another run of {split}")
    for r in rows:
        print("  ".join(map(str, r)))
    notes = [
        "SR with Wilson 95 % intervals. GT: a vlfm_gt run on the same episodes (McNemar's test on the "
        "paired outcomes); GT (published run): the reproduction page's vlfm_gt run (SR only). The outcome "
        f"columns trace each run's failures: never detected; after a detection, a STOP more than {FAR} m "
        f"from the goal but within {FAR} m of another instance's (one the episode does not count), a STOP "
        f"more than {FAR} m from every such goal (a false positive it went to), a STOP nearer (seen, not "
        "reached); the step limit. "
        "Paper SR: the paper's VLFM (Grounding DINO + SAM + GPT-4o), its Table 5, under ideal sensing.",
    ]
    named = {split: t for split, t in sorted(twins.items()) if t[0]}
    notes += [
        f"{split}: {n} episodes name one instance of a category the scene holds more of ("
        + ", ".join(f"{c} {k}" for c, k in cats.most_common())
        + "); a STOP at another is a failure (only the named instance's goal counts)"
        for split, (n, cats) in named.items()
    ]
    if len(named) < len(twins):
        notes.append("No such episode on " + ", ".join(sorted(set(twins) - set(named))) + " (as played).")
    unchecked = sorted({r[0] for r in rows} - set(twins))
    if unchecked:
        notes.append("Not checked for such episodes (no run manifest): " + ", ".join(unchecked) + ".")
    for key, differs in traces.items():
        changed = Counter(t["category"] for t in differs.values())
        notes.append(
            f"{key}: episodes whose outcome differs, by target category: "
            + (", ".join(f"{c} {n}" for c, n in changed.most_common()) or "none")
        )
    out = args.data_out or docs_data_dir() / "perception" / "vlfm_detectors.json"
    write_table(out, "VLFM: the learned detector against the GT detector", COLUMNS, rows, notes=notes)
    episodes = out.with_name(out.stem + "_episodes.json")
    atomic_write_text(episodes, json.dumps(traces, indent=1, sort_keys=True) + "\n")
    print(f"wrote {episodes}")


if __name__ == "__main__":
    main()
