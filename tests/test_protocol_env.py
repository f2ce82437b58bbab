"""BioVLN-Protocol-v0: the goal-switching rule and the protocol metrics on
hand-computed trajectories (pure measures, no simulator), then the env on the CPU: an oracle that reaches
every goal, a wrong STOP that ends or misses, the strict rule, the step budget, the instruction in the
observation, and the refusal of an episode of the other kind."""

from __future__ import annotations

import math
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
import torch

import biovln_ms  # noqa: F401
from biovln_ms.splits import FOUR_CATEGORIES
from biovln_ms.episodes.samplers import ProtocolEpisodes
from biovln_ms.episodes.writer import SplitPlan, write_dataset
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.zones import PlacedInstrument
from biovln_ms.metrics.measure_set import MeasureSet
from biovln_ms.metrics.measures import StepState
from biovln_ms.metrics.protocol_measures import (
    MISSED,
    NONE,
    PENDING,
    REACHED,
    ProtocolBatchContext,
    ProtocolEpisodeContext,
)
from biovln_ms.protocols import load_protocols
from biovln_ms.protocols.vocabulary import decode_text, load_vocabulary, tokenize
from biovln_ms.scene.generator import generate_scene
from biovln_ms.variants import VARIANTS

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
PROTOCOL = VARIANTS["BioVLN-Protocol-v0"]
NAMES = PROTOCOL.measures + ("protocol_reward", "protocol_fail")

# --- the measures on hand-computed trajectories ---------------------------------------------------
# Two 1 x 1 m instruments facing -Y: A at the origin (goal (0, -1.1)) and B at (4, 0) (goal (4, -1.1)), both
# with r = 0.8. Geodesics are straight lines. From the start (0, -4.1) the ordered route A -> B is 3 + 4 m.
A = PlacedInstrument((0.0, 0.0, 0.5), 0.0, (1.0, 1.0, 1.0), (0.0, -1.0), 0.5, 0.6, "a_0", "cabinet")
B = PlacedInstrument((4.0, 0.0, 0.5), 0.0, (1.0, 1.0, 1.0), (0.0, -1.0), 0.5, 0.6, "b_0", "refrigerator")
GA, GB, START = np.array([0.0, -1.1]), np.array([4.0, -1.1]), np.array([0.0, -4.1])
NORTH = math.pi / 2


def _line(g):
    return lambda p: float(np.linalg.norm(np.asarray(p, float)[:2] - g))


def protocol_ctx(goals=((GA, A), (GB, B)), start=START) -> ProtocolEpisodeContext:
    (g0, t0), *rest = goals
    ends = [g for g, _ in goals]
    route = float(np.linalg.norm(ends[0] - start)) + sum(
        float(np.linalg.norm(b - a)) for a, b in zip(ends, ends[1:])
    )
    return ProtocolEpisodeContext(
        goal=g0,
        success_radius=0.8,
        target=t0,
        instruments=[A, B],
        geodesic=_line(g0),
        start_geodesic=float(np.linalg.norm(g0 - start)),
        hfov=math.radians(79),
        other_goals=tuple((g, 0.8, t) for g, t in rest),
        goal_geodesics=tuple(_line(g) for g in ends),
        route_length=route,
    )


def row(p, yaw=NORTH, stop=False, moved=0.25) -> StepState:
    f = lambda v: np.array(v, dtype=np.float64)  # noqa: E731
    return StepState(f([p]), f([yaw]), np.array([stop]), f([0.0 if stop else 0.25]), f([moved]))


class Run:
    """One sub-env stepped by hand; ``history`` keeps every step's reward."""

    def __init__(self, cfg=PROTOCOL, ctx=None, start=START):
        self.m, self.b = MeasureSet(NAMES, 1, cfg=cfg), ProtocolBatchContext(1)
        self.b.set(0, ctx or protocol_ctx())
        self.m.reset(self.b, row(start, moved=0.0))
        self.rewards: list[float] = []

    def step(self, p, yaw=NORTH, stop=False):
        self.m.update(self.b, row(p, yaw, stop, 0.0 if stop else 0.25))
        self.rewards.append(float(self.m["protocol_reward"][0]))
        return self

    def walk(self, a, b, yaw=NORTH):
        """FORWARD steps of 0.25 m from ``a`` (exclusive) to ``b`` (inclusive)."""
        a, b = np.asarray(a, float), np.asarray(b, float)
        n = round(float(np.linalg.norm(b - a)) / 0.25)
        for k in range(1, n + 1):
            self.step(a + (b - a) * k / n, yaw)
        return self

    def __getitem__(self, name):
        value = self.m[name][0]
        return value.tolist() if value.ndim else value.item()


def test_a_correct_stop_advances_and_the_oracle_route_scores_ppl_one():
    r = Run()
    assert r["subgoal_index"] == 0 and r["num_goals"] == 2 and r["step_budget"] == 1000
    assert r["subgoal_status"] == [PENDING, PENDING, NONE, NONE, NONE]
    assert r["distance_to_subgoal"] == pytest.approx(3.0) and r["subgoal_position"] == [0.0, -1.1]
    r.walk(START, GA)
    assert r["subgoal_index"] == 0 and not r["subgoal_found"] and r["steps"] == 12
    r.step(GA, stop=True)  # FOUND at A
    assert r["subgoal_found"] and not r["wrong_stop"] and r["subgoal_index"] == 1
    assert r["subgoal_status"][:2] == [REACHED, PENDING] and r["progress"] == 0.5
    assert not r["protocol_success"] and not r["protocol_fail"]
    assert r["distance_to_subgoal"] == pytest.approx(4.0) and r["subgoal_position"] == [4.0, -1.1]
    assert r["geodesic_distance_to_subgoal"] == pytest.approx(4.0)  # re-queried: the goal changed
    assert r.rewards[-1] == pytest.approx(10.0 - 0.01)  # the bonus; the switch itself pays no progress
    r.walk(GA, GB, yaw=0.0)
    assert r.rewards[-1] == pytest.approx(0.25 - 0.01)  # progress towards B now
    r.step(GB, yaw=NORTH, stop=True)
    assert r["protocol_success"] and r["progress"] == 1.0 and r["subgoal_index"] == 2
    assert r["stage_success"] == [True, True, False, False, False]
    assert r["path_length"] == pytest.approx(7.0) and r["ppl"] == pytest.approx(1.0)
    assert r["steps"] == 12 + 1 + 16 + 1 and r["zone2_steps"] == 0
    assert r["mcr"] == pytest.approx(0.6)  # 0.6 m from A's and B's bodies along y = -1.1


def test_ppl_weighs_progress_by_the_whole_route():
    r = Run().walk(START, (0.0, -5.1)).walk((0.0, -5.1), START)  # a 2 m detour first
    r.walk(START, GA).step(GA, stop=True)
    assert r["progress"] == 0.5 and r["path_length"] == pytest.approx(5.0)
    assert r["ppl"] == pytest.approx(0.5 * 7.0 / 7.0)  # l = 5 m < L = 7 m
    r.walk(GA, GB, yaw=0.0).step(GB, stop=True)
    assert r["ppl"] == pytest.approx(7.0 / 9.0)  # l = 9 m


def test_a_wrong_stop_ends_the_episode():
    r = Run().step(START, stop=True)
    assert r["wrong_stop"] and r["protocol_fail"] and not r["protocol_success"]
    assert r["subgoal_index"] == 0 and r["subgoal_status"][:2] == [PENDING, PENDING]
    assert r["progress"] == 0.0 and r["ppl"] == 0.0 and r.rewards[-1] == pytest.approx(-0.01)


def test_a_wrong_stop_is_a_miss_with_wrong_stop_miss():
    r = Run(replace(PROTOCOL, wrong_stop="miss")).step(START, stop=True)
    assert r["wrong_stop"] and not r["protocol_fail"] and r["subgoal_index"] == 1
    assert r["subgoal_status"][:2] == [MISSED, PENDING] and r["distance_to_subgoal"] == pytest.approx(5.0)
    r.walk(START, (4.0, -4.1), yaw=0.0).walk((4.0, -4.1), GB).step(GB, stop=True)  # 4 + 3 m
    assert r["subgoal_found"] and r["subgoal_status"][:2] == [MISSED, REACHED]
    assert r["protocol_fail"] and not r["protocol_success"]  # every goal done, one missed
    assert r["progress"] == 0.5 and r["ppl"] == pytest.approx(0.5 * 7.0 / 7.0)
    assert r["stage_success"][:2] == [False, True]


@pytest.mark.parametrize(
    "yaw_deg, at, radius_ok, strict_ok",
    [
        (90, GA, True, True),  # looking straight at A's face (-f = +y)
        (90 + 31, GA, True, False),  # turned away from the face
        (90, (0.6, -1.0), True, False),  # within r, beside Zone 3
    ],
)
def test_strict_rule_needs_zone3_and_the_face(yaw_deg, at, radius_ok, strict_ok):
    for rule, ok in (("radius", radius_ok), ("strict", strict_ok)):
        r = Run(replace(PROTOCOL, subgoal_rule=rule)).step(at, yaw=math.radians(yaw_deg), stop=True)
        assert r["subgoal_found"] == ok and r["wrong_stop"] == (not ok), rule
    assert VARIANTS["BioVLN-Protocol-Strict-v0"].subgoal_rule == "strict"


def test_the_step_budget_scales_with_k():
    cfg = replace(PROTOCOL, steps_per_goal=3)
    r = Run(cfg)
    for _ in range(5):
        r.step(START)
    assert r["step_budget"] == 6 and not r["out_of_budget"] and not r["protocol_fail"]
    r.step(START)
    assert r["out_of_budget"] and r["protocol_fail"]
    three = protocol_ctx(((GA, A), (GB, B), (GA, A)))
    assert Run(cfg, three)["step_budget"] == 9 and PROTOCOL.max_episode_steps == 500 * 5


def test_zone2_steps_count_steps_inside_zone2():
    r = Run(start=(1.5, 0.0))
    for p in [(0.9, 0.0), (0.7, 0.0), (0.6, 0.0), (1.5, 0.0)]:  # 0.4, 0.2, 0.1, 1.0 m from A's body
        r.step(p, yaw=math.pi)
    assert r["zone2_steps"] == 2 and r["vrt"] == pytest.approx(3 / 5) and r["mcr"] == pytest.approx(0.1)


def test_a_batch_equals_single_runs_and_partial_resets_keep_other_rows():
    contexts = [protocol_ctx(), protocol_ctx(((GB, B), (GA, A), (GB, B)))]
    rng = np.random.default_rng(0)
    steps = [
        (np.array([rng.uniform(-1, 5, 2) for _ in contexts]), rng.uniform(-3, 3, 2), rng.random(2) < 0.15)
        for _ in range(40)
    ]
    states = [StepState(p, y, s, np.where(s, 0.0, 0.25), np.where(s, 0.0, 0.25)) for p, y, s in steps]
    start = StepState.at_rest(np.array([[0.0, -4.1, NORTH], [4.0, -4.1, NORTH]]))
    cfg = replace(PROTOCOL, wrong_stop="miss")
    batch, b = MeasureSet(NAMES, 2, cfg=cfg), ProtocolBatchContext(2)
    for i, c in enumerate(contexts):
        b.set(i, c)
    batch.reset(b, start)
    history = []
    for s in states:
        batch.update(b, s)
        history.append({k: batch[k].copy() for k in NAMES})
    for i, c in enumerate(contexts):
        single, sb = MeasureSet(NAMES, 1, cfg=cfg), ProtocolBatchContext(1)
        sb.set(0, c)

        def one(s, i=i):
            return StepState(
                *(a[[i]] for a in (s.position, s.yaw, s.stopped, s.commanded_forward, s.moved_forward))
            )

        single.reset(sb, one(start))
        for t, s in enumerate(states):
            single.update(sb, one(s))
            for k in NAMES:
                assert np.array_equal(single[k][0], history[t][k][i]), (i, t, k)
    before = {k: batch[k].copy() for k in NAMES}
    batch.reset(b, start, torch.tensor([1]))
    for k in NAMES:
        assert np.array_equal(batch[k][0], before[k][0]), k
    assert batch["subgoal_index"][1] == 0 and batch["steps"][1] == 0


def test_state_dict_round_trip_continues_identically():
    a = Run()
    a.walk(START, GA).step(GA, stop=True)
    b = Run()
    b.m.load_state_dict(a.m.state_dict())
    for r in (a, b):
        r.walk(GA, GB, yaw=0.0).step(GB, stop=True)
    for k in NAMES:
        assert np.array_equal(a.m[k], b.m[k]), k


def test_bad_protocol_options_are_one_line():
    for field, value in (("wrong_stop", "skip"), ("subgoal_rule", "near"), ("steps_per_goal", 0)):
        with pytest.raises(BioVLNError) as e:
            MeasureSet(NAMES, 1, cfg=replace(PROTOCOL, **{field: value}))
        assert f"field '{field}'" in str(e.value) and "\n" not in str(e.value) and "fix:" in str(e.value)


# --- the env --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """A protocol split (a two-room scene and a single room) and a single-goal split."""
    root = tmp_path_factory.mktemp("data") / "ds"
    two = generate_scene("two_room", 700)
    single = generate_scene("single_room", 700, required_categories=FOUR_CATEGORIES)
    held = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
    library = load_protocols(env=False)
    write_dataset(
        root,
        [
            SplitPlan(
                "protocol_val", [(two, 4, False), (single, 2, False)], sampler=ProtocolEpisodes(library)
            ),
            SplitPlan("ms_val", [(held, 2, False)]),
        ],
        progress=False,
    )
    return str(root)


def make(dataset, env_id="BioVLN-Protocol-v0", **kw):
    kw = {"obs_mode": "state_dict", "reward_mode": "dense", **kw}
    return gym.make(env_id, dataset=dataset, split="protocol_val", **CPU, **kw)


@pytest.fixture(scope="module")
def env(dataset):
    e = make(dataset)
    yield e
    e.close()


def teleport(u, xy, yaw=0.0):
    u.agent.reset_planar(torch.tensor([[float(xy[0]), float(xy[1]), float(yaw)]]))


def test_registered_with_a_budget_bound_of_five_goals():
    assert {"BioVLN-Protocol-v0", "BioVLN-Protocol-Strict-v0", "BioVLN-Protocol-Busy-v0"} <= set(gym.registry)
    import biovln_ms.tasks  # noqa: F401
    from mani_skill.utils.registration import REGISTERED_ENVS

    from biovln_ms.tasks.protocol_env import BioVLNProtocolEnv

    for uid in ("BioVLN-Protocol-v0", "BioVLN-Protocol-Strict-v0", "BioVLN-Protocol-Busy-v0"):
        assert issubclass(REGISTERED_ENVS[uid].cls, BioVLNProtocolEnv)
        assert REGISTERED_ENVS[uid].max_episode_steps == PROTOCOL.steps_per_goal * 5


def test_instruction_is_in_the_observation(env):
    obs, info = env.reset(options={"episode_index": 0})
    u, vocab = env.unwrapped, load_vocabulary()
    text = u.current_episode["protocol"]["instruction"]
    tokens, raw = obs["extra"]["instruction"][0].numpy(), obs["extra"]["instruction_text"][0].numpy()
    assert tokens.shape == (vocab.max_tokens,) and raw.shape == (vocab.max_text_bytes,)
    assert tokens.dtype == np.int32 and raw.dtype == np.uint8
    assert decode_text(raw) == text and vocab.decode(tokens) == " ".join(tokenize(text))
    assert 1 not in tokens.tolist() and tokens[len(tokenize(text)) :].tolist() == [0] * (
        vocab.max_tokens - len(tokenize(text))
    )
    assert u.episode_info().instruction == text
    assert int(info["num_goals"]) == len(u.current_episode["goals"]) == u.current_episode["protocol"]["k"]


def _goal_heading(goal: dict) -> float:
    """The yaw of the goal's first view point (it faces the instrument)."""
    w, _, _, z = goal["view_points"][0]["agent_state"]["rotation"]
    return 2 * math.atan2(z, w)


def test_an_oracle_reaches_every_goal_in_order(env):
    """A scripted oracle: the exact shortest-path follower to each goal in turn, STOP at each."""
    from biovln_ms.baselines.oracle import PointFollower

    obs, info = env.reset(options={"episode_index": 0})
    u = env.unwrapped
    ep, view, task = u.current_episode, u.episode_info(privileged=True).privileged, u.task_spec()
    k = len(ep["goals"])
    total = 0.0
    for j, goal in enumerate(ep["goals"]):
        assert int(info["subgoal_index"]) == j
        g = np.asarray(goal["position"][:2])
        assert np.allclose(info["subgoal_position"][0].numpy(), g)
        cat = u.category_names.index(goal["object_category"])
        assert obs["extra"]["objectgoal"][0].argmax().item() == cat  # the current goal's category
        follower = PointFollower(view, task, g)
        for _ in range(400):
            action = follower.step()
            if action == 0:
                break
            obs, r, term, trunc, info = env.step(action)
            total += float(r)
            assert not bool(term)
        d = float(np.linalg.norm(u.agent.planar_pose()[0][:2] - g))
        rho = float(obs["extra"]["pointgoal_with_gps_compass"][0, 0])
        assert rho == pytest.approx(d, abs=1e-3)  # the pointgoal sensor follows the current goal
        assert d <= goal["radius"], (j, d)
        obs, r, term, trunc, info = env.step(0)
        total += float(r)
        assert bool(info["subgoal_found"]) and float(r) > 9.0
        assert bool(term) == (j == k - 1)
    assert bool(info["success"]) and not bool(info["fail"]) and float(info["progress"]) == 1.0
    assert info["stage_success"][0].tolist() == [True] * k + [False] * (5 - k)
    route = ep["protocol"]["route_length"]
    ppl = route / max(float(info["path_length"]), route)
    assert float(info["ppl"]) == pytest.approx(ppl, abs=1e-5) and 0.5 < ppl <= 1.0
    assert int(info["steps"]) < int(info["step_budget"]) == 500 * k
    _, r, _, _, after = env.step(1)  # ended: nothing changes
    assert float(r) == 0.0 and int(after["steps"]) == int(info["steps"])


def test_a_wrong_stop_ends_or_misses(dataset, env):
    env.reset(options={"episode_index": 1})
    _, _, term, _, info = env.step(0)  # the start is outside the first goal's radius
    assert bool(term) and bool(info["fail"]) and bool(info["wrong_stop"]) and int(info["subgoal_index"]) == 0
    e = make(dataset, wrong_stop="miss")
    try:
        e.reset(options={"episode_index": 1})
        u, goals = e.unwrapped, e.unwrapped.current_episode["goals"]
        _, _, term, _, info = e.step(0)
        assert (
            not bool(term) and int(info["subgoal_index"]) == 1 and int(info["subgoal_status"][0, 0]) == MISSED
        )
        for j, goal in enumerate(goals[1:], 1):
            teleport(u, goal["position"], _goal_heading(goal))
            _, _, term, _, info = e.step(0)
            assert bool(info["subgoal_found"]) and bool(term) == (j == len(goals) - 1)
        assert bool(info["fail"]) and not bool(info["success"])
        assert float(info["progress"]) == pytest.approx((len(goals) - 1) / len(goals))
    finally:
        e.close()


def test_people_walk_a_protocol_and_a_person_collision_ends_it(dataset):
    e = make(dataset, env_id="BioVLN-Protocol-Busy-v0", obs_mode="none")
    try:
        _, info = e.reset(options={"episode_index": 0})
        u = e.unwrapped
        assert u.cfg.people == 2 and u.cfg.fail_measure == "protocol_people_fail"
        assert "person_distance" in info and "occupied_stop" in info
        crowd, goals = u._people.crowds[0], u.current_episode["goals"]
        crowd.timer[:] = 1e3  # both stand on
        crowd.pos[0], crowd.pos[1] = goals[1]["position"][:2], (1.0e4, 1.0e4)  # the second goal's face
        teleport(u, goals[0]["position"], _goal_heading(goals[0]))
        _, _, _, _, info = e.step(0)  # a STOP at the first goal: its face is free
        assert int(info["subgoal_index"]) == 1 and not bool(info["occupied_stop"])
        teleport(u, goals[1]["position"], _goal_heading(goals[1]))
        _, _, _, _, info = e.step(0)  # at the second: a person stands there
        assert int(info["subgoal_index"]) == 2 and bool(info["occupied_stop"])
        e.reset(options={"episode_index": 0})
        person = u._people.crowds[0].pos[0]
        start = np.asarray(u.current_episode["start_position"][:2], float)
        away = (start - person) / np.linalg.norm(start - person)  # toward the start: free floor
        teleport(u, person + 0.45 * away, math.atan2(-away[1], -away[0]))  # facing them, 5 cm apart
        _, _, term, _, info = e.step(1)
        assert bool(info["person_collision"]) and bool(term) and bool(info["fail"])
    finally:
        e.close()


def test_strict_variant_needs_the_face(dataset):
    e = make(dataset, env_id="BioVLN-Protocol-Strict-v0")
    try:
        e.reset(options={"episode_index": 2})
        u, goal = e.unwrapped, e.unwrapped.current_episode["goals"][0]
        teleport(u, goal["position"], _goal_heading(goal) + math.pi)  # within r, back to the face
        _, _, term, _, info = e.step(0)
        assert bool(term) and bool(info["wrong_stop"]) and bool(info["fail"])
        e.reset(options={"episode_index": 2})
        teleport(u, goal["position"], _goal_heading(goal))
        _, _, term, _, info = e.step(0)
        assert not bool(term) and bool(info["subgoal_found"]) and int(info["subgoal_index"]) == 1
    finally:
        e.close()


def test_the_budget_ends_an_episode(dataset):
    e = make(dataset, steps_per_goal=2, obs_mode="none")
    try:
        _, info = e.reset(options={"episode_index": 0})
        budget = int(info["step_budget"])
        assert budget == 2 * len(e.unwrapped.current_episode["goals"])
        for t in range(budget):
            _, _, term, trunc, info = e.step(2)
            assert bool(term) == (t == budget - 1) and not bool(trunc)
        assert bool(info["out_of_budget"]) and bool(info["fail"])
    finally:
        e.close()


def test_state_dict_replay_gives_the_same_rewards_and_infos(env):
    env.reset(options={"episode_index": 3})
    u, goal = env.unwrapped, env.unwrapped.current_episode["goals"][0]
    teleport(u, goal["position"], _goal_heading(goal))
    env.step(0)
    state = u.get_state_dict()
    a = [env.step(act)[1:] for act in (1, 2, 1)]
    u.set_state_dict(state)
    b = [env.step(act)[1:] for act in (1, 2, 1)]
    for (ra, _, _, ia), (rb, _, _, ib) in zip(a, b):
        assert float(ra) == float(rb)
        for key in ("subgoal_index", "subgoal_status", "distance_to_subgoal", "progress", "ppl"):
            assert torch.equal(ia[key], ib[key]), key


def test_an_episode_of_the_other_kind_is_refused(dataset):
    with pytest.raises(BioVLNError, match="holds protocol .multi-goal. episodes"):
        gym.make("BioVLN-OpFace-v0", dataset=dataset, split="protocol_val", **CPU)
    with pytest.raises(BioVLNError, match="holds single-goal episodes"):
        gym.make("BioVLN-Protocol-v0", dataset=dataset, split="ms_val", **CPU)
    with pytest.raises(BioVLNError, match="field 'protocol'"):
        gym.make("BioVLN-OpFace-v0", protocol=True, **CPU)
    with pytest.raises(BioVLNError, match="field 'wrong_stop'"):
        gym.make("BioVLN-Protocol-v0", dataset=dataset, split="protocol_val", wrong_stop="skip", **CPU)


def test_generated_episodes_without_a_split_and_the_state_obs():
    e = gym.make("BioVLN-Protocol-v0", obs_mode="state", **CPU)
    try:
        obs, info = e.reset(seed=0)
        u = e.unwrapped
        assert u.scene_spec.template == "two_room" and "protocol" in u.current_episode
        vocab = load_vocabulary()
        assert obs.shape[-1] >= vocab.max_tokens + vocab.max_text_bytes
        assert e.observation_space.shape == obs.shape
    finally:
        e.close()
