"""The report's figures, drawn with matplotlib: SR by method and split, the protocol stages, safety, the
runs' trajectories on the top-down map and the hard-episode figures (the frontier agent re-run). Kept out
of the tables' module so that rendering tables never imports matplotlib.

Each figure is laid out once, labelled where no label overlaps another, and fitted to its content
(:mod:`biovln_ms.scene.topdown`): legends sit outside the axes and nothing is cut off at an edge."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import FancyArrow

from biovln_ms.baselines.frontier import FREE, OCCUPIED, FrontierPolicy
from biovln_ms.eval import paper
from biovln_ms.eval.aggregate import aggregate, record_error
from biovln_ms.eval.methods import report_methods
from biovln_ms.eval.paper_tables import (
    BENCH_SPLITS,
    PROTOCOL_REPORT_SPLITS,
    SPLITS,
    _get,
    _label,
    _paper_row,
    _partial,
    _parts,
    _ran,
)
from biovln_ms.eval.rollout import rollout
from biovln_ms.scene.rules import scene_navigation
from biovln_ms.scene.topdown import draw_map, fit_figure, label_goals, legend_outside, place_labels
from biovln_ms.variants import BENCHMARK_ENV

SUCCESS_COLOR, FAILURE_COLOR, START_COLOR, GEODESIC_COLOR = "#2ca02c", "#d62728", "#1f77b4", "#ff7f0e"
END_POSE_GID, END_MARK_GID = "end_pose", "end_mark"  # gids of a trajectory's end arrow and its mark
END_ARROW = 0.45  # m: length of the arrow along a trajectory's final heading
MCR_LIMIT = 0.5  # m: the clearance VRT counts violations of


def plot_sr(summ: dict, out: Path) -> Path:
    """SR by method and split from ``summarize``'s data: bars with their Wilson 95 % intervals, the paper's
    values as black ticks, a partial run's bar hatched."""
    methods = [m for m in report_methods() if any(_ran(summ, m, s) for s in SPLITS)]
    splits = [s for s in SPLITS if any(_ran(summ, m, s) for m in methods)]
    fig, ax = plt.subplots(figsize=(9, 4), layout="constrained")
    w = 0.8 / max(len(methods), 1)
    for i, m in enumerate(methods):
        x = np.arange(len(splits)) + i * w
        aggs = [_get(summ, m, s) for s in splits]
        ys = np.array([np.nan if a.get("sr") is None else a["sr"] for a in aggs])
        ci = np.array([a.get("sr_ci95") or [None, None] for a in aggs], dtype=float)
        err = np.nan_to_num(np.abs(ci.T - ys), nan=0.0)
        bars = ax.bar(x, ys, w, yerr=err, capsize=2, label=_label(m), error_kw={"lw": 0.8})
        for bar, s in zip(bars, splits):
            if _partial(summ, m, s):
                bar.set_hatch("//")
        ps = [_paper_row(paper.TABLE5, m).get(s, {}).get("sr", np.nan) for s in splits]
        ax.scatter(x, ps, marker="_", s=200, color="black", zorder=5)
    ax.set_xticks(np.arange(len(splits)) + 0.4 - w / 2, [paper.SPLIT_LABELS[s] for s in splits])
    ax.set_ylabel("success rate (%)")
    ax.set_ylim(0, 105)
    ax.set_title("SR by method and split (bars: ours with 95 % CI, hatched: partial run; ticks: paper)")
    legend_outside(ax)
    fit_figure(fig)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def plot_protocol_stages(summ: dict, out: Path) -> Path | None:
    """Lab protocols: per split, each protocol run's SR and stage 1-5 success with their Wilson 95 %
    intervals (a partial run's bars hatched, its n in the legend); None when no protocol run is there."""
    order = report_methods()
    splits = [
        s for s in PROTOCOL_REPORT_SPLITS if any(p.get(s, {}).get("protocol") for p in summ["runs"].values())
    ]
    if not splits:
        return None
    fig, axes = plt.subplots(
        1, len(splits), figsize=(6.5 * len(splits), 4), squeeze=False, layout="constrained"
    )
    labels = ["SR", *(f"stage {i}" for i in range(1, 6))]
    for ax, s in zip(axes[0], splits):
        ran = [r for r, p in summ["runs"].items() if p.get(s, {}).get("protocol")]
        ran.sort(key=lambda r: (order.index(_parts(r)[0]) if _parts(r)[0] in order else len(order), r))
        w = 0.8 / len(ran)
        for i, run in enumerate(ran):
            agg = _get(summ, run, s)
            ys = np.array([agg["sr"], *agg["stage_sr"]], dtype=float)
            ci = np.array([agg["sr_ci95"], *agg["stage_sr_ci95"]], dtype=float)
            err = np.nan_to_num(np.abs(ci.T - ys), nan=0.0)
            name = f"{_label(run)} (n={agg['episodes']}{', partial' if _partial(summ, run, s) else ''})"
            bars = ax.bar(np.arange(6) + i * w, ys, w, yerr=err, capsize=2, label=name, error_kw={"lw": 0.8})
            if _partial(summ, run, s):
                for bar in bars:
                    bar.set_hatch("//")
        ax.set_xticks(np.arange(6) + 0.4 - w / 2, labels)
        ax.set_ylim(0, 105)
        ax.set_ylabel("success (%)")
        ax.set_title(f"{s}: SR and per-stage success, 95 % CI")
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2)
    fit_figure(fig)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def _split_order(splits) -> list[str]:
    """The benchmark's splits in their order, then the protocol splits, then any other by name."""
    known = [*BENCH_SPLITS, *PROTOCOL_REPORT_SPLITS]
    return [x for x in known if x in splits] + sorted(set(splits) - set(known))


def safety_figure(runs):
    """Safety: each run's MCR (mean minimum clearance) against its VRT, one panel per split on shared axes.
    A method keeps its colour in every panel, hollow under a noise preset; each point is labelled with its
    run, the labels placed where none overlaps another (:func:`~biovln_ms.scene.topdown.place_labels`)."""
    points: dict[str, list[tuple[str, float, float]]] = {}
    for (m, s), recs in sorted(runs.items()):
        a = aggregate(recs)
        if math.isfinite(a["mcr"]) and math.isfinite(a["vrt"]):  # else every episode errored
            points.setdefault(s, []).append((m, a["mcr"], a["vrt"]))
    splits = _split_order(points) or ["none"]
    cols = min(3, len(splits))
    rows = math.ceil(len(splits) / cols)
    fig, axes = plt.subplots(
        rows,
        cols,
        figsize=(4.6 * cols, 3.6 * rows),
        squeeze=False,
        sharex=True,
        sharey=True,
        layout="constrained",
    )
    bases = list(dict.fromkeys(_parts(m)[0] for pts in points.values() for m, _, _ in pts))
    palette = plt.get_cmap("tab10" if len(bases) <= 10 else "tab20")
    color = {b: palette(i % palette.N) for i, b in enumerate(bases)}
    for k, ax in enumerate(axes.flat):
        if k >= len(splits):
            ax.remove()
            continue
        for m, x, y in points.get(splits[k], []):
            c = color[_parts(m)[0]]
            ideal = _parts(m)[1] == "ideal"
            ax.scatter(x, y, s=36, facecolors=c if ideal else "white", edgecolors=c, linewidths=1.5, zorder=3)
        ax.axvline(MCR_LIMIT, color=FAILURE_COLOR, ls="--", lw=1)
        ax.set_title(
            paper.SPLIT_LABELS.get(splits[k], splits[k]) if points else "no run with a finite MCR/VRT"
        )
        if k % cols == 0:
            ax.set_ylabel(f"VRT (% of poses within {MCR_LIMIT} m)")
        if k + cols >= len(splits):
            ax.set_xlabel("MCR (m, mean over episodes)")
            ax.xaxis.set_tick_params(labelbottom=True)
    legend_outside(
        axes.flat[cols - 1],
        [
            Line2D([], [], marker="o", ls="", color="0.3", label="ideal sensing"),
            Line2D([], [], marker="o", ls="", color="0.3", markerfacecolor="white", label="noise preset"),
            Line2D([], [], color=FAILURE_COLOR, ls="--", lw=1, label=f"MCR = {MCR_LIMIT} m"),
        ],
        title="Safety: clearance vs violations",
        title_fontsize=8,
    )
    for ax, split in zip(axes.flat, splits):
        pts = points.get(split, [])
        place_labels(ax, [(x, y) for _, x, y in pts], [_label(m) for m, _, _ in pts], fontsize=7)
    fit_figure(fig)
    return fig


def plot_safety(runs, out: Path) -> Path:
    """Write :func:`safety_figure`."""
    fig = safety_figure(runs)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def _end_heading(rec: dict, p: np.ndarray) -> float | None:
    """The final heading of an episode: its last recorded one, else the direction of its last move; None
    for an episode that never moved and recorded none."""
    headings = rec.get("headings") or []
    if headings:
        return float(headings[-1])
    steps = np.diff(p, axis=0)
    moved = steps[np.linalg.norm(steps, axis=1) > 1e-6]
    return float(math.atan2(moved[-1][1], moved[-1][0])) if len(moved) else None


def draw_trajectory(ax, rec: dict) -> None:
    """One episode's path (green: success, red: failure), its start, and its end pose: an arrow along the
    final heading (gid ``END_POSE_GID``) and a success (circle) or failure (cross) mark (``END_MARK_GID``)."""
    p = np.asarray(rec["positions"], float).reshape(-1, 2)
    ok = bool(rec["success"])
    color = SUCCESS_COLOR if ok else FAILURE_COLOR
    ax.plot(p[:, 0], p[:, 1], "-", color=color, lw=1.6, alpha=0.85, zorder=9)
    ax.plot(*p[0], "o", color=START_COLOR, ms=5, zorder=10)
    yaw = _end_heading(rec, p)
    if yaw is not None:
        arrow = FancyArrow(
            *p[-1],
            END_ARROW * math.cos(yaw),
            END_ARROW * math.sin(yaw),
            width=0.04,
            head_width=0.16,
            head_length=0.13,
            length_includes_head=True,
            color=color,
            ec="black",
            lw=0.4,
            zorder=11,
        )
        arrow.set_gid(END_POSE_GID)
        ax.add_patch(arrow)
    (mark,) = ax.plot(
        *p[-1],
        "o" if ok else "X",
        ms=7 if ok else 8,
        color=color,
        markeredgecolor="black" if ok else "white",
        markeredgewidth=0.8,
        zorder=12,
    )
    mark.set_gid(END_MARK_GID)


def trajectory_handles() -> list:
    """Legend entries of :func:`draw_trajectory`."""
    return [
        Line2D([], [], color=SUCCESS_COLOR, lw=1.6, label="path, success"),
        Line2D([], [], color=FAILURE_COLOR, lw=1.6, label="path, failure"),
        Line2D([], [], marker="o", ls="", color=START_COLOR, ms=5, label="start"),
        Line2D(
            [],
            [],
            marker="o",
            ls="",
            color=SUCCESS_COLOR,
            markeredgecolor="black",
            ms=7,
            label="end: success",
        ),
        Line2D(
            [],
            [],
            marker="X",
            ls="",
            color=FAILURE_COLOR,
            markeredgecolor="white",
            ms=8,
            label="end: failure",
        ),
        Line2D([], [], marker=r"$\rightarrow$", ls="", color="black", ms=12, label="final heading"),
    ]


def trajectories_figure(recs: list[dict], specs, title: str, limit: int = 6):
    """Up to ``limit`` episodes of each of the first two scenes on their top-down maps
    (:func:`draw_trajectory`), the legend outside on the right."""
    by_scene: dict = {}
    for r in recs:
        if record_error(r) is None:  # an errored episode has no trajectory
            by_scene.setdefault(r["scene_id"], []).append(r)
    scenes = list(by_scene)[:2] or [None]
    fig, axes = plt.subplots(
        1, len(scenes), figsize=(7 * len(scenes), 5.5), squeeze=False, layout="constrained"
    )
    drawn = []
    for ax, scene in zip(axes[0], scenes):
        if scene is None:
            ax.set_title(f"{title}: no episode ran")
            continue
        spec = specs(scene)
        draw_map(spec, ax, show_free=False, title=f"{title}: {scene}", goal_labels=False)
        ends = []
        for r in by_scene[scene][:limit]:
            draw_trajectory(ax, r)
            ends += [r["positions"][0], r["positions"][-1]]
        drawn.append((ax, spec, ends))
    legend_outside(axes[0][-1], trajectory_handles())
    for ax, spec, ends in drawn:
        label_goals(ax, spec, avoid=ends)
    fit_figure(fig)
    return fig


def plot_trajectories(recs: list[dict], specs, out: Path, title: str, limit: int = 6) -> Path:
    """Write :func:`trajectories_figure`."""
    fig = trajectories_figure(recs, specs, title, limit)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def is_hard(rec: dict) -> bool:
    """A hard episode: the dataset's tier (geodesic start-goal distance > 6 m)."""
    return rec.get("difficulty") == "hard"


def hard_figure_title(rec: dict, success: bool) -> str:
    """The figure's title: "Hard episode ..." only for a hard one; any other episode is named as the
    longest of the runs, with its tier, and the title says there was no hard episode to show."""
    where = f"{rec['scene_id']}/{rec['episode_id']} (geodesic {rec['geodesic_distance']:.1f} m)"
    what = f"{'success' if success else 'failure'}; blue = free, black = occupied on the agent's map"
    if is_hard(rec):
        return f"Hard episode {where}: {what}"
    return (
        f"No hard episode (geodesic > 6 m) in these runs; the longest, {rec.get('difficulty', 'unknown')} "
        f"episode {where}:\n{what}"
    )


def hard_episodes(runs, limit: int) -> tuple[list[dict], bool]:
    """The frontier episodes that ran to draw, and whether they are hard: the longest hard ones, else
    (no hard episode in the runs) the longest ones."""
    ran = [
        r for (m, _), recs in sorted(runs.items()) if m == "frontier" for r in recs if record_error(r) is None
    ]
    hard = [r for r in ran if is_hard(r)]
    pick = hard or ran
    return sorted(pick, key=lambda r: -r["geodesic_distance"])[:limit], bool(hard)


def hard_episode_figure(rec: dict, dataset, out: Path) -> Path:
    """Start, goal, geodesic path, the frontier agent's path with its end pose and outcome
    (:func:`draw_trajectory`) and its occupancy grid at the end (re-run), titled by ``hard_figure_title``."""
    import gymnasium as gym

    pol = FrontierPolicy()
    env = gym.make(
        BENCHMARK_ENV,
        split=rec["split"],
        dataset=dataset,
        obs_mode=pol.obs_mode,
        sim_backend="physx_cpu",
        render_backend="cpu",
    )
    try:
        poses = []
        for st in rollout(env, pol, rec["index"]):
            poses.append(st.info["agent_pose"][0, :3].cpu().numpy())
            info = st.info
        spec = env.unwrapped.scene_spec
        nav = scene_navigation(spec)
        fig, ax = plt.subplots(figsize=(9, 7), layout="constrained")
        draw_map(spec, ax, show_free=False, goal_labels=False)
        lo, hi = pol.map.lo, pol.map.hi
        g = pol.map.grid[lo[0] : hi[0], lo[1] : hi[1]]
        img = np.zeros((*g.shape, 4))
        img[g == FREE] = (0.2, 0.6, 1.0, 0.25)
        img[g == OCCUPIED] = (0.1, 0.1, 0.1, 0.8)
        x0, y0 = pol.map.origin + lo[::-1] * pol.map.res
        x1, y1 = pol.map.origin + hi[::-1] * pol.map.res
        ax.imshow(img, origin="lower", extent=(x0, x1, y0, y1), zorder=8, interpolation="nearest")
        path = nav.shortest_path(rec["start"], rec["goal"])
        ax.plot(path[:, 0], path[:, 1], "--", color=GEODESIC_COLOR, lw=2, zorder=9)
        t = np.asarray(poses)
        success = bool(info["success"])
        draw_trajectory(
            ax, {"positions": t[:, :2].tolist(), "headings": t[:, 2].tolist(), "success": success}
        )
        ax.plot(*rec["goal"], "D", color=GEODESIC_COLOR, markeredgecolor="black", ms=9, zorder=11)
        ax.set_title(hard_figure_title(rec, success), fontsize=9)
        legend_outside(
            ax,
            [
                Line2D([], [], color=GEODESIC_COLOR, ls="--", lw=2, label="geodesic shortest path"),
                Line2D(
                    [], [], marker="D", ls="", color=GEODESIC_COLOR, markeredgecolor="black", label="goal"
                ),
                *trajectory_handles(),
            ],
        )
        label_goals(ax, spec, avoid=[rec["start"], rec["goal"], t[-1, :2]])
        fit_figure(fig)
        fig.savefig(out, dpi=110)
        plt.close(fig)
    finally:
        env.close()
    return out
