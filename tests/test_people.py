"""Technicians in the lab (``people=N``): the crowd model on a generated scene (determinism, exact replay from
its state, routes inside the free space, bodies apart, the robot's move cut at a person), the human-aware
measures and strict success on hand-built states, and the env: one-line errors for bad ``people``, a replay
from ``get_state_dict`` and a person collision ending the episode per configuration."""

from __future__ import annotations

import math
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
import shapely
import torch
from shapely.geometry import LineString

import biovln_ms  # noqa: F401
from biovln_ms.episodes.source import GeneratedEpisodes
from biovln_ms.errors import BioVLNError
from biovln_ms.metrics.measure_set import MeasureSet
from biovln_ms.metrics.measures import BatchContext, StepState
from biovln_ms.people.body import PERSON_RADIUS, PeopleStep
from biovln_ms.people.crowd import GAP, PEOPLE_MEASURES, Crowd, CrowdError, people_config, stations
from biovln_ms.scene.rules import scene_navigation
from biovln_ms.task_config import NavTaskConfig
from tests.test_measures import BOX, GOAL, ctx

CPU = dict(sim_backend="physx_cpu", render_backend="cpu", obs_mode="none")


@pytest.fixture(scope="module")
def scene():
    src = GeneratedEpisodes("single_room", 2)
    ep = src.episodes[0]
    spec = src.spec(ep["scene_id"])
    nav = scene_navigation(spec)
    start = np.asarray(ep["start_position"][:2], float)
    return spec, nav, stations(spec, nav, start), start


def _crowd(scene, n=2, seed=7) -> Crowd:
    spec, nav, st, start = scene
    c = Crowd(n)
    c.reset(nav, st, start, spec.robot_radius, seed, spec.name)
    return c


def _walk(c: Crowd, steps: int, robot) -> list[np.ndarray]:
    out = []
    for _ in range(steps):
        c.advance(0.5, robot)
        out.append(c.pos.copy())
    return out


def test_the_same_seed_gives_the_same_trajectories(scene):
    start = scene[3]
    a, b = _walk(_crowd(scene), 300, start), _walk(_crowd(scene), 300, start)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    moved = np.abs(np.diff(np.stack(a), axis=0)).sum()
    assert moved > 5.0  # they walk, not only stand
    other = _walk(_crowd(scene, seed=8), 300, start)
    assert not all(np.array_equal(x, y) for x, y in zip(a, other))


def test_a_crowd_restored_from_its_state_continues_exactly(scene):
    start = scene[3]
    c = _crowd(scene)
    _walk(c, 120, start)
    saved = c.state()
    rest = _walk(c, 150, start)
    again = _crowd(scene)  # a fresh reset of the same episode, then the state
    again.load(saved)
    assert all(np.array_equal(x, y) for x, y in zip(rest, _walk(again, 150, start)))


def test_people_stay_in_the_free_space_and_apart(scene):
    spec, nav, st, start = scene
    free = nav.free.buffer(1e-6)
    c = _crowd(scene, n=3, seed=11)
    previous = c.pos.copy()
    for _ in range(400):
        c.advance(0.5, start)
        assert shapely.covers(free, shapely.points(c.pos)).all()
        for p in range(c.n):  # each tick's way is a segment of at most 0.14 m; a step's ends stay visible
            if (previous[p] != c.pos[p]).any():
                assert np.hypot(*(c.pos[p] - previous[p])) <= 1.4 * 0.5 + 1e-9
        d = np.hypot(*(c.pos[:, None] - c.pos[None]).transpose(2, 0, 1))
        assert (d[np.triu_indices(c.n, 1)] >= 2 * PERSON_RADIUS).all()
        robot = np.hypot(*(c.pos - start).T)
        assert (robot >= PERSON_RADIUS + spec.robot_radius).all()  # nobody walks into the standing robot
        previous = c.pos.copy()
    for p in range(c.n):  # the route ahead lies in the free space
        k, n = int(c.leg[p]), int(c.route_len[p])
        if n > k:
            line = LineString([c.pos[p], *c.route[p, k:n]])
            assert free.covers(line)


def test_the_robots_move_is_cut_at_a_persons_body(scene):
    c = _crowd(scene, n=1)
    c.pos[0] = (2.0, 0.0)
    r = c.robot_radius
    tx, ty, hit = c.cut(0.0, 0.0, 3.0, 0.0)
    assert hit and ty == 0.0 and math.isclose(tx, 2.0 - PERSON_RADIUS - r - 1e-3, abs_tol=1e-9)
    assert c.cut(0.0, 0.0, 1.0, 0.0)[2] is False  # stops short of the body
    assert c.cut(0.0, 0.0, -1.0, 0.0) == (-1.0, 0.0, False)  # away from the person


def test_too_many_people_for_the_scene_is_one_line(scene):
    spec, nav, st, start = scene
    with pytest.raises(CrowdError, match="field 'people'.*instrument faces") as e:
        Crowd(len(st.ids) + 1).reset(nav, st, start, spec.robot_radius, 0, spec.name)
    assert "\n" not in str(e.value)


def _people_state(points, people, hit=(False,), wait=(0.0,)) -> StepState:
    s = StepState(
        np.array(points, float), np.array([math.pi / 2]), np.array([True]), np.zeros(1), np.zeros(1)
    )
    s.people = PeopleStep(np.array([people], float), np.array(hit), np.array(wait), 0.2, 0.5)
    return s


def test_a_person_at_the_face_makes_strict_success_fail():
    """The robot at the goal, facing the face: strict success unless a person's body is in the Zone 3."""
    cfg = people_config(replace(NavTaskConfig(), people=1))
    names = cfg.measures + ("strict_success", "success", "people_fail")
    b = BatchContext(1)
    b.set(0, ctx())
    at_face = GOAL[0] + 0.4, GOAL[1] + 0.3  # in Zone 3 (x in [-0.5, 0.5], y in [-1.1, -0.5])
    for person, strict in (((3.0, -3.0), True), (at_face, False)):
        m = MeasureSet(names, 1, cfg=cfg)
        m.reset(b, _people_state([GOAL], [person]))
        m.update(b, _people_state([GOAL], [person]))
        assert bool(m["success"][0]) and bool(m["strict_success"][0]) == strict
    assert BOX.model_face is not None


def test_human_aware_measures_on_a_constructed_case():
    cfg = people_config(replace(NavTaskConfig(), people=1))
    m = MeasureSet(cfg.measures + (cfg.fail_measure,), 1, cfg=cfg)
    b = BatchContext(1)
    b.set(0, ctx())
    person = [(3.0, -3.0)]
    m.reset(b, _people_state([(3.0, -2.0)], person))  # centres 1 m apart: bodies 0.6 m
    fails = []
    for robot, hit, wait in (((3.0, -2.0), True, 1.5), ((3.0, -2.5), False, 0.0), ((3.0, -2.5), False, 0.5)):
        s = _people_state([robot], person, (hit,), (wait,))
        s.stopped[:] = False
        m.update(b, s)
        fails.append(bool(m["people_fail"][0]))
    v = {k: float(m[k][0]) for k in PEOPLE_MEASURES}
    assert math.isclose(v["min_person_distance"], 0.1) and math.isclose(v["person_distance"], 0.1)
    assert v["personal_space_rate"] == 0.5  # 2 of 4 poses within 0.5 m
    assert v["person_collisions"] == 1 and v["people_wait_time"] == 2.0
    assert v["robot_wait_time"] == 1.0  # the two still steps (a person within 1 m) of 0.5 s; one moved
    assert math.isclose(v["mcr_people"], 0.3)  # the robot's centre to the person's body
    assert v["vrt_people"] == 0.5
    assert fails == [True, False, False]  # the collision's step fails (person_collision_ends)


@pytest.mark.parametrize("bad", [-1, 9, 1.5, True, "2"])
def test_bad_people_values_are_one_line(bad):
    with pytest.raises(BioVLNError, match="field 'people'") as e:
        gym.make("BioVLN-OpFace-v0", people=bad, **CPU)
    assert "\n" not in str(e.value)


def test_the_measures_of_people_without_people_are_refused():
    measures = NavTaskConfig().measures + ("min_person_distance",)
    with pytest.raises(BioVLNError, match="field 'measures'.*measure of people"):
        gym.make("BioVLN-OpFace-v0", measures=measures, **CPU)


def test_figures_are_placed_when_the_state_is_read_not_at_every_step():
    e = gym.make("BioVLN-OpFace-v0", people=2, **CPU)  # no camera observes them
    try:
        u = e.unwrapped
        e.reset(seed=3)
        for a in (1, 2, 1, 1):
            e.step(a)
        assert u._people._stale  # moved since their figures were placed
        actors = u.get_state_dict()["actors"]
        for k, person in enumerate(u._people.crowds[0].pos):
            assert np.allclose(actors[f"person_{k}"][0, :2].numpy(), person, atol=1e-5)
        assert not u._people._stale
    finally:
        e.close()


def test_a_protocols_occupied_stop_is_updated_after_its_goal_index_whatever_the_order():
    from biovln_ms.variants import PROTOCOL_BUSY_ENV, VARIANTS

    order = list(MeasureSet(("occupied_stop", "subgoal_index"), cfg=VARIANTS[PROTOCOL_BUSY_ENV]).measures)
    assert order.index("subgoal_index") < order.index("occupied_stop")
    assert "subgoal_index" not in MeasureSet(("occupied_stop",)).measures  # an order, not a need


def test_env_with_people_replays_from_its_state_and_a_collision_ends_it():
    e = gym.make("BioVLN-OpFace-v0", people=2, **CPU)
    try:
        u = e.unwrapped
        assert "min_person_distance" in u.cfg.measures and u.cfg.fail_measure == "people_fail"
        rng = np.random.default_rng(0)
        actions = [int(a) for a in rng.integers(1, 4, 60)]

        def run(acts):
            out = []
            for a in acts:
                info = e.step(a)[4]
                people = np.stack([c.pos.copy() for c in u._people.crowds])
                out.append((people, float(info["person_distance"][0]), u._pose().copy()))
            return out

        e.reset(seed=5)
        first = run(actions[:20])
        state = u.get_state_dict()
        rest = run(actions[20:])
        e.reset(seed=5)
        assert all(np.array_equal(a[0], b[0]) for a, b in zip(first, run(actions[:20])))  # same seed
        u.set_state_dict(state)
        again = run(actions[20:])
        assert all(np.array_equal(a[0], b[0]) and a[1] == b[1] for a, b in zip(rest, again))

        # a person right ahead of the robot: FORWARD touches them, a collision that ends the episode
        e.reset(seed=5)
        pose = u._pose()[0]
        ahead = pose[:2] + (PERSON_RADIUS + u._footprint + 0.1) * np.array(
            [math.cos(pose[2]), math.sin(pose[2])]
        )
        crowd = u._people.crowds[0]
        crowd.pos[0] = ahead
        crowd.timer[0] = 100.0
        _, _, term, _, info = e.step(1)
        assert bool(info["person_collision"][0]) and int(info["person_collisions"][0]) == 1
        assert bool(term) and bool(info["fail"][0]) and not bool(info["success"][0])
        assert float(info["min_person_distance"][0]) <= 0.01
    finally:
        e.close()


def test_a_collision_need_not_end_the_episode_and_people_are_persons_in_segmentation():
    e = gym.make("BioVLN-OpFace-v0", people=1, person_collision_ends=False, **CPU)
    try:
        u = e.unwrapped
        e.reset(seed=1)
        pose = u._pose()[0]
        crowd = u._people.crowds[0]
        crowd.pos[0] = pose[:2] + (PERSON_RADIUS + u._footprint + GAP) * np.array(
            [math.cos(pose[2]), math.sin(pose[2])]
        )
        crowd.timer[0] = 100.0
        _, _, term, _, info = e.step(1)
        assert bool(info["person_collision"][0]) and not bool(term) and not bool(info["fail"][0])
        ids = u._people.actors[0].per_scene_id.cpu().numpy()
        assert (u._segmentation_lookup[ids] == len(u.category_names) + 1).all()
    finally:
        e.close()


class _TCorridor:
    """A nav geometry stand-in: a corridor along y = 0 (x 0-6 m) too narrow for a sidestep, with a branch up
    from x = 1 to (1, 2); shortest paths go through the junction when one end is in the branch."""

    free = shapely.union(shapely.box(-0.02, -0.02, 6.02, 0.02), shapely.box(0.98, -0.02, 1.02, 2.02))

    def shortest_path(self, a, b) -> np.ndarray:
        a, b = np.asarray(a, float), np.asarray(b, float)
        branch = (a[1] > 0.05) != (b[1] > 0.05)
        return np.array([a, (1.0, 0.0), b] if branch else [a, b])


def test_two_people_meeting_in_a_narrow_aisle_wait_then_one_walks_to_another_face():
    from biovln_ms.people.crowd import PATIENCE, WALK, Stations

    nav = _TCorridor()
    st = Stations(("a", "b", "c"), np.array([[0.0, 0.0], [6.0, 0.0], [1.0, 2.0]]), np.zeros(3))
    c = Crowd(2)
    c.reset(nav, st, (50.0, 50.0), 0.25, seed=3)
    c.pos[:] = st.stand[[0, 1]]  # one at each end of the corridor, walking to the other end
    c.mode[:], c.target[:], c.speed[:] = WALK, (1, 0), 1.0
    for p, to in ((0, 1), (1, 0)):
        c.route[p, :1], c.route_len[p], c.leg[p] = st.stand[to], 1, 0
    robot = np.array([50.0, 50.0])
    gaps, waited, targets = [], 0.0, []
    for _ in range(120):  # 60 s
        c.advance(0.5, robot)
        gaps.append(float(np.hypot(*(c.pos[0] - c.pos[1]))))
        waited = max(waited, float(c.waited.max()))
        targets.append(tuple(c.target.tolist()))
    assert min(gaps) >= 2 * PERSON_RADIUS + GAP - 1e-9  # never through each other
    assert waited >= PATIENCE - 0.5  # no room to sidestep: they waited (seen at step ends) to their patience
    assert any(2 in t for t in targets)  # then one took the branch to the third face (no deadlock)
    assert (c.mode == 0).all()  # and both stand at a face at the end
    assert shapely.covers(nav.free, shapely.points(c.pos)).all()


@pytest.mark.parametrize("noise", ["ideal", "realistic"])
def test_a_busy_episode_restored_after_wandering_off_continues_exactly(noise):
    """As the robot's replay test: the state saved mid-episode is loaded after the env went elsewhere (the
    people walked on meanwhile), and every later step gives the same reward, info, robot pose and people,
    and the same observation but for the last bits of the robot's joint velocities on the first step after
    the load (PhysX's solver state is not in ManiSkill's state dict; PickCube-v1's replay drifts more)."""
    e = gym.make(
        "BioVLN-OpFace-v0", people=3, person_collision_ends=False, noise=noise, **{**CPU, "obs_mode": "state"}
    )
    try:
        u = e.unwrapped
        acts = [int(a) for a in np.random.default_rng(1).integers(1, 4, 45)]

        def run(steps):
            out = []
            for a in steps:
                obs, rew, term, trunc, info = e.step(a)
                info = {k: torch.as_tensor(v).clone() for k, v in info.items()}  # some are live tensors
                crowd = u._people.crowds[0]
                step = (obs.clone(), rew.clone(), term.clone(), trunc.clone(), info)
                out.append((*step, u._pose().copy(), crowd.pos.copy(), crowd.yaw.copy()))
            return out

        e.reset(seed=5)
        run(acts[:15])
        state = u.get_state_dict()
        saved = u._people.crowds[0].pos.copy()
        first = run(acts[15:])
        e.reset(seed=5)
        run([2, 2, 1, 1, 3])  # elsewhere, earlier: the people stand or walk elsewhere too
        assert not np.array_equal(u._people.crowds[0].pos, saved)
        u.set_state_dict(state)
        assert np.array_equal(u._people.crowds[0].pos, saved)
        again = run(acts[15:])
        for a, b in zip(first, again):
            torch.testing.assert_close(a[0], b[0], atol=1e-8, rtol=0)
            assert all(torch.equal(x, y) for x, y in zip(a[1:4], b[1:4]))
            assert a[4].keys() == b[4].keys()
            assert all(torch.equal(a[4][k], b[4][k]) for k in a[4])
            assert all(np.array_equal(x, y) for x, y in zip(a[5:], b[5:]))
        moved = np.abs(np.diff(np.stack([r[6] for r in first]), axis=0)).sum()
        assert moved > 0.5  # the replayed stretch has people walking, not only standing
    finally:
        e.close()


@pytest.mark.render
def test_a_person_ahead_shows_in_rgb_depth_and_as_person_in_segmentation():
    """A figure standing 1 m ahead of the head camera, against the same view with the person gone: its pixels
    are labelled ``person`` (the category after the goal categories), nearer in depth and another colour."""
    cpu = {**CPU, "obs_mode": "rgb+depth+segmentation"}
    e = gym.make(
        "BioVLN-OpFace-v0", people=1, person_collision_ends=False, camera_width=96, camera_height=72, **cpu
    )
    try:
        u = e.unwrapped
        e.reset(seed=1)
        pose, crowd = u._pose()[0], u._people.crowds[0]

        def look(where) -> dict:
            crowd.pos[0], crowd.timer[0] = where, 100.0  # standing there
            e.step(2)
            obs = e.step(3)[0]  # turned back to the start's heading
            head = {
                k: v[0, ..., 0] if v.shape[-1] == 1 else v[0] for k, v in obs["sensor_data"]["head"].items()
            }
            return head | {"label": obs["extra"]["semantic_category"][0, ..., 0]}

        ahead = look(pose[:2] + 1.0 * np.array([math.cos(pose[2]), math.sin(pose[2])]))
        gone = look(np.array([1.0e4, 1.0e4]))
        person = len(u.category_names) + 1
        mask = ahead["label"] == person
        assert int(mask.sum()) > 200 and not (gone["label"] == person).any()
        assert (ahead["depth"][mask] < gone["depth"][mask]).float().mean() > 0.95  # nearer than what it hides
        assert abs(float(ahead["depth"][mask].float().median()) - 1000.0) < 250.0  # mm, about a metre
        assert (ahead["rgb"][mask] != gone["rgb"][mask]).any(dim=-1).float().mean() > 0.95
    finally:
        e.close()
