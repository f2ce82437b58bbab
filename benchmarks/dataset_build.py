"""Time `biovln-ms dataset build`: all 47 scenes and every episode of the paper's splits.

    python benchmarks/dataset_build.py [--out /tmp/biovln_bench]

Budget: <= 60 s on a 2-core machine. Reference in the same run: generating the scene specs alone.

The table goes to ``docs/data/benchmarks/dataset_build.json`` (``--data-out``), which the docs' benchmarks
page renders.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from biovln_ms.splits import paper_splits
from biovln_ms.episodes.writer import write_dataset
from biovln_ms.measured import docs_data_dir, write_table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "dataset_build.json")
    args = ap.parse_args()
    out = args.out or Path(tempfile.mkdtemp()) / "biovln"
    t = time.perf_counter()
    splits = paper_splits()
    specs = time.perf_counter() - t
    t = time.perf_counter()
    m = write_dataset(out, splits)
    build = time.perf_counter() - t
    total = sum(s["episodes"] for k, s in m["splits"].items() if k == "full")
    bench = sum(s["episodes"] for k, s in m["splits"].items() if k not in ("full", "train"))
    print(
        f"scene specs: {specs:.2f} s; episodes + files: {build:.2f} s; "
        f"total {specs + build:.2f} s (budget 60 s)"
    )
    print(
        f"{len(m['scenes'])} scenes, {total} episodes in 'full', {bench} in the benchmark splits "
        f"-> whole build = {(specs + build) / specs:.1f}x the spec generation alone"
    )
    write_table(
        args.data_out,
        "Building the paper's datasets",
        [
            "scenes",
            "episodes in full",
            "episodes in the benchmark splits",
            "total",
            "× specs alone",
            "budget",
        ],
        [
            [
                len(m["scenes"]),
                total,
                bench,
                f"{specs + build:.1f} s",
                f"{(specs + build) / specs:.1f}×",
                "60 s",
            ]
        ],
    )


if __name__ == "__main__":
    main()
