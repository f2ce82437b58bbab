"""A scene as habitat-sim 0.2.2 assets: a stage its navmesh can use, a render-only overhead object, and
instance semantics (``export_habitat_scene``).

habitat-sim builds a scene's navmesh (Recast) from the stage's render asset alone (STATIC objects are
left out when it computes one on load), and Recast calls a triangle walkable when its normal, taken
from the winding order, lies within ``agent_max_slope`` of up. Our assembled scene would give a
walkable roof (the ceiling slab's top) and walkable islands on every bench, table and instrument top.
So the scene is split:

=============================  =================================================================
``<scene>.glb`` (the stage)     floor, walls, furniture and instruments, as ``biovln-ms scene export``
                                writes them, less the ceiling; every upward-facing triangle above
                                ``WALKABLE_HEIGHT`` has its winding reversed, so Recast still sees the
                                solid (no floor under a bench top becomes walkable) but not a walkable
                                surface, and back-face culling hides it from above
``<scene>.overhead.glb``        render-only: the ceiling and those top triangles with their original
                                winding, placed as a STATIC object by the scene instance
``<scene>.semantic.glb``        the whole scene, one mesh per instance, each vertex coloured with its
                                instance colour (linear float, so habitat-sim's sRGB conversion gives
                                back the colour listed in the descriptor)
``<scene>.semantic.txt``        the HM3D-format semantic scene descriptor: one line per instance,
                                ``id,RRGGBB,"category",region`` (instance ids from 1; 0 is unknown)
=============================  =================================================================

Instance ids: the spec's objects in order (1..N), then the room shell's parts (floor, wall, baseboard,
ceiling, ... one instance per part). A region is the object's room (its index in ``spec.rooms``), -1
for a wall that borders several.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from biovln_ms.geometry.frames import Z_UP_TO_Y_UP
from biovln_ms.io_utils import atomic_write_bytes, atomic_write_text
from biovln_ms.scene.export_glb import _pack, annotate, assemble
from biovln_ms.scene.spec import SceneSpec

WALKABLE_HEIGHT = 0.1  # m: the highest walkable surface a stage keeps (floor 0, baseboard tops 0.1)
MAX_SLOPE_DEG = 45.0  # habitat-sim's NavMeshSettings.agent_max_slope default
_EPS = 1e-6
SSD_HEADER = "HM3D Semantic Annotations"


@dataclass(frozen=True)
class SceneSemantics:
    """What the dataset needs from a scene's export: each object's instance id and its axis-aligned
    bounding-box centre in habitat's Y-up frame (habitat-lab's goal ``position``)."""

    instance_ids: dict[str, int]
    centres: dict[str, list[float]]


def walkable_tops(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Mask of the triangles Recast would call walkable and that lie above ``WALKABLE_HEIGHT``: normal
    (from the winding, Y-up) within ``MAX_SLOPE_DEG`` of +y and any vertex higher than the limit."""
    tri = vertices[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(n, axis=1)
    up = n[:, 1] > math.cos(math.radians(MAX_SLOPE_DEG)) * norm
    return up & (norm > 0) & (tri[:, :, 1].max(axis=1) > WALKABLE_HEIGHT + _EPS)


def _world(scene: trimesh.Scene, node: str) -> tuple[trimesh.Trimesh, np.ndarray]:
    tf, geom = scene.graph[node]
    mesh = scene.geometry[geom]
    return mesh, trimesh.transform_points(mesh.vertices, tf)


def _add(out: trimesh.Scene, src: trimesh.Scene, node: str, mesh: trimesh.Trimesh) -> None:
    """Add ``mesh`` as ``node`` under its parent frame, both with ``src``'s transforms."""
    parent = src.graph.transforms.parents[node]
    if parent not in out.graph.nodes:
        matrix = src.graph.get(frame_to=parent, frame_from=src.graph.base_frame)[0]
        out.graph.update(frame_to=parent, frame_from=out.graph.base_frame, matrix=matrix)
    local = src.graph.get(frame_to=node, frame_from=parent)[0]
    out.add_geometry(mesh, node_name=node, geom_name=node, parent_node_name=parent, transform=local)


def _with_faces(mesh: trimesh.Trimesh, faces: np.ndarray) -> trimesh.Trimesh:
    """A copy of ``mesh`` with ``faces`` (same vertices, UVs and vertex normals: the shading is unchanged)."""
    out = mesh.copy()
    normals = mesh.vertex_normals.copy()
    out.faces = faces
    out.vertex_normals = normals
    return out


def split_scene(spec: SceneSpec) -> tuple[trimesh.Scene, trimesh.Scene, trimesh.Scene]:
    """The assembled scene (Y-up) and its stage and overhead parts (module docstring)."""
    full = assemble(spec)
    full.apply_transform(Z_UP_TO_Y_UP)
    stage, overhead = trimesh.Scene(), trimesh.Scene()
    for node in full.graph.nodes_geometry:
        mesh, world = _world(full, node)
        if node.startswith("ceiling/"):
            _add(overhead, full, node, mesh)
            continue
        tops = walkable_tops(world, mesh.faces)
        if not tops.any():
            _add(stage, full, node, mesh)
            continue
        faces = mesh.faces.copy()
        faces[tops] = faces[tops][:, ::-1]
        _add(stage, full, node, _with_faces(mesh, faces))
        _add(overhead, full, node, mesh.submesh([np.flatnonzero(tops)], append=True))
    return full, stage, overhead


def instance_color(instance_id: int) -> tuple[int, int, int]:
    """A distinct sRGB colour per id: 24-bit multiplication by an odd constant is a bijection, so ids
    never share a colour, and only id 0 (unknown) is black."""
    c = (instance_id * 0x9E3779) & 0xFFFFFF
    return (c >> 16) & 0xFF, (c >> 8) & 0xFF, c & 0xFF


def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    c = c / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _shell_part(node: str, rooms: list[str]) -> tuple[str, int]:
    """Category and region of a shell node (``room_shell/shell.wall_3``, ``ceiling/shell.ceiling_lab``)."""
    part = node.split("/", 1)[1].removeprefix("shell.")
    category = "baseboard" if part.endswith("_baseboard") else part.split("_", 1)[0]
    suffix = part.split("_", 1)[1] if "_" in part else ""
    return category, rooms.index(suffix) if suffix in rooms else -1


def semantic_glb(full: trimesh.Scene, spec: SceneSpec) -> tuple[bytes, str, SceneSemantics]:
    """The semantic mesh (GLB bytes), its HM3D-format descriptor and the objects' ids and centres."""
    rooms = [r.id for r in spec.rooms]
    objects = {o.id: i + 1 for i, o in enumerate(spec.objects())}
    groups: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    for node in full.graph.nodes_geometry:
        mesh, world = _world(full, node)
        owner = node.split("/", 1)[0]
        groups.setdefault(owner if owner in objects else node, []).append((world, mesh.faces))
    shell = sorted((k for k in groups if k not in objects), key=list(groups).index)
    ids = {**objects, **{k: len(objects) + 1 + i for i, k in enumerate(shell)}}
    by_id = {o.id: o for o in spec.objects()}
    gltf = {"asset": {"version": "2.0", "generator": "biovln-ms"}, "scenes": [{"nodes": []}], "scene": 0}
    for key in ("nodes", "meshes", "accessors", "bufferViews"):
        gltf[key] = []
    binary, lines, centres = bytearray(), [], {}

    def view(data: bytes, target: int) -> int:
        gltf["bufferViews"].append(
            {"buffer": 0, "byteOffset": len(binary), "byteLength": len(data), "target": target}
        )
        binary.extend(data + b"\0" * (-len(data) % 4))
        return len(gltf["bufferViews"]) - 1

    def accessor(arr: np.ndarray, kind: str, ctype: int, target: int, bounds: bool = False) -> int:
        acc = {
            "bufferView": view(arr.tobytes(), target),
            "componentType": ctype,
            "count": len(arr),
            "type": kind,
        }
        if bounds:
            acc["min"], acc["max"] = arr.min(0).tolist(), arr.max(0).tolist()
        gltf["accessors"].append(acc)
        return len(gltf["accessors"]) - 1

    for key in sorted(groups, key=ids.__getitem__):  # node i holds instance i + 1
        parts, iid = groups[key], ids[key]
        offsets = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
        verts = np.concatenate([v for v, _ in parts]).astype(np.float32)
        faces = np.concatenate([f + o for (_, f), o in zip(parts, offsets)]).astype(np.uint32)
        rgb = instance_color(iid)
        colors = np.tile(_srgb_to_linear(np.asarray(rgb, float)).astype(np.float32), (len(verts), 1))
        prim = {
            "attributes": {
                "POSITION": accessor(verts, "VEC3", 5126, 34962, bounds=True),
                "COLOR_0": accessor(colors, "VEC3", 5126, 34962),
            },
            "indices": accessor(faces.reshape(-1), "SCALAR", 5125, 34963),
            "mode": 4,
        }
        gltf["meshes"].append({"name": key, "primitives": [prim]})
        gltf["nodes"].append({"name": key, "mesh": len(gltf["meshes"]) - 1})
        gltf["scenes"][0]["nodes"].append(len(gltf["nodes"]) - 1)
        if key in by_id:
            category, region = by_id[key].category, rooms.index(by_id[key].room)
            lo, hi = verts.min(0).astype(float), verts.max(0).astype(float)
            centres[key] = [round(float(v), 6) + 0.0 for v in (lo + hi) / 2]
        else:
            category, region = _shell_part(key, rooms)
        lines.append((iid, f'{iid},{"%02X%02X%02X" % rgb},"{category}",{region}'))
    gltf["buffers"] = [{"byteLength": len(binary)}]
    ssd = "\n".join([SSD_HEADER, *(line for _, line in sorted(lines))]) + "\n"
    return _pack(gltf, binary), ssd, SceneSemantics(instance_ids=objects, centres=centres)


def stage_config(scene: str) -> dict:
    """habitat-sim stage attributes: the stage GLB (Y-up, metres) and its semantic mesh."""
    frame = {"up": [0, 1, 0], "front": [0, 0, -1]}
    return {
        "render_asset": f"{scene}.glb",
        **frame,
        "origin": [0, 0, 0],
        "units_to_meters": 1.0,
        "semantic_asset": f"{scene}.semantic.glb",
        "semantic_descriptor_filename": f"{scene}.semantic.txt",
        "semantic_up": frame["up"],
        "semantic_front": frame["front"],
    }


def overhead_config(scene: str) -> dict:
    """habitat-sim object attributes of the render-only overhead asset."""
    return {
        "render_asset": f"{scene}.overhead.glb",
        "up": [0, 1, 0],
        "front": [0, 0, -1],
        "units_to_meters": 1.0,
        "is_collidable": False,
    }


def scene_instance(scene: str) -> dict:
    """habitat-sim scene instance: the stage, the overhead object where it stands in the GLB's frame
    (STATIC: rendered, not part of the navmesh habitat-sim computes), the semantic descriptor."""
    return {
        "translation_origin": "asset_local",
        "stage_instance": {"template_name": f"{scene}.stage_config.json"},
        "object_instances": [
            {
                "template_name": f"{scene}.overhead.object_config.json",
                "translation_origin": "asset_local",
                "motion_type": "STATIC",
            }
        ],
        "semantic_scene_instance": scene,
    }


def _json(obj: dict) -> str:
    return json.dumps(obj, indent=1) + "\n"


def export_habitat_scene(spec: SceneSpec, scenes_dir: str | Path) -> tuple[list[Path], SceneSemantics]:
    """Write the scene's habitat-sim files (module docstring, plus its stage, object and scene instance
    configs) under ``scenes_dir``, each atomically; returns them and the objects' ids and centres."""
    d, s = Path(scenes_dir), spec.name
    full, stage, overhead = split_scene(spec)
    sem_bytes, ssd, semantics = semantic_glb(full, spec)
    files = [
        atomic_write_bytes(d / f"{s}.glb", annotate(stage.export(file_type="glb"), spec)),
        atomic_write_bytes(d / f"{s}.overhead.glb", annotate(overhead.export(file_type="glb"), spec)),
        atomic_write_bytes(d / f"{s}.semantic.glb", sem_bytes),
        atomic_write_text(d / f"{s}.semantic.txt", ssd),
        atomic_write_text(d / f"{s}.stage_config.json", _json(stage_config(s))),
        atomic_write_text(d / f"{s}.overhead.object_config.json", _json(overhead_config(s))),
        atomic_write_text(d / f"{s}.scene_instance.json", _json(scene_instance(s))),
    ]
    return files, semantics
