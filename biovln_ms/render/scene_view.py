"""SAPIEN views of whole scenes (through the ``BioVLN-LabScene-v0`` ManiSkill env)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from biovln_ms.variants import LAB_SCENE_ENV
from biovln_ms.episodes.generator import EpisodeSampler
from biovln_ms.render.goal_views import HEAD_HEIGHT, GoalViewRenderer
from biovln_ms.render.sapien_utils import render_backend
from biovln_ms.scene.rules import scene_navigation
from biovln_ms.scene.spec import SceneSpec


def render_overview(
    spec: SceneSpec, out: str | Path, size: tuple[int, int] = (960, 720), lighting: str = "fast"
) -> Path:
    """Render the scene from above at an angle (ceiling left out) to a PNG, under the lighting preset
    ``lighting`` (:data:`biovln_ms.render.lighting.LIGHTING`)."""
    import gymnasium as gym

    import biovln_ms.tasks.lab_scene_env  # noqa: F401  (registers the env)

    env = gym.make(
        LAB_SCENE_ENV,
        specs=[spec],
        ceiling=False,
        render_size=size,
        lighting=lighting,
        render_mode="rgb_array",
        obs_mode="none",
        sim_backend="physx_cpu",
        render_backend=render_backend(),
    )
    try:
        env.reset(seed=0)
        frame = env.render()
        img = np.asarray(frame.cpu().numpy() if hasattr(frame, "cpu") else frame)[0].astype(np.uint8)
    finally:
        env.close()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(img).save(out)
    return out


def robot_eye_pose(spec: SceneSpec) -> tuple[np.ndarray, np.ndarray]:
    """(eye, target) of the head camera (0.88 m, level) at the start of the spec's first episode (episode
    sampler, seed 0): turned to the target object when the start sees its goal, else along the first leg
    of the shortest path (the way the robot sets off)."""

    nav = scene_navigation(spec)
    episode = EpisodeSampler(spec, nav).episodes(1, seed=0)[0]
    start = np.asarray(episode["start_position"][:2], float)
    target = next(o for o in spec.goal_objects() if o.id == episode["object_id"])
    path = nav.shortest_path(start, episode["goals"][0]["position"][:2])
    look = np.asarray(target.position[:2], float) if len(path) <= 2 else np.asarray(path[1], float)
    return np.array([*start, HEAD_HEIGHT]), np.array([*look, HEAD_HEIGHT])


def render_robot_and_top_views(
    spec: SceneSpec,
    out_dir: str | Path,
    lighting: str = "quality",
    eye_size: tuple[int, int] = (640, 480),
    top_width: int = 900,
) -> tuple[Path, Path]:
    """Two PNGs of ``spec`` under ``lighting``: ``<name>_robot.png``, the head camera's frame (the env's
    640x480, 79 degree camera and shader) at its first episode's start (:func:`robot_eye_pose`); and
    ``<name>_top.png``, straight down from above the ceiling (left out), the whole floor in the frame."""

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    eye, target = robot_eye_pose(spec)
    w, h = eye_size
    rgb, _ = GoalViewRenderer(spec, lighting, width=w, height=h).view(eye, target)
    robot = out_dir / f"{spec.name}_robot.png"
    Image.fromarray(rgb).save(robot)
    xy = np.concatenate([np.asarray(r.polygon) for r in spec.rooms])
    lo, hi = xy.min(0), xy.max(0)
    span = np.maximum(hi - lo, 1.0) * 1.04
    th = int(round(top_width * span[1] / span[0]))
    hfov = 50.0
    half = np.tan(np.radians(hfov) / 2)
    height = max(span[0] / 2, span[1] / 2 * top_width / th) / half  # metres above the floor: all in view
    renderer = GoalViewRenderer(
        spec, lighting, width=top_width, height=th, hfov_deg=hfov, ceiling=False, far=height + 5.0
    )
    centre = (lo + hi) / 2
    rgb, _ = renderer.view([*centre, height], [*centre, 0.0], up=(0.0, 1.0, 0.0))
    top = out_dir / f"{spec.name}_top.png"
    Image.fromarray(rgb).save(top)
    return robot, top
