"""The whole benchmark's wall time on this machine (the budget: the geometric methods' part within
60 min): ``biovln-ms benchmark``'s runs, each with its episodes, SR and wall time, and the totals.

    python benchmarks/baselines.py [--out /tmp/biovln_bench] [--workers 2] [--all]
    python benchmarks/baselines.py --from /tmp/biovln_bench     # the table of a suite that already ran

Without ``--all`` only the geometric methods (oracle, 3-zone oracle, frontier, random) run; with it, every
method of the suite (VLFM, PPO and BC too, training included). A suite folder that exists is resumed, and
its log keeps the time of every session. The table goes to ``docs/data/benchmarks/baselines.json``
(``--data-out``), which the docs' benchmarks page renders.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from biovln_ms.eval.suite import GEOMETRIC, SUITE_METHODS, Suite, run_suite
from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.render.sapien_utils import vulkan_device_label


def table_rows(log: dict) -> tuple[list[list], list[str]]:
    """The suite log's runs as table rows, and the note with the totals."""
    rows = []
    for key, e in sorted(log["runs"].items(), key=lambda kv: Suite.order(kv[0])):
        method, split, preset = (key.split("/") + ["", ""])[:3]  # train/ppo: a training stage
        if e["status"] == "skipped":
            rows.append([method, split, preset, None, None, f"skipped: {e['reason']}"])
        else:
            sr = None if e.get("sr") is None else f"{e['sr']:.1f}"
            rows.append([method, split, preset, e.get("episodes"), sr, f"{e['seconds'] / 60:.1f} min"])
    return rows, [f"{Suite.totals_line(log['runs'])} Budget: 60 min."]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=None, help="suite folder (default: a new temporary one)")
    ap.add_argument("--from", dest="from_dir", type=Path, default=None, help="only tabulate this suite")
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--all", action="store_true", help="every method, not only the geometric ones")
    ap.add_argument("--note", action="append", default=[], help="a line under the table (e.g. the load)")
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "baselines.json")
    args = ap.parse_args()
    if args.from_dir:
        log = json.loads((args.from_dir / "suite.json").read_text())
    else:
        out = args.out or Path(tempfile.mkdtemp()) / "suite"
        methods = SUITE_METHODS if args.all else GEOMETRIC
        log = run_suite(out, methods, workers=args.workers, paper_tables=args.all)
    rows, notes = table_rows(log)
    write_table(
        args.data_out,
        "The whole benchmark (`biovln-ms benchmark`): every run and its wall time",
        ["method", "split", "noise", "episodes", "SR %", "wall time"],
        rows,
        notes=notes + args.note,
        render_device=vulkan_device_label(),
    )
    for line in notes:
        print(line)


if __name__ == "__main__":
    main()
