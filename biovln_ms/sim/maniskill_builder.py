"""The ManiSkill scene builder of BioVLN lab scenes, registered as ``BioVLN-Lab``.

``build_configs`` are scene specs; with several parallel envs each env can get a different spec
(ManiSkill's ``set_scene_idxs``), as ManiSkill's ReplicaCAD and AI2-THOR builders do.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence, Union

import numpy as np
import sapien
import shapely
import torch
import trimesh
from mani_skill.utils.scene_builder import SceneBuilder
from mani_skill.utils.scene_builder.registration import register_scene_builder

from biovln_ms.scene.rules import scene_free_space, validate_spec
from biovln_ms.sim.sapien_builder import BuiltScene, add_lights, add_spec_to_scene
from biovln_ms.scene.loading import load_spec
from biovln_ms.scene.spec import SceneSpec

SpecLike = Union[SceneSpec, str, Path]


def as_spec(s: SpecLike) -> SceneSpec:
    return s if isinstance(s, SceneSpec) else validate_spec(load_spec(s), str(s))


@register_scene_builder("BioVLN-Lab")
class LabSceneBuilder(SceneBuilder):
    """Builds scene specs: room shell, furniture and instruments (one static actor each)."""

    builds_lighting = True

    def __init__(
        self,
        env,
        specs: Sequence[SpecLike],
        ceiling: bool = True,
        robot_init_qpos_noise: float = 0.0,
        lighting: str = "fast",
        variants: bool = True,
    ) -> None:
        super().__init__(env, robot_init_qpos_noise=robot_init_qpos_noise)
        self.build_configs = [as_spec(s) for s in specs]
        self.variants = variants  # each instrument's own look (add_spec_to_scene's ``variants``)
        self.init_configs = [None]
        self.ceiling = ceiling
        self.lighting = lighting  # a preset of biovln_ms.render.lighting.LIGHTING
        self.env_specs: list[SceneSpec] = []
        self.built: dict[int, BuiltScene] = {}

    def build(self, build_config_idxs: int | list[int] = 0) -> None:
        if isinstance(build_config_idxs, int):
            build_config_idxs = [build_config_idxs] * self.env.num_envs
        if len(build_config_idxs) != self.env.num_envs:
            raise ValueError(
                f"build_config_idxs: {len(build_config_idxs)} given for {self.env.num_envs} envs"
            )
        self.env_specs = [self.build_configs[i] for i in build_config_idxs]
        self.built = {}
        self.scene_objects = {}
        self.movable_objects = {}
        self.articulations = {}
        for bci in sorted(set(build_config_idxs)):
            env_idx = [i for i, v in enumerate(build_config_idxs) if v == bci]
            spec = self.build_configs[bci]
            prefix = "" if self.env.num_envs == 1 else f"scs-{bci}_"
            idxs = None if self.env.num_envs == 1 else env_idx
            built = add_spec_to_scene(
                self.scene,
                spec,
                ceiling=self.ceiling,
                scene_idxs=idxs,
                name_prefix=prefix,
                variants=self.variants,
            )
            add_lights(self.scene, spec, scene_idxs=idxs, lighting=self.lighting)
            self.built[bci] = built
            for obj_id, actor in built.objects.items():
                self.scene_objects[f"{prefix}{obj_id}"] = actor

    @property
    def navigable_positions(self) -> list[trimesh.Trimesh]:
        """Per sub-env, the floor a robot of the spec's radius can stand on, as a flat triangle mesh at z = 0
        (ManiSkill's ReplicaCAD / AI2-THOR builders expose the same property from precomputed files)."""
        meshes = {}
        for spec in self.env_specs:
            if spec.name not in meshes:
                meshes[spec.name] = free_space_mesh(scene_free_space(spec))
        return [meshes[spec.name] for spec in self.env_specs]

    def initialize(self, env_idx: torch.Tensor, init_config_idxs: list[int] | None = None) -> None:
        """The scene is static: nothing to reset between episodes."""

    def ceiling_bodies(self) -> list:
        """The render bodies of every built scene's ceilings (a follow camera above the robot hides them)."""
        return [
            e.find_component_by_type(sapien.render.RenderBodyComponent)
            for b in self.built.values()
            for a in b.shell
            if a.name.endswith("ceiling")
            for e in a._objs
        ]

    def segmentation_ids(self, bci: int = 0) -> dict[int, str]:
        """Per-scene segmentation id -> object id for one build config."""
        out = {}
        for obj_id, actor in self.built[bci].objects.items():
            for sid in np.atleast_1d(
                actor.per_scene_id.cpu().numpy() if hasattr(actor.per_scene_id, "cpu") else actor.per_scene_id
            ):
                out[int(sid)] = obj_id
        return out


def free_space_mesh(free) -> trimesh.Trimesh:
    """A (Multi)Polygon triangulated (constrained Delaunay, holes kept) into a mesh in the z = 0 plane."""
    tris = shapely.constrained_delaunay_triangles(free)
    coords = np.array([np.asarray(t.exterior.coords)[:3] for t in tris.geoms], float)  # (k, 3, 2)
    vertices = np.concatenate([coords.reshape(-1, 2), np.zeros((coords.shape[0] * 3, 1))], axis=1)
    mesh = trimesh.Trimesh(vertices, np.arange(len(vertices)).reshape(-1, 3), process=True)
    mesh.fix_normals()
    return mesh
