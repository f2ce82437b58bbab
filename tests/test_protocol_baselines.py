"""Lab-protocol baselines: the instruction parser (rule-based and LLM), the sub-goal chains,
the language agent, the harness's protocol records and aggregates, the report's table, the suite's stage and
the habitat exporter's refusal."""

from __future__ import annotations

import json
import math
from collections import Counter

import gymnasium as gym
import numpy as np
import pytest

import biovln_ms  # noqa: F401
from biovln_ms.splits import FOUR_CATEGORIES
from biovln_ms.episodes.dataset import EpisodeDataset
from biovln_ms.episodes.samplers import ProtocolEpisodes
from biovln_ms.episodes.writer import SplitPlan, write_dataset
from biovln_ms.errors import BioVLNError
from biovln_ms.eval.rollout import rollout
from biovln_ms.protocols import load_protocols
from biovln_ms.protocols.episodes import hosted_protocols
from biovln_ms.protocols.instructions import AmbiguousInstructionError, instruction, pick_instances
from biovln_ms.protocols.parser import InstructionParseError, Relation, parse_relation, parse_targets
from biovln_ms.protocols.vocabulary import load_vocabulary
from biovln_ms.scene.generator import generate_scene

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
SMALL = dict(camera_width=160, camera_height=120)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> str:
    """Protocol episodes of a single room (the four MS categories: the two single-room protocols), and a
    single-goal split of the same scene."""
    root = tmp_path_factory.mktemp("data") / "ds"
    scene = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
    library = load_protocols(env=False)
    plans = [
        SplitPlan("protocol_val", [(scene, 3, False)], sampler=ProtocolEpisodes(library)),
        SplitPlan("ms_val", [(scene, 2, False)]),
    ]
    write_dataset(root, plans, progress=False)
    return str(root)


def _generated_instructions(n: int):
    """``n`` instructions of the grammar over scenes of every template (relations of every kind)."""
    library = load_protocols(env=False)
    out = []
    for seed in range(700, 720):
        for template in ("open_plan", "suite", "two_room", "single_room"):
            scene = generate_scene(template, seed)
            rng = np.random.default_rng(seed)
            for protocol in hosted_protocols(scene, library):
                try:
                    visits = pick_instances(protocol, scene, rng)
                    out.append((scene, visits, instruction(protocol, scene, visits, rng)))
                except AmbiguousInstructionError:
                    continue
                if len(out) == n:
                    return out
    return out


# --- the rule parser ---------------------------------------------------------------------------------
def test_the_rule_parser_reads_back_200_generated_instructions():
    got = _generated_instructions(200)
    assert len(got) == 200
    kinds = Counter()
    vocab = load_vocabulary()
    for _, _, instr in got:
        want = [(t.category, t.relation) for t in instr.targets]
        parsed = parse_targets(instr.text)
        assert [t.pair() for t in parsed] == want, instr.text
        # the token sensor, decoded to words, reads the same
        assert [t.pair() for t in parse_targets(vocab.decode(vocab.encode(instr.text)))] == want
        kinds.update(t.relation.kind for t in parsed if t.relation)
    assert {"room", "wall", "side", "extreme"} <= set(kinds), kinds


def test_the_parser_knows_synonyms_case_and_structure():
    text = "PLEASE head to the Fridge, then visit the BSC by the north wall; lastly, go to the bin in room 3."
    parsed = parse_targets(text)
    assert [t.pair() for t in parsed] == [
        ("refrigerator", None),
        ("biosafety_cabinet", "by the north wall"),
        ("waste_bin", "in room 3"),
    ]
    assert parsed[1].relation == Relation("wall", direction="north")
    assert parsed[2].relation.room_ordinal == 2 and parse_relation("in room B").room_ordinal == 1
    support = parse_relation("on the lab bench farthest east")
    assert support == Relation("support", category="lab_bench", support=Relation("extreme", direction="east"))
    assert support.text == "on the lab bench farthest east"
    side = parse_relation("to the left of the mini centrifuge")
    assert (side.kind, side.direction, side.category) == ("side", "left", "mini_centrifuge")
    # a purpose naming an instrument is no visit
    only = parse_targets("Go to the centrifuge to spin the tubes from the refrigerator.")
    assert [t.pair() for t in only] == [("centrifuge", None)]


@pytest.mark.parametrize(
    "text, match",
    [
        ("Go to the zeppelin.", "names no instrument the catalog knows"),
        ("Go to the centrifuge near the window.", "cannot read 'near the window"),
        ("Spin the tubes.", "names no instrument to visit"),
    ],
)
def test_unreadable_instructions_are_one_line_errors(text, match):
    with pytest.raises(InstructionParseError, match=match) as err:
        parse_targets(text)
    assert "\n" not in str(err.value) and "field 'instruction'" in str(err.value) and "fix:" in str(err.value)
    with pytest.raises(InstructionParseError, match="not a relation of the grammar"):
        parse_relation("somewhere nice")


def test_pick_instances_draws_goal_objects_only():
    """Furniture of a visited category that is no goal (a plain bench) is never drawn."""
    library = load_protocols(env=False)
    checked = 0
    for seed in range(700, 712):
        scene = generate_scene("two_room", seed)
        goals = {o.id for o in scene.goal_objects()}
        furniture = {o.category for o in scene.objects() if o.id not in goals}
        for protocol in library:
            if not set(protocol.categories()) & furniture:
                continue
            rng = np.random.default_rng(seed)
            for _ in range(10):
                try:
                    visits = pick_instances(protocol, scene, rng)
                except AmbiguousInstructionError:
                    break
                assert set(visits) <= goals
                checked += 1
    assert checked > 0


# --- the LLM parser ----------------------------------------------------------------------------------
def _client(srv):
    from biovln_ms.llm.client import JSONChatClient, LLMConfig

    url = f"http://127.0.0.1:{srv.server_address[1]}/v1"
    return JSONChatClient(LLMConfig(url, "test-model", "sk-test", timeout=2.0, max_retries=0))


def test_the_llm_parser_against_a_loopback_server(openai_server):
    from biovln_ms.baselines.protocol.language import LLMInstructionParser

    text = "Go to the refrigerator, then visit the centrifuge by the west wall."
    categories = tuple(load_protocols(env=False).categories()) + ("biosafety_cabinet",)
    answers = {
        "ok": json.dumps(
            {
                "targets": [
                    {"category": "refrigerator", "relation": None},
                    {"category": "centrifuge", "relation": "by the west wall"},
                ]
            }
        ),
        "garbage": "the fridge, I think",
        "bad_category": json.dumps({"targets": [{"category": "fridge", "relation": None}]}),
    }
    openai_server.mode = "ok"
    openai_server.reply = lambda body: answers[openai_server.mode]
    parser = LLMInstructionParser(_client(openai_server))
    got = parser.parse(text, categories)
    assert [t.pair() for t in got] == [("refrigerator", None), ("centrifuge", "by the west wall")]
    assert json.loads(openai_server.requests[0]["body"]["messages"][1]["content"])["instruction"] == text
    assert parser.consulted == 1 and parser.fallbacks == 0
    # a malformed or invalid reply falls back to the rule parser, counted ...
    for mode in ("garbage", "bad_category"):
        openai_server.mode = mode
        fresh = LLMInstructionParser(_client(openai_server))
        assert [t.pair() for t in fresh.parse(text, categories)] == [t.pair() for t in parse_targets(text)]
        assert fresh.fallbacks == 1
    # ... or, without the fallback, is a one-line error naming what was wrong
    strict = LLMInstructionParser(_client(openai_server), fallback=False)
    openai_server.mode = "garbage"
    with pytest.raises(InstructionParseError, match=r"no valid target list \(not_json\)"):
        strict.parse(text, categories)
    openai_server.mode = "bad_category"
    with pytest.raises(InstructionParseError, match=r"\(invalid_answer\)"):
        strict.parse(text, categories)


def test_method_specs_and_the_parser_option(monkeypatch):
    from biovln_ms.eval.methods import METHODS, method_spec
    from biovln_ms.variants import PROTOCOL_ENV

    protocol = {m for m, s in METHODS.items() if s.env_id == PROTOCOL_ENV}
    assert protocol == {
        "protocol_oracle",
        "protocol_frontier",
        "protocol_vlfm",
        "protocol_vlfm_gt",
        "protocol_language",
    }
    assert [m for m in protocol if METHODS[m].privileged] == ["protocol_oracle"]
    spec = method_spec("protocol_language", {"parser": "rule"})
    spec.preflight(parser="rule")
    with pytest.raises(BioVLNError, match="unknown parser 'regex'"):
        spec.preflight(parser="regex")
    monkeypatch.delenv("BIOVLN_LLM_API_KEY", raising=False)
    monkeypatch.delenv("DEEPSEEK_API_KEY", raising=False)
    with pytest.raises(BioVLNError, match="BIOVLN_LLM_API_KEY"):
        spec.preflight(parser="llm")


# --- the env: what the oracles and the goal sensors see ------------------------------------------------
def test_the_privileged_view_and_the_goal_sensors_follow_the_current_subgoal(dataset):
    from biovln_ms.baselines.frontier import goal_from_sensor
    from biovln_ms.baselines.protocol.oracle import ProtocolOraclePolicy

    env = gym.make("BioVLN-Protocol-v0", dataset=dataset, split="protocol_val", obs_mode="state_dict", **CPU)
    try:
        policy = ProtocolOraclePolicy()
        u = env.unwrapped
        seen = []
        for st in rollout(env, policy, 0, privileged=True):
            j = int(st.info["subgoal_index"])
            if j >= int(st.info["num_goals"]):
                break
            view = policy.episode_info.privileged
            now = st.info["subgoal_position"][0].numpy()
            assert np.allclose(view.goal, now)
            goal = u.current_episode["goals"][j]
            assert view.success_radius == pytest.approx(goal["radius"])
            assert view.target.center_xy == pytest.approx(u.scene_spec.get(goal["object_id"]).position[:2])
            pose = st.info["agent_pose"][0].numpy().astype(float)
            sensed = goal_from_sensor(pose, st.obs["extra"]["pointgoal_with_gps_compass"][0].numpy())
            assert np.allclose(sensed, now, atol=1e-3)
            assert st.obs["extra"]["objectgoal"][0].argmax().item() == u.category_names.index(
                goal["object_category"]
            )
            seen.append(j)
        assert bool(st.info["success"]) and sorted(set(seen)) == list(range(int(st.info["num_goals"])))
    finally:
        env.close()


# --- the chains --------------------------------------------------------------------------------------
def test_a_robot_boxed_in_beside_an_instrument_plans_its_way_out():
    """A leg starts where the last STOP was, 0.15 m from an instrument's side (a single-goal robot gets there
    beside a wall it saw late): the grown obstacles cover the robot, so with the full growth its own cell is
    all it can reach and it would give up; the planner's escape rule reaches the goal."""
    from biovln_ms.baselines.frontier import FrontierParams, FrontierPolicy
    from biovln_ms.baselines.frontier.occupancy import FREE, OCCUPIED, OccupancyMap
    from biovln_ms.baselines.frontier.planner import FrontierPlanner, PlanField, boxed_in

    params = FrontierParams(robot_radius=0.2)
    occ = OccupancyMap(np.zeros(2), params.resolution, 20.0)
    r0, c0 = occ.cell(np.zeros(2))
    occ.grid[r0 - 40 : r0 + 41, c0 - 40 : c0 + 41] = FREE  # 4 m of known floor
    occ.grid[r0 - 10 : r0 + 11, c0 + 3] = OCCUPIED  # the instrument's side, 0.15 m east
    occ.lo, occ.hi = np.array([r0 - 40, c0 - 40]), np.array([r0 + 41, c0 + 41])
    rules = FrontierPolicy(params)
    rules.goal = np.array([-1.5, 0.0])
    assert boxed_in(occ, np.zeros(2), params.inflate_cells)
    assert PlanField.compute(occ, np.zeros(2), params.inflate_cells).reachable().sum() == 1
    out = FrontierPlanner(params, rules).plan(occ, np.zeros(3))
    assert out.mode == "goal" and np.linalg.norm(out.path[-1] - rules.goal) < 0.1 and len(out.path) > 10
    assert not boxed_in(occ, out.path[-1], params.inflate_cells)  # away from it, the full growth again


def test_the_oracle_chain_reaches_every_goal(dataset):
    from biovln_ms.baselines.protocol.oracle import ProtocolOraclePolicy

    env = gym.make("BioVLN-Protocol-v0", dataset=dataset, split="protocol_val", obs_mode="none", **CPU)
    try:
        for index in range(3):
            policy = ProtocolOraclePolicy()
            for st in rollout(env, policy, index, privileged=True):
                info = st.info
            k = int(info["num_goals"])
            assert bool(info["success"]) and float(info["progress"]) == 1.0
            assert info["stage_success"][0].tolist()[:k] == [True] * k
            assert len(policy.episode_stats()["leg_steps"]) == k
    finally:
        env.close()


@pytest.mark.slow
def test_the_frontier_chain_runs_an_episode_end_to_end(dataset):
    from biovln_ms.baselines.protocol.frontier import ProtocolFrontierPolicy

    env = gym.make(
        "BioVLN-Protocol-v0", dataset=dataset, split="protocol_val", obs_mode="rgbd", **SMALL, **CPU
    )
    try:
        policy = ProtocolFrontierPolicy()
        steps = 0
        for st in rollout(env, policy, 0):
            steps += st.action is not None
            info = st.info
        assert st.done and steps == int(info["steps"])
        stats = policy.episode_stats()
        assert sum(stats["leg_steps"]) == steps and len(stats["pose_estimates"]) == steps
        assert len(stats["leg_steps"]) == int(info["subgoal_index"]) + (not bool(info["success"]))
    finally:
        env.close()


@pytest.mark.slow
def test_the_language_agent_reads_the_instruction_not_the_goal_sensors(dataset):
    """It runs an episode with the goal sensors taken out of its observations, and parses the targets."""
    from biovln_ms.baselines.protocol.language import ProtocolLanguagePolicy

    env = gym.make(
        "BioVLN-Protocol-v0",
        dataset=dataset,
        split="protocol_val",
        obs_mode="depth+segmentation",
        **SMALL,
        **CPU,
    )
    hidden = ("pointgoal_with_gps_compass", "pointgoal", "objectgoal")
    try:
        policy = ProtocolLanguagePolicy()
        act = policy.act
        policy.act = lambda obs, info: act(
            {**obs, "extra": {k: v for k, v in obs["extra"].items() if k not in hidden}}, info
        )
        for st in rollout(env, policy, 0):
            info = st.info
        ep = env.unwrapped.current_episode
        stats = policy.episode_stats()
        assert [tuple(t) for t in stats["targets"]] == [
            (g["object_category"], r) for g, r in zip(ep["goals"], ep["protocol"]["relations"])
        ]
        assert st.done and float(info["progress"]) > 0.0
    finally:
        env.close()


# --- the harness, its aggregates and the report ------------------------------------------------------
def test_the_harness_runs_protocol_splits_and_refuses_the_other_kind(dataset, tmp_path):
    from biovln_ms.eval.harness import EvalConfig, evaluate, load_records

    cfg = EvalConfig("protocol_oracle", "protocol_val", str(tmp_path), dataset, workers=1)
    summary = evaluate(cfg, progress=False, echo=lambda *_: None)
    recs = load_records(cfg.run_dir / "episodes.jsonl")
    assert cfg.run_dir.parent.name == "protocol_oracle@protocol" and len(recs) == 3
    for r in recs:
        k = r["protocol"]["k"]
        assert r["success"] and r["progress"] == 1.0 and r["stage_success"] == [True] * k
        assert len(r["found_at"]) == k and r["found_at"][-1] == r["steps"] and r["wrong_stops"] == 0
        assert r["ppl"] > 0.5 and r["zone2_steps"] >= 0 and len(r["protocol"]["goals"]) == k
        assert "spl" not in r and "dtg" not in r
    o = summary["overall"]
    assert (o["episodes"], o["sr"], o["progress"], o["errors"]) == (3, 100.0, 1.0, 0)
    assert o["stage_sr"][:2] == [100.0, 100.0] and set(summary) >= {"per_protocol", "per_k"}
    assert json.loads((cfg.run_dir / "summary.json").read_text())["overall"]["ppl"] == pytest.approx(
        o["ppl"], abs=1e-5
    )
    with pytest.raises(BioVLNError, match="split 'ms_val' holds the other kind"):
        evaluate(EvalConfig("protocol_oracle", "ms_val", str(tmp_path), dataset, workers=1), progress=False)
    with pytest.raises(BioVLNError, match="runs single-goal episodes"):
        evaluate(EvalConfig("oracle", "protocol_val", str(tmp_path), dataset, workers=1), progress=False)
    with pytest.raises(BioVLNError, match="field 'record_dir'"):
        evaluate(EvalConfig("protocol_oracle", "protocol_val", str(tmp_path), record_dir=str(tmp_path)))
    with pytest.raises(BioVLNError, match="field 'handoff_dir': a hand-off is one goal's") as err:
        evaluate(EvalConfig("protocol_oracle", "protocol_val", str(tmp_path), handoff_dir=str(tmp_path)))
    assert "\n" not in str(err.value)


def _fake(index: int, k: int, reached: int, method: str = "protocol_frontier", **extra) -> dict:
    """A protocol record as the harness writes it: the first ``reached`` of ``k`` goals reached."""
    stage = [i < reached for i in range(k)]
    return {
        "success": reached == k,
        "progress": reached / k,
        "ppl": 0.8 * reached / k,
        "stage_success": stage,
        "subgoal_status": [1 if s else 0 for s in stage],
        "found_at": [10 * (i + 1) for i in range(reached)],
        "wrong_stops": int(reached < k),
        "out_of_budget": False,
        "zone2_steps": 2,
        "steps": 30,
        "mcr": 0.5,
        "vrt": 0.1,
        "collisions": 0,
        "path_length": 7.0,
        "positions": [[0.0, 0.0], [1.0, 0.0]],
        "method": method,
        "split": "protocol_val",
        "scene_id": "s",
        "episode_id": str(index),
        "index": index,
        "difficulty": "medium",
        "protocol": {"id": "p", "k": k, "route_length": 6.0, "needs_relation": 0, "goals": []},
        **extra,
    }


def test_protocol_aggregates_count_errored_episodes_as_failures():
    from biovln_ms.eval.aggregate import aggregate, aggregate_all, record_error

    recs = [_fake(0, 3, 3), _fake(1, 3, 1), _fake(2, 2, 2), {**_fake(3, 4, 0), "error": "RuntimeError: x"}]
    assert record_error(recs[0]) is None
    assert record_error({**recs[0], "ppl": math.nan}) == "metric 'ppl' is nan"
    a = aggregate(recs)
    assert (a["episodes"], a["errors"], a["successes"], a["sr"]) == (4, 1, 2, 50.0)
    assert a["progress"] == pytest.approx((1 + 1 / 3 + 1 + 0) / 4)
    assert a["ppl"] == pytest.approx(0.8 * (1 + 1 / 3 + 1) / 4)
    assert a["stage_episodes"] == [4, 4, 3, 1, 0]  # K = 3, 3, 2 and 4 (the errored one fails every stage)
    assert a["stage_sr"][:4] == pytest.approx([75.0, 50.0, 100 / 3, 0.0]) and math.isnan(a["stage_sr"][4])
    assert a["zone2_steps"] == 2.0 and a["wrong_stops"] == pytest.approx(1 / 3)
    lo, hi = a["sr_ci95"]
    assert 0 < lo < 50.0 < hi < 100
    assert set(aggregate_all(recs)["per_k"]) == {"2", "3", "4"}


def test_the_report_renders_the_lab_protocols_table_from_fake_records():
    from biovln_ms.eval.paper_tables import protocol_table
    from biovln_ms.eval.report import TABLES, summarize, tables_of

    runs = {
        ("protocol_oracle", "protocol_val"): [_fake(i, 3, 3, "protocol_oracle") for i in range(4)],
        ("protocol_frontier", "protocol_val"): [_fake(i, 3, i % 4) for i in range(4)],
        ("protocol_frontier", "protocol_test"): [_fake(i, 2, 2) for i in range(2)],
    }
    summ = summarize(runs, {"protocol_val": 160, "protocol_test": 160})  # the dataset's split sizes
    assert TABLES["protocols"] is protocol_table
    md = "\n".join(protocol_table(summ))
    assert md.startswith("## Lab protocols: ours [95 % CI]")
    assert "**protocol_val** (full split: 160 episodes)" in md and "**protocol_test**" in md
    assert "| Protocol Oracle (privileged) | partial (4/160) | 100.0 [51.0, 100.0] | 1.000 [" in md
    row = next(line for line in md.splitlines() if line.startswith("| Protocol Frontier | partial (4/160)"))
    # stages: 3 of 4 reached goal 1, 2 of 4 goal 2, 1 of 4 goal 3; no episode has a 4th or 5th goal
    assert "| 75.0; n=4 | 50.0; n=4 | 25.0; n=4 | – | – |" in row
    assert md.index("Protocol Oracle") < md.index("| Protocol Frontier")
    assert any(block for block in tables_of(summ))  # every table renders beside it
    assert protocol_table(summarize({})) == []


def test_the_report_plots_each_protocol_runs_stage_success(tmp_path):
    from matplotlib.image import imread

    from biovln_ms.eval.figures import plot_protocol_stages
    from biovln_ms.eval.report import summarize

    runs = {
        ("protocol_oracle", "protocol_val"): [_fake(i, 3, 3, "protocol_oracle") for i in range(4)],
        ("protocol_frontier", "protocol_test"): [_fake(i, 2, i % 3) for i in range(3)],
    }
    png = plot_protocol_stages(summarize(runs, {"protocol_val": 4}), tmp_path / "stages.png")
    assert png == tmp_path / "stages.png" and imread(png).shape[1] > 1000  # two panels side by side
    assert plot_protocol_stages(summarize({}), tmp_path / "none.png") is None
    assert not (tmp_path / "none.png").exists()


def test_the_suite_runs_the_protocol_methods_on_the_protocol_splits_ideal_only():
    from biovln_ms.eval.suite import PROTOCOL_METHODS, PROTOCOL_SPLITS, plan

    runs = plan(
        ["oracle", "protocol_oracle", "protocol_frontier"],
        ["ms_val"],
        ["ideal", "realistic"],
        False,
        people=False,
    )
    assert [r.key for r in runs] == [
        "oracle/ms_val/ideal",
        "oracle/ms_val/realistic",
        "protocol_oracle/protocol_val/ideal",
        "protocol_oracle/protocol_test/ideal",
        "protocol_frontier/protocol_val/ideal",
        "protocol_frontier/protocol_test/ideal",
    ]
    assert PROTOCOL_SPLITS == ("protocol_val", "protocol_test") and "protocol_language" in PROTOCOL_METHODS


def test_the_habitat_exporter_refuses_a_protocol_split(dataset, tmp_path):
    from biovln_ms.bridges.habitat import export_habitat

    with pytest.raises(BioVLNError, match="field 'split': split 'protocol_val' holds protocol") as err:
        export_habitat(EpisodeDataset(dataset), "protocol_val", tmp_path / "out")
    assert "\n" not in str(err.value) and not (tmp_path / "out").exists()
