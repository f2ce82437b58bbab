"""Build a scene spec into a SAPIEN or ManiSkill scene (thin layer over the pure-geometry spec).

Each instrument and piece of furniture becomes a static actor named by its id, with its own
segmentation id and its own look (:mod:`biovln_ms.sim.instance_looks`); walls and the floor are box
colliders, instruments use their catalog collision (a box, or the cached coacd convex hulls).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sapien

from biovln_ms.assetgen.variation import variant_for
from biovln_ms.catalog import load_catalog
from biovln_ms.paths import ASSET_DIR, COLLISION_DIR
from biovln_ms.render.lighting import apply_lighting
from biovln_ms.scene.shell import FLOOR_DEPTH, shell_glbs, wall_spans
from biovln_ms.scene.spec import ObjectSpec, SceneSpec
from biovln_ms.sim.instance_looks import apply_variant

#: ManiSkill's group-2 collision bits of a mobile base's wheels (30) and base link (31)
#: (``mani_skill.agents.robots.fetch``): the floor ignores them, as ManiSkill's own grounds do. Such a base
#: is carried at its height by its planar joints and rests on nothing; Fetch's wheels reach 5 mm below the
#: floor, so the edge where two rooms' floor boxes meet (a door, a corridor) stopped them.
FLOOR_IGNORED_BITS = (1 << 30) | (1 << 31)


def frictionless():
    """Scene colliders are frictionless: the robot stops at them and slides along them without its
    heading being twisted (PhysX averages the two materials' friction)."""
    return sapien.physx.PhysxMaterial(0.0, 0.0, 0.0)


def yaw_quat(yaw: float) -> list[float]:
    """wxyz quaternion of a rotation about Z."""
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


@dataclass
class BuiltScene:
    """Handles to what was built: actors by object id, plus the shell."""

    objects: dict[str, object] = field(default_factory=dict)
    shell: list = field(default_factory=list)


def _builder(scene, scene_idxs):
    b = scene.create_actor_builder()
    if scene_idxs is not None:
        b.set_scene_idxs(scene_idxs)
    return b


def add_spec_to_scene(
    scene,
    spec: SceneSpec,
    *,
    ceiling: bool = True,
    scene_idxs: list[int] | None = None,
    name_prefix: str = "",
    asset_dir: Path = ASSET_DIR,
    variants: bool = True,
) -> BuiltScene:
    """Add the spec's shell, furniture and instruments to ``scene`` (sapien.Scene or ManiSkillScene).
    Objects look as the GLBs in ``asset_dir`` show them, each in its own variant (``variants``)."""
    cat = load_catalog()
    built = BuiltScene()
    shell_path, ceiling_path = shell_glbs(spec)
    mat = frictionless()
    b = _builder(scene, scene_idxs)
    b.add_visual_from_file(str(shell_path))
    for r in spec.rooms:
        xy = np.asarray(r.polygon)
        lo, hi = xy.min(0), xy.max(0)
        b.add_box_collision(
            sapien.Pose([*(lo + hi) / 2, -FLOOR_DEPTH / 2]),
            half_size=[*(hi - lo) / 2, FLOOR_DEPTH / 2],
            material=mat,
        )
    for w, (start, end) in zip(spec.walls, wall_spans(spec)):
        n = np.asarray(w.interior)
        length = float(np.linalg.norm(end - start))
        centre = (start + end) / 2 - n * w.thickness / 2
        yaw = math.atan2(end[1] - start[1], end[0] - start[0])
        b.add_box_collision(
            sapien.Pose([*centre, w.height / 2], yaw_quat(yaw)),
            half_size=[length / 2, w.thickness / 2, w.height / 2],
            material=mat,
        )
    b.initial_pose = sapien.Pose()
    shell = b.build_static(name=f"{name_prefix}room_shell")
    _floor_ignores_mobile_bases(shell)
    built.shell.append(shell)
    if ceiling:
        b = _builder(scene, scene_idxs)
        b.add_visual_from_file(str(ceiling_path))
        b.initial_pose = sapien.Pose()
        built.shell.append(b.build_static(name=f"{name_prefix}ceiling"))
    uploads: dict = {}  # textures shared by this scene's variants
    for o in spec.objects():
        glb = Path(asset_dir) / f"{o.category}.glb"
        actor = _add_object(scene, o, glb, cat.get(o.category).collision, scene_idxs, name_prefix)
        if variants:
            apply_variant(actor, o.category, glb, variant_for(spec.name, spec.seed, o.id), uploads)
        built.objects[o.id] = actor
    return built


def _add_object(scene, o: ObjectSpec, glb: Path, collision: str, scene_idxs, name_prefix: str):
    b = _builder(scene, scene_idxs)
    b.add_visual_from_file(str(glb))
    if collision == "coacd":
        b.add_multiple_convex_collisions_from_file(
            str(COLLISION_DIR / f"{o.category}.obj"), material=frictionless()
        )
    else:
        b.add_box_collision(half_size=[s / 2 for s in o.size], material=frictionless())
    b.initial_pose = sapien.Pose(list(o.position), yaw_quat(o.yaw))
    return b.build_static(name=f"{name_prefix}{o.id}")


def _floor_ignores_mobile_bases(shell) -> None:
    """Set :data:`FLOOR_IGNORED_BITS` on the shell's floor boxes (below z = 0, the walls above)."""
    for entity in getattr(shell, "_objs", [shell]):  # a ManiSkill Actor (an entity per sub-scene) or Entity
        body = entity.find_component_by_type(sapien.physx.PhysxRigidStaticComponent)
        for shape in body.get_collision_shapes():
            if shape.local_pose.p[2] < 0:
                groups = shape.get_collision_groups()
                groups[2] |= FLOOR_IGNORED_BITS
                shape.set_collision_groups(groups)


def add_lights(
    scene,
    spec: SceneSpec,
    shadows: bool = False,
    scene_idxs: list[int] | None = None,
    lighting: str = "fast",
) -> None:
    """The lighting preset ``lighting`` (:data:`biovln_ms.render.lighting.LIGHTING`) for the spec's rooms:
    ambient light, a directional key light (shadowed with ``shadows``) and ceiling fixtures."""

    apply_lighting(scene, spec, lighting, key_shadow=shadows, scene_idxs=scene_idxs)
