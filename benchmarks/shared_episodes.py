"""PPO with several envs per worker process, when the envs share their split's episodes and when each
reads its own copy, in interleaved runs.

    python benchmarks/shared_episodes.py [--pairs 3] [--timesteps 24576]

``gym.make(..., split=...)`` hands the envs of one process one read of the split
(``DatasetEpisodes.shared``). ManiSkill ends each scene change with a full ``gc.collect()``, which walks
every object the process's first env did not freeze (``freeze_live_objects``): a copy of the split per env
adds its episodes to each walk. Each pair runs ``train ppo``'s SB3 PPO with 8 envs in 2 processes of 4
(``n_steps`` 256, ``vec_scaling.py``'s ``--envs-per-process 4`` row) once each way, in alternating order;
early training has the shortest episodes (a random STOP), hence the most resets and scene changes.
Beside them, the resident memory of a fresh process of 4 envs both ways. The full collection's own time
(:func:`collection`) is in ``vec_scaling.py``'s notes. Writes ``docs/data/benchmarks/shared_episodes.json``.
"""

from __future__ import annotations

import argparse
import gc
import resource
import time
from pathlib import Path

import numpy as np
import torch
from stable_baselines3.common.vec_env import VecMonitor

from biovln_ms.cluster import closing_vec_env
from biovln_ms.episodes.source import DatasetEpisodes
from biovln_ms.learning.algorithms import algo_class
from biovln_ms.learning.grouped_vec_env import GroupedSubprocVecEnv
from biovln_ms.learning.rl import RLConfig
from biovln_ms.measured import docs_data_dir, in_fresh_process, write_table
from biovln_ms.splits import dataset_root
from biovln_ms.variants import RL_ENV
from biovln_ms.wrappers import make_gym_env

SPLIT = "train"
WAYS = ("shared", "own copy")


def shared_env():
    """The RL env as ``train ppo`` makes it: ``gym.make``'s shared read of the split."""
    return make_gym_env(RL_ENV, split=SPLIT, obs_mode="state", control_mode="discrete")


def own_env():
    """The same env with its own read of the split."""
    episodes = DatasetEpisodes(SPLIT, dataset_root(None))
    return make_gym_env(RL_ENV, episodes=episodes, obs_mode="state", control_mode="discrete")


FACTORIES = {"shared": shared_env, "own copy": own_env}


def ppo_rate(way: str, timesteps: int) -> float:
    """Env steps/s of ``learn`` (after the workers started): 8 envs in 2 processes, ``n_steps`` 256."""
    torch.set_num_threads(1)
    venv = VecMonitor(GroupedSubprocVecEnv([FACTORIES[way]] * 8, processes=2), info_keywords=("success",))
    venv.seed(0)
    with closing_vec_env(venv):
        hyper = {**RLConfig().defaults(), "n_steps": 256}
        model = algo_class("ppo")("MlpPolicy", venv, seed=0, device="cpu", verbose=0, **hyper)
        t = time.perf_counter()
        model.learn(total_timesteps=timesteps)
        return model.num_timesteps / (time.perf_counter() - t)


def _made(way: str, envs: int = 4) -> list:
    """``envs`` envs made ``way`` and reset."""
    made = [FACTORIES[way]() for _ in range(envs)]
    for env in made:
        env.reset(seed=0)
    return made


def _resident(way: str) -> float:
    """The peak resident memory in MiB of this process after :func:`_made`."""
    _made(way)
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _collect(way: str) -> tuple[float, int]:
    """After :func:`_made` in this process: the median ms of a full collection (ManiSkill's at a scene
    change) and the objects it walks."""
    made = _made(way)
    times = []
    for _ in range(7):
        t = time.perf_counter()
        gc.collect()
        times.append(time.perf_counter() - t)
    walked = len(gc.get_objects())
    for env in made:
        env.close()
    return float(np.median(times)) * 1e3, walked


def resident(way: str) -> float:
    return in_fresh_process(_resident, way)


def collection(way: str) -> tuple[float, int]:
    return in_fresh_process(_collect, way)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pairs", type=int, default=3)
    ap.add_argument("--timesteps", type=int, default=24576)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "shared_episodes.json")
    args = ap.parse_args()
    rates: dict[str, list[float]] = {w: [] for w in WAYS}
    for k in range(args.pairs):
        for way in WAYS if k % 2 == 0 else WAYS[::-1]:
            rates[way].append(ppo_rate(way, args.timesteps))
            print(f"pair {k + 1}, {way}: {rates[way][-1]:.0f} env steps/s", flush=True)
    memory = {w: resident(w) for w in WAYS}
    ratios = [s / o for s, o in zip(rates["shared"], rates["own copy"])]
    rows = [
        [way, ", ".join(f"{r:.0f}" for r in rates[way]), f"{np.median(rates[way]):.0f}", f"{memory[way]:.0f}"]
        for way in WAYS
    ]
    notes = [
        f"SB3 PPO (train ppo's defaults, n_steps 256), 8 envs in 2 processes of 4, {args.timesteps} "
        f"timesteps a run, {args.pairs} pairs in alternating order; shared over own copy per pair: "
        + ", ".join(f"{r:.2f}x" for r in ratios)
        + f" (median {np.median(ratios):.2f}x).",
        "Memory: the peak resident set of a fresh process after making and resetting 4 envs.",
    ]
    for row in rows:
        print(*row, sep="  |  ")
    print(*notes, sep="\n")
    columns = ["the envs' episodes", "PPO env steps/s, per pair", "median", "4 envs' process (MiB)"]
    write_table(args.data_out, "Envs of one process sharing their split's episodes", columns, rows, notes)


if __name__ == "__main__":
    main()
