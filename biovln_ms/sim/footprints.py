"""Floor footprints of what the robot collides with: an object's Zone 1 box where its collision shape is that
box, else the convex hull of its coacd collision parts projected on the floor (round bins and centrifuges
are smaller than their bounding boxes, and the robot may legitimately pass close to the boxes' corners)."""

from __future__ import annotations

from functools import lru_cache

import shapely
import trimesh
from shapely import affinity
from shapely.geometry import MultiPoint, Polygon

from biovln_ms.catalog import load_catalog
from biovln_ms.paths import COLLISION_DIR
from biovln_ms.scene.spec import SceneSpec


@lru_cache(maxsize=None)
def _local_hull(category: str) -> Polygon:
    """The floor projection of a coacd collision file, in the asset's own frame (centred, Z up)."""
    mesh = trimesh.load(COLLISION_DIR / f"{category}.obj", force="mesh", process=False)
    return MultiPoint(mesh.vertices[:, :2]).convex_hull


def collision_footprints(spec: SceneSpec) -> list[Polygon]:
    """One footprint per object of ``spec``, in the world frame."""
    cat = load_catalog()
    out = []
    for o in spec.objects():
        if cat.get(o.category).collision == "coacd":
            hull = affinity.rotate(_local_hull(o.category), o.yaw, origin=(0.0, 0.0), use_radians=True)
            out.append(affinity.translate(hull, o.position[0], o.position[1]))
        else:
            out.append(o.placed().zone1())
    return [shapely.make_valid(g) for g in out]
