"""What the robot's head camera sees of a goal object from its Zone-3 goal.

A plain SAPIEN scene of a whole spec, lit by a preset of :mod:`biovln_ms.render.lighting`, seen by a
camera like the env's head camera (ManiSkill's "minimal" shader with 8-bit colour, 0.88 m high and
level, the task's field of view). :func:`distinct_colours` counts the distinct RGB values on one
object's pixels, the paper's measure of surface diversity (Table 8).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from biovln_ms.errors import BioVLNError
from biovln_ms.paths import ASSET_DIR
from biovln_ms.render.sapien_utils import env_camera_scene, look_at_pose
from biovln_ms.scene.generator import GenerationError, generate_scene
from biovln_ms.scene.spec import ObjectSpec, SceneSpec
from biovln_ms.scene.templates import TemplateError, get_template

#: height of the head camera (agents/robots/biovln_base.py)
HEAD_HEIGHT = 0.88
#: the templates whose scenes show the goal categories, in order, and the seeds tried for each
SHOWCASE_TEMPLATES = ("two_room", "molecular_biology")
SHOWCASE_SEEDS = range(4)
#: furniture goals: every scene has them, none need asking for
FURNITURE = ("lab_bench", "lab_table")


def showcase_scenes(categories: list[str]) -> list[tuple[SceneSpec, list[ObjectSpec]]]:
    """Scenes that show each of ``categories`` once: for each template of :data:`SHOWCASE_TEMPLATES` and
    seed of :data:`SHOWCASE_SEEDS` in turn, the scene asked to hold as many of the categories still
    unseen as its slots allow (added greedily, in catalog order), with the first instance of each it
    holds. Deterministic: the same categories give the same scenes."""

    out, left = [], list(categories)
    for template in SHOWCASE_TEMPLATES:
        for seed in SHOWCASE_SEEDS:
            offered = [c for c in left if c in get_template(template).categories()]
            if not offered:
                break
            spec, required = None, []
            for c in offered:
                if c in FURNITURE:
                    continue
                try:
                    spec = generate_scene(template, seed, required_categories=[*required, c])
                    required.append(c)
                except (TemplateError, GenerationError):
                    continue
            spec = spec or generate_scene(template, seed)
            held = {o.category for o in spec.goal_objects()}
            mine = [c for c in offered if c in held]
            if mine:
                out.append((spec, [next(o for o in spec.goal_objects() if o.category == c) for c in mine]))
                left = [c for c in left if c not in mine]
    if left:
        raise BioVLNError(
            f"no showcase scene holds {', '.join(left)}",
            field="SHOWCASE_TEMPLATES",
            fix="add a template that offers it (biovln_ms/render/goal_views.py)",
        )
    return out


def goal_views(obj: ObjectSpec, offsets_deg: tuple[float, ...] = (0.0, -15.0, 15.0)) -> list[np.ndarray]:
    """Head-camera eyes around ``obj``: its Eq. 1 goal turned by each offset about the object's centre
    (0 is the goal itself; ±15° stay within the success radius of every catalog asset)."""
    c = np.asarray(obj.position[:2], float)
    g = np.asarray(obj.goal, float)
    out = []
    for deg in offsets_deg:
        a = math.radians(deg)
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        out.append(np.array([*(c + rot @ (g - c)), HEAD_HEIGHT]))
    return out


def distinct_colours(rgb: np.ndarray, mask: np.ndarray) -> int:
    """Number of distinct RGB triples of ``rgb`` (H, W, 3 uint8) inside ``mask`` (H, W bool)."""
    px = rgb[mask].astype(np.uint32)
    if px.size == 0:
        return 0
    return int(np.unique((px[:, 0] << 16) | (px[:, 1] << 8) | px[:, 2]).size)


class GoalViewRenderer:
    """One SAPIEN scene of ``spec`` under ``lighting`` and one head-like camera moved between views
    (``ceiling=False`` leaves the ceiling out and ``far`` moves the far plane, for views from above)."""

    def __init__(
        self,
        spec: SceneSpec,
        lighting: str = "quality",
        width: int = 640,
        height: int = 480,
        hfov_deg: float = 79.0,
        asset_dir: Path = ASSET_DIR,
        variants: bool = True,
        ceiling: bool = True,
        far: float = 20.0,
    ) -> None:

        from biovln_ms.sim.sapien_builder import add_lights, add_spec_to_scene

        self.scene = env_camera_scene()  # the env's head camera's shader pack and picture formats
        self.spec = spec
        self.built = add_spec_to_scene(
            self.scene, spec, asset_dir=asset_dir, variants=variants, ceiling=ceiling
        )
        add_lights(self.scene, spec, lighting=lighting)
        vfov = 2 * math.atan(math.tan(math.radians(hfov_deg) / 2) * height / width)
        self.camera = self.scene.add_camera("head", width, height, vfov, 0.05, far)

    def render(self, obj: ObjectSpec, eye: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """RGB (H, W, 3 uint8) from ``eye`` looking at ``obj``'s centre, and the mask of ``obj``'s pixels."""
        rgb, seg = self.view(eye, obj.position)
        return rgb, seg == self.built.objects[obj.id].per_scene_id

    def view(
        self, eye, target, up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    ) -> tuple[np.ndarray, np.ndarray]:
        """RGB (H, W, 3 uint8) from ``eye`` looking at ``target``, and the per-actor segmentation ids."""

        self.camera.entity.set_pose(look_at_pose(eye, target, up))
        self.scene.update_render()
        self.camera.take_picture()
        rgb = np.asarray(self.camera.get_picture("Color"))[..., :3]
        if rgb.dtype != np.uint8:
            rgb = (np.clip(rgb, 0, 1) * 255).round().astype(np.uint8)
        return rgb, np.asarray(self.camera.get_picture("PositionSegmentation"))[..., 3]
