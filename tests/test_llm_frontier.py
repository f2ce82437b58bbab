"""The LLM client and LLM-Frontier against a local OpenAI-compatible server on loopback."""

import json
import logging
import subprocess
import sys
import time

import numpy as np
import pytest

from biovln_ms.llm.client import JSONChatClient, LLMConfig, LLMConfigError

SECRET = "sk-test-secret-123"


CONTENT = {
    "choice1": '{"choice": 1}',
    "garbage": "I would go left",
    "out_of_range": '{"choice": 7}',
    "slow": '{"choice": 0}',
    "zero": '{"choice": 0}',
}


@pytest.fixture
def server(openai_server):
    """The shared loopback endpoint, answering by ``server.mode``."""
    openai_server.mode = "choice1"

    def reply(body):
        if openai_server.mode == "slow":
            time.sleep(1.5)
        return CONTENT[openai_server.mode]

    openai_server.reply = reply
    return openai_server


def client_for(srv, **kw):
    url = f"http://127.0.0.1:{srv.server_address[1]}/v1"
    cfg = LLMConfig(url, "deepseek-chat", SECRET, timeout=1.0, max_retries=0)
    return JSONChatClient(cfg, **kw)


def test_json_answer_temperature_zero_and_cache(server, tmp_path, caplog):
    caplog.set_level(logging.DEBUG)
    c = client_for(server, cache_path=tmp_path / "cache.jsonl")

    def ok(o: dict) -> bool:
        return isinstance(o.get("choice"), int)

    assert c.ask("sys", "which?", ok) == {"choice": 1}
    req = server.requests[0]
    assert req["path"] == "/v1/chat/completions" and req["auth"] == f"Bearer {SECRET}"
    assert req["body"]["temperature"] == 0 and req["body"]["response_format"] == {"type": "json_object"}
    assert c.ask("sys", "which?", ok) == {"choice": 1} and len(server.requests) == 1  # cached
    assert c.stats.calls == 1 and c.stats.cache_hits == 1
    c2 = client_for(server, cache_path=tmp_path / "cache.jsonl")  # the cache persists
    assert c2.ask("sys", "which?", ok) == {"choice": 1} and len(server.requests) == 1
    assert SECRET not in repr(c.config) and SECRET not in caplog.text


def test_garbage_out_of_range_timeout_and_down_are_counted(server):
    c = client_for(server)

    def valid(o: dict) -> bool:
        return isinstance(o.get("choice"), int) and 0 <= o["choice"] < 3

    server.mode = "garbage"
    assert c.ask("s", "a", valid) is None
    server.mode = "out_of_range"
    assert c.ask("s", "b", valid) is None
    server.mode = "slow"
    assert c.ask("s", "c", valid) is None
    assert c.stats.failure_kinds["not_json"] == 1 and c.stats.failure_kinds["invalid_answer"] == 1
    assert c.stats.failures == 3
    port = server.server_address[1]
    server.shutdown()
    server.server_close()
    down = JSONChatClient(LLMConfig(f"http://127.0.0.1:{port}/v1", "m", SECRET, timeout=0.5, max_retries=0))
    assert down.ask("s", "d") is None and down.stats.failures == 1


def test_no_endpoint_refuses_clearly(monkeypatch, tmp_path):
    monkeypatch.delenv("BIOVLN_LLM_API_KEY", raising=False)
    monkeypatch.delenv("DEEPSEEK_API_KEY", raising=False)
    with pytest.raises(LLMConfigError, match="no LLM endpoint configured"):
        LLMConfig.from_env()
    env = {
        k: v
        for k, v in __import__("os").environ.items()
        if k not in ("BIOVLN_LLM_API_KEY", "DEEPSEEK_API_KEY")
    }
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "biovln_ms.cli",
            "eval",
            "--method",
            "llm_frontier",
            "--split",
            "ms_val",
            "-o",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        env=env,
    )
    assert r.returncode == 2 and "LLM-Frontier numbers are not reported" in r.stderr


class _Stub:
    def __init__(self, answer):
        self.answer, self.prompts = answer, []

    def ask(self, system, user, validate):
        self.prompts.append(json.loads(user))
        return self.answer if self.answer is not None and validate(self.answer) else None


def test_choice_among_near_equidistant_frontiers():
    from biovln_ms.baselines.frontier.planner import Candidate
    from biovln_ms.baselines.llm_frontier import LLMFrontierPolicy

    cands = [
        Candidate(2.0, np.array([1.0, 1.0]), 20),
        Candidate(2.5, np.array([5.0, 1.0]), 30),
        Candidate(2.9, np.array([1.0, 5.0]), 15),
        Candidate(6.0, np.array([9.0, 9.0]), 40),
    ]
    pol = LLMFrontierPolicy(client=_Stub({"choice": 2}))
    pol.category = "refrigerator"
    assert np.allclose(pol.choose(cands, np.array([0.0, 0.0, 0.0])), [1.0, 5.0])
    prompt = pol.client.prompts[0]
    assert prompt["target_instrument"] == "refrigerator" and len(prompt["frontiers"]) == 3  # top-3 within 1 m
    pol = LLMFrontierPolicy(client=_Stub({"choice": 9}))  # invalid -> nearest, counted
    pol.category = "cabinet"
    assert np.allclose(pol.choose(cands, np.zeros(3)), [1.0, 1.0]) and pol.fallbacks == 1
    pol = LLMFrontierPolicy(client=_Stub({"choice": 0}))
    pol.category = "cabinet"
    assert np.allclose(pol.choose(cands[:1] + cands[3:], np.zeros(3)), [1.0, 1.0]) and pol.consulted == 0


def test_llm_frontier_runs_an_episode_against_the_local_server(server):
    import gymnasium as gym

    import biovln_ms  # noqa: F401
    from biovln_ms.baselines.llm_frontier import LLMFrontierPolicy

    server.mode = "zero"
    env = gym.make(
        "BioVLN-OpFace-v0",
        obs_mode="rgbd",
        camera_width=320,
        camera_height=240,
        sim_backend="physx_cpu",
        render_backend="cpu",
    )
    pol = LLMFrontierPolicy(client=client_for(server))
    obs, info = env.reset(seed=3)
    pol.reset(env.unwrapped.episode_info())
    for _ in range(500):
        obs, _, term, trunc, info = env.step(pol.act(obs, info))
        if bool(term) or bool(trunc):
            break
    env.close()
    assert bool(term) or bool(trunc)
    assert pol.episode_stats()["llm_consulted"] == len(server.requests) + pol.client.stats.cache_hits


@pytest.mark.slow
def test_llm_frontier_runs_with_people_through_the_harness(server, monkeypatch, held_out_dataset, tmp_path):
    """LLM-Frontier on the busy variant, configured from the environment as ``biovln-ms eval`` is, against
    the loopback endpoint: it finishes the episodes, and its records carry the people's measures."""
    from biovln_ms.eval.harness import EvalConfig, evaluate, load_records

    monkeypatch.setenv("BIOVLN_LLM_API_KEY", SECRET)
    monkeypatch.setenv("BIOVLN_LLM_BASE_URL", f"http://127.0.0.1:{server.server_address[1]}/v1")
    monkeypatch.setenv("BIOVLN_LLM_CACHE", str(tmp_path / "llm.jsonl"))  # no answer cached before
    server.mode = "zero"
    ds = held_out_dataset(ms_val=2)
    cfg = EvalConfig(
        "llm_frontier",
        "ms_val",
        str(tmp_path),
        ds,
        env_id="BioVLN-OpFace-Busy-v0",
        workers=1,
        camera=(320, 240),
        max_episodes=2,
    )
    summary = evaluate(cfg, progress=False)
    assert summary["overall"]["episodes"] == 2 and summary["overall"]["errors"] == 0
    recs = load_records(cfg.run_dir / "episodes.jsonl")
    assert len(recs) == 2
    assert all(r["env_id"] == "BioVLN-OpFace-Busy-v0" and r["min_person_distance"] > 0 for r in recs)
    assert all("person_collisions" in r and r["policy_stats"]["llm_fallbacks"] == 0 for r in recs)
    assert len(server.requests) <= sum(r["policy_stats"]["llm_consulted"] for r in recs)  # the rest: cached
