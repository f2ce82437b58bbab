"""Can Fetch's gripper reach each goal category's interaction point from where the benchmark says to stand?

Two measurements, both with the reach rule of ``biovln_ms.sim.reach`` (IK on Fetch's URDF, base fixed, 2 cm,
approach within 30 degrees of the face normal, no collision):

1. **Poses.** Each goal category alone at the origin (yaw 0): on the floor, or for a table-top one on a lab
   bench (0.76 m) whose edge stands ``SUPPORT_EDGE_MARGIN`` in front of its face, as the generator places
   them. Base poses on a ``--step`` grid in the face's frame, centred on the Eq. 1 goal g, within the success
   radius r of g, with Fetch's 0.29 m footprint clear of every body, each facing the face (heading -f). For
   each pose: is the interaction point reachable? Reported over the poses inside Zone 3 and over the whole r
   disc, with the reachable standoffs (distance from the face) on the face's centre line, and a proposal:
   delta* the middle of that band (when g itself is not reachable), r* the largest radius about the goal
   within which at least ``COVER`` of the poses are reachable.
2. **Episodes.** The oracle and the frontier method run with ``robot="fetch"`` (``biovln-ms eval --robot
   fetch``) on ``--splits`` (default MS VAL): the share of their radius successes from which the point is
   reachable (``info["reachable"]`` at STOP). The runs go to ``--results`` and resume there.

    python benchmarks/reachability.py [--step 0.05] [--splits ms_val] [--methods oracle,frontier]

The table goes to ``docs/data/benchmarks/reachability.json`` (``--data-out``), one top-down figure per
category to ``docs/images/reachability/`` (``--images``): the instrument (grey), its support (light grey),
Zone 2 (dashed), Zone 3 (green), the face (red), the r circle (blue) about g (star), the interaction point
(yellow ring), and every sampled pose as a dot, green where the point is reachable, red where it is not.
"""

from __future__ import annotations

import argparse
import math
from collections import defaultdict
from pathlib import Path

import numpy as np

from biovln_ms.catalog import AssetSpec, load_catalog
from biovln_ms.constants import SUPPORT_EDGE_MARGIN
from biovln_ms.geometry.zones import PlacedInstrument
from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.robot_specs import ROBOTS
from biovln_ms.sim.reach import Box, FetchArm

FOOTPRINT = ROBOTS["fetch"].footprint_radius
SUPPORT = ("lab_bench", 0.76, 1.55, 3.0)  # a table-top instrument's support: category, height, depth, width
COVER = 0.9  # r*: the share of poses within it that must be reachable
IMAGES = Path(__file__).resolve().parents[1] / "docs" / "images" / "reachability"


def setup(asset: AssetSpec) -> tuple[PlacedInstrument, list[Box], np.ndarray]:
    """The instrument at the origin, its boxes (its own, and its support's for a table-top one) and its
    interaction point in the world."""
    bottom = SUPPORT[1] if asset.placement == "table_top" else 0.0
    centre = (0.0, 0.0, bottom + asset.height / 2)
    inst = PlacedInstrument.from_asset(asset, centre, 0.0)
    boxes = [Box(asset.name, centre, 0.0, tuple(d / 2 for d in asset.dimensions))]
    if asset.placement == "table_top":
        f, (_, height, depth, width) = inst.face, SUPPORT
        edge = asset.d_half + SUPPORT_EDGE_MARGIN
        c = f * (edge - depth / 2)
        half = (depth / 2, width / 2) if abs(f[0]) > 0.5 else (width / 2, depth / 2)
        boxes.append(Box(SUPPORT[0], (c[0], c[1], height / 2), 0.0, (*half, height / 2)))
    point = np.array([*inst.center_xy, centre[2]]) + np.asarray(asset.interaction.point)
    return inst, boxes, point


def poses(asset: AssetSpec, inst: PlacedInstrument, boxes: list[Box], step: float) -> list[dict]:
    """The grid of base poses within r of g whose footprint is clear of every box, facing the face: each
    with its world (x, y, yaw), standoff from the face plane, offset along it and Zone-3 membership."""
    f = inst.face
    along = np.array([-f[1], f[0]])
    g, r = inst.goal(), asset.success_radius
    zone3 = inst.zone3()
    n = int(math.ceil(r / step))
    out = []
    for i in range(-n, n + 1):
        for j in range(-n, n + 1):
            du, dv = i * step, j * step
            if math.hypot(du, dv) > r + 1e-9:
                continue
            p = g + f * du + along * dv
            if any(b.distance(np.array([p[0], p[1], 0.0])) < FOOTPRINT for b in boxes):
                continue
            standoff = asset.approach_distance + du
            inside = zone3.buffer(1e-6).contains(_point(p))
            yaw = math.atan2(-f[1], -f[0])
            out.append(
                dict(
                    x=p[0],
                    y=p[1],
                    yaw=yaw,
                    du=du,
                    standoff=standoff,
                    offset=dv,
                    zone3=inside,
                    goal=i == j == 0,
                )
            )
    return out


def _point(p):
    from shapely.geometry import Point

    return Point(float(p[0]), float(p[1]))


def share(flags: list[bool]) -> str:
    return f"{100 * sum(flags) / len(flags):.0f} % ({sum(flags)}/{len(flags)})" if flags else "–"


def reach_all(
    arm: FetchArm, ps: list[dict], point: np.ndarray, inst: PlacedInstrument, boxes: list[Box]
) -> None:
    """Set each pose's ``reach``: whether the gripper reaches ``point`` from it."""
    for p in ps:
        p["reach"] = arm.reach((p["x"], p["y"], p["yaw"]), point, inst.face, boxes, inst.category).reachable


def band(ps: list[dict]) -> tuple[float, float] | None:
    """The smallest and largest standoff on the face's centre line from which the point is reachable."""
    ok = [p["standoff"] for p in ps if abs(p["offset"]) < 1e-9 and p["reach"]]
    return (min(ok), max(ok)) if ok else None


def cover_radius(ps: list[dict], r_max: float) -> float:
    """The largest radius (0.05 m steps, up to ``r_max``) about the grid's goal within which at least
    ``COVER`` of the poses are reachable (0 when none is)."""
    dist = np.array([math.hypot(p["du"], p["offset"]) for p in ps])
    ok = np.array([p["reach"] for p in ps])
    best = 0.0
    for r in np.arange(0.05, r_max + 1e-9, 0.05):
        inside = dist <= r + 1e-9
        if inside.any() and ok[inside].mean() >= COVER:
            best = float(r)
    return round(best, 2)


def figure(
    asset: AssetSpec,
    inst: PlacedInstrument,
    boxes: list[Box],
    point: np.ndarray,
    ps: list[dict],
    out: Path,
    note: str,
) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Polygon

    fig, ax = plt.subplots(figsize=(6.4, 6.4))
    for b in boxes[1:]:  # the support (yaw 0)
        xy = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * np.asarray(b.half[:2]) + np.asarray(
            b.center[:2]
        )
        ax.add_patch(
            Polygon(xy, closed=True, fc="#dddddd", ec="#999999", label=f"support ({b.name}, 0.76 m)")
        )
    ax.add_patch(
        Polygon(inst.zone2_corners(), closed=True, fill=False, ls="--", ec="#777777", label="Zone 2")
    )
    ax.add_patch(Polygon(inst.zone3_corners(), closed=True, fc="#b8e6b0", ec="none", label="Zone 3"))
    ax.add_patch(Polygon(inst.zone3_corners(), closed=True, fill=False, ec="#1f6f1f", lw=2, zorder=4))
    ax.add_patch(
        Polygon(inst.zone1_corners(), closed=True, fc="#888888", ec="#333333", label=f"{asset.name} (Zone 1)")
    )
    c, f = inst.center_xy, inst.face
    along = np.array([-f[1], f[0]]) * inst.face_width / 2
    face_mid = c + f * asset.d_half
    ax.plot(
        *np.array([face_mid - along, face_mid + along]).T, color="#d62020", lw=4, label="operational face"
    )
    g = inst.goal()
    ax.add_patch(
        Circle(
            g,
            asset.success_radius,
            fill=False,
            ec="#2050c0",
            ls="--",
            lw=1.5,
            label=f"r = {asset.success_radius} m",
        )
    )
    xs = np.array([[p["x"], p["y"]] for p in ps])
    ok = np.array([p["reach"] for p in ps])
    if len(xs):
        ax.scatter(*xs[ok].T, s=10, c="#1a9a1a", label="reachable")
        ax.scatter(*xs[~ok].T, s=10, c="#d03030", label="not reachable")
    ax.plot(*g, marker="*", ms=16, color="#102060", ls="", label="goal g (Eq. 1)")
    ax.plot(
        *point[:2],
        marker="o",
        ms=13,
        mfc="none",
        mec="#e0b000",
        mew=3,
        ls="",
        label=f"{asset.interaction.label} ({point[2]:.2f} m)",
    )
    ax.set_aspect("equal")
    lo = np.minimum(xs.min(0) if len(xs) else g, c - inst.half_xy.max()) - 0.3
    hi = np.maximum(xs.max(0) if len(xs) else g, c + inst.half_xy.max()) + 0.3
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(
        f"{asset.name}: delta {asset.approach_distance} m, r {asset.success_radius} m\n{note}", fontsize=10
    )
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return out


def episodes(methods: list[str], splits: list[str], results: Path, workers: int) -> dict:
    """Per method: per category (and "all"), the radius successes and how many are reachable."""
    from biovln_ms.eval.harness import EvalConfig, evaluate, load_records, unique_records
    from biovln_ms.eval.aggregate import record_error

    out: dict = {}
    for m in methods:
        counts: dict = defaultdict(lambda: [0, 0, 0])  # episodes, successes, reachable successes
        for s in splits:
            cfg = EvalConfig(m, s, str(results), robot="fetch", workers=workers)
            evaluate(cfg, progress=False)
            recs, _ = unique_records(load_records(cfg.run_dir / "episodes.jsonl"))
            for r in recs:
                ok = record_error(r) is None
                for key in (r["object_category"], "all"):
                    c = counts[key]
                    c[0] += 1
                    c[1] += ok and r["success"]
                    c[2] += ok and r["success"] and r["reachable"]
        out[m] = dict(counts)
    return out


def fraction(c) -> str:
    """Reachable successes of (episodes, successes, reachable successes): "–" without episodes."""
    if not c:
        return "–"
    return f"{100 * c[2] / c[1]:.0f} % ({c[2]}/{c[1]})" if c[1] else f"no success in {c[0]}"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--step", type=float, default=0.05, help="grid step of the sampled base poses (m)")
    ap.add_argument("--splits", default="ms_val", help="splits of the episode runs, comma-separated")
    ap.add_argument("--methods", default="oracle,frontier", help="methods of the episode runs ('' for none)")
    ap.add_argument("--results", type=Path, default=Path("outputs/reachability"), help="the runs' results")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--images", type=Path, default=IMAGES)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "reachability.json")
    args = ap.parse_args(argv)
    cat, arm = load_catalog(), FetchArm.load()
    methods = [m for m in args.methods.split(",") if m]
    splits = [s for s in args.splits.split(",") if s]
    runs = episodes(methods, splits, args.results, args.workers) if methods else {}
    rows, notes = [], []
    for name in cat.goal_categories():
        asset = cat.get(name)
        inst, boxes, point = setup(asset)
        ps = poses(asset, inst, boxes, args.step)
        reach_all(arm, ps, point, inst, boxes)
        z3 = [p["reach"] for p in ps if p["zone3"]]
        disc = [p["reach"] for p in ps]
        goal = next((p["reach"] for p in ps if p["goal"]), None)
        standoffs = band(ps)
        delta, grid = asset.approach_distance, ps
        if standoffs and not goal:  # propose a goal in the middle of the reachable band, and sample about it
            delta = round((standoffs[0] + standoffs[1]) / 2, 2)
            moved = asset.model_copy(update={"approach_distance": delta})
            grid = poses(moved, PlacedInstrument.from_asset(moved, inst.center, 0.0), boxes, args.step)
            reach_all(arm, grid, point, inst, boxes)
        r_star = cover_radius(grid, asset.success_radius)
        note = f"Zone 3 reachable {share(z3)}; r disc {share(disc)}"
        figure(asset, inst, boxes, point, ps, args.images / f"{name}.png", note)
        row = [
            name,
            asset.interaction.label,
            round(float(point[2]), 2),
            asset.approach_distance,
            asset.success_radius,
        ]
        row += [share(z3), share(disc), {True: "yes", False: "no", None: "blocked"}[goal]]
        row += ["none" if standoffs is None else f"{standoffs[0]:.2f}-{standoffs[1]:.2f}", delta, r_star]
        row += [fraction(runs[m].get(name)) for m in methods]
        rows.append(row)
        print(" | ".join(str(c) for c in row), flush=True)
    if methods:
        rows.append(
            ["all (episodes)", "", None, None, None, "", "", "", "", None, None]
            + [fraction(runs[m].get("all")) for m in methods]
        )
    columns = [
        "category",
        "interaction point",
        "height m",
        "delta m",
        "r m",
        "Zone-3 poses reachable",
        "r-disc poses reachable",
        "from g",
        "reachable standoffs m",
        "delta* m",
        "r* m",
    ]
    columns += [f"{m} successes reachable" for m in methods]
    notes = [
        f"Poses: a {args.step} m grid about the Eq. 1 goal g within r, Fetch's {FOOTPRINT} m footprint "
        "clear of every body, facing the face; the instrument alone, a table-top one on a 0.76 m lab "
        f"bench whose edge is {SUPPORT_EDGE_MARGIN} m in front of its face. Reachable: biovln_ms.sim.reach "
        "(IK on Fetch's URDF, base fixed, torso and arm free within limits; TCP within 2 cm, approach "
        "within 30 degrees of the face normal; no collision with any box, the floor or itself).",
        "From g: the goal pose itself. Reachable standoffs: the distances from the face, on its centre "
        "line, from which the point is reachable (poses nearer than the footprint allows are not sampled).",
        "delta*: the middle of that band where g is not reachable (else delta); r*: the largest radius "
        f"about the goal at delta* within which at least {COVER:.0%} of the poses are reachable "
        "(proposals; the benchmark's numbers are unchanged).",
    ]
    if methods:
        notes.append(
            f"Episodes: {', '.join(methods)} with robot_uids='fetch' on {', '.join(splits)} (biovln-ms "
            "eval --robot fetch): the share of their radius successes whose final pose reaches the "
            "interaction point (info['reachable'] at STOP, the heading as the robot stopped)."
        )
    write_table(args.data_out, "Reachability of the interaction points by Fetch", columns, rows, notes)


if __name__ == "__main__":
    main()
