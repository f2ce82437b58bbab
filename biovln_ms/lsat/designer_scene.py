"""The LSAT Target scene (paper Table 4): one designer-authored lab, written as a Blender-style GLB.

This plays the designer: instruments placed by hand in an 8 x 6 m room (free placement, not a
procedural template), compact as in the paper — a 5.9 m bench island splits the room, the wall
instruments face narrow aisles — with the paper's eight LSAT categories (Table 6: cabinet, incubator,
lab bench, lab table, mini centrifuge, pipette stand, refrigerator, waste bin). Node names are what a
designer types (``Refrigerator``, ``Incubator.001``, ``Storage Cabinet``); each instrument's parts are
children. ``target_*`` empties mark where the robot should stand, placed by eye in front of the
operational face; two goal objects (the bench and the waste bin) have no marker, so the import
exercises both strategies. The file is a proper glTF: Y-up, Blender's "+Y up" convention.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import trimesh

from biovln_ms.assetgen.generate import load_glb
from biovln_ms.catalog import load_catalog
from biovln_ms.geometry.zones import rot2
from biovln_ms.io_utils import atomic_write_bytes
from biovln_ms.geometry.frames import Z_UP_TO_Y_UP
from biovln_ms.paths import ASSET_DIR

ROOM = (8.0, 6.0, 3.0)  # x, y, wall height (m)

# (node name, category, centre x, centre y, yaw in degrees, marker name or None,
# marker offset (along face, lateral) m)
LayoutRow = tuple[str, str, float, float, float, str | None, tuple[float, float] | None]
LAYOUT: list[LayoutRow] = [
    ("Lab Bench", "lab_bench", 4.0, 2.2, 90, None, None),
    ("Lab Table", "lab_table", 2.0, 5.55, 0, "target_lab_table", (0.55, 0.10)),
    ("Refrigerator", "refrigerator", 4.2, 5.545, 0, "target_refrigerator", (0.50, -0.04)),
    ("Incubator.001", "incubator", 5.3, 5.325, 90, "target_incubator.001", (0.55, 0.05)),
    ("Storage Cabinet", "cabinet", 7.308, 4.0, 180, "target_cabinet", (0.60, 0.00)),
    ("Waste Bin", "waste_bin", 0.40, 4.0, 0, None, None),
    ("Mini Centrifuge", "mini_centrifuge", 2.5, 2.62, -90, "target_minicentrifuge", (0.45, 0.0)),
    ("Pipette Stand", "pipette", 5.5, 2.78, 180, "target_pipette", (0.40, 0.03)),
]


def _z_up_to_gltf(m: np.ndarray) -> np.ndarray:
    return Z_UP_TO_Y_UP @ m


def _box(name: str, scene: trimesh.Scene, size, centre) -> None:
    mesh = trimesh.creation.box(size)
    scene.add_geometry(
        mesh,
        node_name=name,
        geom_name=name,
        transform=_z_up_to_gltf(trimesh.transformations.translation_matrix(centre)),
    )


def build_target_scene() -> trimesh.Scene:
    """The scene as a trimesh Scene in glTF's Y-up frame."""
    return build_designer_scene(LAYOUT)


def build_designer_scene(layout: list[LayoutRow]) -> trimesh.Scene:
    """A designer's ROOM (floor and four walls) holding ``layout``'s rows, as a trimesh Scene in glTF's
    Y-up frame: each row a node named as given, its category's asset parts as children, and its marker
    empty; a table-top row stands on the bench or table row under it."""
    cat = load_catalog()
    scene = trimesh.Scene()
    w, d, h = ROOM
    _box("Floor", scene, (w, d, 0.02), (w / 2, d / 2, -0.01))
    t = 0.1
    _box("Wall_North", scene, (w + 2 * t, t, h), (w / 2, d + t / 2, h / 2))
    _box("Wall_South", scene, (w + 2 * t, t, h), (w / 2, -t / 2, h / 2))
    _box("Wall_East", scene, (t, d, h), (w + t / 2, d / 2, h / 2))
    _box("Wall_West", scene, (t, d, h), (-t / 2, d / 2, h / 2))
    base = scene.graph.base_frame
    for name, category, x, y, yaw_deg, marker, offset in layout:
        a = cat.get(category)
        yaw = math.radians(yaw_deg)
        if a.placement == "table_top":
            support = next(
                s
                for s in layout
                if s[1] in cat.support_heights and abs(x - s[2]) < 3.0 and abs(y - s[3]) < 1.0
            )
            z = cat.support_heights[support[1]] + a.dimensions[2] / 2
        else:
            z = a.dimensions[2] / 2
        pose = trimesh.transformations.rotation_matrix(yaw, [0, 0, 1])
        pose[:3, 3] = (x, y, z)
        scene.graph.update(frame_to=name, frame_from=base, matrix=_z_up_to_gltf(pose))
        parts = load_glb(ASSET_DIR / f"{category}.glb")
        for node in parts.graph.nodes_geometry:
            transform, geom = parts.graph[node]
            scene.add_geometry(
                parts.geometry[geom],
                node_name=f"{name}|{node.split('.', 1)[-1]}",
                geom_name=f"{name}|{geom}",
                parent_node_name=name,
                transform=transform,
            )
        if marker:
            face = rot2(yaw) @ np.asarray(a.face_vector)
            lateral = np.array([-face[1], face[0]])
            xy = np.array([x, y]) + face * (a.d_half + offset[0]) + lateral * offset[1]
            scene.graph.update(
                frame_to=marker,
                frame_from=base,
                matrix=_z_up_to_gltf(trimesh.transformations.translation_matrix([xy[0], xy[1], 0.0])),
            )
    return scene


def write_target_glb(out: str | Path) -> Path:
    """Write the LSAT Target GLB (deterministic bytes)."""
    buf = io.BytesIO(build_target_scene().export(file_type="glb"))
    return atomic_write_bytes(out, buf.getvalue())


def target_glb_path() -> Path:
    """The shipped LSAT Target GLB."""
    return ASSET_DIR / "scenes" / "lsat_target.glb"
