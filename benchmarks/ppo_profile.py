"""Where SB3 PPO's wall time goes in the trainer process, as ``biovln-ms train ppo`` runs it on the CPU.

    python benchmarks/ppo_profile.py [--timesteps 16384] [--n-envs 2]

PPO at ``train ppo``'s defaults (``RLConfig``: SubprocVecEnv workers, state observations of
BioVLN-OpFace-RL-v0, torch on one thread in the trainer), each part timed by a wrapper around the method
that does it (no profiler): waiting for the env processes (``step_wait``: their step and reset, and the
pipes), handing them the actions (``step_async``), the policy's action choice in the rollout, the update
(``train``: the epochs over the rollout), and the rest (SB3's rollout buffer, callbacks, obs conversion).
Beside it, one env alone under random actions with STOP (PPO's early episodes are as short), in this
process and in one worker process, its time split into the env's step, its resets and what is around them;
and a bare pipe round trip for scale. The table goes to ``docs/data/benchmarks/ppo_profile.json``.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

from biovln_ms.cluster import closing_vec_env
from biovln_ms.learning.algorithms import algo_class
from biovln_ms.learning.rl import RLConfig, make_vec_env
from biovln_ms.measured import docs_data_dir, timed, write_table
from biovln_ms.variants import RL_ENV
from biovln_ms.wrappers import make_gym_env

PARTS = (
    ("wait", "waiting for the env processes (their step and reset, the pipes)"),
    ("async", "handing the env processes their actions"),
    ("policy", "the policy's action choice (rollout)"),
    ("train", "the update (epochs over the rollout)"),
)


class _Clocked(gym.Wrapper):
    """The env with its own ``step`` and ``reset`` timed (:func:`timed`), read back with
    ``env_method("clock")``."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.spent = {"step": 0.0, "reset": 0.0}
        self.step = timed(env.step, self.spent, "step")
        self.reset = timed(env.reset, self.spent, "reset")

    def clock(self) -> dict:
        return dict(self.spent)


def _clocked_env() -> gym.Env:
    return _Clocked(make_gym_env(RL_ENV, split="train", obs_mode="state", control_mode="discrete"))


def env_alone(steps: int, worker: bool) -> dict[str, float]:
    """One env under random actions with STOP (episodes of a few steps, as early in PPO's training), in this
    process (DummyVecEnv) or in one worker process (SubprocVecEnv: a pipe round trip per step): env steps/s,
    and per env step the ms spent in the env's ``step``, in its resets, and around them (the vector env, the
    pipe and the processes' wake-ups)."""
    vec = SubprocVecEnv([_clocked_env], start_method="spawn") if worker else DummyVecEnv([_clocked_env])
    with closing_vec_env(vec):
        vec.seed(0)
        vec.reset()
        rng = np.random.default_rng(0)
        for _ in range(20):  # warm-up
            vec.step(rng.integers(0, 4, 1))
        before = vec.env_method("clock")[0]
        t = time.perf_counter()
        for _ in range(steps):
            vec.step(rng.integers(0, 4, 1))
        wall = time.perf_counter() - t
        after = vec.env_method("clock")[0]
    step, reset = (after[k] - before[k] for k in ("step", "reset"))
    ms = 1e3 / steps
    return {
        "rate": steps / wall,
        "step": step * ms,
        "reset": reset * ms,
        "around": (wall - step - reset) * ms,
    }


def _echo(conn) -> None:
    while (msg := conn.recv()) is not None:
        conn.send(msg)


def pipe_round_trip(n: int = 5000) -> float:
    """Microseconds of a bare round trip of a step-sized message through a pipe to a spawned process."""
    ctx = mp.get_context("spawn")
    here, there = ctx.Pipe()
    proc = ctx.Process(target=_echo, args=(there,), daemon=True)
    proc.start()
    msg = (np.zeros(32, np.float32), 0.0, False, {"success": False})
    for _ in range(200):
        here.send(msg)
        here.recv()
    t = time.perf_counter()
    for _ in range(n):
        here.send(msg)
        here.recv()
    us = (time.perf_counter() - t) / n * 1e6
    here.send(None)
    proc.join()
    return us


def ppo_parts(timesteps: int, n_envs: int) -> tuple[dict[str, float], float, int]:
    """Seconds per part, ``learn``'s seconds and its timesteps."""
    cfg = RLConfig(timesteps=timesteps, n_envs=n_envs, seed=0, eval_split=None)
    torch.set_num_threads(1)  # as train_rl on CPU envs
    venv = make_vec_env(cfg)
    spent = dict.fromkeys((k for k, _ in PARTS), 0.0)
    with closing_vec_env(venv):  # ^C or an error: no close handshake with envs that may be mid-step
        model = algo_class("ppo")("MlpPolicy", venv, seed=cfg.seed, device="cpu", verbose=0, **cfg.defaults())
        venv.step_wait = timed(venv.step_wait, spent, "wait")
        venv.step_async = timed(venv.step_async, spent, "async")
        model.policy.forward = timed(model.policy.forward, spent, "policy")  # the rollout's calls only
        model.train = timed(model.train, spent, "train")
        t = time.perf_counter()
        model.learn(total_timesteps=cfg.timesteps)
        return spent, time.perf_counter() - t, int(model.num_timesteps)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--timesteps", type=int, default=16384)
    ap.add_argument("--n-envs", type=int, default=2)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "ppo_profile.json")
    args = ap.parse_args()
    spent, total, steps = ppo_parts(args.timesteps, args.n_envs)
    alone, worker = env_alone(3000, worker=False), env_alone(3000, worker=True)
    pipe_us = pipe_round_trip()
    rows = [[label, f"{spent[k] / steps * 1e3:.3f}", f"{100 * spent[k] / total:.0f} %"] for k, label in PARTS]
    rest = total - sum(spent.values())
    rows.append(["the rest (SB3's rollout buffer, callbacks, obs conversion)", f"{rest / steps * 1e3:.3f}",
                 f"{100 * rest / total:.0f} %"])  # fmt: skip
    rows.append(["learn, whole", f"{total / steps * 1e3:.3f}", "100 %"])
    for row in rows:
        print(f"{row[0]:<66} {row[1]:>8} ms/env step {row[2]:>6}")
    notes = [
        f"PPO at train ppo's defaults, {args.n_envs} SubprocVecEnv workers, {steps} timesteps: "
        f"{steps / total:.0f} env steps/s; ms per env step (a vector step is {args.n_envs} env steps).",
        f"One env alone, random actions with STOP: {alone['rate']:.0f} env steps/s in this process, "
        f"{worker['rate']:.0f} in one worker process. Per env step (ms), in this process / in the worker: "
        f"the env's step {alone['step']:.3f} / {worker['step']:.3f}, its resets {alone['reset']:.3f} / "
        f"{worker['reset']:.3f}, around them {alone['around']:.3f} / {worker['around']:.3f} (the vector env; "
        f"in the worker also the pipe and both processes' wake-ups). A bare pipe round trip between two "
        f"processes that do nothing else: {pipe_us:.0f} us.",
    ]
    print(*notes, sep="\n")
    columns = ["part", "ms per env step", "share"]
    write_table(args.data_out, "Where PPO's time goes (the trainer process)", columns, rows, notes)


if __name__ == "__main__":
    main()
