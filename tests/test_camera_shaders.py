"""The depth-only camera pack (biovln_ms.render.camera_shaders) renders the minimal pack's depth and
segmentation bit for bit, in the minimal pack's int16 format whatever was rendered before, and is what an
observation of depth or segmentation without colour gets."""

import gymnasium as gym
import numpy as np
import pytest
import torch
from mani_skill.envs.utils.observations import parse_obs_mode_to_struct

import biovln_ms  # noqa: F401
from biovln_ms.render.camera_shaders import DEPTH_ONLY_DIR, head_camera_shader
from biovln_ms.render.sapien_utils import new_scene

CPU = dict(sim_backend="physx_cpu", render_backend="cpu", camera_width=160, camera_height=120)


@pytest.mark.parametrize(
    "obs_mode, pack",
    [
        ("depth", str(DEPTH_ONLY_DIR)),
        ("depth+segmentation", str(DEPTH_ONLY_DIR)),
        ("segmentation", str(DEPTH_ONLY_DIR)),
        ("rgbd", "minimal"),
        ("rgb+depth+segmentation", "minimal"),
        ("state", "minimal"),  # no picture observed: render_mode="sensors" still shows colour
        ("none", "minimal"),
        ("rgb+normal", "default"),
    ],
)
def test_the_pack_follows_what_is_observed(obs_mode, pack):
    assert head_camera_shader(parse_obs_mode_to_struct(obs_mode).visual).shader_pack == pack


def test_the_pack_is_our_two_shaders():
    assert {p.name for p in DEPTH_ONLY_DIR.iterdir()} == {"gbuffer.vert", "gbuffer.frag"}


def _frames(obs_mode: str, **kw) -> tuple[str, list[torch.Tensor], list[torch.Tensor | None], gym.Env]:
    env = gym.make("BioVLN-OpFace-v0", split="ms_val", obs_mode=obs_mode, **CPU, **kw)
    obs, _ = env.reset(seed=0, options={"episode_index": 3})
    shader = env.unwrapped._sensors["head"].config.shader_config.shader_pack
    depth, seg = [], []
    for a in [1, 1, 2, 1, 3, 3, 1, 2]:
        head = obs["sensor_data"]["head"]
        depth.append(head["depth"].clone())
        seg.append(head["segmentation"].clone() if "segmentation" in head else None)
        obs, *_ = env.step(a)
    return shader, depth, seg, env


@pytest.mark.parametrize("lighting", ["fast", "quality"])
def test_depth_and_segmentation_equal_the_minimal_packs(lighting):
    new_scene()  # a plain SAPIEN view first: it leaves the process's picture formats at float32
    shader, depth, seg, env = _frames("depth+segmentation", lighting=lighting)  # before any minimal camera
    space = env.observation_space["sensor_data"]["head"]["depth"].dtype
    env.close()
    ref_shader, ref_depth, ref_seg, ref_env = _frames("rgb+depth+segmentation", lighting=lighting)
    ref_env.close()
    assert (ref_shader, shader) == ("minimal", str(DEPTH_ONLY_DIR))
    assert {d.dtype for d in depth + ref_depth} == {torch.int16} and space == np.int16
    assert np.mean([(d > 0).float().mean().item() for d in ref_depth]) > 0.9
    assert all(torch.equal(a, b) for a, b in zip(depth, ref_depth))
    assert all(torch.equal(a, b) and a.dtype == b.dtype for a, b in zip(seg, ref_seg))
    assert len({int(v) for s in seg for v in s.unique()}) > 3  # several objects in view


def test_depth_survives_a_new_scene_after_a_default_pack_camera():
    """A follow camera on SAPIEN's default pack (float32 pictures) made before the head camera is rebuilt."""
    env = gym.make(
        "BioVLN-OpFace-v0",
        split="ms_val",
        obs_mode="depth",
        human_render_camera_configs=dict(shader_pack="default"),
        **CPU,
    )
    for episode in (0, 10):  # a new scene: the head camera is made again, after the follow camera
        obs, _ = env.reset(seed=0, options={"episode_index": episode, "reconfigure": True})
        depth = obs["sensor_data"]["head"]["depth"]
        assert set(obs["sensor_data"]["head"]) == {"depth"}
        assert depth.dtype == torch.int16 and (depth > 0).float().mean() > 0.9
    env.close()
