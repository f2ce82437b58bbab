"""Thin SAPIEN helpers: a lit scene, look-at cameras, and clear errors when no renderer exists."""

from __future__ import annotations

import itertools
import time

import numpy as np

from biovln_ms.errors import RenderError

BACKPORTS_FIX = (
    "install a Vulkan driver: on Debian bookworm without a GPU run `bash scripts/install_system.sh` "
    "(adds bookworm-backports and installs mesa-vulkan-drivers >= 24.3 for lavapipe)"
)


def render_backend() -> str:
    """ManiSkill's ``render_backend`` for this machine: "gpu" with a CUDA device, else "cpu" (lavapipe)."""
    import torch

    return "gpu" if torch.cuda.is_available() else "cpu"


def plain_scene():
    """A bare SAPIEN scene (CPU physics) rendering on the device ManiSkill's envs use here.

    SAPIEN holds one render device per process: a scene made on its default device would make every
    later env asking for "cpu" fail, so plain scenes name the device as the envs do.
    """
    import sapien

    device = sapien.Device("cuda" if render_backend() == "gpu" else "cpu")
    try:
        return sapien.Scene([sapien.physx.PhysxCpuSystem(), sapien.render.RenderSystem(device)])
    except RuntimeError as e:
        raise RenderError(f"SAPIEN cannot create a render device ({e})", fix=BACKPORTS_FIX) from None


def env_camera_scene():
    """A :func:`plain_scene` whose cameras render as the env's head camera does: ManiSkill's "minimal"
    shader pack and its 8-bit picture formats (SAPIEN's global settings)."""
    import sapien

    sapien.render.set_camera_shader_dir("minimal")
    sapien.render.set_picture_format("Color", "r8g8b8a8unorm")
    sapien.render.set_picture_format("ColorRaw", "r8g8b8a8unorm")
    sapien.render.set_picture_format("PositionSegmentation", "r16g16b16a16sint")
    return plain_scene()


def new_scene(ambient: float = 0.35):
    """A SAPIEN scene with ambient, key and fill lights; raises RenderError without a Vulkan device."""
    import sapien

    # ManiSkill switches SAPIEN's global camera shader and picture formats (its minimal pack has
    # 8-bit colour and no "Segmentation" picture): plain-SAPIEN views restore the default pack.
    sapien.render.set_camera_shader_dir("default")
    for picture in ("Color", "ColorRaw", "PositionSegmentation"):
        sapien.render.set_picture_format(picture, "r32g32b32a32sfloat")
    scene = plain_scene()
    scene.set_ambient_light([ambient] * 3)
    scene.add_directional_light([0.4, 0.6, -1.0], [0.9, 0.9, 0.88])
    scene.add_directional_light([-0.5, -0.3, -0.6], [0.35, 0.35, 0.4])
    return scene


def look_at_pose(eye, target, up=(0.0, 0.0, 1.0)):
    """SAPIEN pose of a camera at ``eye`` looking at ``target`` (SAPIEN cameras look along +x, z up)."""
    import sapien

    eye = np.asarray(eye, float)
    forward = np.asarray(target, float) - eye
    forward /= np.linalg.norm(forward)
    left = np.cross(up, forward)
    if np.linalg.norm(left) < 1e-6:
        left = np.array([0.0, 1.0, 0.0])
    left /= np.linalg.norm(left)
    true_up = np.cross(forward, left)
    mat = np.eye(4)
    mat[:3, :3] = np.stack([forward, left, true_up], axis=1)
    mat[:3, 3] = eye
    return sapien.Pose(mat)


def take_rgb(scene, camera) -> np.ndarray:
    """uint8 RGB (H, W, 3) from a camera after updating the render state."""
    scene.update_render()
    camera.take_picture()
    rgb = np.asarray(camera.get_picture("Color"))[..., :3]
    return rgb if rgb.dtype == np.uint8 else (np.clip(rgb, 0, 1) * 255).round().astype(np.uint8)


SOFTWARE_RENDERERS = ("llvmpipe", "lavapipe", "swiftshader", "softpipe")


def device_kind(device) -> str:
    """'CPU' for a software Vulkan driver (Mesa lavapipe/llvmpipe, SwiftShader), else 'GPU'.

    SAPIEN's ``Device.is_cpu()`` means "not a Vulkan device" and is False for lavapipe, so the
    driver name decides.
    """
    name = device.name.lower()
    return "CPU" if device.is_cpu() or any(s in name for s in SOFTWARE_RENDERERS) else "GPU"


def vulkan_device_label() -> str:
    """The first Vulkan device SAPIEN lists, with its kind, e.g. 'llvmpipe (LLVM 15.0.6, 256 bits) (CPU)'
    (for benchmark tables; unlike ``new_scene`` it leaves SAPIEN's global render settings alone)."""
    import sapien

    for line in sapien.render.get_device_summary().splitlines():
        if ":" in line and not line.startswith(" "):
            name = line.split(":", 1)[1].strip()
            return f"{name} ({'CPU' if any(s in name.lower() for s in SOFTWARE_RENDERERS) else 'GPU'})"
    return "none"


def _head_frame(env):
    """One raw SAPIEN frame of the env's head camera, as a function: update_render + take_picture + the
    read-back of every picture its shader pack makes (colour and position/segmentation, or the latter alone
    for the depth-only pack), which it returns."""
    u = env.unwrapped
    head = u.scene.sensors["head"]
    cams, pictures = head.camera._render_cameras, list(head.config.shader_config.texture_names)

    def frame() -> list:
        u.scene.update_render()
        out = []
        for c in cams:
            c.take_picture()
            out += [c.get_picture(picture) for picture in pictures]
        return out

    return frame


def raw_camera_rate(env, frames: int) -> float:
    """Frames/s of the env's head camera rendered by SAPIEN alone at its current view (:func:`_head_frame`):
    the reference the benchmarks divide by."""
    frame = _head_frame(env)
    for _ in range(3):
        frame()
    t = time.perf_counter()
    for _ in range(frames):
        frame()
    return frames / (time.perf_counter() - t)


def raw_camera_rate_at(env, views: list) -> float:
    """Frames/s of raw SAPIEN frames (:func:`_head_frame`) at recorded views: ``(episode index, robot joint
    positions)`` pairs, as a walk of the env visited them. Each episode's scene is loaded and the robot
    placed (``set_qpos``) untimed; the frames are the walk's own (the same views, up to the last bit of a
    pose), so the reference renders what the env did."""
    spent, n = 0.0, 0
    for episode, group in itertools.groupby(views, key=lambda v: v[0]):
        env.reset(options={"episode_index": episode})
        frame, robot = _head_frame(env), env.unwrapped.agent.robot
        frame()
        for _, qpos in group:
            robot.set_qpos(qpos)
            t = time.perf_counter()
            frame()
            spent += time.perf_counter() - t
            n += 1
    return n / spent
