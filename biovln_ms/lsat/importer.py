"""LSAT import (paper §3.3 P1, §3.4): a designer-authored GLB -> a validated BioVLN scene spec.

What a designer's GLB needs (node names; Blender duplicates such as ``.001`` are fine):

- ``floor*`` meshes: each is a room; its axis-aligned footprint becomes the room rectangle, and walls
  are derived along the union of the floors (as for procedural scenes);
- instruments and goal furniture named by category (``Refrigerator``, ``centrifuge.001``, ``Lab Bench``;
  fuzzy, ``biovln_ms.lsat.names``), or carrying ``extras.category`` (our ``scene export`` writes it);
  their parts may be children;
- optionally ``target_<category>`` empties: world-space goals (**strategy 1**), each given to the
  nearest instrument of its category.

**Strategy 2** (an instrument without a marker): the footprint's minimum-area rectangle gives the centre
and the orientation; which of the four sides is the operational face is told from geometry when the
instrument has named face parts (door, handle, display, keypad, panel, sash, screen, controls): the side
they sit on; otherwise from the node's own rotation applied to the catalog's default face. The goal is
then Eq. 1, g = c + f(d + δ). Table-top instruments are put on the furniture under them at the Eq. 4
height. Sizes are the catalog's (the scene builder renders catalog assets at the designer's poses); a
measured footprint more than 5 cm off is reported.

Designer scenes keep free placement: the spec's ``template`` is ``lsat`` and only the rules a scene must
keep (catalog, Eq. 3, Eq. 4, inside rooms, goals navigable and mutually reachable) refuse it; the other
generator rules are listed as warnings in the coverage report.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from shapely.geometry import MultiPoint, Point, Polygon, box

from biovln_ms.catalog import load_catalog
from biovln_ms.constants import ROBOT_RADIUS
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.zones import placement_z, rot2, wrap_angle
from biovln_ms.lsat.gltf import GLTFScene, Node, read_gltf
from biovln_ms.lsat.names import TARGET_PREFIX, Match, is_target_marker, match_category, normalise
from biovln_ms.scene.spec import DESIGNER_TEMPLATE, SCHEMA_VERSION, ObjectSpec, SceneSpec, SceneSpecError, parse_spec

FACE_PART_WORDS = ("door", "handle", "display", "keypad", "panel", "sash", "screen", "control")
SIZE_TOLERANCE = 0.05  # m
NEAR_SQUARE = 0.1  # m: footprints closer to square than this take their axes from the node's rotation
SUPPORT_TOLERANCE = 0.03  # m between a table-top instrument's bottom and its support's top
DEFAULT_WALL_HEIGHT = 3.0


class LSATImportError(BioVLNError):
    """A designer GLB that cannot become a valid scene."""


@dataclass
class ImportReport:
    source: str
    instruments: list[dict] = field(default_factory=list)  # id, node, category, goal_strategy, face_from
    markers: list[dict] = field(default_factory=list)  # node, category, assigned_to
    unmatched: list[str] = field(default_factory=list)  # node names that matched no category
    ambiguous: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    def coverage(self) -> dict:
        goals = [i for i in self.instruments if i["is_goal"]]
        return {"instruments_found": len(self.instruments), "goal_objects": len(goals),
                "goals_strategy1": sum(i["goal_strategy"] == 1 for i in goals),
                "goals_strategy2": sum(i["goal_strategy"] == 2 for i in goals),
                "missing": [i["id"] for i in goals if i["goal_strategy"] is None],
                "markers_unassigned": [m["node"] for m in self.markers if m.get("assigned_to") is None],
                "unmatched_names": len(self.unmatched), "ambiguous_names": len(self.ambiguous)}

    def to_markdown(self) -> str:
        c = self.coverage()
        lines = [f"# LSAT import of `{self.source}`", "",
                 f"Instruments found: {c['instruments_found']} ({c['goal_objects']} goal objects); goals from markers "
                 f"(strategy 1): {c['goals_strategy1']}; from geometry + Eq. 1 (strategy 2): {c['goals_strategy2']}; "
                 f"missing: {len(c['missing'])}.", "",
                 "| id | node | category | goal from | face from |", "|---|---|---|---|---|"]
        for i in self.instruments:
            strat = {1: "marker (strategy 1)", 2: "Eq. 1 (strategy 2)", None: "–"}[i["goal_strategy"]]
            lines.append(f"| {i['id']} | `{i['node']}` | {i['category']} | {strat} | {i['face_from']} |")
        for title, items in (("Markers without an instrument", [m["node"] for m in self.markers if m.get("assigned_to") is None]),
                             ("Names matching no category", self.unmatched),
                             ("Ambiguous names (not guessed)", [f"`{a['node']}`: {', '.join(a['candidates'])}" for a in self.ambiguous]),
                             ("Warnings", self.warnings)):
            if items:
                lines += ["", f"## {title}", ""] + [f"- {x}" for x in items]
        return "\n".join(lines) + "\n"


@dataclass
class _Found:
    node: Node
    category: str
    points: np.ndarray


def _footprint(points: np.ndarray) -> tuple[np.ndarray, float, float, float]:
    """Centre, orientation angle of the first side, and the two side lengths of the min-area rectangle."""
    rect = MultiPoint([tuple(p) for p in np.unique(np.round(points[:, :2], 5), axis=0)]).minimum_rotated_rectangle
    if not isinstance(rect, Polygon):
        raise ValueError("degenerate footprint")
    c = np.asarray(rect.exterior.coords)[:4]
    e1, e2 = c[1] - c[0], c[2] - c[1]
    return np.asarray(rect.centroid.coords[0]), math.atan2(e1[1], e1[0]), float(np.linalg.norm(e1)), float(np.linalg.norm(e2))


def _face_parts(scene: GLTFScene, node: Node) -> np.ndarray:
    """Vertices of the parts whose names say they are on the operational face, with their own children
    (a nested part counted once)."""
    on_face = {m.index for n in scene.subtree(node)[1:] if any(w in normalise(n.name) for w in FACE_PART_WORDS)
               for m in scene.subtree(n)}
    pts = [p for p in (scene.mesh_points(scene.nodes[i]) for i in sorted(on_face)) if len(p)]
    return np.concatenate(pts) if pts else np.zeros((0, 3))


def _resolve_yaw(scene: GLTFScene, f: _Found, theta: float, a: float, b: float, centre) -> tuple[float, str]:
    """The yaw that puts the catalog's model axes on the footprint's sides and its face where it is.

    The rectangle's sides give the axes up to 180 deg; for a near-square footprint (a round bin) they
    say nothing, so the node's own rotation gives them. The face parts (or, without them, the node's
    rotation and the catalog's default face) then pick the side."""
    cat = load_catalog().get(f.category)
    w, d = cat.dimensions[0], cat.dimensions[1]
    x_axis = f.node.world[:3, :3] @ np.array([1.0, 0.0, 0.0])
    node_yaw = math.atan2(x_axis[1], x_axis[0])
    if abs(w - d) < NEAR_SQUARE:
        candidates = [wrap_angle(node_yaw + k * math.pi / 2) for k in range(4)]
    else:
        base = theta if abs(a - w) + abs(b - d) <= abs(a - d) + abs(b - w) else theta + math.pi / 2
        candidates = [wrap_angle(base), wrap_angle(base + math.pi)]
    if cat.face_vector is None:
        return candidates[0], "no face (catalog)"
    parts = _face_parts(scene, f.node)
    if len(parts):
        offset = parts[:, :2].mean(0) - centre
        if np.linalg.norm(offset) > 0.02:
            scores = [float(np.dot(rot2(y) @ cat.face_vector, offset)) for y in candidates]
            return candidates[int(np.argmax(scores))], "geometry (face parts)"
    diffs = [abs(wrap_angle(y - node_yaw)) for y in candidates]
    return candidates[int(np.argmin(diffs))], "node rotation (catalog face)"


def _is_floor(name: str) -> bool:
    """'Floor', 'floor_lab.001', or a floor part under a shell node ('room_shell/shell.floor_lab')."""
    return re.search(r"(^|_)floor", normalise(re.split(r"[/|]", name)[-1])) is not None


def _category(node: Node) -> Match:
    """The node's catalog category: its ``extras.category`` when that names one (our exporter writes it),
    else its name, fuzzily."""
    cat = node.extras.get("category")
    if isinstance(cat, str) and cat in load_catalog():
        return Match(node.name, cat, cat, 0)
    return match_category(node.name)


def _rooms(scene: GLTFScene, report: ImportReport) -> tuple[list[tuple[str, str, tuple]], float]:
    floors = [n for n in scene.nodes if _is_floor(n.name)]
    rects, tops = [], []
    for n in floors:
        pts = scene.subtree_points(n)
        if len(pts) < 3:
            report.warnings.append(f"floor node '{n.name}' has no mesh: ignored")
            continue
        x0, y0 = pts[:, :2].min(0)
        x1, y1 = pts[:, :2].max(0)
        if x1 - x0 < 1.0 or y1 - y0 < 1.0:
            report.warnings.append(f"floor node '{n.name}' is smaller than 1 x 1 m: ignored")
            continue
        rects.append((f"room_{len(rects)}", "room", tuple(round(float(v), 4) for v in (x0, y0, x1, y1))))
        tops.append(float(pts[:, 2].max()))
    if not rects:
        raise LSATImportError("no floor: no mesh node named 'floor...' of at least 1 x 1 m", source=report.source,
                              field="nodes", fix="name the floor mesh 'floor' (one per room: 'floor_lab', 'floor_corridor')")
    if max(tops) - min(tops) > 0.05 or abs(min(tops)) > 0.05:
        report.warnings.append(f"floor tops range {min(tops):.3f}..{max(tops):.3f} m: BioVLN assumes the floor at z = 0")
    walls = [n for n in scene.nodes if normalise(n.name).startswith("wall")]
    heights = [pts[:, 2].max() for pts in (scene.subtree_points(n) for n in walls) if len(pts)]
    return rects, float(max(heights)) if heights else DEFAULT_WALL_HEIGHT


def import_glb(path: str | Path, name: str | None = None, allow_external: bool = False,
               robot_radius: float = ROBOT_RADIUS) -> tuple[SceneSpec, ImportReport]:
    """Read, interpret and validate a designer GLB; the spec passes ``parse_spec`` (designer rules)."""
    from biovln_ms.scene.generator import make_object, rooms_from_rects
    from biovln_ms.scene.rules import check_layout

    path = Path(path)
    scene = read_gltf(path, allow_external=allow_external)
    report = ImportReport(str(path))
    cat = load_catalog()
    rects, wall_height = _rooms(scene, report)
    rooms, walls, openings = rooms_from_rects(rects, wall_height)

    found: list[_Found] = []
    markers: list[tuple[Node, str]] = []
    claimed: set[int] = set()
    for n in scene.nodes:  # parents come before children (tree order)
        key = normalise(n.name)
        if n.parent in claimed:
            claimed.add(n.index)
            continue
        if key.startswith(("floor", "wall", "ceiling", "room", "light", "camera")) or _is_floor(n.name):
            continue
        if is_target_marker(n.name):
            m = match_category(n.name, TARGET_PREFIX)
            if m.ambiguous:
                report.ambiguous.append({"node": n.name, "candidates": list(m.candidates)})
            elif m.category is None:
                report.unmatched.append(n.name)
            else:
                markers.append((n, m.category))
            continue
        m = _category(n)
        if m.ambiguous:
            report.ambiguous.append({"node": n.name, "candidates": list(m.candidates)})
            claimed.add(n.index)
            continue
        if m.category is None:
            if n.mesh is not None or n.children:
                report.unmatched.append(n.name)
            continue
        pts = scene.subtree_points(n)
        claimed.add(n.index)
        if len(pts) < 3:
            report.warnings.append(f"'{n.name}' ({m.category}) has no mesh: skipped")
            continue
        found.append(_Found(n, m.category, pts))

    # furniture first (supports), then instruments; ids by category and order of appearance
    found.sort(key=lambda f: (cat.get(f.category).placement != "furniture", f.node.index))
    counts: Counter = Counter()
    furniture: list[ObjectSpec] = []
    instruments: list[ObjectSpec] = []
    floor_boxes = {rid: box(*rect) for rid, _, rect in rects}
    entries: dict[str, dict] = {}
    for f in found:
        a = cat.get(f.category)
        try:
            centre, theta, s1, s2 = _footprint(f.points)
        except ValueError:
            report.warnings.append(f"'{f.node.name}' has a degenerate footprint: skipped")
            continue
        yaw, face_from = _resolve_yaw(scene, f, theta, s1, s2, centre)
        local = f.points[:, :2] @ rot2(yaw)  # rows: R(-yaw) p, the footprint in the instrument's own axes
        lo, hi = local.min(0), local.max(0)
        centre = rot2(yaw) @ ((lo + hi) / 2)  # the box centre along the resolved axes
        measured = sorted(hi - lo)
        if max(abs(x - y) for x, y in zip(measured, sorted(a.dimensions[:2]))) > SIZE_TOLERANCE:
            report.warnings.append(f"'{f.node.name}': footprint {measured[1]:.2f} x {measured[0]:.2f} m differs from the "
                                   f"catalog's {a.dimensions[0]:.2f} x {a.dimensions[1]:.2f} m (the catalog's is used)")
        room = next((rid for rid, poly in floor_boxes.items() if poly.contains(Point(centre))), None)
        if room is None:
            raise LSATImportError(f"'{f.node.name}' stands outside every floor", source=str(path), field=f.node.name,
                                  fix="move it onto a floor mesh, or add a floor under it")
        support, z = None, a.dimensions[2] / 2
        bottom = float(f.points[:, 2].min())
        if a.placement == "table_top":
            sup = next((o for o in furniture if o.placed().zone1().contains(Point(centre))), None)
            if sup is None:
                raise LSATImportError(f"table-top instrument '{f.node.name}' stands on no bench or table", source=str(path),
                                      field=f.node.name, fix="put it on a 'Lab Bench' or 'Lab Table' node")
            support = sup.id
            top = cat.support_heights[sup.category]
            z = placement_z(top, 0.0, -a.dimensions[2] / 2)
            if abs(bottom - top) > SUPPORT_TOLERANCE:
                report.warnings.append(f"'{f.node.name}': bottom at {bottom:.3f} m, its support's top at {top:.3f} m (snapped, Eq. 4)")
        elif abs(bottom) > SUPPORT_TOLERANCE:
            report.warnings.append(f"'{f.node.name}': bottom at {bottom:.3f} m above the floor (snapped to the floor)")
        obj_id = f.node.extras.get("object_id")  # our exporter's ids survive a round trip
        if not (isinstance(obj_id, str) and re.fullmatch(r"[A-Za-z0-9_\-]{1,64}", obj_id) and obj_id not in entries):
            while f"{f.category}_{counts[f.category]}" in entries:
                counts[f.category] += 1
            obj_id = f"{f.category}_{counts[f.category]}"
        flag = f.node.extras.get("is_goal")  # our exporter says which furniture is a goal; else the catalog does
        is_goal = flag if isinstance(flag, bool) else a.goal_category
        obj = make_object(cat, obj_id, f.category, centre, z, yaw, a.placement, room, support, None, is_goal)
        (furniture if a.placement == "furniture" else instruments).append(obj)
        entries[obj_id] = {"id": obj_id, "node": f.node.name, "category": f.category, "is_goal": is_goal,
                           "goal_strategy": 2 if is_goal else None, "face_from": face_from}

    # strategy 1: each marker to the nearest goal object of its category
    by_id = {o.id: o for o in [*furniture, *instruments]}
    for node, category in markers:
        xy = node.origin[:2]
        cands = [o for o in by_id.values() if o.category == category and o.is_goal]
        rec = {"node": node.name, "category": category, "assigned_to": None}
        if cands:
            o = min(cands, key=lambda o: math.dist(o.position[:2], xy))
            if entries[o.id]["goal_strategy"] == 1:
                report.warnings.append(f"marker '{node.name}': '{o.id}' already has a marker; ignored")
            else:
                by_id[o.id] = o.model_copy(update={"goal": (float(xy[0]), float(xy[1])), "goal_source": "marker"})
                entries[o.id]["goal_strategy"] = 1
                rec["assigned_to"] = o.id
        report.markers.append(rec)
    furniture = [by_id[o.id] for o in furniture]
    instruments = [by_id[o.id] for o in instruments]
    report.instruments = list(entries.values())
    if not instruments:
        raise LSATImportError("no instrument found", source=str(path), field="nodes",
                              fix=f"name instrument nodes by category ({', '.join(cat.names())})")
    obj = {"schema_version": SCHEMA_VERSION, "name": name or path.stem, "template": DESIGNER_TEMPLATE, "seed": 0,
           "generator_version": 0, "robot_radius": robot_radius, "catalog_sha256": cat.sha256,
           "rooms": [r.model_dump() for r in rooms], "walls": [w.model_dump() for w in walls],
           "openings": [o.model_dump() for o in openings], "furniture": [o.model_dump() for o in furniture],
           "instruments": [o.model_dump() for o in instruments]}
    try:
        spec = parse_spec(obj, source=str(path))
    except SceneSpecError as e:
        raise LSATImportError(f"the imported scene breaks a rule: {e.message}", source=str(path), field=e.field,
                              fix=e.fix or "move the named object in the authoring tool") from None
    report.warnings += [f"generator rule '{v.rule}': {v.message}" for v in check_layout(spec)]
    return spec, report
