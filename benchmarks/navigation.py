"""Navigation geometry: per-scene build time and geodesic query time, per template.

    python benchmarks/navigation.py [--scenes 10] [--queries 200]

Budgets: build <= 100 ms per scene, <= 1 ms per query. Reference in the same run: the shapely
free-space construction alone (part of the build) and one straight-line visibility test. A scene outside
the table is built and queried first, so loading the compiled visibility kernels is not counted.

The table goes to ``docs/data/benchmarks/navigation.json`` (``--data-out``), which the docs' benchmarks
page renders.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from biovln_ms.geometry.navigation import NavGeometry
from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.scene.generator import generate_scene
from biovln_ms.scene.rules import scene_free_space


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=10)
    ap.add_argument("--queries", type=int, default=200)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "navigation.json")
    args = ap.parse_args()
    rows = []
    print(
        f"{'template':<12} {'build ms':>9} {'x free-space':>12} "
        f"{'query ms':>9} {'x visibility':>12} {'reflex verts':>12}"
    )
    # a scene outside the table first: the compiled visibility kernels load before anything is timed
    warm = NavGeometry(scene_free_space(generate_scene("single_room", 10_000)), 0.2)
    warm.geodesic_distance(warm.vertices[0], warm.vertices[-1])
    for template in ("single_room", "two_room", "suite", "open_plan"):
        builds, frees, queries, vis, nverts = [], [], [], [], []
        for seed in range(args.scenes):
            spec = generate_scene(template, seed)
            t = time.perf_counter()
            free = scene_free_space(spec)
            frees.append(time.perf_counter() - t)
            t = time.perf_counter()
            nav = NavGeometry(free, spec.robot_radius)
            builds.append(time.perf_counter() - t + frees[-1])
            nverts.append(len(nav.vertices))
            rng = np.random.default_rng(seed)
            cells = np.argwhere(nav.grid.free)
            centres = nav.grid.cell_centres()
            pts = centres[tuple(cells[rng.integers(len(cells), size=args.queries)].T)]
            goals = [nav.snap(o.goal) for o in spec.goal_objects()]
            t = time.perf_counter()
            for k, p in enumerate(pts):
                nav.geodesic_distance(p, goals[k % len(goals)])
            queries.append((time.perf_counter() - t) / len(pts))
            t = time.perf_counter()
            for k, p in enumerate(pts):
                nav._visible(p[None], goals[k % len(goals)][None])
            vis.append((time.perf_counter() - t) / len(pts))
        b, f, q, v = (np.mean(x) * 1e3 for x in (builds, frees, queries, vis))
        print(f"{template:<12} {b:9.1f} {b / f:12.1f} {q:9.3f} {q / v:12.1f} {np.mean(nverts):12.0f}")
        rows.append(
            [template, f"{b:.1f}", f"{b / f:.1f}×", f"{q:.3f}", f"{q / v:.1f}×", f"{np.mean(nverts):.0f}"]
        )
    write_table(
        args.data_out,
        f"Navigation geometry, mean over {args.scenes} scenes and {args.queries} queries per scene",
        [
            "template",
            "build ms (budget 100)",
            "× free-space alone",
            "query ms (budget 1)",
            "× one visibility test",
            "reflex vertices",
        ],
        rows,
    )


if __name__ == "__main__":
    main()
