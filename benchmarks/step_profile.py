"""Where a state-only step of BioVLN-OpFace-v0 spends its time, beside PickCube-v1 in the same run.

    python benchmarks/step_profile.py [--steps 3000] [--repeats 3]

Each part of ``env.step`` is timed by a wrapper around the method that does it (no profiler, whose
overhead would inflate the Python parts): SAPIEN's physics (the control step's substeps), the robot's
command (action check, drive targets), the controller's end of step (swept check, put-back), the
measures, ``info``, the observation, the reward, and the rest (ManiSkill's and gymnasium's step code).
PickCube-v1 (``obs_mode="state"``, CPU physics) is the reference the issue's ratio divides by. The
table goes to ``docs/data/benchmarks/step_profile.json``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch

import biovln_ms  # noqa: F401
from biovln_ms.measured import docs_data_dir, timed, write_table
from biovln_ms.sim.maniskill_compat import maniskill_task_id

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")


def _parts(env) -> dict[str, float]:
    """Wrap the methods that do each part of a step; the returned dict accumulates their seconds."""
    u = env.unwrapped
    spent = dict.fromkeys(
        ("SAPIEN physics", "robot command", "controller end of step", "measures", "info", "observation",
         "reward"), 0.0
    )  # fmt: skip
    u.scene.step = timed(u.scene.step, spent, "SAPIEN physics")
    u.agent.set_action = timed(u.agent.set_action, spent, "robot command")
    ctrl = u.agent.controller
    ctrl.end_step = timed(ctrl.end_step, spent, "controller end of step")
    u._measures.update = timed(u._measures.update, spent, "measures")
    u.get_info = timed(u.get_info, spent, "info")
    u.get_obs = timed(u.get_obs, spent, "observation")
    u.get_reward = timed(u.get_reward, spent, "reward")
    return spent


def _run(env, steps: int, seed: int = 0) -> float:
    """Seconds for ``steps`` random steps (the nav env: FORWARD, LEFT, RIGHT), resetting at episode ends."""
    rng = np.random.default_rng(seed)
    sample = (lambda: int(rng.integers(1, 4))) if isinstance(env.action_space, gym.spaces.Discrete) else None
    t = time.perf_counter()
    for _ in range(steps):
        a = sample() if sample else env.action_space.sample()
        _, _, term, trunc, _ = env.step(a)
        if bool(term) or bool(trunc):
            env.reset()
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--repeats", type=int, default=3, help="interleaved blocks per env; the best is kept")
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "step_profile.json")
    args = ap.parse_args()
    torch.set_num_threads(1)

    nav = gym.make("BioVLN-OpFace-v0", split="ms_val", obs_mode="state", **CPU)
    cube_id = maniskill_task_id("PickCube")  # PickCube-v1 on ManiSkill 3 (ManiSkill 4 announces -v4)
    cube = gym.make(cube_id, obs_mode="state", **CPU)
    nav.reset(seed=0, options={"episode_index": 0})
    cube.reset(seed=0)
    _run(nav, 50), _run(cube, 50)  # warm-up
    nav_s, cube_s = [], []
    for r in range(args.repeats):  # interleaved, so a busy moment costs both
        nav_s.append(_run(nav, args.steps, r))
        cube_s.append(_run(cube, args.steps, r))
    nav_rate, cube_rate = args.steps / min(nav_s), args.steps / min(cube_s)

    u = nav.unwrapped
    spent = _parts(nav)
    total = _run(nav, args.steps, 99)
    per_step = {k: 1e3 * v / args.steps for k, v in spent.items()}
    per_step["the rest (ManiSkill's and gymnasium's step code)"] = 1e3 * total / args.steps - sum(
        per_step.values()
    )
    step_ms = 1e3 * total / args.steps
    rows = [[part, f"{ms:.3f}", f"{100 * ms / step_ms:.0f} %"] for part, ms in per_step.items()]
    rows.append(["whole step", f"{step_ms:.3f}", "100 %"])
    notes = [
        f"State-only steps/s, best of {args.repeats} interleaved blocks of {args.steps}: BioVLN-OpFace-v0 "
        f"{nav_rate:.0f}, ManiSkill {cube_id} {cube_rate:.0f} ({nav_rate / cube_rate:.2f}x).",
        f"A control step is {u.sim_freq // u.control_freq} physics substeps (sim {u.sim_freq} Hz, control "
        f"{u.control_freq} Hz); the parts are timed in a block of their own, with the wrappers in place.",
    ]
    for r in rows:
        print(f"{r[0]:<52} {r[1]:>8} ms {r[2]:>6}")
    print(notes[0])
    write_table(args.data_out, "Where a state-only step spends its time", ["part", "ms per step", "share"],
                rows, notes)  # fmt: skip
    nav.close()
    cube.close()


if __name__ == "__main__":
    main()
