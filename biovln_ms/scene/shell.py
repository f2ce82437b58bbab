"""The room shell of a scene spec as meshes: floor, walls with baseboards, door jambs, ceiling.

Textures tile per metre (so an 8 m wall is not one stretched image). The shell depends only on the
spec's rooms and walls; its GLBs are cached under ``$BIOVLN_CACHE_DIR`` (default
``~/.cache/biovln_ms``) keyed by their hash and written atomically.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import trimesh

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.parts import Kit
from biovln_ms.io_utils import atomic_write_bytes
from biovln_ms.paths import cache_dir
from biovln_ms.scene.spec import SceneSpec

FLOOR_DEPTH = 0.05
BASEBOARD = (0.10, 0.015)  # height, thickness


def _key(spec: SceneSpec) -> str:
    data = {
        "rooms": [r.model_dump(mode="json") for r in spec.rooms],
        "walls": [w.model_dump(mode="json") for w in spec.walls],
        "openings": [o.model_dump(mode="json") for o in spec.openings],
        "v": 2,  # 2: walls stop at concave corners (wall_spans)
    }
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]


def wall_spans(spec: SceneSpec) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each wall's run along its line, ``(a, b)``: its segment, lengthened by the thickness at an end where
    the piece that adds lies outside the floor (a convex corner, which it closes). At a concave corner (a
    door's jamb meeting the corridor wall) the piece would stand on the floor, so the wall stops at its end:
    every wall box then lies outside the floor, where the free space (``scene.rules``) assumes it."""
    from shapely.geometry import Polygon
    from shapely.ops import unary_union

    floor = unary_union([Polygon(r.polygon) for r in spec.rooms])
    spans = []
    for w in spec.walls:
        s, e, n = np.asarray(w.start, float), np.asarray(w.end, float), np.asarray(w.interior, float)
        d = (e - s) / np.linalg.norm(e - s)
        ends = []
        for p, out in ((s, -d), (e, d)):
            q = p + out * w.thickness
            piece = Polygon([p, q, q - n * w.thickness, p - n * w.thickness])
            ends.append(q if piece.intersection(floor).area < 1e-9 else p)
        spans.append((ends[0], ends[1]))
    return spans


def _kit() -> Kit:
    return Kit("shell", 1.0, 1.0, 1.0)


def shell_scene(spec: SceneSpec, ceiling: bool) -> trimesh.Scene:
    """Floor + walls (+ baseboards and door jambs), or with ``ceiling`` only the ceiling slabs."""
    k = _kit()
    if ceiling:
        mat = k.material(
            "ceiling", texture=tx.floor_vinyl((0.93, 0.93, 0.92), k.seed("ceiling")), tile=0.6, roughness=0.9
        )
        for r in spec.rooms:
            xy = np.asarray(r.polygon)
            k.box_span(f"ceiling_{r.id}", (*xy.min(0), r.height), (*xy.max(0), r.height + FLOOR_DEPTH), mat)
        return k.scene((0.0, -1.0))
    floor = k.material(
        "floor", texture=tx.floor_vinyl((0.55, 0.60, 0.58), k.seed("floor")), tile=0.5, roughness=0.7
    )
    wall = k.material("wall", texture=tx.powder_coat((0.86, 0.87, 0.84), k.seed("wall"), amount=5), tile=0.5)
    base = k.material("baseboard", color=(0.25, 0.26, 0.28, 1.0), texture=None)
    jamb = k.material("jamb", texture=tx.powder_coat((0.45, 0.50, 0.58), k.seed("jamb"), amount=8), tile=0.25)
    for r in spec.rooms:
        xy = np.asarray(r.polygon)
        k.box_span(f"floor_{r.id}", (*xy.min(0), -FLOOR_DEPTH), (*xy.max(0), 0.0), floor)
    for w, (a, b) in zip(spec.walls, wall_spans(spec)):
        s, e, n = np.asarray(w.start), np.asarray(w.end), np.asarray(w.interior)
        # the wall stands outside the floor; its run closes the convex corners (wall_spans)
        outer_a, outer_b = a - n * w.thickness, b - n * w.thickness
        pts = np.array([a, b, outer_a, outer_b])
        k.box_span(f"{w.id}", (*pts.min(0), 0.0), (*pts.max(0), w.height), wall)
        bb = np.array([s, e, s + n * BASEBOARD[1], e + n * BASEBOARD[1]])
        k.box_span(f"{w.id}_baseboard", (*bb.min(0), 0.0), (*bb.max(0), BASEBOARD[0]), base)
    for o in spec.openings:
        c, n = np.asarray(o.center), np.asarray(o.normal)
        along = np.array([-n[1], n[0]])
        for side in (-1, 1):
            p = c + along * side * (o.width / 2 - 0.04)
            lo = p - along * 0.04 - n * 0.1
            hi = p + along * 0.04 + n * 0.1
            k.box_span(f"{o.id}_jamb_{side}", (*np.minimum(lo, hi), 0.0), (*np.maximum(lo, hi), 2.2), jamb)
    return k.scene((0.0, -1.0))


def shell_glbs(spec: SceneSpec) -> tuple[Path, Path]:
    """Paths of the cached shell and ceiling GLBs (generated on first use)."""
    folder = cache_dir() / "shells" / _key(spec)
    paths = folder / "shell.glb", folder / "ceiling.glb"
    for path, ceiling in zip(paths, (False, True)):
        if not path.exists():
            atomic_write_bytes(path, shell_scene(spec, ceiling).export(file_type="glb"))
    return paths
