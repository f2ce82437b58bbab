"""PPO written as a ManiSkill-style loop on ``ManiSkillVectorEnv``: the rollout, GAE and clipped updates in
torch on the env's device, one batched env of ``num_envs`` sub-envs (thousands on ``physx_cuda``; one on
the CPU, where ManiSkill allows no more).

It differs from ManiSkill's PPO example in two ways:

- partial resets always (``ignore_terminations=False``): STOP ends an episode and the env then holds still
  until reset, so a loop that ignored terminations would fill its rollouts with frozen, rewardless steps;
- the training-only STOP settings of :class:`biovln_ms.wrappers.StopShaping` (STOP masked in an episode's
  first steps, a failed STOP penalised), throughout or in the first ``stop_shaping_steps`` steps, with the
  policy's logits masked by ``action_masks()``.

Evaluation runs the greedy policy on the env as registered: no ``StopShaping``, no masks. The learning
guide's recipe runs it with ``python benchmarks/ppo_recipe.py loop``.
"""

from __future__ import annotations

import io
import json
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable

import gymnasium as gym
import numpy as np
import torch
from mani_skill.vector.wrappers.gymnasium import ManiSkillVectorEnv
from torch import nn

from biovln_ms.io_utils import atomic_write_bytes, atomic_write_text
from biovln_ms.variants import RL_ENV
from biovln_ms.wrappers import StopShaping


@dataclass
class LoopConfig:
    steps: int = 100_000  # env steps, all sub-envs together
    env_id: str = RL_ENV
    split: str = "train"
    dataset: str | None = None
    num_envs: int = 1
    sim_backend: str = "physx_cpu"
    seed: int = 0
    stop_mask_steps: int = 0
    stop_penalty: float = 0.0
    #: the STOP settings apply in the first this many env steps only (None: throughout), so that the rest
    #: of training learns STOP in the env as evaluation runs it
    stop_shaping_steps: int | None = None
    rollout: int = 2048  # transitions per update, all sub-envs together
    minibatch: int = 256
    epochs: int = 10
    lr: float = 3e-4
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip: float = 0.2
    ent_coef: float = 0.01
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    #: batched steps between resets of all sub-envs (with num_envs > 1): a partial reset keeps a sub-env's
    #: scene, so without these the sub-envs would stay in the scenes of their first reset
    rotate_every: int = 500


def _layer(i: int, o: int, std: float = math.sqrt(2)) -> nn.Linear:
    layer = nn.Linear(i, o)
    nn.init.orthogonal_(layer.weight, std)
    nn.init.zeros_(layer.bias)
    return layer


class Agent(nn.Module):
    """Separate actor and critic MLPs (64, 64, tanh), orthogonal initialisation; masked categorical."""

    def __init__(self, obs_dim: int, n_actions: int) -> None:
        super().__init__()
        self.critic = nn.Sequential(
            _layer(obs_dim, 64), nn.Tanh(), _layer(64, 64), nn.Tanh(), _layer(64, 1, 1.0)
        )
        self.actor = nn.Sequential(
            _layer(obs_dim, 64), nn.Tanh(), _layer(64, 64), nn.Tanh(), _layer(64, n_actions, 0.01)
        )

    def value(self, obs: torch.Tensor) -> torch.Tensor:
        return self.critic(obs).squeeze(-1)

    def dist(self, obs: torch.Tensor, mask: torch.Tensor | None = None) -> torch.distributions.Categorical:
        logits = self.actor(obs)
        if mask is not None:
            logits = logits.masked_fill(~mask, -1e8)
        return torch.distributions.Categorical(logits=logits)

    @torch.no_grad()
    def act(self, obs: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        """The greedy action (evaluation)."""
        return self.dist(obs, mask).probs.argmax(-1)


def make_env(
    cfg: LoopConfig, split: str, shaped: bool = True
) -> tuple[ManiSkillVectorEnv, StopShaping | None]:
    """The vector env with partial resets, on ``StopShaping`` when ``shaped`` (training)."""
    if cfg.sim_backend == "physx_cpu":
        torch.set_num_threads(1)  # the simulator on one core: more torch threads only contend with it
    extra = {"render_backend": "cpu"} if cfg.sim_backend == "physx_cpu" else {}
    env = gym.make(
        cfg.env_id,
        num_envs=cfg.num_envs,
        sim_backend=cfg.sim_backend,
        obs_mode="state",
        control_mode="discrete",
        split=split,
        dataset=cfg.dataset,
        **extra,
    )
    shaping = StopShaping(env, cfg.stop_mask_steps, cfg.stop_penalty) if shaped else None
    venv = ManiSkillVectorEnv(shaping or env, ignore_terminations=False, record_metrics=True)
    return venv, shaping


def train(
    cfg: LoopConfig, out: str | Path | None = None, echo: Callable[[str], None] = print
) -> tuple[Agent, dict]:
    """Train; returns the agent and the log: every finished episode as (step, success, return, length) and
    the throughput. With ``out``, writes ``agent.pt`` (weights only) and ``train.json`` after every update,
    so an interrupted run keeps what it learnt."""
    torch.manual_seed(cfg.seed)
    np.random.seed(cfg.seed)
    venv, shaping = make_env(cfg, cfg.split)
    device, n = venv.device, venv.num_envs
    obs, _ = venv.reset(seed=cfg.seed)
    agent = Agent(obs.shape[-1], venv.single_action_space.n).to(device)
    opt = torch.optim.Adam(agent.parameters(), lr=cfg.lr, eps=1e-5)
    t_len, n_act = max(1, cfg.rollout // n), venv.single_action_space.n
    buf = {
        "obs": torch.zeros((t_len, n, obs.shape[-1]), device=device),
        "mask": torch.ones((t_len, n, n_act), dtype=torch.bool, device=device),
        "act": torch.zeros((t_len, n), dtype=torch.long, device=device),
        **{k: torch.zeros((t_len, n), device=device) for k in ("logp", "rew", "done", "val")},
    }
    episodes: list[list] = []
    step, batched, next_done = 0, 0, torch.zeros(n, device=device)
    t0 = time.perf_counter()
    log = _log(cfg, 0, 0.0, episodes)
    try:
        while step < cfg.steps:
            for t in range(t_len):
                mask = shaping.action_masks()
                with torch.no_grad():
                    d = agent.dist(obs, mask)
                    action = d.sample()
                    buf["val"][t] = agent.value(obs)
                buf["obs"][t], buf["mask"][t], buf["act"][t] = obs, mask, action
                buf["logp"][t], buf["done"][t] = d.log_prob(action), next_done
                obs, reward, term, trunc, info = venv.step(action)
                step, batched = step + n, batched + 1
                if cfg.stop_shaping_steps and step >= cfg.stop_shaping_steps:  # from the next step on
                    shaping.mask_steps = 0
                    shaping.set_penalty(0.0)
                reward = reward.to(device, torch.float32)
                done = term | trunc
                if done.any():
                    final = info["final_info"]["episode"]
                    cut = trunc & ~term  # truncated: bootstrap the value of the true next observation
                    if cut.any():
                        with torch.no_grad():
                            reward[cut] += cfg.gamma * agent.value(info["final_observation"][cut])
                    for i in torch.nonzero(done).flatten().tolist():
                        ret, length = round(float(final["return"][i]), 3), int(final["episode_len"][i])
                        episodes.append([step, int(final["success_once"][i]), ret, length])
                if n > 1 and cfg.rotate_every and batched % cfg.rotate_every == 0:
                    with torch.no_grad():  # the running episodes end here as truncated
                        reward[~done] += cfg.gamma * agent.value(obs[~done])
                    obs, _ = venv.reset()  # every sub-env on to the split's next scenes
                    done = torch.ones_like(done)
                buf["rew"][t], next_done = reward, done.to(torch.float32)
            _update(agent, opt, cfg, obs, next_done, buf)
            log = _log(cfg, step, time.perf_counter() - t0, episodes)
            if out is not None:
                _save(Path(out), agent, log)
            recent = np.array([e[1::2] for e in episodes[-100:]]).reshape(-1, 2)  # success, length
            success, length = recent.mean(0) if len(recent) else (0.0, 0.0)
            echo(
                f"step {step}: {len(episodes)} episodes, last-100 success {100 * success:.0f}%, mean "
                f"length {length:.1f}, {log['steps_per_second']:.0f} steps/s"
            )
    finally:
        venv.close()
    return agent, log


def _log(cfg: LoopConfig, step: int, seconds: float, episodes: list[list]) -> dict:
    return {
        "config": asdict(cfg),
        "steps": step,
        "seconds": round(seconds, 1),
        "steps_per_second": round(step / seconds, 1) if seconds else 0.0,
        "episodes": episodes,  # [step, success, return, length]
    }


def _save(out: Path, agent: Agent, log: dict) -> None:
    out.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    torch.save(agent.state_dict(), buf)
    atomic_write_bytes(out / "agent.pt", buf.getvalue())
    atomic_write_text(out / "train.json", json.dumps(log))


def _update(agent: Agent, opt, cfg: LoopConfig, next_obs, next_done, buf: dict) -> None:
    """GAE over the rollout, then ``epochs`` passes of clipped PPO over shuffled minibatches."""
    rew, done, val = buf["rew"], buf["done"], buf["val"]
    with torch.no_grad():
        next_value = agent.value(next_obs)
        adv = torch.zeros_like(rew)
        last = torch.zeros_like(next_value)
        for t in reversed(range(rew.shape[0])):
            not_done = 1.0 - (next_done if t == rew.shape[0] - 1 else done[t + 1])
            nv = next_value if t == rew.shape[0] - 1 else val[t + 1]
            delta = rew[t] + cfg.gamma * nv * not_done - val[t]
            last = delta + cfg.gamma * cfg.gae_lambda * not_done * last
            adv[t] = last
        ret = adv + val
    b_obs, b_mask = buf["obs"].flatten(0, 1), buf["mask"].flatten(0, 1)
    b_act, b_logp, b_adv, b_ret = buf["act"].flatten(), buf["logp"].flatten(), adv.flatten(), ret.flatten()
    size = b_act.shape[0]
    for _ in range(cfg.epochs):
        for idx in torch.randperm(size, device=b_act.device).split(cfg.minibatch):
            d = agent.dist(b_obs[idx], b_mask[idx])
            ratio = (d.log_prob(b_act[idx]) - b_logp[idx]).exp()
            a = b_adv[idx]
            a = (a - a.mean()) / (a.std() + 1e-8) if a.numel() > 1 else a
            pg = torch.max(-a * ratio, -a * ratio.clamp(1 - cfg.clip, 1 + cfg.clip)).mean()
            v_loss = 0.5 * ((agent.value(b_obs[idx]) - b_ret[idx]) ** 2).mean()
            loss = pg + cfg.vf_coef * v_loss - cfg.ent_coef * d.entropy().mean()
            opt.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(agent.parameters(), cfg.max_grad_norm)
            opt.step()


@torch.no_grad()
def evaluate(agent: Agent, cfg: LoopConfig, split: str, episodes: int) -> dict:
    """The greedy policy on the first ``episodes`` episodes of ``split`` in the env as registered: no
    ``StopShaping``, no masks, so STOP is the policy's own choice from the first step. ``timeouts``: the
    episodes that ran to the step limit without a STOP."""
    venv, _ = make_env(cfg, split, shaped=False)
    obs, _ = venv.reset(seed=0)  # the split's episodes from the first, whatever the training seed
    results: list[tuple[int, int, bool]] = []
    try:
        while len(results) < episodes:
            obs, _, term, trunc, info = venv.step(agent.act(obs))
            for i in torch.nonzero(term | trunc).flatten().tolist():
                final = info["final_info"]["episode"]
                results.append((int(final["success_once"][i]), int(final["episode_len"][i]), not term[i]))
    finally:
        venv.close()
    results = results[:episodes]
    return {
        "split": split,
        "episodes": len(results),
        "success_rate": float(np.mean([r[0] for r in results])),
        "mean_length": float(np.mean([r[1] for r in results])),
        "timeouts": sum(r[2] for r in results),
    }
