"""The learning guide's PPO recipe end to end, a few thousand steps of each loop: the ManiSkill-style loop
on ManiSkillVectorEnv (STOP masked and penalised in the first half), SB3 PPO with the STOP penalty, each
evaluated in the env as registered, and the report that turns their run folders into the guide's table,
curves and figure."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
import torch

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def dataset(held_out_dataset):
    return held_out_dataset(train=4, ms_val=3)


@pytest.mark.slow
def test_both_loops_train_evaluate_unshaped_and_report(dataset, tmp_path):
    from biovln_ms.eval.learned import train_and_evaluate
    from biovln_ms.learning.ppo_loop import Agent, LoopConfig, evaluate, train
    from biovln_ms.learning.rl import RLConfig

    small = dict(rollout=512, minibatch=128, epochs=2)
    cfg = LoopConfig(
        steps=2048, stop_mask_steps=5, stop_penalty=10.0, stop_shaping_steps=1024, dataset=dataset, **small
    )
    agent, log = train(cfg, tmp_path / "loop", echo=lambda s: None)
    episodes = log["episodes"]  # [step, success, return, length]
    assert log["steps"] == 2048 and episodes
    shaped = [e for e in episodes if e[0] <= 1024]  # ended while the settings applied
    plain = [e for e in episodes if e[0] - e[3] >= 1024]  # began after they ended
    assert shaped and min(e[3] for e in shaped) > cfg.stop_mask_steps  # no STOP in the first 5 steps
    assert plain and min(e[3] for e in plain) <= cfg.stop_mask_steps  # STOP allowed from the first step
    # a failed STOP cost a success's worth (normalised: 1), more than any progress made (at most 0.8)
    assert all(e[2] < 0 for e in shaped if not e[1] and e[3] < 500)
    saved = Agent(26, 4)
    saved.load_state_dict(torch.load(tmp_path / "loop" / "agent.pt", weights_only=True))
    ev = evaluate(agent, cfg, "ms_val", 2)
    assert ev["episodes"] == 2 and 0.0 <= ev["success_rate"] <= 1.0
    (tmp_path / "loop" / "eval.json").write_text(json.dumps(ev))

    sb3 = RLConfig(
        timesteps=2048,
        n_envs=1,
        dataset=dataset,
        stop_penalty=10.0,
        eval_episodes=2,
        hyperparams={"n_steps": 512, "batch_size": 128},
    )
    r = train_and_evaluate(sb3, tmp_path / "sb3", echo=lambda s: None, progress=False)
    assert r.timesteps >= 2048 and r.eval_summary["overall"]["episodes"] == 2  # the harness: no shaping

    data, image = tmp_path / "data", tmp_path / "curves.png"
    cmd = [
        sys.executable,
        str(ROOT / "benchmarks" / "ppo_recipe.py"),
        "report",
        "--steps",
        "2000",
        "--window",
        "500",
    ]
    cmd += ["--data-out", str(data), "--image", str(image), str(tmp_path / "sb3"), str(tmp_path / "loop")]
    subprocess.run(cmd, check=True, capture_output=True, cwd=tmp_path)
    table = json.loads((data / "ppo_recipe.json").read_text())
    assert [row[:2] for row in table["rows"]] == [
        ["SB3 (1 env)", "failed STOP -10"],
        ["ManiSkill-style (1 env)", "STOP masked 5 steps, failed STOP -10 in the first 1.024k steps"],
    ]
    curves = json.loads((data / "ppo_curves.json").read_text())["runs"]
    assert table["columns"][2:6] == ["0–0.5k", "0.5–1k", "1–1.5k", "1.5–2k"]
    assert [[p[0] for p in c["curve"]] for c in curves] == [[500, 1000, 1500, 2000]] * 2
    assert sum(p[2] for p in curves[1]["curve"]) == sum(e[0] <= 2000 for e in episodes)
    assert image.read_bytes()[:4] == b"\x89PNG"
