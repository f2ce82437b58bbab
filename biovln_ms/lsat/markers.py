"""Marker helpers shared by the importer and the Blender add-on: where a ``target_*`` marker goes in
front of an instrument (Eq. 1), and a check of marker names against the catalog."""

from __future__ import annotations

import numpy as np

from biovln_ms.catalog import load_catalog
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.zones import goal_position, rot2
from biovln_ms.lsat.names import TARGET_PREFIX, is_target_marker, match_category


def suggested_marker(node_name: str, center_xy, yaw: float) -> tuple[str, tuple[float, float]]:
    """(marker name, Z-up position) for an instrument node: g = c + f(d + delta) (Eq. 1), f the
    catalog's face turned by the node's yaw."""
    m = match_category(node_name)
    if m.category is None:
        why = f"ambiguous between {', '.join(m.candidates)}" if m.ambiguous else "matches no catalog category"
        raise BioVLNError(
            f"'{node_name}' {why}",
            field="name",
            fix=f"rename it after its category ({', '.join(load_catalog().names())})",
        )
    a = load_catalog().get(m.category)
    if a.face_vector is None:
        raise BioVLNError(
            f"'{m.category}' has no operational face", field="category", fix="it cannot be a goal"
        )
    face = rot2(yaw) @ np.asarray(a.face_vector, float)
    g = goal_position(center_xy, face, a.d_half, a.approach_distance)
    return f"{TARGET_PREFIX}{m.category}", (float(g[0]), float(g[1]))


def check_markers(names: list[str]) -> list[dict]:
    """One row per ``target_*`` name: its category, or why it has none (unmatched / ambiguous)."""
    rows = []
    for n in names:
        if not is_target_marker(n):
            continue
        m = match_category(n, TARGET_PREFIX)
        status = "ok" if m.category else ("ambiguous" if m.ambiguous else "unmatched")
        rows.append(
            {
                "name": n,
                "category": m.category,
                "distance": m.distance,
                "status": status,
                "candidates": list(m.candidates),
            }
        )
    return rows
