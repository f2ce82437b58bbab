"""`biovln-ms train`: behavioural cloning and one RL command per Stable-Baselines3 algorithm."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from biovln_ms.cli.common import app
from biovln_ms.constants import CHECKPOINT_EVERY
from biovln_ms.learning.algorithms import SB3_CONTROL_MODES
from biovln_ms.variants import RL_ENV

train_app = typer.Typer(
    help="Train learned policies (BC and RL).\n\nBehavioural cloning (bc) and RL with Stable-Baselines3 "
    f"({', '.join(SB3_CONTROL_MODES)}).",
    no_args_is_help=True,
)
app.add_typer(train_app, name="train")


@train_app.command("bc")
def train_bc_cmd(
    data: list[Path] = typer.Option(
        ..., "--data", help="Recording folder(s) of `eval --record` (repeatable)."
    ),
    out: Path = typer.Option(
        Path("ckpt/bc"), "--out", "-o", help="Folder for bc.pt, loss.png, history.json."
    ),
    epochs: int = typer.Option(500, help="Maximum epochs (the paper: 500)."),
    patience: int = typer.Option(50, help="Early-stopping patience in epochs (the paper: 50)."),
    batch_size: int = typer.Option(32, help="Batch size (the paper: 32)."),
    lr: float = typer.Option(1e-4, help="Adam learning rate (the paper: 1e-4)."),
    image_size: int = typer.Option(224, help="Input size in pixels (the paper: 224)."),
    max_minutes: Optional[float] = typer.Option(
        None, help="Wall-clock budget; stops after the epoch past it."
    ),
    pretrained: Optional[Path] = typer.Option(
        None, help="torchvision-layout ResNet-18 state dict to start from."
    ),
    seed: int = typer.Option(0, help="Seed of the split, the shuffling and the initial weights."),
) -> None:
    """Behavioural cloning on recorded trajectories.

    The paper's appendix, Table 17."""
    from biovln_ms.learning.bc import BCConfig, train_bc

    cfg = BCConfig(
        lr=lr,
        batch_size=batch_size,
        max_epochs=epochs,
        patience=patience,
        image_size=image_size,
        max_minutes=max_minutes,
        pretrained=str(pretrained) if pretrained else None,
        seed=seed,
    )
    r = train_bc(data, out, cfg, echo=typer.echo)
    typer.echo(
        f"best epoch {r.best_epoch} (val loss {r.best_val_loss:.4f}) of {r.epochs}, {r.stopped_by}, "
        f"{r.minutes:.1f} min -> {r.checkpoint}"
    )


def _train_rl(
    algo: str,
    timesteps: int,
    out: Optional[Path],
    n_envs: int,
    split: str,
    eval_split: str,
    eval_episodes: Optional[int],
    seed: int,
    ray_address: Optional[str],
    dataset: Optional[Path],
    sim_backend: Optional[str] = None,
    stop_penalty: float = 0.0,
    stop_penalty_steps: Optional[int] = None,
    scene_visit_episodes: int = 0,
    envs_per_process: int = 1,
) -> None:
    from biovln_ms.eval.learned import train_and_evaluate
    from biovln_ms.eval.tables import headline
    from biovln_ms.learning.rl import RLConfig

    cfg = RLConfig(
        algo=algo,
        timesteps=timesteps,
        n_envs=n_envs,
        split=split,
        seed=seed,
        ray_address=ray_address,
        sim_backend=sim_backend,
        eval_split=eval_split or None,
        eval_episodes=eval_episodes,
        dataset=str(dataset) if dataset else None,
        stop_penalty=stop_penalty,
        stop_penalty_steps=stop_penalty_steps,
        scene_visit_episodes=scene_visit_episodes,
        envs_per_process=envs_per_process,
    )
    r = train_and_evaluate(cfg, out or Path(f"runs/{algo}"), echo=typer.echo)
    if r.eval_summary:
        typer.echo(f"{algo} on {eval_split}: {headline(r.eval_summary)}")


def _rl_command(algo: str):
    def command(
        timesteps: int = typer.Option(
            200_000,
            "--timesteps",
            help="Environment steps to train for, rounded up to whole rollouts over all envs (PPO, A2C: "
            "n_steps x n-envs; SAC: n-envs).",
        ),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help=f"Run folder (default runs/{algo})."),
        n_envs: int = typer.Option(
            2, help="Parallel envs (one process or Ray actor each; see --envs-per-process)."
        ),
        split: str = typer.Option("train", help="Training split."),
        eval_split: str = typer.Option(
            "ms_val", help="Split evaluated through the harness afterwards ('' skips)."
        ),
        eval_episodes: Optional[int] = typer.Option(None, help="Only the first N evaluation episodes."),
        seed: int = typer.Option(0, help="Seed."),
        ray_address: Optional[str] = typer.Option(
            None, help="Envs on Ray actors: 'local', 'auto' or 'ray://host:port'."
        ),
        dataset: Optional[Path] = typer.Option(None, help="Dataset folder (default: built on first use)."),
        sim_backend: Optional[str] = typer.Option(
            None,
            help="One batched env of --n-envs sub-envs on this backend (physx_cuda on a GPU; physx_cpu "
            "allows one) instead of one process per env.",
        ),
        stop_penalty: float = typer.Option(
            0.0,
            help="Training only: the reward a STOP outside the success radius costs (the learning "
            "guide's recipe); evaluation uses the env as registered.",
        ),
        stop_penalty_steps: Optional[int] = typer.Option(
            None, help="The STOP penalty applies in the first N timesteps only (default: throughout)."
        ),
        scene_visit_episodes: int = typer.Option(
            0,
            help="N of each scene's episodes per pass over the split's scenes (0: all of a scene's at "
            "once), so training meets more scenes of a large split.",
        ),
        envs_per_process: int = typer.Option(
            1,
            min=1,
            help="At most this many envs per worker process, spread evenly (1: SB3's SubprocVecEnv); "
            "fewer round trips per step, the same transitions.",
        ),
    ) -> None:
        _train_rl(
            algo,
            timesteps,
            out,
            n_envs,
            split,
            eval_split,
            eval_episodes,
            seed,
            ray_address,
            dataset,
            sim_backend,
            stop_penalty,
            stop_penalty_steps,
            scene_visit_episodes,
            envs_per_process,
        )

    command.__doc__ = (
        f"{algo.upper()} with Stable-Baselines3 on the RL env.\n\n{RL_ENV}: TensorBoard logs, a checkpoint "
        f"every {CHECKPOINT_EVERY:,} timesteps, learning curve, then evaluation through the harness."
    )
    return command


def _register_rl_commands() -> None:
    for algo in SB3_CONTROL_MODES:
        train_app.command(algo)(_rl_command(algo))


_register_rl_commands()
