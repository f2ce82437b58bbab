"""The step's pictures, submitted before the measures run (:mod:`biovln_ms.render.step_capture`), are the
same bytes as pictures taken in ``get_obs``; one picture per step; a reset or a state load after a pending
capture takes fresh pictures."""

import gymnasium as gym
import numpy as np
import pytest
import torch

import biovln_ms  # noqa: F401

pytestmark = pytest.mark.render

CPU = dict(sim_backend="physx_cpu", render_backend="cpu")
ACTIONS = [1, 1, 2, 1, 3, 1, 1, 2, 2, 1, 3, 1]


def _env(**kwargs):
    return gym.make("BioVLN-OpFace-v0", camera_width=64, camera_height=48, **CPU, **kwargs)


def _pair(**kwargs):
    """Two envs alike, but the second takes its pictures in ``get_obs``."""
    envs = [_env(**kwargs) for _ in "ab"]
    envs[1].unwrapped.capture_during_step = False
    return envs


def _leaves(tree, prefix=""):
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield from _leaves(v, f"{prefix}/{k}")
    else:
        yield prefix, np.asarray(tree.cpu() if isinstance(tree, torch.Tensor) else tree)


def _same(a, b) -> None:
    la, lb = dict(_leaves(a)), dict(_leaves(b))
    assert la.keys() == lb.keys()
    for k in la:
        assert la[k].tobytes() == lb[k].tobytes(), k


def _poses(env) -> np.ndarray:
    """The robot's pose and the people's figures' poses now."""
    u = env.unwrapped
    people = [a.pose.raw_pose.cpu().numpy().ravel() for a in u._people.actors] if u._people else []
    return np.concatenate([u._pose().ravel(), *people])


def _watch_pictures(env) -> list[np.ndarray]:
    """The poses at each picture the head camera takes (appended as they are taken)."""
    head = env.unwrapped.scene.sensors["head"]
    taken, capture = [], head.capture

    def recorded():
        taken.append(_poses(env))
        return capture()

    head.capture = recorded
    return taken


def _watch_evaluate(env, taken: list) -> list[tuple[bool, int]]:
    """At each ``evaluate`` (the step's info, before its observation): pending capture?, pictures so far."""
    u, seen = env.unwrapped, []
    evaluate = u.evaluate

    def recorded():
        seen.append((u._capture_pending, len(taken)))
        return evaluate()

    u.evaluate = recorded
    return seen


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(split="ms_val", obs_mode="rgbd"),
        dict(split="ms_val", obs_mode="rgbd", noise="realistic"),
        dict(split="busy_val", obs_mode="rgb+depth+segmentation", person_collision_ends=False),
    ],
    ids=["ideal", "realistic", "people"],
)
def test_pictures_during_the_step_are_the_same_bytes(kwargs):
    early, late = _pair(**kwargs)
    try:
        for seed in (0, 1):
            _same(early.reset(seed=seed)[0], late.reset(seed=seed)[0])
            taken = {e: _watch_pictures(e) for e in (early, late)}
            seen = {e: _watch_evaluate(e, taken[e]) for e in (early, late)}
            for n, a in enumerate(ACTIONS, 1):
                out_e, out_l = early.step(a), late.step(a)
                _same(out_e[0], out_l[0])  # observation
                _same(out_e[4], out_l[4])  # info
                assert [float(x) for x in out_e[1:4]] == [float(x) for x in out_l[1:4]]
                for e in (early, late):  # one picture a step, of the scene as the step left it
                    assert len(taken[e]) == n and np.array_equal(taken[e][-1], _poses(e))
                assert seen[early][-1] == (True, n)  # taken before the info, pending until the read-back
                assert seen[late][-1] == (False, n - 1)
                if bool(out_e[2]) or bool(out_e[3]):
                    break
    finally:
        early.close(), late.close()


def test_a_pending_capture_is_not_read_after_a_reset_or_a_state_load():
    early, late = _pair(split="ms_val", obs_mode="rgbd")
    try:
        early.reset(seed=0), late.reset(seed=0)
        for _ in range(3):
            early.step(1), late.step(1)
        early.unwrapped.start_capture()  # a capture whose step never reached get_obs
        _same(early.reset(seed=3)[0], late.reset(seed=3)[0])
        state = early.unwrapped.get_state_dict()
        for _ in range(3):
            early.step(1), late.step(1)
        early.unwrapped.start_capture()
        early.unwrapped.set_state_dict(state), late.unwrapped.set_state_dict(state)
        _same(early.unwrapped.get_obs(), late.unwrapped.get_obs())
    finally:
        early.close(), late.close()


def test_a_step_that_raises_leaves_no_capture_pending():
    env = _env(split="ms_val", obs_mode="rgbd")
    try:
        env.reset(seed=0)
        u = env.unwrapped
        evaluate = u.evaluate
        u.evaluate = lambda: 1 / 0  # fails after the capture, before the read-back
        with pytest.raises(ZeroDivisionError):
            env.step(1)
        assert not u._capture_pending
        u.evaluate = evaluate
        taken = _watch_pictures(env)
        env.unwrapped.get_obs()  # takes its own picture
        assert len(taken) == 1
    finally:
        env.close()


def test_state_observations_take_no_pictures():
    env = gym.make("BioVLN-OpFace-v0", split="ms_val", obs_mode="state", **CPU)
    try:
        env.reset(seed=0)
        taken = _watch_pictures(env)
        for _ in range(4):
            env.step(1)
        assert taken == [] and not env.unwrapped._capture_pending
    finally:
        env.close()
