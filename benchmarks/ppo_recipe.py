"""The learning guide's PPO recipe: train with the ManiSkill-style loop (``loop``; ``evaluate`` re-runs its
evaluation), and turn run folders of either loop into the guide's measured table, curves and figure
(``report``).

    biovln-ms train ppo --timesteps 100000 --stop-penalty 10 --stop-penalty-steps 50000 --out runs/sb3
    python benchmarks/ppo_recipe.py loop --steps 100000 --stop-mask-steps 10 --out runs/loop
    python benchmarks/ppo_recipe.py report runs/sb3 runs/loop

A run folder is ``biovln-ms train ppo``'s (``train.json``, ``episodes.csv``, ``eval/`` from its evaluation
or ``biovln-ms eval``) or this script's ``loop`` (``train.json`` with every episode, ``agent.pt``,
``eval.json``). A run's training success is that of the episodes that ended in each window of ``--window``
env steps; its evaluation is the greedy policy on MS VAL in the env as registered (no STOP settings).
``report`` writes ``docs/data/learning/ppo_recipe.json`` (the table), ``docs/data/learning/ppo_curves.json``
(the curves) and ``docs/images/ppo_recipe.png``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from biovln_ms.io_utils import atomic_write_text, save_figure
from biovln_ms.learning.rl import CURVE_WINDOW as WINDOW, read_episode_log, success_curve
from biovln_ms.measured import docs_data_dir, write_runs, write_table
from biovln_ms.variants import RL_ENV

IMAGE = docs_data_dir().parent / "images" / "ppo_recipe.png"


def train_loop(a: argparse.Namespace) -> None:
    from biovln_ms.learning.ppo_loop import LoopConfig, train

    cfg = LoopConfig(
        steps=a.steps,
        num_envs=a.num_envs,
        sim_backend=a.sim_backend,
        seed=a.seed,
        stop_mask_steps=a.stop_mask_steps,
        stop_penalty=a.stop_penalty,
        stop_shaping_steps=a.stop_shaping_steps,
        dataset=a.dataset,
    )
    agent, _ = train(cfg, a.out)
    if a.eval_split:
        write_eval(agent, cfg, a)


def evaluate_run(a: argparse.Namespace) -> None:
    """A loop run folder's ``agent.pt``, evaluated again (e.g. on another split)."""
    import torch

    from biovln_ms.learning.ppo_loop import Agent, LoopConfig

    cfg = LoopConfig(**json.loads((a.out / "train.json").read_text())["config"])
    state = torch.load(a.out / "agent.pt", weights_only=True)
    agent = Agent(state["actor.0.weight"].shape[1], state["actor.4.weight"].shape[0])
    agent.load_state_dict(state)
    write_eval(agent, cfg, a)


def write_eval(agent, cfg, a: argparse.Namespace) -> None:
    from biovln_ms.learning.ppo_loop import evaluate

    result = evaluate(agent, cfg, a.eval_split, a.eval_episodes)
    atomic_write_text(a.out / "eval.json", json.dumps(result, indent=1))
    print(f"greedy on {a.eval_split}, env as registered: {result}")


def read_run(folder: Path) -> dict:
    """A run folder: loop, STOP setting, episodes [(step, success)], steps/s, MS VAL success or None."""
    train = json.loads((folder / "train.json").read_text())
    cfg = train["config"]
    if "episodes" in train and isinstance(train["episodes"], list):  # the ManiSkill-style loop
        episodes = [(e[0], e[1]) for e in train["episodes"]]
        loop = f"ManiSkill-style ({cfg['num_envs']} env)"
        ev = json.loads((folder / "eval.json").read_text()) if (folder / "eval.json").is_file() else None
        evaluation = (ev["success_rate"], ev["timeouts"]) if ev else None
    else:  # biovln-ms train ppo
        episodes = [(r["timesteps"], r["success"]) for r in read_episode_log(folder / "episodes.csv")]
        loop = f"SB3 ({cfg['n_envs']} env{'s' if cfg['n_envs'] > 1 else ''})"
        runs = sorted((folder / "eval").glob("*/*/episodes.jsonl"))  # biovln-ms eval's records
        rows = [json.loads(line) for line in runs[0].read_text().splitlines()] if runs else []
        evaluation = (
            (np.mean([r["success"] for r in rows]), sum(r["truncated"] for r in rows)) if rows else None
        )
    parts = [f"STOP masked {cfg['stop_mask_steps']} steps"] if cfg.get("stop_mask_steps") else []
    parts += [f"failed STOP -{cfg['stop_penalty']:g}"] if cfg.get("stop_penalty") else []
    early = cfg.get("stop_penalty_steps") or cfg.get("stop_shaping_steps")
    if parts and early:
        parts[-1] += f" in the first {early / 1000:g}k steps"
    return {
        "run": folder.name,
        "loop": loop,
        "setting": ", ".join(parts) or "none (env as registered)",
        "episodes": episodes,
        "steps_per_second": train["steps_per_second"],
        "seed": cfg["seed"],
        "eval": None
        if evaluation is None
        else {"success_rate": float(evaluation[0]), "timeouts": int(evaluation[1])},
    }


def report(a: argparse.Namespace) -> None:
    runs = [read_run(Path(f)) for f in a.runs]
    for r in runs:
        r["curve"] = success_curve(r.pop("episodes"), a.steps, a.window)
    data = a.data_out
    write_runs(data / "ppo_curves.json", runs, window_steps=a.window)

    def at(r: dict, mark: int) -> str:
        point = next((p for p in r["curve"] if p[0] == mark), None)
        return "–" if point is None or point[1] is None else f"{100 * point[1]:.0f} ({point[2]})"

    # the first window, then the windows that end at a quarter, half, three quarters and all of the steps
    marks = sorted({a.window, *(a.steps * q // 4 // a.window * a.window for q in (1, 2, 3, 4))} - {0})
    heads = [f"{(m - a.window) / 1000:g}–{m / 1000:g}k" for m in marks]
    write_table(
        data / "ppo_recipe.json",
        f"PPO on {RL_ENV} (train split): training success % (episodes) per {a.window:,}-step window",
        ["loop", "STOP setting (training only)", *heads, "steps/s", "MS VAL SR %", "MS VAL timeouts"],
        [
            [
                r["loop"],
                r["setting"],
                *(at(r, m) for m in marks),
                f"{r['steps_per_second']:.0f}",
                *(
                    ("–", "–")
                    if r["eval"] is None
                    else (f"{100 * r['eval']['success_rate']:.0f}", r["eval"]["timeouts"])
                ),
            ]
            for r in runs
        ],
        notes=[
            f"Seed {', '.join(sorted({str(r['seed']) for r in runs}))}, one run per row. MS VAL: the greedy "
            "policy on its 50 episodes in the env as registered (no mask, no penalty); timeouts: episodes "
            "that reached the 500-step limit without a STOP.",
            "steps/s: each run's own on this machine at the time, which other jobs shared: it does not "
            "compare the loops.",
            "Runs of one seed whose settings differ only in when they end are the same run until then.",
        ],
    )
    plot(runs, a.image, a.window)
    print(f"wrote {a.image}")


def plot(runs: list[dict], path: Path, window: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    loops = list(dict.fromkeys(r["loop"] for r in runs))
    colour = {k: f"C{i}" for i, k in enumerate(dict.fromkeys(r["setting"] for r in runs))}  # one per setting
    rows = max(sum(r["loop"] == loop for r in runs) for loop in loops)  # legend lines under a panel
    size = (5.2 * len(loops), 3.4 + 0.2 * rows)
    fig, axes = plt.subplots(1, len(loops), figsize=size, squeeze=False, sharey=True)
    for ax, loop in zip(axes[0], loops):
        for r in (r for r in runs if r["loop"] == loop):
            pts = [(p[0], p[1]) for p in r["curve"] if p[1] is not None]
            x, y = [p[0] / 1000 for p in pts], [100 * p[1] for p in pts]
            ax.plot(x, y, marker=".", color=colour[r["setting"]], label=r["setting"])
        ax.set(title=loop, xlabel="env steps (thousands)", ylim=(-2, 102))
        ax.grid(alpha=0.3)
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), fontsize=8, frameon=False)
    axes[0][0].set_ylabel(f"training success % (per {window:,} steps)")
    fig.suptitle(f"PPO on {RL_ENV}: the STOP settings")
    fig.tight_layout()
    save_figure(fig, path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    lp = sub.add_parser("loop", help="train with the ManiSkill-style loop, then evaluate greedily")
    lp.add_argument("--steps", type=int, default=100_000)
    lp.add_argument("--num-envs", type=int, default=1)
    lp.add_argument("--sim-backend", default="physx_cpu")
    lp.add_argument("--seed", type=int, default=0)
    lp.add_argument("--stop-mask-steps", type=int, default=0)
    lp.add_argument("--stop-penalty", type=float, default=0.0)
    lp.add_argument("--stop-shaping-steps", type=int, default=None, help="the settings apply this long only")
    lp.add_argument("--dataset", default=None)
    lp.add_argument("--out", type=Path, default=Path("runs/ppo_loop"))
    ep = sub.add_parser("evaluate", help="evaluate a loop run folder's agent.pt again, greedily")
    ep.add_argument("out", type=Path)
    for p in (lp, ep):
        p.add_argument("--eval-split", default="ms_val", help="'' skips the evaluation")
        p.add_argument("--eval-episodes", type=int, default=50)
    rp = sub.add_parser("report", help="run folders -> the guide's table, curves and figure")
    rp.add_argument("runs", nargs="+", type=Path)
    rp.add_argument("--steps", type=int, default=100_000, help="the curves end here")
    rp.add_argument("--window", type=int, default=WINDOW, help="env steps per point of a curve")
    rp.add_argument("--data-out", type=Path, default=docs_data_dir() / "learning")
    rp.add_argument("--image", type=Path, default=IMAGE)
    a = ap.parse_args()
    {"loop": train_loop, "evaluate": evaluate_run, "report": report}[a.command](a)


if __name__ == "__main__":
    main()
