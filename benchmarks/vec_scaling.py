"""Env steps per second with 1 and 2 worker processes on the CPU, the ManiSkill way (one env per process),
and Stable-Baselines3 PPO end to end.

    python benchmarks/vec_scaling.py [--steps 3000] [--ppo-steps 20480]

Rows: one env in this process (the reference); ``gym.make_vec(..., vectorization_mode="async")`` and SB3's
``SubprocVecEnv`` with 1 and 2 workers (random actions, state observations of ``BioVLN-OpFace-RL-v0``);
``biovln-ms train ppo``'s SB3 PPO at its defaults with 1 and 2 envs (rollouts and updates: ``learn``'s
time, after the worker processes have started). Scaling is the 2-worker rate over the 1-worker rate. Writes
``docs/data/benchmarks/vec_scaling.json``.
"""

from __future__ import annotations

import argparse
import time
from functools import partial
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch

import biovln_ms  # noqa: F401
from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.variants import RL_ENV
from biovln_ms.wrappers import make_gym_env

ENV = dict(split="train", obs_mode="state")


def _rate(vec, steps: int, n: int) -> float:
    """Env steps per second (all workers together) over ``steps`` vector steps of random actions."""
    vec.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(20):  # warm-up
        vec.step(rng.integers(1, 4, n))
    t = time.perf_counter()
    for _ in range(steps):
        vec.step(rng.integers(1, 4, n))
    return steps * n / (time.perf_counter() - t)


def single(steps: int) -> float:
    env = make_gym_env(RL_ENV, **ENV)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    t = time.perf_counter()
    for a in rng.integers(1, 4, steps):
        _, _, term, trunc, _ = env.step(int(a))
        if term or trunc:
            env.reset()
    rate = steps / (time.perf_counter() - t)
    env.close()
    return rate


def make_vec(n: int, steps: int) -> float:
    vec = gym.make_vec(
        RL_ENV, num_envs=n, vectorization_mode="async", vector_kwargs={"context": "spawn"}, **ENV
    )
    try:
        return _rate(vec, steps // n, n)
    finally:
        vec.close()


def subproc(n: int, steps: int) -> float:
    from stable_baselines3.common.vec_env import SubprocVecEnv

    vec = SubprocVecEnv([partial(make_gym_env, RL_ENV, **ENV)] * n, start_method="spawn")
    try:
        vec.seed(0)
        vec.reset()
        rng = np.random.default_rng(0)
        for _ in range(20):
            vec.step(rng.integers(1, 4, n))
        t = time.perf_counter()
        for _ in range(steps // n):
            vec.step(rng.integers(1, 4, n))
        return (steps // n) * n / (time.perf_counter() - t)
    finally:
        vec.close()


def ppo(n: int, timesteps: int, out: Path) -> float:
    from biovln_ms.learning.rl import RLConfig, train_rl

    cfg = RLConfig(timesteps=timesteps, n_envs=n, seed=0, eval_split=None)
    return train_rl(cfg, out / f"ppo{n}", echo=lambda *_: None, progress=False).steps_per_second


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--ppo-steps", type=int, default=20480)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "vec_scaling.json")
    ap.add_argument("--work", type=Path, default=Path("outputs/vec_scaling"))
    args = ap.parse_args()
    torch.set_num_threads(1)
    one = single(args.steps)
    rows = [["one env in this process", "1", f"{one:.0f}", "1.00x"]]
    for label, fn in (("gym.make_vec, async", make_vec), ("SB3 SubprocVecEnv", subproc)):
        rates = [fn(n, args.steps) for n in (1, 2)]
        for n, r in zip((1, 2), rates):
            rows.append([label, str(n), f"{r:.0f}", f"{r / one:.2f}x"])
        print(f"{label}: {rates[0]:.0f} -> {rates[1]:.0f} env steps/s ({rates[1] / rates[0]:.2f}x with 2)")
    for n in (1, 2):
        r = ppo(n, args.ppo_steps, args.work)
        rows.append(["SB3 PPO, train ppo's defaults (learn)", str(n), f"{r:.0f}", f"{r / one:.2f}x"])
        print(f"PPO with {n} env(s): {r:.0f} env steps/s")
    write_table(
        args.data_out,
        "Parallel envs on the CPU and PPO end to end",
        ["how", "worker processes", "env steps/s", "over one env in-process"],
        rows,
        [
            f"{args.steps} random steps per row (state observations, {RL_ENV}); "
            f"PPO {args.ppo_steps} timesteps."
        ],
    )


if __name__ == "__main__":
    main()
