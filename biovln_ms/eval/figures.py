"""The report's figures, drawn with matplotlib: SR by method and split, the protocol stages, safety, the
runs' trajectories on the top-down map and the hard-episode figures (the frontier agent re-run). Kept out
of the tables' module so that rendering tables never imports matplotlib."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from biovln_ms.baselines.frontier import FREE, OCCUPIED, FrontierPolicy
from biovln_ms.eval import paper
from biovln_ms.eval.aggregate import aggregate, record_error
from biovln_ms.eval.methods import report_methods
from biovln_ms.eval.paper_tables import (
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
from biovln_ms.variants import BENCHMARK_ENV


def plot_sr(summ: dict, out: Path) -> Path:
    """SR by method and split from ``summarize``'s data: bars with their Wilson 95 % intervals, the paper's
    values as black ticks, a partial run's bar hatched."""
    methods = [m for m in report_methods() if any(_ran(summ, m, s) for s in SPLITS)]
    splits = [s for s in SPLITS if any(_ran(summ, m, s) for m in methods)]
    fig, ax = plt.subplots(figsize=(9, 4))
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
    ax.legend(fontsize=8, ncol=3)
    fig.tight_layout()
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
    fig, axes = plt.subplots(1, len(splits), figsize=(6.5 * len(splits), 4), squeeze=False)
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
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def plot_safety(runs, out: Path) -> Path:
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for (m, s), recs in sorted(runs.items()):
        a = aggregate(recs)
        if not (math.isfinite(a["mcr"]) and math.isfinite(a["vrt"])):  # every episode errored
            continue
        ax.scatter(a["mcr"], a["vrt"], s=40)
        ax.annotate(f"{m} {s}", (a["mcr"], a["vrt"]), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.axvline(0.5, color="#d62728", ls="--", lw=1)
    ax.set_xlabel("MCR (m, mean over episodes)")
    ax.set_ylabel("VRT (% of poses within 0.5 m)")
    ax.set_title("Safety: minimum clearance vs violation rate")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def plot_trajectories(recs: list[dict], specs, out: Path, title: str, limit: int = 6) -> Path:
    from biovln_ms.scene.topdown import draw_map

    by_scene: dict = {}
    for r in recs:
        if record_error(r) is None:  # an errored episode has no trajectory
            by_scene.setdefault(r["scene_id"], []).append(r)
    scenes = list(by_scene)[:2]
    fig, axes = plt.subplots(1, len(scenes), figsize=(7 * len(scenes), 5.5), squeeze=False)
    for ax, scene in zip(axes[0], scenes):
        draw_map(specs(scene), ax, show_free=False, title=f"{title}: {scene}")
        for r in by_scene[scene][:limit]:
            p = np.asarray(r["positions"])
            ax.plot(
                p[:, 0],
                p[:, 1],
                "-",
                color="#2ca02c" if r["success"] else "#d62728",
                lw=1.6,
                alpha=0.85,
                zorder=9,
            )
            ax.plot(*p[0], "o", color="#1f77b4", ms=5, zorder=10)
    fig.tight_layout()
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
    """Start, goal, geodesic path and the frontier agent's occupancy grid at the end (re-run), titled by
    ``hard_figure_title``."""
    import gymnasium as gym

    from biovln_ms.scene.topdown import draw_map

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
        traj = []
        for st in rollout(env, pol, rec["index"]):
            traj.append(st.info["agent_pose"][0, :2].cpu().numpy())
            info = st.info
        spec = env.unwrapped.scene_spec
        nav = scene_navigation(spec)
        fig, ax = plt.subplots(figsize=(9, 7))
        draw_map(spec, ax, show_free=False)
        lo, hi = pol.map.lo, pol.map.hi
        g = pol.map.grid[lo[0] : hi[0], lo[1] : hi[1]]
        img = np.zeros((*g.shape, 4))
        img[g == FREE] = (0.2, 0.6, 1.0, 0.25)
        img[g == OCCUPIED] = (0.1, 0.1, 0.1, 0.8)
        x0, y0 = pol.map.origin + lo[::-1] * pol.map.res
        x1, y1 = pol.map.origin + hi[::-1] * pol.map.res
        ax.imshow(img, origin="lower", extent=(x0, x1, y0, y1), zorder=8, interpolation="nearest")
        path = nav.shortest_path(rec["start"], rec["goal"])
        ax.plot(path[:, 0], path[:, 1], "--", color="#ff7f0e", lw=2, zorder=9, label="geodesic shortest path")
        t = np.asarray(traj)
        ax.plot(
            t[:, 0],
            t[:, 1],
            "-",
            color="#2ca02c" if bool(info["success"]) else "#d62728",
            lw=2,
            zorder=10,
            label="frontier",
        )
        ax.plot(*rec["start"], "o", color="#1f77b4", ms=9, zorder=11)
        ax.plot(*rec["goal"], "X", color="#d62728", ms=11, zorder=11)
        ax.set_title(hard_figure_title(rec, bool(info["success"])), fontsize=9)
        ax.legend(loc="upper left", fontsize=8)
        fig.tight_layout()
        fig.savefig(out, dpi=110)
        plt.close(fig)
    finally:
        env.close()
    return out
