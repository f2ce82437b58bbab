"""Time what a first use pays once: the first ``gym.make`` of each obs mode in a fresh process, cold (every
cache empty) and warm (the caches the cold run filled), and the robots' default datasets, built on the first
``gym.make(..., split=...)``.

    python benchmarks/first_use.py [--modes state rgbd ...] [--robots biovln_base fetch]

Each measurement runs in a new process. Cold means empty: ``BIOVLN_CACHE_DIR`` (the room-shell meshes),
``BIOVLN_DATA_DIR`` (the datasets) and ``XDG_CACHE_HOME`` (Mesa's shader cache and any other user cache),
each a fresh folder; warm runs again with the folders the cold run filled. The operating system's file
cache is not emptied. Times are wall clock with the process's CPU time (user + system) beside them: on a
shared machine the wall time grows with the load, the CPU time much less.

The table goes to ``docs/data/benchmarks/first_use.json`` (``--data-out``), rendered by the envs guide.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

MODES = ("state", "depth", "rgb", "rgbd", "rgb+depth+segmentation", "pointcloud")
ROBOTS = ("biovln_base", "fetch")
CPU = dict(sim_backend="physx_cpu", render_backend="cpu")


def _clock() -> tuple[float, float]:
    """(wall, CPU) seconds so far: CPU is this process's user + system time, every thread included."""
    t = os.times()
    return time.perf_counter(), t.user + t.system


def _since(start: tuple[float, float]) -> list[float]:
    wall, cpu = _clock()
    return [round(wall - start[0], 1), round(cpu - start[1], 1)]


def child_make(mode: str) -> dict:
    """In a fresh process: the ManiSkill imports, the first ``gym.make`` (its first reset renders), and
    a second ``gym.make`` in the same process."""
    start = _clock()
    import gymnasium as gym

    import biovln_ms  # noqa: F401

    import biovln_ms.tasks  # noqa: F401  (what the first gym.make imports: ManiSkill, SAPIEN, torch)

    imports = _since(start)
    t = _clock()
    env = gym.make("BioVLN-OpFace-v0", obs_mode=mode, **CPU)
    first = _since(t)
    env.close()
    t = _clock()
    env = gym.make("BioVLN-OpFace-v0", obs_mode=mode, **CPU)
    second = _since(t)
    env.close()
    from biovln_ms.render.sapien_utils import vulkan_device_label

    return {"imports": imports, "first": first, "second": second, "device": vulkan_device_label()}


def child_dataset(robot: str) -> dict:
    """In a fresh process: the default dataset of ``robot``, as the first ``gym.make(split=...)`` gets it."""
    from biovln_ms.splits import ensure_default_dataset

    t = _clock()
    ensure_default_dataset(echo=lambda *_: None, robot=robot, progress=False)
    return {"dataset": _since(t)}


def run_child(kind: str, arg: str, caches: Path) -> dict:
    env = dict(os.environ)
    for var, sub in (("BIOVLN_CACHE_DIR", "biovln"), ("BIOVLN_DATA_DIR", "data"), ("XDG_CACHE_HOME", "xdg")):
        env[var] = str(caches / sub)
    env.pop("MESA_SHADER_CACHE_DIR", None)  # Mesa's cache follows XDG_CACHE_HOME
    cmd = [sys.executable, __file__, "--child", kind, arg]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def cell(t: list[float]) -> str:
    def s(v: float) -> str:
        return f"{v:.0f}" if v >= 10 else f"{v:.1f}"

    return f"{s(t[0])} s ({s(t[1])} s CPU)"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--modes", nargs="*", default=list(MODES))
    ap.add_argument("--robots", nargs="*", default=list(ROBOTS))
    ap.add_argument("--child", nargs=2, metavar=("KIND", "ARG"), help=argparse.SUPPRESS)
    ap.add_argument("--data-out", type=Path, default=None)
    args = ap.parse_args()
    if args.child:
        kind, arg = args.child
        print(json.dumps(child_make(arg) if kind == "make" else child_dataset(arg)))
        return
    from biovln_ms.measured import docs_data_dir, write_table

    rows, device, loads = [], None, []
    for mode in args.modes:
        with tempfile.TemporaryDirectory(prefix="biovln-first-use-") as tmp:
            cold = run_child("make", mode, Path(tmp))
            warm = run_child("make", mode, Path(tmp))
        loads.append(os.getloadavg()[0])
        device = cold["device"]
        row = [
            f"`{mode}`",
            cell([a + b for a, b in zip(cold["imports"], cold["first"])]),
            cell([a + b for a, b in zip(warm["imports"], warm["first"])]),
            cell(warm["imports"]),
            cell(warm["second"]),
        ]
        print(" | ".join(row), flush=True)
        rows.append(row)
    for robot in args.robots:
        with tempfile.TemporaryDirectory(prefix="biovln-first-use-") as tmp:
            cold = run_child("dataset", robot, Path(tmp))
            warm = run_child("dataset", robot, Path(tmp))
        loads.append(os.getloadavg()[0])
        row = [f"{robot}'s default dataset", cell(cold["dataset"]), cell(warm["dataset"]), "", ""]
        print(" | ".join(row), flush=True)
        rows.append(row)
    write_table(
        args.data_out or docs_data_dir() / "benchmarks" / "first_use.json",
        "First use: one-time costs",
        ["what", "cold: first time on a machine", "warm: a new process", "of which imports", "the next make"],
        rows,
        notes=[
            "An obs mode's row: `gym.make(\"BioVLN-OpFace-v0\", obs_mode=...)` in a new process, imports "
            "included (the first make imports ManiSkill, SAPIEN and torch; its first reset compiles the "
            "camera's shaders and renders), cold with every cache empty, warm with the caches the cold run "
            "filled; *the next make* is a second env in the same process. A dataset's row: the first "
            "`gym.make(..., split=...)` for that robot builds it, later ones check it.",
            "Wall clock, with the process's CPU time in brackets; the machine was shared (load average "
            f"{min(loads):.0f} to {max(loads):.0f} on its cores), which lengthens the wall times, not "
            "the CPU times.",
        ],
        render_device=device,
    )


if __name__ == "__main__":
    main()
