"""Measures and the Eq. 5 reward against hand-built trajectories (pure geometry, no simulator), single and
batched: 64 sub-envs stepped together give exactly what 64 separate runs give."""

import math
from dataclasses import replace

import numpy as np
import pytest
import torch

from biovln_ms.geometry.zones import PlacedInstrument
from biovln_ms.metrics.measures import (
    BatchContext,
    EpisodeContext,
    Measure,
    StepState,
    register_measure,
)
from biovln_ms.metrics.measure_set import MeasureSet
from biovln_ms.task_config import NavTaskConfig
from biovln_ms.variants import VARIANTS

# A 1 x 1 m instrument at the origin facing -Y; its Zone 3 (delta 0.6) is y in [-1.1, -0.5].
BOX = PlacedInstrument((0.0, 0.0, 0.5), 0.0, (1.0, 1.0, 1.0), (0.0, -1.0), 0.5, 0.6, "box_0", "cabinet")
GOAL = (0.0, -1.1)
NAMES = NavTaskConfig().measures + ("nav_reward", "failed_stop", "strict_failed_stop", "facing_face")


def ctx(goal=GOAL, radius=0.8, start_geodesic=4.0):
    g = np.asarray(goal)
    return EpisodeContext(
        goal=g,
        success_radius=radius,
        target=BOX,
        instruments=[BOX],
        geodesic=lambda p: float(np.linalg.norm(np.asarray(p) - g)),
        start_geodesic=start_geodesic,
        hfov=math.radians(79),
    )


def state(points, yaws, stopped=None, commanded=None, moved=None) -> StepState:
    """A batch of robots: one row per sub-env."""
    n = len(points)
    f = lambda v: np.array(v, dtype=np.float64)  # noqa: E731
    return StepState(
        f(points),
        f(yaws),
        np.array(stopped or [False] * n),
        f(commanded or [0.0] * n),
        f(moved or [0.0] * n),
    )


def run(points, yaws=None, stop_last=True, commanded=None, moved=None, cfg=None):
    """One sub-env along ``points``."""
    cfg = cfg or NavTaskConfig()
    m = MeasureSet(NAMES, 1, cfg=cfg)
    b = BatchContext(1)
    b.set(0, ctx(start_geodesic=float(np.linalg.norm(np.asarray(points[0]) - np.array(GOAL)))))
    yaws = yaws or [math.pi / 2] * len(points)
    m.reset(b, state([points[0]], [yaws[0]]))
    rewards = []
    for i, (p, y) in enumerate(zip(points[1:], yaws[1:]), 1):
        last = i == len(points) - 1
        m.update(
            b,
            state(
                [p],
                [y],
                [stop_last and last],
                [(commanded or [0.25] * len(points))[i]],
                [(moved or [0.25] * len(points))[i]],
            ),
        )
        rewards.append(float(m["nav_reward"][0]))
    return m, rewards


def v(m, name):
    return m[name][0].item()


def test_straight_success_has_spl_one():
    pts = [(0.0, -4.1 + 0.25 * k) for k in range(13)]  # 3.0 m straight to y = -1.1
    m, _ = run(pts)
    assert v(m, "success") and v(m, "steps") == 12
    assert v(m, "path_length") == pytest.approx(3.0)
    assert v(m, "spl") == pytest.approx(1.0)
    assert v(m, "soft_spl") == pytest.approx(1.0)
    assert v(m, "distance_to_goal") == pytest.approx(0.0, abs=1e-9)
    assert v(m, "in_zone3") and v(m, "facing_instrument")


def test_detour_halves_spl_and_failure_zeroes_it():
    pts = [(0.0, -4.1), (3.0, -4.1), (3.0, -1.1), (0.0, -1.1)]  # 9 m for a 3 m shortest path
    m, _ = run(pts)
    assert v(m, "success") and v(m, "spl") == pytest.approx(3.0 / 9.0)
    m, _ = run(pts[:3])  # stops at (3.0, -1.1): 3 m from the goal, radius 0.8
    assert not v(m, "success") and v(m, "spl") == 0.0 and v(m, "failed_stop")
    assert v(m, "soft_spl") == pytest.approx((1 - 3.0 / 3.0) * 3.0 / 6.0)


def test_mcr_vrt_zone2_and_clearance_use_the_robot_centre():
    # x = 0.5 + clearance: poses at clearance 1.0, 0.4, 0.2, 1.0
    pts = [(1.5, 0.0), (0.9, 0.0), (0.7, 0.0), (1.5, 0.0)]
    m, _ = run(pts, stop_last=False)
    assert v(m, "mcr") == pytest.approx(0.2)
    assert v(m, "vrt") == pytest.approx(2 / 4)  # start included
    assert v(m, "clearance") == pytest.approx(1.0)
    m, _ = run(pts[:3], stop_last=False)
    assert v(m, "zone2_violation")  # 0.2 m from the body is inside the 0.25 m Zone 2


def test_collisions_count_blocked_forward_moves():
    pts = [(2.0, 0.0), (2.0, 0.0), (2.0, 0.0)]
    m, _ = run(pts, stop_last=False, commanded=[0, 0.25, 0.25], moved=[0, 0.0, 0.25])
    assert v(m, "collisions") == 1


def test_facing_uses_half_the_horizontal_fov():
    m, _ = run(
        [(0.0, -3.0), (0.0, -3.0)], yaws=[math.pi / 2, math.pi / 2 + math.radians(39)], stop_last=False
    )
    assert v(m, "facing_instrument")
    m, _ = run(
        [(0.0, -3.0), (0.0, -3.0)], yaws=[math.pi / 2, math.pi / 2 + math.radians(41)], stop_last=False
    )
    assert not v(m, "facing_instrument")


@pytest.mark.parametrize(
    "end, yaw, radius_ok, strict_ok",
    [
        ((0.0, -1.1), 90, True, True),  # at the goal, looking straight at the face (-f = +y)
        ((0.0, -1.1), 90 + 29, True, True),
        ((0.0, -1.1), 90 + 31, True, False),  # within r and Zone 3, but turned away from the face
        ((0.6, -1.0), 90, True, False),  # within r, but beside Zone 3 (x > 0.5)
        ((0.0, -2.0), 90, False, False),
    ],
)
def test_strict_success_needs_zone3_and_the_face(end, yaw, radius_ok, strict_ok):
    m, _ = run([(0.0, -3.0), end], yaws=[math.pi / 2, math.radians(yaw)])
    assert v(m, "success") == radius_ok and v(m, "strict_success") == strict_ok
    assert v(m, "strict_failed_stop") == (not strict_ok)


def test_any_instance_counts_when_an_episode_has_several_goals():
    # a second box of the same category 4 m to the right, facing -Y: its goal is (4.0, -1.1)
    other = PlacedInstrument((4.0, 0.0, 0.5), 0.0, (1.0, 1.0, 1.0), (0.0, -1.0), 0.5, 0.6, "box_1", "cabinet")
    goals = [np.array(GOAL), np.array((4.0, -1.1))]
    c = ctx(start_geodesic=3.0)
    c.other_goals = ((goals[1], 0.8, other),)
    c.geodesic = lambda p: min(float(np.linalg.norm(np.asarray(p) - g)) for g in goals)
    m, b = MeasureSet(NAMES, 1), BatchContext(1)
    b.set(0, c)
    m.reset(b, state([(4.0, -4.1)], [math.pi / 2]))
    assert v(m, "distance_to_goal") == pytest.approx(3.0)  # the nearest instance
    assert v(m, "geodesic_distance_to_goal") == pytest.approx(3.0)
    m.update(b, state([(4.0, -1.1)], [math.pi / 2], stopped=[True], commanded=[0.25], moved=[0.25]))
    assert v(m, "success") and v(m, "strict_success") and v(m, "in_zone3") and v(m, "facing_face")
    assert v(m, "distance_to_goal") == pytest.approx(0.0)
    assert b.k == 2 and b.goal_ok[0].tolist() == [True, True]
    b.set(0, ctx())  # a one-goal episode after it: the second slot is masked
    assert b.goal_ok[0].tolist() == [True, False]


def test_unknown_measure_and_cycles_are_refused():
    with pytest.raises(KeyError, match="unknown measure 'teleports'"):
        MeasureSet(names=("teleports",))


def test_registering_again_is_fine_for_the_same_class_but_not_for_another():
    def make(body: str):
        ns: dict = {}
        exec(f"class Twice(Measure):\n    uuid = 'twice_test'\n    {body}", {"Measure": Measure}, ns)
        ns["Twice"].__module__ = "notebook_cell"
        return ns["Twice"]

    register_measure(make("dtype = None"))
    register_measure(make("dtype = None"))  # a re-run cell: the same module and name
    other = make("dtype = None")
    other.__qualname__ = "Other"
    with pytest.raises(ValueError, match="already registered"):
        register_measure(other)


# --- Eq. 5 against hand-computed values ---------------------------------------------------------
def test_dense_reward_eq5_by_hand():
    """0.25 m steps from (0.5, -2.1) at clearance >= 0.5: each step pays (d_{t-1} - d_t) - 0.01; the last (a
    STOP at d = 0.707 < r = 0.8) adds the 10.0 success bonus once."""
    pts = [(0.5, -2.1), (0.5, -1.85), (0.5, -1.6), (0.5, -1.6)]
    d = [math.hypot(0.5, y + 1.1) for y in (-2.1, -1.85, -1.6, -1.6)]
    _, r = run(pts, stop_last=True)
    expected = [d[0] - d[1] - 0.01, d[1] - d[2] - 0.01, d[2] - d[3] - 0.01 + 10.0]
    assert r == pytest.approx(expected, abs=1e-12)


def test_flat_safety_penalty_below_half_a_metre():
    # x = 0.5 + clearance: step into clearance 0.4 (penalty 0.05), then 0.3 (again 0.05), then out to 0.6
    pts = [(1.5, -0.0), (0.9, 0.0), (0.8, 0.0), (1.1, 0.0)]
    d = [math.hypot(x, 1.1) for x, _ in pts]
    _, r = run(pts, stop_last=False)
    assert r == pytest.approx(
        [d[0] - d[1] - 0.01 - 0.05, d[1] - d[2] - 0.01 - 0.05, d[2] - d[3] - 0.01], abs=1e-12
    )


def test_rl_variant_proportional_penalty_and_normalised_reward():
    cfg = VARIANTS["BioVLN-OpFace-RL-v0"]
    assert cfg.proportional_safety and cfg.safety_penalty == 1.0
    pts = [(1.5, 0.0), (0.9, 0.0), (0.6, 0.0)]  # clearance 1.0, 0.4, 0.1
    d = [math.hypot(x, 1.1) for x, _ in pts]
    _, r = run(pts, stop_last=False, cfg=cfg)
    assert r == pytest.approx(
        [d[0] - d[1] - 0.01 - (1 - 0.4 / 0.5), d[1] - d[2] - 0.01 - (1 - 0.1 / 0.5)], abs=1e-12
    )
    assert cfg.success_bonus == 10.0  # normalized_dense divides by it (tested in test_nav_env)


def test_sparse_reward_is_success_only():
    pts = [(0.0, -2.0), (0.0, -1.75), (0.0, -1.5)]
    m, _ = run(pts, stop_last=True)
    assert m["success"].astype(float).tolist() == [1.0]
    m, _ = run(pts, stop_last=False)
    assert m["success"].astype(float).tolist() == [0.0]


# --- batched == separate --------------------------------------------------------------------------
def _random_trajectories(n: int, steps: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    start = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-4, -1.2, n)])
    pos, yaw = [start], [rng.uniform(-np.pi, np.pi, n)]
    stop, cmd, moved = [np.zeros(n, bool)], [np.zeros(n)], [np.zeros(n)]
    for t in range(steps):
        a = rng.integers(0, 4, n)
        c = np.where(a == 1, 0.25, 0.0)
        blocked = rng.random(n) < 0.1
        mv = np.where(blocked, 0.0, c)
        y = yaw[-1] + np.where(a == 2, np.pi / 6, np.where(a == 3, -np.pi / 6, 0.0))
        p = pos[-1] + mv[:, None] * np.column_stack([np.cos(yaw[-1]), np.sin(yaw[-1])])
        pos.append(p), yaw.append(y), stop.append((a == 0) & (t > 3)), cmd.append(c), moved.append(mv)
    return pos, yaw, stop, cmd, moved


@pytest.mark.parametrize("variant", ["BioVLN-OpFace-v0", "BioVLN-OpFace-RL-v0"])
def test_batch_of_64_equals_64_single_runs(variant):
    n, steps = 64, 30
    cfg = VARIANTS[variant]
    pos, yaw, stop, cmd, moved = _random_trajectories(n, steps)
    radii = np.linspace(0.8, 1.3, n)
    contexts = [
        replace(ctx(radius=float(radii[i]), start_geodesic=float(np.linalg.norm(pos[0][i] - GOAL))))
        for i in range(n)
    ]

    def st(t, rows):
        return state(
            pos[t][rows].tolist(),
            yaw[t][rows].tolist(),
            stop[t][rows].tolist(),
            cmd[t][rows].tolist(),
            moved[t][rows].tolist(),
        )

    batch, bctx = MeasureSet(NAMES, n, cfg=cfg), BatchContext(n)
    for i in range(n):
        bctx.set(i, contexts[i])
    batch.reset(bctx, st(0, slice(None)))
    history = [{k: batch[k].copy() for k in NAMES}]
    for t in range(1, steps + 1):
        batch.update(bctx, st(t, slice(None)))
        history.append({k: batch[k].copy() for k in NAMES})
    for i in range(n):
        single, sctx = MeasureSet(NAMES, 1, cfg=cfg), BatchContext(1)
        sctx.set(0, contexts[i])
        single.reset(sctx, st(0, [i]))
        for t in range(1, steps + 1):
            single.update(sctx, st(t, [i]))
            for k in NAMES:
                assert np.array_equal(single[k][0], history[t][k][i]), (i, t, k)


def test_partial_reset_touches_only_the_named_rows():
    n = 4
    pos, yaw, stop, cmd, moved = _random_trajectories(n, 5, seed=3)
    m, b = MeasureSet(NAMES, n), BatchContext(n)
    for i in range(n):
        b.set(i, ctx())

    def full(t):
        return state(pos[t].tolist(), yaw[t].tolist(), stop[t].tolist(), cmd[t].tolist(), moved[t].tolist())

    m.reset(b, full(0))
    for t in range(1, 6):
        m.update(b, full(t))
    before = {k: m[k].copy() for k in NAMES}
    m.reset(b, full(0), torch.tensor([1, 3]))
    for k in NAMES:
        assert np.array_equal(m[k][[0, 2]], before[k][[0, 2]]), k
    assert m["steps"].tolist() == [5, 0, 5, 0] and m["path_length"][[1, 3]].tolist() == [0.0, 0.0]


def test_state_dict_round_trip_continues_identically():
    pos, yaw, stop, cmd, moved = _random_trajectories(2, 10, seed=5)

    def full(t):
        return state(pos[t].tolist(), yaw[t].tolist(), stop[t].tolist(), cmd[t].tolist(), moved[t].tolist())

    b = BatchContext(2)
    b.set(0, ctx()), b.set(1, ctx(radius=1.2))
    a, c = MeasureSet(NAMES, 2), MeasureSet(NAMES, 2)
    a.reset(b, full(0))
    for t in range(1, 5):
        a.update(b, full(t))
    c.load_state_dict(a.state_dict())
    for t in range(5, 11):
        a.update(b, full(t))
        c.update(b, full(t))
        for k in NAMES:
            assert np.array_equal(a[k], c[k]), (t, k)
