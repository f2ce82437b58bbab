"""Time a training split at scale (`biovln-ms dataset build --template ...`): the target itself by default.

    python benchmarks/dataset_scale.py [--template single_room] [--scenes 10000] [--episodes-per-scene 20]
                                       [--workers 2] [--sample 50] [--target-scenes 10000]

First ``--sample`` scenes of each of ``--sample-templates`` in this process (CPU time per scene, without
process start-up), then ``--scenes`` scenes on ``--workers`` spawned processes (wall time, as the command
runs). With fewer ``--scenes`` than ``--target-scenes`` the target's time is extrapolated: scenes are
independent, so the time grows linearly with their number. Budget: 10,000 scenes x 20 episodes in 60
minutes on a 2-core machine (about 5 minutes of it, the default run).

The table goes to ``docs/data/benchmarks/dataset_scale.json`` (``--data-out``), which the datasets guide
renders.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

from biovln_ms.splits import held_out_seeds
from biovln_ms.episodes.bulk import build_training_split
from biovln_ms.episodes.dataset import MAX_MANIFEST_BYTES, EpisodeDataset
from biovln_ms.measured import docs_data_dir, write_table

BUDGET_S = 3600


def _size(root: Path) -> int:
    return sum(p.stat().st_size for p in root.rglob("*") if p.is_file())


def _bytes(n: float) -> str:
    return f"{n / 2**30:.2f} GiB" if n >= 2**30 else f"{n / 2**20:.1f} MiB"


def _minutes(s: float) -> str:
    return f"{s / 60:.1f} min" if s >= 60 else f"{s:.1f} s"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--template", default="single_room")
    ap.add_argument("--scenes", type=int, default=10_000)
    ap.add_argument("--episodes-per-scene", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--sample", type=int, default=50, help="scenes built in this process for CPU per scene")
    ap.add_argument(
        "--sample-templates",
        default="single_room,two_room,suite,open_plan,molecular_biology",
        help="templates whose CPU per scene is measured (the build's template first)",
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--target-scenes", type=int, default=10_000)
    ap.add_argument("--out", type=Path, default=None, help="work folder (default: a temporary one, removed)")
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "dataset_scale.json")
    args = ap.parse_args()
    work = args.out or Path(tempfile.mkdtemp(prefix="biovln-scale-"))
    held = held_out_seeds()
    k, target, w = args.episodes_per_scene, args.target_scenes, args.workers
    common = dict(held_out=held, first_seed=args.seed)
    templates = [args.template] + [t for t in args.sample_templates.split(",") if t and t != args.template]
    rows, notes = [], []
    try:
        # CPU per scene of each template, in this process (no process start-up, no contention between workers)
        for i, template in enumerate(templates):
            n = args.sample if i == 0 else max(1, args.sample // 2)
            cpu0, t0 = time.process_time(), time.perf_counter()
            build_training_split(
                work / f"sample-{template}", template, n, k, workers=1, progress=False, **common
            )
            cpu = (time.process_time() - cpu0) / n
            wall1 = time.perf_counter() - t0
            if i == 0:
                cpu_main, load1 = cpu, os.getloadavg()[0]
            rows.append(
                [
                    template,
                    f"{n:,} × {k}",
                    "1 (this process)",
                    _minutes(wall1),
                    f"{n / wall1:.2f}",
                    f"{cpu * 1e3:.0f} ms",
                    f"{os.getloadavg()[0]:.1f}",
                    f"{_minutes(target * cpu / w)} (CPU / {w})",
                    _minutes(BUDGET_S),
                ]
            )
            print(rows[-1])
        # the build as the command runs it
        t0 = time.perf_counter()
        m = build_training_split(
            work / "scale", args.template, args.scenes, k, workers=w, progress=True, **common
        )
        wall = time.perf_counter() - t0
        load = os.getloadavg()
        est = target * wall / args.scenes
        rows.append(
            [
                args.template,
                f"{args.scenes:,} × {k}",
                str(w),
                _minutes(wall),
                f"{args.scenes / wall:.2f}",
                None,
                f"{load[0]:.1f}",
                f"{_minutes(est)} "
                + ("(measured)" if args.scenes == target else f"(wall × {target / args.scenes:g})"),
                _minutes(BUDGET_S),
            ]
        )
        t0 = time.perf_counter()
        EpisodeDataset(work / "scale")  # what gym.make(dataset=...) does first: every file's hash checked
        load_s = time.perf_counter() - t0
        size = _size(work / "scale")
        manifest = (work / "scale" / "manifest.json").stat().st_size
    finally:
        if args.out is None:
            shutil.rmtree(work, ignore_errors=True)
    split = m["splits"]["train"]
    scale = target / args.scenes
    notes += [
        f"The last column: {target:,} scenes × {k} episodes on {w} workers. For the {args.scenes:,}-scene "
        + (
            "build, its wall time"
            if args.scenes == target
            else f"build, its wall time × {scale:g} (scenes are independent and the assembly is linear)"
        )
        + f"; for the one-process samples, the CPU time per scene × {target:,} / {w} (idle cores, no "
        f"contention). The "
        f"{args.scenes:,}-scene build ran at {args.scenes / wall / (w / cpu_main):.0%} of that ideal rate.",
        f"The machine is shared: the load average (1 min) was {load1:.1f} after the first sample and "
        f"{load[0]:.1f} after the build ({load[1]:.1f} over 5 min) on {os.cpu_count()} cores.",
        f"The build's split: {split['description']}.",
        f"On disk: {_bytes(size)}, its manifest {_bytes(manifest)} (the loader's limit is "
        f"{MAX_MANIFEST_BYTES // 2**20} MiB). Loading it with every file's hash checked, as gym.make does, "
        f"took {_minutes(load_s)}"
        + ("." if args.scenes == target else f" ({_minutes(load_s * scale)} at {target:,} scenes)."),
    ]
    for n in notes:
        print(n)
    write_table(
        args.data_out,
        "Building a training split at scale",
        [
            "template",
            "scenes × episodes",
            "workers",
            "wall",
            "scenes/s",
            "CPU per scene",
            "load average",
            f"{target:,} × {k} on {w} workers",
            "budget",
        ],
        rows,
        notes=notes,
    )


if __name__ == "__main__":
    main()
