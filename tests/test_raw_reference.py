"""The speed benchmarks' raw SAPIEN reference at a walk's views renders the frames the env rendered, in the
env itself or in a second env made alike (``env_speed.py`` replays each block of its walk in one)."""

import gymnasium as gym
import numpy as np
import pytest

import biovln_ms  # noqa: F401
from biovln_ms.render import sapien_utils

pytestmark = pytest.mark.render


def _make():
    return gym.make(
        "BioVLN-OpFace-v0", split="ms_val", obs_mode="rgbd", camera_width=96, camera_height=72,
        sim_backend="physx_cpu", render_backend="cpu",
    )  # fmt: skip


@pytest.mark.parametrize("where", ["the env", "a second env"])
def test_the_raw_reference_renders_the_walks_own_frames(monkeypatch, where):
    env = _make()
    ref = env if where == "the env" else _make()
    try:
        u = env.unwrapped
        env.reset(options={"episode_index": 0})
        views, frames = [], []
        for a in np.random.default_rng(0).integers(1, 4, 40):
            obs, _, term, trunc, _ = env.step(int(a))
            views.append((u._episode_index[0], u.agent.robot.get_qpos().clone()))
            frames.append(obs["sensor_data"]["head"]["rgb"][0].numpy())
            if bool(term) or bool(trunc):
                env.reset()
        made, rendered = sapien_utils._head_frame, []

        def spied(env):
            frame = made(env)

            def recorded():
                pictures = frame()
                rendered.append(pictures[0][..., :3])  # the colour picture
                return pictures

            return recorded

        monkeypatch.setattr(sapien_utils, "_head_frame", spied)
        assert sapien_utils.raw_camera_rate_at(ref, views) > 0
        episodes = len({v[0] for v in views})
        assert len(rendered) == len(views) + episodes  # a warm-up frame per episode's scene
        replayed = [p for k, p in enumerate(rendered) if k not in _warm_ups(views)]
        same = sum(np.array_equal(a, b) for a, b in zip(replayed, frames))
        diff = max(np.abs(a.astype(int) - b.astype(int)).max() for a, b in zip(replayed, frames))
        assert same >= 0.8 * len(frames) and diff <= 2  # a pose set from joints may differ in its last bit
    finally:
        env.close()
        if ref is not env:
            ref.close()


def _warm_ups(views) -> set[int]:
    """Indices, among the rendered frames, of each episode's warm-up frame."""
    out, k, last = set(), 0, None
    for episode, _ in views:
        if episode != last:
            out.add(k)
            k, last = k + 1, episode
        k += 1
    return out
