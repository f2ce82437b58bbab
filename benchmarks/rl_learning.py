"""Does PPO learn on BioVLN-OpFace-RL-v0 within a CPU budget? Trains Stable-Baselines3 PPO on the
``train`` split, then evaluates it and the random policy on MS VAL through the harness (the same
variant, 10-degree turns), and prints the table with the training throughput against the env's own
state-only step rate measured in the same run.

    python benchmarks/rl_learning.py --timesteps 300000 --n-envs 2 --out runs/ppo_bench

The table goes to ``docs/data/benchmarks/rl_learning.json`` (``--data-out``), which the docs' benchmarks
page renders.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from biovln_ms.eval.harness import EvalConfig, evaluate
from biovln_ms.eval.learned import train_and_evaluate
from biovln_ms.io_utils import atomic_write_text
from biovln_ms.variants import RL_ENV
from biovln_ms.learning.rl import RLConfig
from biovln_ms.measured import docs_data_dir, write_table


def raw_state_rate(steps: int = 2000) -> float:
    """Steps/s of the RL env alone (one process, random actions)."""
    from biovln_ms.wrappers import make_gym_env

    env = make_gym_env(RL_ENV, split="train")
    env.reset(seed=0)
    t = time.perf_counter()
    for _ in range(steps):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            env.reset()
    rate = steps / (time.perf_counter() - t)
    env.close()
    return rate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--timesteps", type=int, default=300_000)
    ap.add_argument("--n-envs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("runs/ppo_bench"))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "rl_learning.json")
    args = ap.parse_args()
    raw = raw_state_rate()
    r = train_and_evaluate(
        RLConfig(algo="ppo", timesteps=args.timesteps, n_envs=args.n_envs, seed=args.seed), args.out / "ppo"
    )
    rnd = evaluate(
        EvalConfig("random", "ms_val", str(args.out / "ppo" / "eval"), env_id=RL_ENV, workers=args.n_envs)
    )
    ppo = r.eval_summary["overall"]
    rows = [("PPO", ppo), ("Random", rnd["overall"])]
    lines = [
        f"PPO on {RL_ENV}: {r.timesteps} timesteps in {r.minutes:.1f} min on this machine "
        f"({r.steps_per_second:.0f} steps/s with {args.n_envs} envs; "
        f"the env alone: {raw:.0f} steps/s in one process, "
        f"ratio {r.steps_per_second / raw:.2f})",
        "",
        "| MS VAL (RL variant) | episodes | SR % | SPL | MCR m | VRT % |",
        "|---|---|---|---|---|---|",
    ]
    lines += [
        f"| {n} | {o['episodes']} | {o['sr']:.1f} | {o['spl']:.3f} | {o['mcr']:.3f} | {o['vrt']:.1f} |"
        for n, o in rows
    ]
    text = "\n".join(lines)
    print(text)
    atomic_write_text(
        args.out / "summary.md", text + f"\n\nLearning curve: {args.out / 'ppo' / 'learning_curve.png'}\n"
    )
    atomic_write_text(
        args.out / "summary.json",
        json.dumps(
            {
                "ppo": ppo,
                "random": rnd["overall"],
                "timesteps": r.timesteps,
                "minutes": r.minutes,
                "steps_per_second": r.steps_per_second,
                "env_state_steps_per_second": raw,
            },
            indent=1,
        ),
    )
    write_table(
        args.data_out,
        f"PPO on {RL_ENV}, evaluated on MS VAL (the RL variant)",
        ["method", "episodes", "SR %", "SPL", "MCR m", "VRT %"],
        [
            [n, o["episodes"], f"{o['sr']:.1f}", f"{o['spl']:.3f}", f"{o['mcr']:.2f}", f"{o['vrt']:.1f}"]
            for n, o in rows
        ],
        notes=[
            f"{r.timesteps:,} timesteps in {r.minutes:.1f} min with {args.n_envs} envs: "
            f"{r.steps_per_second:.0f} steps/s, {r.steps_per_second / raw:.2f}× one env process alone "
            f"({raw:.0f} steps/s). Training success over the last 100 episodes: "
            f"{100 * r.final_success_rate:.0f} %."
        ],
    )


if __name__ == "__main__":
    main()
