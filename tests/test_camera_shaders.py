"""The depth-only camera pack (biovln_ms.render.camera_shaders) renders the minimal pack's depth and
segmentation bit for bit, and is what an observation without colour gets."""

import gymnasium as gym
import numpy as np
import pytest

import biovln_ms  # noqa: F401
from biovln_ms.render.camera_shaders import DEPTH_ONLY_DIR, head_camera_shader

CPU = dict(sim_backend="physx_cpu", render_backend="cpu", camera_width=160, camera_height=120)


def test_the_pack_follows_what_is_observed():
    assert head_camera_shader(rgb=False, normal=False, albedo=False).shader_pack == str(DEPTH_ONLY_DIR)
    assert head_camera_shader(rgb=True, normal=False, albedo=False).shader_pack == "minimal"
    assert head_camera_shader(rgb=False, normal=True, albedo=False).shader_pack == "default"
    assert {p.name for p in DEPTH_ONLY_DIR.iterdir()} == {"gbuffer.vert", "gbuffer.frag"}


def _frames(obs_mode: str, steps: int, **kw) -> tuple[np.ndarray, np.ndarray]:
    env = gym.make("BioVLN-OpFace-v0", split="ms_val", obs_mode=obs_mode, **CPU, **kw)
    obs, _ = env.reset(seed=0, options={"episode_index": 3})
    shader = env.unwrapped._sensors["head"].config.shader_config.shader_pack
    depth, seg = [], []
    for a in [1, 1, 2, 1, 3, 3, 1, 2][:steps]:
        head = obs["sensor_data"]["head"]
        depth.append(head["depth"].numpy().copy())
        seg.append(head["segmentation"].numpy().copy() if "segmentation" in head else None)
        obs, *_ = env.step(a)
    env.close()
    return shader, np.stack(depth), seg


@pytest.mark.parametrize("lighting", ["fast", "quality"])
def test_depth_and_segmentation_equal_the_minimal_packs(lighting):
    ref_shader, ref_depth, ref_seg = _frames("rgb+depth+segmentation", 8, lighting=lighting)
    shader, depth, seg = _frames("depth+segmentation", 8, lighting=lighting)
    assert (ref_shader, shader) == ("minimal", str(DEPTH_ONLY_DIR))
    assert (ref_depth > 0).mean() > 0.9
    assert np.array_equal(depth, ref_depth)
    assert all(np.array_equal(a, b) for a, b in zip(seg, ref_seg))
    assert len({int(v) for s in seg for v in np.unique(s)}) > 3  # several objects in view


def test_depth_only_observation_has_no_colour():
    env = gym.make("BioVLN-OpFace-v0", split="ms_val", obs_mode="depth", **CPU)
    obs, _ = env.reset(seed=0)
    assert set(obs["sensor_data"]["head"]) == {"depth"}
    env.close()
