"""The layout rules every scene satisfies (paper §3.2-3.3), as checks that name what broke.

Used by the generator (to retry a seed) and, through ``validate_spec``, wherever a spec is read (to refuse a
hand-edited one): loading a spec (:mod:`biovln_ms.scene.loading`) checks its limits and schema only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations
from typing import TYPE_CHECKING

import numpy as np
from shapely.geometry import LineString, Point
from shapely.ops import unary_union

from biovln_ms.catalog import load_catalog
from biovln_ms.constants import SUPPORT_EDGE_MARGIN
from biovln_ms.geometry.freespace import free_space, island_of
from biovln_ms.geometry.navigation import NavGeometry
from biovln_ms.geometry.zones import goal_position, placement_z, zone2_disjoint
from biovln_ms.scene.spec import DESIGNER_TEMPLATE, ObjectSpec, SceneSpec, SceneSpecError

if TYPE_CHECKING:
    from biovln_ms.geometry.navigation import NavGeometry

TOL = 1e-4


@dataclass(frozen=True)
class Violation:
    rule: str
    field: str
    message: str
    objects: tuple[str, ...] = ()


def floor_polygon(spec: SceneSpec):
    from shapely.geometry import Polygon

    return unary_union([Polygon(r.polygon) for r in spec.rooms])


def obstacle_footprints(spec: SceneSpec) -> list:
    """Zone 1 of every object (table-top instruments too: they may overhang their support)."""
    return [o.placed().zone1() for o in spec.objects()]


def scene_free_space(spec: SceneSpec, radius: float | None = None):
    return free_space(
        floor_polygon(spec), obstacle_footprints(spec), spec.robot_radius if radius is None else radius
    )


def scene_navigation(
    spec: SceneSpec, radius: float | None = None, grid_resolution: float = 0.05
) -> NavGeometry:
    """NavGeometry of a scene spec (radius defaults to the spec's robot radius). Imported here, not at the
    top: the rules also run inside Blender (the LSAT add-on), whose environment has no scipy."""

    r = spec.robot_radius if radius is None else radius
    return NavGeometry(scene_free_space(spec, r), r, grid_resolution)


def _at(obj: ObjectSpec) -> str:
    """The object as a rule message names it: its id and where it stands (x, y in m)."""
    return f"'{obj.id}' at ({obj.position[0]:.2f}, {obj.position[1]:.2f})"


def _index(spec: SceneSpec, obj: ObjectSpec) -> str:
    if obj in spec.instruments:
        return f"instruments[{spec.instruments.index(obj)}]"
    if obj in spec.dressing:
        return f"dressing[{spec.dressing.index(obj)}]"
    return f"furniture[{spec.furniture.index(obj)}]"


# Designer-authored scenes (LSAT) keep free placement: only these rules refuse them; the generator's
# other rules (flush walls, Zone 2 disjoint, Zone 3 clear, ...) are reported by the importer as warnings.
DESIGNER_RULES = frozenset(
    {"catalog", "Eq. 3", "Eq. 4", "support", "inside rooms", "goal navigable", "goals mutually reachable"}
)


def validate_spec(spec: SceneSpec, source: str = "<scene spec>") -> SceneSpec:
    """``spec`` if it is consistent with the catalog and keeps the layout rules (a designer-authored scene:
    ``DESIGNER_RULES`` only), else ``SceneSpecError`` naming ``source``, the field and the rule of the
    first problem, with how many more there are."""
    for problems in (check_consistency(spec), check_layout(spec)):
        if spec.template == DESIGNER_TEMPLATE:
            problems = [p for p in problems if p.rule in DESIGNER_RULES]
        if problems:
            p = problems[0]
            more = f" (+{len(problems) - 1} more)" if len(problems) > 1 else ""
            raise SceneSpecError(f"{p.message}{more}", source=source, field=p.field, fix=f"rule: {p.rule}")
    return spec


def check_consistency(spec: SceneSpec) -> list[Violation]:
    """Each object agrees with the catalog, and its face and goal with its own pose (Eq. 1, Eq. 4)."""
    cat = load_catalog()
    out: list[Violation] = []
    supports = {f.id: f for f in spec.furniture}
    dressing = {a.name for a in cat.dressing()}
    for o in spec.objects():
        where = _index(spec, o)
        if o.category not in cat and o.category not in dressing:
            out.append(
                Violation(
                    "catalog",
                    f"{where}.category",
                    f"{_at(o)}: unknown category '{o.category}'; known: {', '.join(cat.names())}",
                    (o.id,),
                )
            )
            continue
        a = cat.get(o.category)
        if (a.mount is not None) != (o in spec.dressing):
            out.append(
                Violation(
                    "catalog",
                    f"{where}.category",
                    f"{_at(o)}: '{o.category}' is {'' if a.mount else 'not '}lab dressing: it belongs in "
                    f"{'dressing' if a.mount else 'furniture or instruments'}",
                    (o.id,),
                )
            )
            continue
        if any(abs(x - y) > TOL for x, y in zip(o.size, a.dimensions)):
            out.append(
                Violation(
                    "catalog",
                    f"{where}.size",
                    f"{_at(o)}: size {list(o.size)} differs from the catalog's {list(a.dimensions)}",
                    (o.id,),
                )
            )
        if o.face is not None and a.face_vector is not None:
            c, s = math.cos(o.yaw), math.sin(o.yaw)
            m = a.face_vector
            expect = (c * m[0] - s * m[1], s * m[0] + c * m[1])
            if math.dist(expect, o.face) > 1e-3:
                out.append(
                    Violation(
                        "Eq. 3",
                        f"{where}.face",
                        f"{_at(o)}: face {list(o.face)} is not the catalog face {a.face} turned by yaw "
                        f"{o.yaw:.4f} ({[round(v, 4) for v in expect]})",
                        (o.id,),
                    )
                )
        if o.is_goal:
            for key in ("d_half", "approach_distance", "success_radius"):
                if abs(getattr(o, key) - getattr(a, key)) > TOL:
                    out.append(
                        Violation(
                            "catalog",
                            f"{where}.{key}",
                            f"{_at(o)}: {key} {getattr(o, key)} differs from the catalog's {getattr(a, key)}",
                            (o.id,),
                        )
                    )
            g = goal_position(o.position[:2], o.face, o.d_half, o.approach_distance)
            if o.goal_source is None and math.dist(g, o.goal) > 1e-3:
                out.append(
                    Violation(
                        "Eq. 1",
                        f"{where}.goal",
                        f"{_at(o)}: goal {list(o.goal)} is not c + f(d + delta) = {[round(v, 4) for v in g]}",
                        (o.id,),
                    )
                )
        if o.placement == "table_top":
            sup = supports.get(o.support)
            if sup is None:
                out.append(
                    Violation(
                        "Eq. 4",
                        f"{where}.support",
                        f"{_at(o)}: a table-top instrument needs a support",
                        (o.id,),
                    )
                )
                continue
            top = cat.support_heights.get(sup.category)
            if top is None:
                out.append(
                    Violation(
                        "Eq. 4",
                        f"{where}.support",
                        f"{_at(o)} stands on '{sup.category}', which has no support height in the catalog",
                        (o.id,),
                    )
                )
                continue
            z = placement_z(top, 0.0, -o.size[2] / 2)
            if abs(o.position[2] - z) > 1e-3:
                out.append(
                    Violation(
                        "Eq. 4",
                        f"{where}.position",
                        f"{_at(o)}: z = {o.position[2]} but on '{sup.id}' (top {top} m) it must be {z:.4f}",
                        (o.id,),
                    )
                )
            if not sup.placed().zone1().buffer(TOL).contains(o.placed().zone1()):
                out.append(
                    Violation(
                        "support",
                        f"{where}.position",
                        f"{_at(o)} is not fully on its support '{sup.id}'",
                        (o.id, sup.id),
                    )
                )
        elif abs(o.position[2] - a.mount_height - o.size[2] / 2) > 1e-3:
            what = f"hung {a.mount_height} m up a wall" if a.mount_height else "floor-standing"
            out.append(
                Violation(
                    "Eq. 4",
                    f"{where}.position",
                    f"{_at(o)}: z = {o.position[2]} but a {what} object rests at "
                    f"{a.mount_height + o.size[2] / 2:.4f}",
                    (o.id,),
                )
            )
    return out


def _related(a: ObjectSpec, b: ObjectSpec) -> bool:
    """An instrument and its own support (or two on nothing) are exempt from mutual Zone-2 rules."""
    return a.support == b.id or b.support == a.id


def check_layout(spec: SceneSpec, radius: float | None = None) -> list[Violation]:
    """The generator's rules: inside rooms, flush walls, Zone 2 disjoint (Eq. 2), Zone 3 clear, goals
    navigable."""
    out: list[Violation] = []
    floor = floor_polygon(spec)
    objs = [*spec.furniture, *spec.instruments]
    placed = {o.id: o.placed() for o in spec.objects()}
    walls = [LineString([w.start, w.end]) for w in spec.walls]
    supports = {f.id: f for f in spec.furniture}
    for o in objs:
        where = _index(spec, o)
        p = placed[o.id]
        if not floor.buffer(TOL).contains(p.zone1()):
            out.append(
                Violation(
                    "inside rooms", f"{where}.position", f"{_at(o)} is not inside the rooms' floor", (o.id,)
                )
            )
        if o.placement == "wall" and o.face is not None and o.d_half is not None:
            back = np.asarray(o.position[:2]) - np.asarray(o.face) * o.d_half
            if min((w.distance(Point(back)) for w in walls), default=math.inf) > 0.01:
                out.append(
                    Violation(
                        "flush with wall",
                        f"{where}.position",
                        f"the back of {_at(o)} is not against a wall",
                        (o.id,),
                    )
                )
            if floor.contains(Point(back - 0.05 * np.asarray(o.face))):
                out.append(
                    Violation(
                        "faces interior (Eq. 3)",
                        f"{where}.yaw",
                        f"{_at(o)} does not face the room interior",
                        (o.id,),
                    )
                )
        if (
            o.placement == "table_top"
            and o.support in supports
            and o.face is not None
            and o.d_half is not None
        ):
            sup = supports[o.support].placed()
            front = np.asarray(o.position[:2]) + np.asarray(o.face) * (o.d_half + SUPPORT_EDGE_MARGIN + 0.01)
            if sup.zone1().contains(Point(front)):
                out.append(
                    Violation(
                        "faces a free edge",
                        f"{where}.yaw",
                        f"{_at(o)} does not face an edge of '{o.support}'",
                        (o.id,),
                    )
                )
    for a, b in combinations(objs, 2):
        if _related(a, b):
            continue
        if not zone2_disjoint(placed[a.id], placed[b.id]):
            out.append(
                Violation(
                    "Zone 2 disjoint (Eq. 2)",
                    f"{_index(spec, b)}.position",
                    f"Zone 2 of {_at(a)} and {_at(b)} overlap",
                    (a.id, b.id),
                )
            )
    wall_geom = unary_union(walls).buffer(1e-3)
    for o in objs:
        if not o.is_goal:
            continue
        z3 = placed[o.id].zone3()
        where = _index(spec, o)
        if not floor.buffer(TOL).contains(z3) or z3.buffer(-1e-3).intersects(wall_geom):
            out.append(
                Violation("Zone 3 clear", f"{where}.position", f"Zone 3 of {_at(o)} crosses a wall", (o.id,))
            )
        for b in objs:
            if b.id == o.id or _related(o, b):
                continue
            if z3.intersection(placed[b.id].zone2()).area > 1e-6:
                out.append(
                    Violation(
                        "Zone 3 clear",
                        f"{where}.position",
                        f"Zone 3 of {_at(o)} overlaps Zone 1/2 of {_at(b)}",
                        (o.id, b.id),
                    )
                )
    out += _dressing_rules(spec, floor, walls, placed)
    free = scene_free_space(spec, radius)
    islands = {}
    for o in spec.goal_objects():
        isl = island_of(free, o.goal)
        if isl is None:
            out.append(
                Violation(
                    "goal navigable",
                    f"{_index(spec, o)}.goal",
                    f"goal ({o.goal[0]:.2f}, {o.goal[1]:.2f}) of {_at(o)} is not on navigable floor "
                    f"for a {spec.robot_radius if radius is None else radius} m robot",
                    (o.id,),
                )
            )
        else:
            islands.setdefault(isl, []).append(o.id)
    if len(islands) > 1:
        groups = sorted(islands.values(), key=len)
        goals = {o.id: o.goal for o in spec.goal_objects()}
        where = " | ".join(
            ", ".join(f"'{i}' goal ({goals[i][0]:.2f}, {goals[i][1]:.2f})" for i in group) for group in groups
        )
        out.append(
            Violation(
                "goals mutually reachable",
                "instruments",
                f"goals lie on {len(islands)} separate islands: {where}",
                tuple(groups[0]),
            )
        )
    return out


#: lab dressing stands at least this far from other bodies (m), and a wall piece's back this close to a wall
DRESSING_GAP = 0.02
WALL_FLUSH = 0.01


def _dressing_rules(spec: SceneSpec, floor, walls: list, placed: dict) -> list[Violation]:
    """Lab dressing: inside the floor (on its support for table-top pieces), wall pieces against a
    wall, clear of every goal's Zones 2 and 3 (its own support excepted) and of every other body."""
    out: list[Violation] = []
    on_walls = {a.name for a in load_catalog().dressing() if a.mount == "wall"}
    goals = spec.goal_objects()
    for i, d in enumerate(spec.dressing):
        where = f"dressing[{i}].position"
        z1 = placed[d.id].zone1()
        if not floor.buffer(TOL).contains(z1):
            out.append(Violation("inside rooms", where, f"{_at(d)} is not inside the rooms' floor", (d.id,)))
        if d.category in on_walls:
            back = LineString(placed[d.id].zone1_corners()[[2, 3]])  # the model +Y side: its back
            if min((w.distance(back) for w in walls), default=math.inf) > WALL_FLUSH:
                out.append(
                    Violation(
                        "flush with wall", where, f"the back of {_at(d)} is not against a wall", (d.id,)
                    )
                )
        for g in goals:
            if g.id == d.support:
                continue
            zones = placed[g.id].zone2().union(placed[g.id].zone3())
            if z1.intersection(zones).area > 1e-6:
                out.append(
                    Violation(
                        "dressing clear of goals",
                        where,
                        f"{_at(d)} stands in Zone 2/3 of {_at(g)}",
                        (d.id, g.id),
                    )
                )
        for o in [*spec.furniture, *spec.dressing[:i]]:
            if o.id == d.support or o.is_goal:
                continue
            if z1.intersection(placed[o.id].zone1().buffer(DRESSING_GAP, join_style=2)).area > 1e-6:
                out.append(
                    Violation("dressing clear of bodies", where, f"{_at(d)} overlaps {_at(o)}", (d.id, o.id))
                )
    return out
