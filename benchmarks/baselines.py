"""The whole MS DEV + VAL + TEST evaluation of oracle, random, frontier and zone3_oracle (budget 30 min),
with steps/s per method and, for reference, the raw SAPIEN 640x480 RGB-D render rate of the same
machine measured in the same run.

    python benchmarks/baselines.py [--out /tmp/biovln_baselines] [--workers 2]

The table goes to ``docs/data/benchmarks/baselines.json`` (``--data-out``), which the docs' benchmarks
page renders.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from biovln_ms.eval.harness import EvalConfig, evaluate, load_records
from biovln_ms.measured import docs_data_dir, write_table

METHODS = ("oracle", "random", "zone3_oracle", "frontier")
SPLITS = ("ms_dev", "ms_val", "ms_test")


def raw_render_rate() -> float:
    import gymnasium as gym

    import biovln_ms  # noqa: F401
    from biovln_ms.render.sapien_utils import raw_camera_rate as rate

    env = gym.make(
        "BioVLN-OpFace-v0", split="ms_val", obs_mode="rgbd", sim_backend="physx_cpu", render_backend="cpu"
    )
    env.reset(seed=0)
    r = rate(env, 40)
    env.close()
    return r


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "baselines.json")
    args = ap.parse_args()
    out = args.out or Path(tempfile.mkdtemp()) / "results"
    t_all = time.perf_counter()
    rows = []
    for m in METHODS:
        for s in SPLITS:
            t = time.perf_counter()
            summ = evaluate(EvalConfig(m, s, str(out), workers=args.workers), progress=False)
            dt = time.perf_counter() - t
            steps = sum(r.get("steps", 0) for r in load_records(Path(out) / m / s / "episodes.jsonl"))
            rows.append((m, s, summ["overall"]["episodes"], summ["overall"]["sr"], dt, steps / dt))
    total = time.perf_counter() - t_all
    print(f"{'method':<13} {'split':<8} {'eps':>4} {'SR %':>6} {'time s':>7} {'steps/s (all workers)':>22}")
    for m, s, n, sr, dt, sps in rows:
        print(f"{m:<13} {s:<8} {n:>4} {sr:6.1f} {dt:7.1f} {sps:22.1f}")
    print(f"total {total / 60:.1f} min (budget 30 min) -> {out}")
    raw = raw_render_rate()
    print(f"raw SAPIEN 640x480 RGB-D frames/s (one process, for reference): {raw:.1f}")
    write_table(
        args.data_out,
        "MS DEV + VAL + TEST with four baselines",
        ["method", "split", "episodes", "SR %", "time", "steps/s (all workers)"],
        [[m, s, n, f"{sr:.1f}", f"{dt:.0f} s", f"{sps:.0f}"] for m, s, n, sr, dt, sps in rows],
        notes=[
            f"Total {total / 60:.1f} min (budget 30 min) with {args.workers or 'one worker per core'} "
            f"workers; raw SAPIEN 640×480 RGB-D in one process: {raw:.0f} frames/s."
        ],
    )


if __name__ == "__main__":
    main()
