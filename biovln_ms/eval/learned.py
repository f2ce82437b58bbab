"""Train a Stable-Baselines3 method, then evaluate it through the harness, so its results sit beside the
baselines' (``biovln-ms train ppo|a2c|sac``)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Callable

from biovln_ms.eval.harness import EvalConfig, evaluate
from biovln_ms.learning.rl import RLConfig, RLResult, train_rl


def train_and_evaluate(
    cfg: RLConfig, out: str | Path, echo: Callable[[str], None] = print, progress: bool = True
) -> RLResult:
    """``train_rl``, then (when ``cfg.eval_split``) the harness on that split with the saved model."""
    result = train_rl(cfg, out, echo=echo, progress=progress)
    if not cfg.eval_split:
        return result
    summary = evaluate(
        EvalConfig(
            cfg.algo,
            cfg.eval_split,
            str(Path(out) / "eval"),
            cfg.dataset,
            cfg.env_id,
            workers=None if cfg.sim_backend else cfg.n_envs,  # one batched env trained: a worker per core
            max_episodes=cfg.eval_episodes,
            method_kwargs={"checkpoint": str(result.model)},
        ),
        progress=progress,
        echo=echo,
    )
    return replace(result, eval_summary=summary)
