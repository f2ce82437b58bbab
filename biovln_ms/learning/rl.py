"""RL with Stable-Baselines3 on ``BioVLN-OpFace-RL-v0`` (appendix "Gym Environment for RL Training").

One env per process (``SubprocVecEnv``, spawn), several per process (``GroupedSubprocVecEnv``) or,
beyond one machine, one env per Ray actor
(``RayVecEnv``); ``VecMonitor`` records each episode's return, length and ``success``. The run folder
holds TensorBoard logs (``tb/``), atomic checkpoints (``checkpoints/``), ``model.zip``, the episode log
``episodes.csv`` and ``learning_curve.png``; the trained policy is then evaluated through the harness
(``eval/``), exactly like the baselines.
"""

from __future__ import annotations

import csv
import gc
import io
import json
import time
from dataclasses import asdict, dataclass, field
from functools import partial
from pathlib import Path
from typing import Callable

import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.type_aliases import TrainFrequencyUnit

from biovln_ms.cluster import check_address, closing_vec_env, exit_on_sigterm
from biovln_ms.constants import CHECKPOINT_EVERY
from biovln_ms.episodes.source import SEED_RULE
from biovln_ms.tasks.config_checks import is_gpu_backend
from biovln_ms.errors import BioVLNError
from biovln_ms.learning.algorithms import SB3_CONTROL_MODES, algo_class
from biovln_ms.variants import RL_ENV
from biovln_ms.io_utils import atomic_write_bytes, atomic_write_text, save_figure


@dataclass
class RLConfig:
    algo: str = "ppo"
    timesteps: int = 200_000
    env_id: str = RL_ENV
    split: str = "train"
    dataset: str | None = None
    n_envs: int = 2
    seed: int = 0
    checkpoint_every: int = CHECKPOINT_EVERY  # timesteps
    eval_split: str | None = "ms_val"  # evaluated through the harness after training (None: skip)
    eval_episodes: int | None = None
    ray_address: str | None = None  # run the envs on Ray actors ("local", "auto", "ray://host:port")
    #: one batched env of n_envs sub-envs on this backend (e.g. "physx_cuda"), stepped by BatchedVecEnv;
    #: None: one env per process. On physx_cpu it sets torch to one thread, as make_gym_env does.
    sim_backend: str | None = None
    #: batched steps between resets of all sub-envs (BatchedVecEnv.rotate_every; with n_envs > 1), which
    #: move them on through the split's scenes; the default is the step limit (500)
    rotate_scenes_every: int | None = 500
    hyperparams: dict = field(default_factory=dict)  # passed to the SB3 constructor (e.g. n_steps, ent_coef)
    #: the reward a STOP outside the success radius costs in training (biovln_ms.wrappers.StopShaping;
    #: evaluation uses the env as registered). Masking STOP is not offered here: SB3's policies cannot
    #: mask an action (biovln_ms.learning.ppo_loop's can)
    stop_penalty: float = 0.0
    #: the penalty applies in the first this many timesteps only (None: throughout), so that the policy's
    #: STOP is learnt from the env's own reward in the rest of training
    stop_penalty_steps: int | None = None
    #: the RL env's ``scene_visit_episodes``: this many of each scene's episodes per pass (0: all at once)
    scene_visit_episodes: int = 0
    #: envs per worker process (GroupedSubprocVecEnv; 1: SB3's SubprocVecEnv, one env per process): a
    #: round trip to a worker then carries this many env steps; the transitions are the same
    envs_per_process: int = 1

    def defaults(self) -> dict:
        """Our defaults per algorithm (SB3's otherwise); ``hyperparams`` override them."""
        base = {
            "ppo": {"n_steps": 1024, "batch_size": 256, "ent_coef": 0.01, "gamma": 0.99},
            "a2c": {"n_steps": 16, "ent_coef": 0.01},
            "sac": {"learning_starts": 2000, "buffer_size": 200_000},
        }[self.algo]
        return {**base, **self.hyperparams}


class EpisodeLog(BaseCallback):
    """Every finished episode (return, length, success) to a list and TensorBoard
    (``rollout/success_rate``); an atomic checkpoint every ``every`` timesteps."""

    def __init__(self, out: Path, every: int) -> None:
        super().__init__()
        self.out, self.every, self.rows, self.next_ckpt = out, every, [], every
        self.t0 = time.perf_counter()

    def _on_step(self) -> bool:
        for env, info in enumerate(self.locals["infos"]):
            ep = info.get("episode")
            if ep is not None:
                self.rows.append(
                    {
                        "timesteps": self.num_timesteps,
                        "env": env,
                        "return": float(ep["r"]),
                        "length": int(ep["l"]),
                        "success": float(info.get("success", 0.0)),
                        "seconds": round(time.perf_counter() - self.t0, 2),
                    }
                )
        if self.rows:
            self.logger.record(
                "rollout/success_rate", float(np.mean([r["success"] for r in self.rows[-100:]]))
            )
        if self.num_timesteps >= self.next_ckpt:
            name = f"{self.model.__class__.__name__.lower()}_{self.num_timesteps}.zip"
            save_model(self.model, self.out / "checkpoints" / name)
            self.next_ckpt += self.every
        return True


class EndStopPenalty(BaseCallback):
    """Sets every env's STOP penalty to 0 once ``steps`` timesteps have passed."""

    def __init__(self, steps: int) -> None:
        super().__init__()
        self.steps, self.ended = steps, False

    def _on_step(self) -> bool:
        if not self.ended and self.num_timesteps >= self.steps:
            self.training_env.env_method("set_penalty", 0.0)
            self.ended = True
        return True


class FreezeAtStart(BaseCallback):
    """An env that steps in the trainer's process ends each scene change in ManiSkill's full
    ``gc.collect()``, which would walk SB3's and torch's objects (made after the env froze what lived then,
    :func:`~biovln_ms.sim.maniskill_compat.freeze_live_objects`). At the start of training, after SB3's
    first reset, what lives is collected and frozen; ``train_rl`` unfreezes it when training ends."""

    def _on_training_start(self) -> None:
        gc.collect()
        gc.freeze()

    def _on_step(self) -> bool:
        return True


def save_model(model, path: Path) -> Path:
    """``model.save`` to a temporary name in the same folder, then rename (never a half-written zip)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    model.save(buf)
    return atomic_write_bytes(path, buf.getvalue())


def make_vec_env(cfg: RLConfig, n_envs: int | None = None):
    """SubprocVecEnv (spawn) of ``n_envs`` single-env processes (``cfg.envs_per_process`` > 1: a
    GroupedSubprocVecEnv of that many per process), a RayVecEnv, or one batched env of ``n_envs``
    sub-envs on ``cfg.sim_backend`` (BatchedVecEnv); wrapped in VecMonitor."""
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

    from biovln_ms.wrappers import StopShaping, make_gym_env

    n = n_envs or cfg.n_envs
    env_kwargs = dict(
        split=cfg.split, dataset=cfg.dataset, control_mode=SB3_CONTROL_MODES[cfg.algo], obs_mode="state"
    )
    if cfg.scene_visit_episodes:
        env_kwargs["scene_visit_episodes"] = cfg.scene_visit_episodes
    factory = partial(make_gym_env, cfg.env_id, stop_penalty=cfg.stop_penalty, **env_kwargs)
    if cfg.sim_backend:
        import gymnasium as gym

        from biovln_ms.learning.batched_vec_env import BatchedVecEnv

        if cfg.sim_backend == "physx_cpu":  # one torch thread, as make_gym_env: the process path's bits
            torch.set_num_threads(1)
        env = gym.make(cfg.env_id, num_envs=n, sim_backend=cfg.sim_backend, **env_kwargs)
        if cfg.stop_penalty:
            env = StopShaping(env, penalty=cfg.stop_penalty)
        venv = BatchedVecEnv(env, rotate_every=cfg.rotate_scenes_every if n > 1 else None)
    elif cfg.ray_address:
        from biovln_ms.learning.ray_vec_env import RayVecEnv

        venv = RayVecEnv([factory] * n, address=cfg.ray_address)
    elif n == 1:
        venv = DummyVecEnv([factory])
    elif cfg.envs_per_process > 1:
        from biovln_ms.learning.grouped_vec_env import GroupedSubprocVecEnv

        venv = GroupedSubprocVecEnv([factory] * n, processes=-(-n // cfg.envs_per_process))
    else:
        venv = SubprocVecEnv([factory] * n, start_method="spawn")
    venv.seed(cfg.seed)
    return VecMonitor(venv, info_keywords=("success",))


def steps_in_process(venv) -> bool:
    """Whether the envs of :func:`make_vec_env`'s vector env step in this process (one env, or a batched
    env), not in worker processes or Ray actors."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    from biovln_ms.learning.batched_vec_env import BatchedVecEnv

    return isinstance(venv.unwrapped, (DummyVecEnv, BatchedVecEnv))


@dataclass
class RLResult:
    model: Path
    timesteps: int
    minutes: float
    steps_per_second: float
    episodes: int
    final_success_rate: float
    eval_summary: dict | None = None  # set by biovln_ms.eval.learned.train_and_evaluate


def rollout_steps(model) -> int:
    """The timesteps SB3 collects between two checks of ``total_timesteps``, so a run ends at a multiple:
    ``n_steps`` per env for PPO and A2C, ``train_freq`` steps per env for SAC (1 if it counts episodes)."""
    if isinstance(model, OnPolicyAlgorithm):
        return model.n_steps * model.n_envs
    freq = getattr(model, "train_freq", None)
    if freq is not None and freq.unit == TrainFrequencyUnit.STEP:
        return freq.frequency * model.n_envs
    return 1  # counted in episodes: not known ahead


def train_rl(
    cfg: RLConfig, out: str | Path, echo: Callable[[str], None] = print, progress: bool = True
) -> RLResult:
    """Train, save and plot (``biovln_ms.eval.learned.train_and_evaluate`` then evaluates through the
    harness)."""
    cls = algo_class(cfg.algo)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if cfg.timesteps <= 0:
        raise BioVLNError(
            f"timesteps must be positive, got {cfg.timesteps}",
            field="timesteps",
            fix="e.g. --timesteps 200000",
        )
    if cfg.ray_address is not None:
        check_address(cfg.ray_address)
    if cfg.envs_per_process < 1 or (cfg.envs_per_process > 1 and (cfg.sim_backend or cfg.ray_address)):
        raise BioVLNError(
            f"envs_per_process {cfg.envs_per_process}: at least 1, and above 1 only for worker processes",
            field="envs_per_process",
            fix="1 (one env per process), or drop --sim-backend / --ray-address",
        )
    if cfg.sim_backend and cfg.ray_address:
        raise BioVLNError(
            "a batched env (sim_backend) runs in this process, not on Ray actors",
            field="sim_backend",
            fix="drop --ray-address, or --sim-backend",
        )
    restore = exit_on_sigterm()  # a kill ends the env processes too (closing_vec_env below)
    threads = torch.get_num_threads()
    if not (cfg.sim_backend and is_gpu_backend(cfg.sim_backend)):  # envs on CPU cores: an MLP needs one
        torch.set_num_threads(1)  # thread, more only contend with the env processes (restored below)
    try:
        venv = make_vec_env(cfg)
        in_process = steps_in_process(venv)
        batched = getattr(venv.unwrapped, "base", None)  # a BatchedVecEnv's env
        device = str(batched.device) if batched is not None else "cpu"  # where the batched env steps
        try:
            with closing_vec_env(venv):  # a kill, ^C or error: no handshake with envs that may be mid-step
                model = cls(
                    "MlpPolicy",
                    venv,
                    seed=cfg.seed,
                    device=device,
                    verbose=0,
                    tensorboard_log=str(out / "tb"),
                    **cfg.defaults(),
                )
                log = EpisodeLog(out, cfg.checkpoint_every)
                callbacks = [log] + (
                    [EndStopPenalty(cfg.stop_penalty_steps)] if cfg.stop_penalty_steps else []
                )
                callbacks += [FreezeAtStart()] if in_process else []
                rollout = rollout_steps(model)
                total = -(-cfg.timesteps // rollout) * rollout
                if total != cfg.timesteps:
                    echo(
                        f"{cfg.algo} learns in whole rollouts of {rollout:,} steps over its {model.n_envs} "
                        f"env(s): training {total:,} timesteps, not {cfg.timesteps:,}"
                    )
                t0 = time.perf_counter()
                model.learn(
                    total_timesteps=total,
                    callback=callbacks,
                    progress_bar=progress,
                    tb_log_name=cfg.algo,
                )
                seconds = time.perf_counter() - t0
        finally:
            if in_process:  # collectable again, the env's first freeze too (the next env freezes anew)
                gc.unfreeze()
    finally:
        restore()
        torch.set_num_threads(threads)
    model_path = save_model(model, out / "model.zip")
    write_episode_log(log.rows, out / "episodes.csv")
    plot_learning_curve(
        log.rows, out / "learning_curve.png", f"{cfg.algo.upper()} on {cfg.env_id} ({cfg.split})"
    )
    sr = float(np.mean([r["success"] for r in log.rows[-100:]])) if log.rows else 0.0
    atomic_write_text(
        out / "train.json",
        json.dumps(
            {
                "config": asdict(cfg),
                "seed_rule": SEED_RULE,
                "timesteps": int(model.num_timesteps),
                "minutes": round(seconds / 60, 2),
                "steps_per_second": round(model.num_timesteps / seconds, 1),
                "episodes": len(log.rows),
                "final_success_rate": sr,
            },
            indent=1,
        ),
    )
    echo(
        f"{cfg.algo}: {model.num_timesteps} timesteps in {seconds / 60:.1f} min "
        f"({model.num_timesteps / seconds:.0f} steps/s), "
        f"{len(log.rows)} episodes, last-100 success {100 * sr:.0f}% -> {model_path}"
    )
    return RLResult(
        model_path, int(model.num_timesteps), seconds / 60, model.num_timesteps / seconds, len(log.rows), sr
    )


#: env steps per point of the learning guide's success curves
CURVE_WINDOW = 5_000


def success_curve(episodes: list[tuple[int, float]], end: int, window: int) -> list[list]:
    """[window end, success rate or None, episodes] per ``window`` env steps up to ``end``, from (the step an
    episode ended at, its success) pairs: a learning curve that counts each finished episode once."""
    steps = np.array([e[0] for e in episodes])
    success = np.array([e[1] for e in episodes], float)
    out = []
    for hi in range(window, end + 1, window):
        sel = (steps > hi - window) & (steps <= hi)
        out.append([hi, round(float(success[sel].mean()), 4) if sel.any() else None, int(sel.sum())])
    return out


def success_axes(ax, window: int) -> None:
    """Label and scale a matplotlib axes for :func:`success_curve` lines (x in thousands of env steps,
    success in %)."""
    ax.set(xlabel="env steps (thousands)", ylabel=f"training success % (per {window:,} steps)")
    ax.set_ylim(-2, 102)
    ax.grid(alpha=0.3)


#: the columns of a run's ``episodes.csv`` (EpisodeLog's rows)
EPISODE_LOG_FIELDS = ("timesteps", "env", "return", "length", "success", "seconds")


def read_episode_log(path: Path) -> list[dict]:
    """A run's ``episodes.csv``: the step each episode ended at, its env, return, length and success (a log
    written before it named the env counts every episode as env 0's)."""
    with Path(path).open() as f:
        return [
            {
                "timesteps": int(r["timesteps"]),
                "env": int(r.get("env") or 0),
                "return": float(r["return"]),
                "length": int(r["length"]),
                "success": float(r["success"]),
            }
            for r in csv.DictReader(f)
        ]


def write_episode_log(rows: list[dict], path: Path) -> None:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=EPISODE_LOG_FIELDS)
    w.writeheader()
    w.writerows(rows)
    atomic_write_text(path, buf.getvalue())


def plot_learning_curve(rows: list[dict], path: Path, title: str, window: int = 50) -> None:
    """Return and success rate (moving average over ``window`` episodes) against timesteps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    if rows:
        t = np.array([r["timesteps"] for r in rows])
        for a, key, label in ((ax[0], "return", "episode return"), (ax[1], "success", "success rate")):
            v = np.array([r[key] for r in rows], float)
            k = min(window, len(v))
            ma = np.convolve(v, np.ones(k) / k, mode="valid")
            a.plot(t, v, ".", alpha=0.15, color="grey")
            a.plot(t[k - 1 :], ma, color="C0", label=f"moving mean ({k} episodes)")
            a.set(xlabel="timesteps", ylabel=label)
            a.grid(alpha=0.3)
            a.legend(loc="lower right")
        ax[1].set_ylim(-0.02, 1.02)
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
