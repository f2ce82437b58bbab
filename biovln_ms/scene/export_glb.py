"""Export an assembled scene as one GLB (the paper's P2 output).

A node per instrument / piece of furniture named by its id (with the parts as children), the room
shell as ``room_shell`` and ``ceiling``. Every object node carries ``extras`` (category, id, goal,
face, success radius); every primitive carries a semantic ``COLOR_0`` vertex colour, one colour per
category (``SEMANTIC_COLORS``), as the paper's semantic-annotation stage does. Viewers that honour
COLOR_0 tint the textures with it.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import trimesh

from biovln_ms.assetgen.generate import load_glb
from biovln_ms.catalog import PAPER_GOAL_CATEGORIES, load_catalog
from biovln_ms.geometry.frames import Z_UP_TO_Y_UP
from biovln_ms.io_utils import atomic_write_bytes
from biovln_ms.paths import asset_glb
from biovln_ms.scene.shell import shell_scene
from biovln_ms.scene.spec import SceneSpec, SceneSpecError

ROOM_CATEGORY = "room"


def semantic_colors() -> dict[str, tuple[int, int, int, int]]:
    """A fixed RGBA colour per category: the paper's ten (catalog order), the room shell, then the
    other categories and the lab dressing, each appended at the end, so a new category never changes an
    existing colour."""
    cat = load_catalog()
    later = [n for n in cat.names() if n not in PAPER_GOAL_CATEGORIES]
    names = [*PAPER_GOAL_CATEGORIES, ROOM_CATEGORY, *later, *(a.name for a in cat.dressing())]
    rng = np.random.default_rng(7)
    cols = rng.integers(40, 256, size=(len(names), 3))
    return {n: (int(c[0]), int(c[1]), int(c[2]), 255) for n, c in zip(names, cols)}


def _yaw_matrix(position, yaw: float) -> np.ndarray:
    m = trimesh.transformations.rotation_matrix(yaw, [0, 0, 1])
    m[:3, 3] = position
    return m


def assemble(spec: SceneSpec) -> trimesh.Scene:
    scene = trimesh.Scene()
    for shell_name, ceiling in (("room_shell", False), ("ceiling", True)):
        part = shell_scene(spec, ceiling)
        scene.graph.update(frame_to=shell_name, frame_from=scene.graph.base_frame, matrix=np.eye(4))
        for node in part.graph.nodes_geometry:
            tf, geom = part.graph[node]
            scene.add_geometry(
                part.geometry[geom],
                node_name=f"{shell_name}/{geom}",
                geom_name=f"{shell_name}/{geom}",
                parent_node_name=shell_name,
                transform=tf,
            )
    assets: dict[str, trimesh.Scene] = {}

    for o in spec.objects():
        if o.category not in assets:
            assets[o.category] = load_glb(asset_glb(o.category))
        asset = assets[o.category]
        scene.graph.update(
            frame_to=o.id, frame_from=scene.graph.base_frame, matrix=_yaw_matrix(o.position, o.yaw)
        )
        for node in asset.graph.nodes_geometry:
            tf, geom = asset.graph[node]
            part = geom.split(".", 1)[-1]
            scene.add_geometry(
                asset.geometry[geom],
                node_name=f"{o.id}/{part}",
                geom_name=f"{o.id}/{part}",
                parent_node_name=o.id,
                transform=tf,
            )
    return scene


def _chunks(glb: bytes) -> tuple[dict, bytearray]:
    magic, version, _ = struct.unpack_from("<III", glb, 0)
    if magic != 0x46546C67 or version != 2:
        raise ValueError("not a glTF 2.0 binary")
    jlen, jtype = struct.unpack_from("<II", glb, 12)
    gltf = json.loads(glb[20 : 20 + jlen])
    off = 20 + jlen
    blen, _ = struct.unpack_from("<II", glb, off)
    return gltf, bytearray(glb[off + 8 : off + 8 + blen])


def _pack(gltf: dict, binary: bytearray) -> bytes:
    # allow_nan=False is the last guard against non-finite output (unreachable for a validated spec): it
    # covers extras, node matrices and, through the POSITION accessors' min/max, every vertex.
    try:
        j = json.dumps(gltf, separators=(",", ":"), sort_keys=True, allow_nan=False).encode()
    except ValueError:
        raise SceneSpecError(
            "cannot export: the scene GLB would hold a non-finite number (NaN or infinity)",
            fix="check the spec with `biovln-ms scene validate`",
        ) from None
    j += b" " * (-len(j) % 4)
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(j) + 8 + len(binary)
    return (
        struct.pack("<III", 0x46546C67, 2, total)
        + struct.pack("<II", len(j), 0x4E4F534A)
        + j
        + struct.pack("<II", len(binary), 0x004E4942)
        + bytes(binary)
    )


def annotate(glb: bytes, spec: SceneSpec) -> bytes:
    """Add object extras to nodes and a semantic COLOR_0 to every primitive."""
    gltf, binary = _chunks(glb)
    colors = semantic_colors()
    objects = {o.id: o for o in spec.objects()}
    mesh_owner: dict[int, str] = {}
    for node in gltf.get("nodes", []):
        name = node.get("name", "")
        owner = name.split("/", 1)[0]
        if name in objects:
            o = objects[name]
            node["extras"] = {
                "object_id": o.id,
                "category": o.category,
                "is_goal": o.is_goal,
                "placement": o.placement,
                "goal": list(o.goal) if o.goal else None,
                "face": list(o.face) if o.face else None,
                "success_radius": o.success_radius,
                "semantic_color": list(colors[o.category]),
            }
        elif name in ("room_shell", "ceiling"):
            node["extras"] = {"category": ROOM_CATEGORY, "semantic_color": list(colors[ROOM_CATEGORY])}
        if "mesh" in node:
            mesh_owner[node["mesh"]] = objects[owner].category if owner in objects else ROOM_CATEGORY
    gltf.setdefault("bufferViews", [])
    gltf.setdefault("accessors", [])
    for mi, mesh in enumerate(gltf.get("meshes", [])):
        rgba = colors[mesh_owner.get(mi, ROOM_CATEGORY)]
        for prim in mesh["primitives"]:
            count = gltf["accessors"][prim["attributes"]["POSITION"]]["count"]
            binary += b"\0" * (-len(binary) % 4)
            data = np.tile(np.array(rgba, np.uint8), (count, 1)).tobytes()
            gltf["bufferViews"].append(
                {"buffer": 0, "byteOffset": len(binary), "byteLength": len(data), "target": 34962}
            )
            binary += data
            gltf["accessors"].append(
                {
                    "bufferView": len(gltf["bufferViews"]) - 1,
                    "componentType": 5121,
                    "normalized": True,
                    "count": count,
                    "type": "VEC4",
                }
            )
            prim["attributes"]["COLOR_0"] = len(gltf["accessors"]) - 1
    gltf["buffers"][0]["byteLength"] = len(binary) + (-len(binary) % 4)
    gltf.setdefault("asset", {})["extras"] = {
        "scene": spec.name,
        "template": spec.template,
        "seed": spec.seed,
        "semantic_colors": {k: list(v) for k, v in colors.items()},
    }
    return _pack(gltf, binary)


def export_scene_glb(spec: SceneSpec, out: str | Path) -> Path:
    """Write the assembled, annotated scene GLB atomically, in glTF's Y-up frame (Blender, Habitat and
    viewers show it upright; ``biovln-ms lsat import`` reads it back)."""

    scene = assemble(spec)
    scene.apply_transform(Z_UP_TO_Y_UP)
    glb = scene.export(file_type="glb")
    return atomic_write_bytes(out, annotate(glb, spec))
