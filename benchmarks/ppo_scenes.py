"""Training data at scale: PPO trained for the same steps on the paper's 39 train scenes and on a generated
split of 10,000 scenes, evaluated on MS TEST and the Hard track under both noise presets.

    biovln-ms dataset build --template single_room --scenes 10000 --episodes-per-scene 20 -o data/gen10k
    biovln-ms train ppo --timesteps 100000 --n-envs 2 --stop-penalty 10 --stop-penalty-steps 50000 \\
        --scene-visit-episodes 2 --eval-split '' --seed S -o runs/scenes39_sS      # S = 0, 1, 2
    biovln-ms train ppo ... (the same) --dataset data/gen10k -o runs/scenes10k_sS
    biovln-ms eval -m ppo --checkpoint runs/scenes39_s0/model.zip -s ms_test --noise ideal \\
        -o runs/scenes39_s0/eval/ideal     # and hard_test; --noise realistic --max-episodes 40 into
                                           # .../realistic (the published table: seed 0 only)
    python benchmarks/ppo_scenes.py report runs/scenes39_s0 runs/scenes10k_s0 runs/scenes39_s1 \\
        runs/scenes39_s2 runs/scenes10k_s1 runs/scenes10k_s2

All runs use the learning guide's SB3 recipe (2 envs, STOP penalty in the first half) and take two
episodes of a scene in a row (``--scene-visit-episodes 2``), so the runs differ in the training split and
the seed. The splits differ in more than their size: the 39 train scenes are 32 ``single_room`` and 7
``two_room``, the generated ones all ``single_room``; neither holds the Hard track's ``suite`` or
``open_plan`` layouts. A run folder's ``eval/<preset>/`` holds ``biovln-ms eval`` results folders of any
splits. ``report`` gives a row per run, McNemar's test between the first two (so: the two seed-0 runs
first), and, for a training split run with several seeds, the mean (range) over them and Welch's t between
two such splits. It writes ``docs/data/learning/ppo_scenes.json`` (the table),
``docs/data/learning/ppo_scenes_curves.json`` and ``docs/images/ppo_scenes.png`` (training success per
window of steps, one line per training split).
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

import numpy as np

from biovln_ms.episodes.source import DatasetEpisodes, EpisodeCursor, seed_position
from biovln_ms.eval.harness import episode_key, load_records
from biovln_ms.eval.stats import mcnemar, wilson_interval
from biovln_ms.io_utils import save_figure
from biovln_ms.learning.rl import CURVE_WINDOW as WINDOW, read_episode_log, success_axes, success_curve
from biovln_ms.measured import docs_data_dir, write_runs, write_table
from biovln_ms.splits import default_dataset_dir
from biovln_ms.variants import RL_ENV

IMAGE = docs_data_dir().parent / "images" / "ppo_scenes.png"
SPLITS = {"ms_test": "MS TEST", "hard_test": "Hard TEST"}
PRESETS = ("ideal", "realistic")


def scenes_seen(cfg: dict, played: list[int], seed_rule: str | None = None) -> tuple[int, int, str]:
    """(scenes in the training split, distinct scenes the run played, its templates), ``played[i]`` the
    episodes env ``i`` finished: SB3 seeds env ``i`` with ``seed + i``, which starts it at that seed's
    position of the env's shuffled order (``seed_rule``, the run's ``train.json``: "golden" for
    :func:`~biovln_ms.episodes.source.seed_position`; None, a run made before it: ``seed + i``), and each
    later reset takes the next."""
    source = DatasetEpisodes(cfg["split"], cfg["dataset"] or default_dataset_dir())
    order = EpisodeCursor(source, shuffle=True, visit=cfg.get("scene_visit_episodes", 0)).order
    n = len(order)
    starts = [
        seed_position(cfg["seed"] + i, n) if seed_rule == "golden" else (cfg["seed"] + i) % n
        for i in range(len(played))
    ]
    scenes = {
        source.episodes[order[(a + k) % n]]["scene_id"] for a, m in zip(starts, played) for k in range(m)
    }
    ids = {e["scene_id"] for e in source.episodes}
    templates = Counter(source.dataset.manifest["scenes"][s]["template"] for s in ids)
    return len(ids), len(scenes), ", ".join(f"{n:,} {t}" for t, n in templates.most_common())


def evaluation(folder: Path) -> dict:
    """{preset: {split: {episode: (success, spl, truncated)}}} from the run's ``eval/<preset>/`` results
    (``biovln-ms eval``'s records)."""
    out: dict = {}
    for preset in PRESETS:
        for records in sorted((folder / "eval" / preset).glob("*/*/episodes.jsonl")):
            out.setdefault(preset, {})[records.parent.name] = {
                episode_key(r): (bool(r["success"]), float(r["spl"]), bool(r["truncated"]))
                for r in load_records(records)
            }
    return out


def summaries(runs: list[dict]) -> dict:
    """{preset: {split: {run index: summary}}} over the runs evaluated there: SR (Wilson 95 % interval),
    SPL and timeouts on the episodes all of them played, and in the first run's McNemar's p against the
    second (the same episodes: paired) when both were evaluated there."""
    out: dict = {}
    for preset in PRESETS:
        for split in SPLITS:
            played = {i: r["eval"].get(preset, {}).get(split) for i, r in enumerate(runs)}
            played = {i: p for i, p in played.items() if p}
            if not played:
                continue
            keys = sorted(set.intersection(*(set(p) for p in played.values())))
            if not keys:
                raise SystemExit(f"ppo_scenes: the runs evaluated on {split} ({preset}) share no episode")
            cells = {}
            for i, p in played.items():
                k = sum(p[e][0] for e in keys)
                cells[i] = {
                    "episodes": len(keys),
                    "sr": round(100 * k / len(keys), 1),
                    "sr_ci95": [round(100 * v, 1) for v in wilson_interval(k, len(keys))],
                    "spl": round(float(np.mean([p[e][1] for e in keys])), 3),
                    "timeouts": int(sum(p[e][2] for e in keys)),
                }
            if 0 in played and 1 in played:
                first, second = ([played[i][e][0] for e in keys] for i in (0, 1))
                cells[0]["mcnemar_p"] = float(f"{mcnemar(first, second).p_value:.2g}")
            out.setdefault(preset, {})[split] = cells
    return out


def seed_groups(runs: list[dict]) -> list[list[dict]]:
    """The runs grouped by training split, a split's runs together when their seeds differ (seeds of one
    recipe); where a split's runs repeat a seed, each run alone."""
    by_split: dict[str, list[dict]] = {}
    for r in runs:
        by_split.setdefault(r["split"], []).append(r)
    out = []
    for group in by_split.values():
        out += [group] if len({r["seed"] for r in group}) == len(group) else [[r] for r in group]
    return out


def read_run(folder: Path, end: int, window: int) -> dict:
    train = json.loads((folder / "train.json").read_text())
    cfg = train["config"]
    rows = read_episode_log(folder / "episodes.csv")
    episodes = [(r["timesteps"], r["success"]) for r in rows]
    played = [sum(r["env"] == i for r in rows) for i in range(cfg["n_envs"])]
    total, seen, templates = scenes_seen(cfg, played, train.get("seed_rule"))
    return {
        "run": folder.name,
        "split": f"{cfg['dataset'] and Path(cfg['dataset']).name or 'paper'}:{cfg['split']}",
        "scenes": total,
        "scenes_seen": seen,
        "templates": templates,
        "scene_visit_episodes": cfg.get("scene_visit_episodes", 0),
        "episodes": len(episodes),
        "steps": train["timesteps"],
        "steps_per_second": train["steps_per_second"],
        "seed": cfg["seed"],
        "curve": success_curve(episodes, end, window),
        "eval": evaluation(folder),
    }


def report(a: argparse.Namespace) -> None:
    runs = [read_run(Path(f), a.steps, a.window) for f in a.runs]
    summary = summaries(runs)
    for k, r in enumerate(runs):
        r["eval"] = {p: {s: cells[k] for s, cells in d.items() if k in cells} for p, d in summary.items()}
    write_runs(a.data_out / "ppo_scenes_curves.json", runs, window_steps=a.window)

    def cell(r: dict, preset: str, split: str) -> str:
        e = r["eval"].get(preset, {}).get(split)
        if e is None:
            return "–"
        low, high = e["sr_ci95"]
        return f"{e['sr']:.1f} [{low:.0f}, {high:.0f}] / {e['spl']:.2f} (n {e['episodes']})"

    def p_cell(preset: str, split: str) -> str:
        p = runs[0]["eval"].get(preset, {}).get(split, {}).get("mcnemar_p")
        if p is None:
            return "–"
        return "p < 0.0001" if p < 1e-4 else f"p = {p:.2g}"

    def late_rate(r: dict) -> float | None:  # training success over the last quarter of the steps
        pts = [p for p in r["curve"] if p[0] > 3 * a.steps // 4 and p[1] is not None]
        n = sum(p[2] for p in pts)
        return None if not n else 100 * sum(p[1] * p[2] for p in pts) / n

    def late(r: dict) -> str:
        v = late_rate(r)
        return "–" if v is None else f"{v:.0f}"

    def over_seeds(group: list[dict]) -> list[str]:
        """A training split's runs: the mean (lowest-highest) of each figure over its seeds."""

        def span(values: list[float], fmt: str) -> str:
            if len(values) < len(group):
                return "–"
            return f"{fmt.format(np.mean(values))} ({fmt.format(min(values))}-{fmt.format(max(values))})"

        def cells(preset: str, split: str) -> str:
            es = [r["eval"].get(preset, {}).get(split) for r in group]
            if not all(es):
                return "–"
            return f"{span([e['sr'] for e in es], '{:.1f}')} / {span([e['spl'] for e in es], '{:.2f}')}"

        first = group[0]
        return [
            f"{first['scenes']:,}: mean (range) over {len(group)} seeds",
            ", ".join(str(r["seed"]) for r in group),
            span([r["scenes_seen"] for r in group], "{:,.0f}"),
            span([r["episodes"] for r in group], "{:,.0f}"),
            span([v for r in group if (v := late_rate(r)) is not None], "{:.0f}"),
            "",
            *(cells(p, s) for p in PRESETS for s in SPLITS),
        ]

    def welch_row(a_runs: list[dict], b_runs: list[dict]) -> list[str]:
        """Welch's t-test of two training splits' SRs across their seeds (each seed one sample)."""
        from scipy.stats import ttest_ind

        def cell(preset: str, split: str) -> str:
            a_sr, b_sr = ([r["eval"].get(preset, {}).get(split) for r in g] for g in (a_runs, b_runs))
            if not (all(a_sr) and all(b_sr)):
                return "–"
            p = ttest_ind([e["sr"] for e in a_sr], [e["sr"] for e in b_sr], equal_var=False).pvalue
            return f"p = {p:.2g}"

        return [
            "Welch's t over seeds (SR)",
            "",
            "",
            "",
            "",
            "",
            *(cell(p, s) for p in PRESETS for s in SPLITS),
        ]

    seeded = [g for g in seed_groups(runs) if len(g) > 1]

    write_table(
        a.data_out / "ppo_scenes.json",
        f"PPO on {RL_ENV}: training scenes, the same steps",
        [
            "training scenes (templates)",
            "seed",
            "scenes met in training",
            "episodes",
            "training success % (last quarter)",
            "steps/s",
            *(f"{SPLITS[s]} {p}: SR % [95 % CI] / SPL" for p in PRESETS for s in SPLITS),
        ],
        [
            [
                f"{r['scenes']:,} ({r['templates']})",
                str(r["seed"]),
                f"{r['scenes_seen']:,}",
                f"{r['episodes']:,}",
                late(r),
                f"{r['steps_per_second']:.0f}",
                *(cell(r, p, s) for p in PRESETS for s in SPLITS),
            ]
            for r in runs
        ]
        + [
            [
                "McNemar, the first two rows (paired episodes)",
                "",
                "",
                "",
                "",
                "",
                *(p_cell(p, s) for p in PRESETS for s in SPLITS),
            ]
        ]
        + [over_seeds(g) for g in seeded]
        + ([welch_row(*seeded)] if len(seeded) == 2 else []),
        notes=[
            "One run per row (the seed in its column), "
            f"{runs[0]['steps']:,} steps each, the SB3 recipe of the learning guide, "
            f"{', '.join(sorted({str(r['scene_visit_episodes']) for r in runs}))} episodes of a scene per "
            "pass (scene_visit_episodes).",
            "The greedy policy in the env as registered through biovln-ms eval; realistic: the policy's own "
            "pose estimate instead of GPS+compass. n: the episodes every run played (the first of the split "
            "where an evaluation was cut short).",
            "McNemar: the first two runs' outcomes on the same episodes (biovln_ms.eval.stats.mcnemar).",
            "steps/s: each run's own on this machine at the time.",
            "Mean (range) over seeds: a training split's runs, the figures all its seeds have; a cell that "
            "not every seed has is left out (–).",
        ],
    )
    plot(runs, a.image, a.window)
    print(f"wrote {a.data_out / 'ppo_scenes.json'} and {a.image}")


def plot(runs: list[dict], path: Path, window: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for group in seed_groups(runs):  # a line each: the mean over its seeds, their range shaded
        steps = sorted({p[0] for r in group for p in r["curve"] if p[1] is not None})
        by_run = [{p[0]: 100 * p[1] for p in r["curve"] if p[1] is not None} for r in group]
        steps = [t for t in steps if all(t in c for c in by_run)]
        values = np.array([[c[t] for t in steps] for c in by_run])
        x = np.array(steps) / 1000
        seeds = f", mean of {len(group)} seeds" if len(group) > 1 else ""
        label = f"{group[0]['scenes']:,} training scenes{seeds}"
        (line,) = ax.plot(x, values.mean(0), marker=".", label=label)
        if len(group) > 1:
            ax.fill_between(x, values.min(0), values.max(0), color=line.get_color(), alpha=0.2, lw=0)
    success_axes(ax, window)
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title(f"PPO on {RL_ENV}: training scenes", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    rp = sub.add_parser("report", help="run folders -> the learning guide's table, curves and figure")
    rp.add_argument("runs", nargs="+", type=Path)
    rp.add_argument("--steps", type=int, default=100_000, help="the curves end here")
    rp.add_argument("--window", type=int, default=WINDOW, help="env steps per point of a curve")
    rp.add_argument("--data-out", type=Path, default=docs_data_dir() / "learning")
    rp.add_argument("--image", type=Path, default=IMAGE)
    a = ap.parse_args()
    report(a)


if __name__ == "__main__":
    main()
