"""Time procedural scene generation: N seeds of a template, with a progress bar.

    python benchmarks/scene_generation.py [--template single_room] [--n 1000]

Reference in the same run: the cost of only validating an already-generated spec (the layout
rules are most of the work), printed as a ratio.

The table goes to ``docs/data/benchmarks/scene_generation.json`` (``--data-out``), which the docs' benchmarks
page renders.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from tqdm import tqdm

from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import check_layout


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--template", default="single_room")
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "scene_generation.json")
    args = ap.parse_args()
    t0 = time.perf_counter()
    specs = [
        generate_scene(args.template, seed) for seed in tqdm(range(args.n), desc=f"{args.template} specs")
    ]
    gen = time.perf_counter() - t0
    t0 = time.perf_counter()
    for s in specs[:200]:
        check_layout(s)
    check = (time.perf_counter() - t0) / min(200, len(specs))
    per = gen / args.n
    print(f"{args.n} {args.template} specs in {gen:.2f} s ({per * 1e3:.2f} ms/spec; budget 20 s per 1000)")
    print(
        f"rule check of one finished spec: {check * 1e3:.2f} ms -> "
        f"generation = {per / check:.2f}x one rule check"
    )
    write_table(
        args.data_out,
        "Procedural scene generation",
        [
            "template",
            "specs",
            "time",
            "per spec",
            "rule check of one spec",
            "generation / rule check",
            "budget",
        ],
        [
            [
                args.template,
                args.n,
                f"{gen:.1f} s",
                f"{per * 1e3:.2f} ms",
                f"{check * 1e3:.2f} ms",
                f"{per / check:.1f}×",
                "20 s per 1,000",
            ]
        ],
    )


if __name__ == "__main__":
    main()
