"""Env steps per second with 1 and 2 worker processes on the CPU, the ManiSkill way (one env per process)
and with several envs per process, and Stable-Baselines3 PPO end to end.

    python benchmarks/vec_scaling.py [--steps 3000] [--ppo-steps 20480]

Rows: one env in this process (the reference); ``gym.make_vec(..., vectorization_mode="async")`` and SB3's
``SubprocVecEnv`` with 1 and 2 workers, and 8 envs as ``SubprocVecEnv`` (8 processes) and as
``GroupedSubprocVecEnv`` (2 processes of 4), random actions, state observations of ``BioVLN-OpFace-RL-v0``;
``biovln-ms train ppo``'s SB3 PPO at its defaults with 1 and 2 envs, and with 8 envs (``n_steps`` 256,
so an update sees the same 2,048 steps as with 2) in 8 processes and in 2 (rollouts and updates:
``learn``'s time, after the worker processes have started; PPO with 1 env steps it in the trainer's
process, as ``train ppo`` does). The two 8-env PPO runs see the same transitions: the note says whether
their learning curves are identical. A note times the full ``gc.collect()`` ManiSkill runs at each scene
change in a fresh process of 4 envs, when they share the split's episodes (as ``gym.make`` gives them,
``DatasetEpisodes.shared``) and when each reads its own copy. Writes
``docs/data/benchmarks/vec_scaling.json``, the PPO runs' training success per 5,000 env steps in
``vec_scaling_curves.json`` beside it and their plot in ``docs/images/vec_scaling_ppo.png`` (the published
run: ``--ppo-steps 100352``, long enough to learn).
"""

from __future__ import annotations

import argparse
import time
from functools import partial
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from shared_episodes import collection

import biovln_ms  # noqa: F401
from biovln_ms.io_utils import save_figure
from biovln_ms.learning.rl import CURVE_WINDOW, success_axes, success_curve
from biovln_ms.measured import docs_data_dir, vec_step_rate, write_runs, write_table
from biovln_ms.variants import RL_ENV
from biovln_ms.wrappers import make_gym_env

ENV = dict(split="train", obs_mode="state")
IMAGE = docs_data_dir().parent / "images" / "vec_scaling_ppo.png"


def _factories(n: int) -> list:
    """``n`` factories of the RL env for worker processes (picklable)."""
    return [partial(make_gym_env, RL_ENV, **ENV)] * n


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
        vec.reset(seed=0)
        return vec_step_rate(vec, steps // n, n)
    finally:
        vec.close()


def subproc(n: int, steps: int) -> float:
    from stable_baselines3.common.vec_env import SubprocVecEnv

    return vec_step_rate(SubprocVecEnv(_factories(n), start_method="spawn"), steps // n, n, seed=True)


def grouped(n: int, steps: int, processes: int = 2) -> float:
    from biovln_ms.learning.grouped_vec_env import GroupedSubprocVecEnv

    return vec_step_rate(GroupedSubprocVecEnv(_factories(n), processes), steps // n, n, seed=True)


def ppo(n: int, timesteps: int, out: Path, envs_per_process: int = 1) -> tuple[float, list[dict]]:
    """Env steps/s of ``train ppo`` with ``n`` envs, and its episode log (the learning curve's rows, without
    their wall time)."""
    from biovln_ms.learning.rl import RLConfig, read_episode_log, train_rl

    hyper = {"n_steps": 2048 // n} if n > 2 else {}  # an update sees 2,048 steps, as with 2 envs
    cfg = RLConfig(
        timesteps=timesteps, n_envs=n, seed=0, eval_split=None, hyperparams=hyper,
        envs_per_process=envs_per_process,
    )  # fmt: skip
    run = out / f"ppo{n}x{envs_per_process}"
    rate = train_rl(cfg, run, echo=lambda *_: None, progress=False).steps_per_second
    return rate, read_episode_log(run / "episodes.csv")


def plot_curves(runs: list[dict], path: Path, window: int) -> None:
    """Training success per ``window`` env steps of each PPO run, one line each."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for i, r in enumerate(runs):
        pts = [(p[0] / 1000, 100 * p[1]) for p in r["curve"] if p[1] is not None]
        style = dict(ls="--", lw=2.5, alpha=0.6) if i == len(runs) - 1 else dict(marker=".")
        ax.plot(*zip(*pts), label=f"{r['how']}: {r['steps_per_second']:.0f} env steps/s", **style)
    success_axes(ax, window)
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(f"SB3 PPO on {RL_ENV}: learning per env step, by how the envs run", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--ppo-steps", type=int, default=20480)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "vec_scaling.json")
    ap.add_argument("--work", type=Path, default=Path("outputs/vec_scaling"))
    ap.add_argument("--image", type=Path, default=IMAGE)
    args = ap.parse_args()
    torch.set_num_threads(1)
    one = single(args.steps)
    rows = [["one env in this process", "0", "1", f"{one:.0f}", "1.00x"]]
    runs = []  # the PPO runs' curves

    def row(label: str, processes: int, envs: int, rate: float) -> None:
        rows.append([label, str(processes), str(envs), f"{rate:.0f}", f"{rate / one:.2f}x"])

    for label, fn in (("gym.make_vec, async", make_vec), ("SB3 SubprocVecEnv", subproc)):
        rates = [fn(n, args.steps) for n in (1, 2)]
        for n, r in zip((1, 2), rates):
            row(label, n, n, r)
        print(f"{label}: {rates[0]:.0f} -> {rates[1]:.0f} env steps/s ({rates[1] / rates[0]:.2f}x with 2)")
    row("SB3 SubprocVecEnv", 8, 8, subproc(8, args.steps))
    row("GroupedSubprocVecEnv", 2, 8, grouped(8, args.steps))
    print(f"8 envs: SubprocVecEnv {rows[-2][3]}, grouped in 2 processes {rows[-1][3]} env steps/s")
    label = "SB3 PPO, train ppo's defaults (learn)"

    def ppo_row(how: str, label: str, n: int, envs_per_process: int = 1) -> list[dict]:
        processes = 0 if n == 1 else -(-n // envs_per_process)  # train ppo steps one env in its process
        rate, log = ppo(n, args.ppo_steps, args.work, envs_per_process)
        row(label, processes, n, rate)
        episodes = [(r["timesteps"], r["success"]) for r in log]
        curve = success_curve(episodes, args.ppo_steps, CURVE_WINDOW)
        runs.append({"how": how, "processes": processes, "envs": n, "steps_per_second": round(rate, 1),
                     "episodes": len(log), "curve": curve})  # fmt: skip
        print(f"PPO, {how}: {rate:.0f} env steps/s")
        return log

    ppo_row("1 env in the trainer's process", label, 1)
    ppo_row("2 envs, 2 processes (the default)", label, 2)
    log8 = ppo_row("8 envs, 8 processes", label + ", n_steps 256", 8)
    glog8 = ppo_row("8 envs, 2 processes of 4", label + ", n_steps 256, --envs-per-process 4", 8, 4)
    same = "identical" if log8 == glog8 else "different"
    (shared_ms, shared_objects), (own_ms, own_objects) = collection("shared"), collection("own copy")
    print(f"4 envs in a process, a full collection: {shared_ms:.1f} ms shared, {own_ms:.1f} ms own copies")
    r8, g8 = runs[-2]["steps_per_second"], runs[-1]["steps_per_second"]
    print(f"PPO with 8 envs: {r8:.0f} (8 processes) and {g8:.0f} (2 processes) env steps/s; curves {same}")
    write_table(
        args.data_out,
        "Parallel envs on the CPU and PPO end to end",
        ["how", "worker processes", "envs", "env steps/s", "over one env in-process"],
        rows,
        [
            f"{args.steps} random steps per row (state observations, {RL_ENV}); "
            f"PPO {args.ppo_steps} timesteps.",
            f"The two 8-env PPO runs' episode logs (returns, lengths, successes, in order) are {same}.",
            f"4 envs in one fresh process: the full collection ManiSkill runs at each scene change takes "
            f"{shared_ms:.1f} ms ({shared_objects:,} objects walked) with the split's episodes shared, as "
            f"gym.make gives them; {own_ms:.1f} ms ({own_objects:,}) with a copy per env.",
        ],
    )
    write_runs(args.data_out.with_name("vec_scaling_curves.json"), runs, window_steps=CURVE_WINDOW)
    plot_curves(runs, args.image, CURVE_WINDOW)


if __name__ == "__main__":
    main()
