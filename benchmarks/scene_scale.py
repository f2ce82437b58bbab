"""Step and reset time as the scene grows: the shipped templates, then a generated 30 x 20 m hall with 5 to
48 instruments (every slot it has; the same floor, so only the instrument count changes).

    python benchmarks/scene_scale.py [--steps 1500] [--seeds 3]

For each scene: its rooms, instruments and floor area; the time to build it (``gym.make`` and the first
reset: generation, episodes, meshes, SAPIEN actors); a reset within it; and the state-only step time, with
the measures' share of it (the per-step part that reads the scene's geometry). The hall's rows answer
whether a step costs more with more instruments faster than linearly: a line fitted to them, and each
interval's cost per added instrument. A first scene is built untimed (the process's first build pays for
imports and caches). Writes ``docs/data/benchmarks/scene_scale.json`` and ``docs/images/scene_scale.png``
(step and reset against the hall's instruments, and every scene's against its floor area).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import shapely
import torch

import biovln_ms  # noqa: F401
from biovln_ms.io_utils import save_figure
from biovln_ms.measured import docs_data_dir, timed, write_table
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.templates import register_template

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
#: the hall's instrument counts (48: every slot)
HALL_COUNTS = (5, 10, 20, 30, 40, 48)
WALL = ["refrigerator", "incubator", "cabinet", "biosafety_cabinet", "fume_hood", "ultra_low_freezer"]
TOP = ["centrifuge", "mini_centrifuge", "pipette", "thermal_cycler", "microscope", "shaker"]


def hall(active: int, width: float = 30.0, depth: float = 20.0) -> dict:
    """A ``width`` x ``depth`` m hall: wall slots every 3 m on all four walls, six bench islands with two
    table-top slots each, four floor slots; ``active`` of them hold an instrument."""
    slots = []
    for wall, length in (("N", width), ("S", width), ("W", depth), ("E", depth)):
        for i, a in enumerate(np.arange(0.0, length - 2.9, 3.0)):
            cats = WALL[i % len(WALL) :] + WALL[: i % len(WALL)]
            slots.append(
                dict(
                    id=f"{wall}{i}",
                    placement="wall",
                    room="hall",
                    wall=wall,
                    span=[float(a), float(a) + 3.0],
                    categories=cats[:3],
                )
            )
    furniture = []
    for k, (x, y) in enumerate([(x, y) for x in (8.0, 15.0, 22.0) for y in (7.0, 13.0)]):
        furniture.append(
            dict(
                id=f"island_{k}",
                category="lab_bench",
                room="hall",
                center=[x, y],
                face=[0.0, 1.0 if y < depth / 2 else -1.0],
                goal=True,
            )
        )
        for j, span in enumerate(([0.1, 0.45], [0.55, 0.9])):
            slots.append(
                dict(
                    id=f"island_{k}_top_{j}",
                    placement="table_top",
                    support=f"island_{k}",
                    span=span,
                    categories=TOP[(k + j) % 6 :][:3] or TOP[:3],
                )
            )
    for k, x in enumerate((4.0, 11.5, 18.5, 26.0)):
        slots.append(
            dict(
                id=f"floor_{k}",
                placement="floor",
                room="hall",
                region=[x - 0.5, 9.0, x + 0.5, 11.0],
                categories=["waste_bin"],
            )
        )
    active = min(active, len(slots))
    return dict(
        name=f"hall_{int(width)}x{int(depth)}_{active}",
        description="benchmark hall",
        wall_height=3.5,
        rooms=[dict(id="hall", kind="room", rect=[0.0, 0.0, width, depth])],
        furniture=furniture,
        slots=slots,
        active_slots=[active, active],
        yaw_jitter_deg=0.0,
        max_attempts=400,
    )


def area(spec) -> float:
    return shapely.union_all([shapely.Polygon(r.polygon) for r in spec.rooms]).area


def measure(template: str, seed: int, steps: int) -> dict:
    spec = generate_scene(template, seed)
    t = time.perf_counter()
    env = gym.make("BioVLN-OpFace-v0", template=template, scene_seed=seed, obs_mode="state", **CPU)
    env.reset(seed=0)
    build = time.perf_counter() - t
    u = env.unwrapped
    resets = []
    for i in range(5):
        t = time.perf_counter()
        env.reset(seed=i + 1)
        resets.append(time.perf_counter() - t)
    spent = {"measures": 0.0}
    u._measures.update = timed(u._measures.update, spent, "measures")
    rng = np.random.default_rng(seed)
    env.step(1)
    spent["measures"] = 0.0
    t = time.perf_counter()
    for a in rng.integers(1, 4, steps):
        _, _, term, trunc, _ = env.step(int(a))
        if bool(term) or bool(trunc):
            env.reset()
    step = (time.perf_counter() - t) / steps
    env.close()
    return dict(
        rooms=len(spec.rooms),
        instruments=len(spec.instruments),
        area=area(spec),
        build=build,
        reset=statistics.median(resets),
        step=step,
        measures=spent["measures"] / steps,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=1500)
    ap.add_argument("--seeds", type=int, default=3, help="scenes per row; the median is reported")
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "scene_scale.json")
    ap.add_argument("--plot", type=Path, default=docs_data_dir().parent / "images" / "scene_scale.png")
    args = ap.parse_args()
    torch.set_num_threads(1)
    names = ["single_room", "two_room", "suite", "open_plan"]
    for n in HALL_COUNTS:
        names.append(register_template(hall(n)).name)
    measure(names[0], args.seeds, 10)  # untimed, a seed no row uses: the first build pays for imports
    rows, hall_pts, all_pts = [], [], []
    for name in names:
        runs = [measure(name, seed, args.steps) for seed in range(args.seeds)]
        r = {k: statistics.median(x[k] for x in runs) for k in runs[0]}
        print(
            f"{name:<18} {r['instruments']:>4.0f} instr. {r['area']:>6.0f} m2  build {r['build']:.2f} s  "
            f"reset {1e3 * r['reset']:.1f} ms  step {1e3 * r['step']:.3f} ms  measures "
            f"{1e3 * r['measures']:.3f} ms"
        )
        rows.append(
            [
                name,
                int(r["rooms"]),
                int(r["instruments"]),
                f"{r['area']:.0f}",
                f"{r['build']:.2f} s",
                f"{1e3 * r['reset']:.1f} ms",
                f"{1e3 * r['step']:.3f} ms",
                f"{1e3 * r['measures']:.3f} ms",
            ]
        )
        all_pts.append((name, r["area"], 1e3 * r["step"], 1e3 * r["reset"]))
        if name.startswith("hall_"):
            hall_pts.append((r["instruments"], 1e3 * r["step"], 1e3 * r["measures"], 1e3 * r["reset"]))
    x, step, meas, reset = map(np.array, zip(*hall_pts))
    slope, icept = np.polyfit(x, step, 1)
    growth = (step[-1] / step[0]) / (x[-1] / x[0])
    per_added = np.diff(step) / np.diff(x) * 1e3  # us per added instrument, interval by interval
    notes = [
        f"30 x 20 m hall: step time {step[0]:.3f} ms at {x[0]:.0f} instruments, {step[-1]:.3f} ms at "
        f"{x[-1]:.0f} (a line fits {icept:.3f} + {slope * 1e3:.2f} us per instrument); the step grew "
        f"{step[-1] / step[0]:.2f}x for {x[-1] / x[0]:.0f}x the instruments ({growth:.2f} of linear).",
        "Per added instrument, interval by interval: "
        + ", ".join(f"{a:.0f}-{b:.0f}: {c:+.1f} us" for a, b, c in zip(x[:-1], x[1:], per_added))
        + " (the step's cost per instrument does not grow where these do not).",
        f"Median of {args.seeds} scenes per row; {args.steps} random state-only steps per scene.",
    ]
    print(*notes, sep="\n")
    write_table(
        args.data_out,
        "Step and reset time as the scene grows",
        [
            "scene",
            "rooms",
            "instruments",
            "floor m2",
            "build (make + first reset)",
            "reset in scene",
            "state-only step",
            "of which measures",
        ],
        rows,
        notes,
    )

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(13, 3.6))
    ax[0].plot(x, step, "o-", label="whole step")
    ax[0].plot(x, meas, "s-", label="measures")
    ax[0].plot(x, icept + slope * x, ":", color="grey", label="a line fitted to the step")
    ax[0].set(xlabel="instruments in the 30 x 20 m hall", ylabel="ms per state-only step", ylim=(0, None))
    ax[0].legend(fontsize=8)
    ax[1].plot(x, reset, "o-")
    ax[1].set(xlabel="instruments in the 30 x 20 m hall", ylabel="ms per reset in the scene", ylim=(0, None))
    for i, (name, a, st, rs) in enumerate(all_pts):  # a colour per template, the hall's rows as one
        hall_row = name.startswith("hall_")
        colour = "grey" if hall_row else f"C{i}"
        first_hall = hall_row and not any(n.startswith("hall_") for n, *_ in all_pts[:i])
        label = "30 x 20 m hall" if first_hall else (None if hall_row else name)
        ax[2].plot([a], [st], "o", color=colour, label=label)
        ax[2].plot([a], [rs], "s", color=colour)
    ax[2].set(xlabel="floor area (m2)", ylabel="ms: step (o), reset in the scene (s)", ylim=(0, None))
    ax[2].legend(fontsize=8, loc="center right")
    fig.tight_layout()
    save_figure(fig, args.plot)
    print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
