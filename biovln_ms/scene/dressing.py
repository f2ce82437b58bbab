"""Lab dressing: the non-goal objects real labs have, added by the generator on request.

:func:`dress` gives each room of a generated scene what :data:`PER_ROOM` lists (a sink with an eyewash
station beside it, a shelving unit of bottles and boxes, a fire extinguisher, safety posters, a trolley and
stools) and each bench or table a glassware tray, under the zone rules (:mod:`biovln_ms.scene.rules`):
nothing in a goal's Zone 2 or Zone 3, nothing in another body, wall pieces flush with a wall and facing
the room, floor pieces clear of the doorways, and every goal still navigable and on one island with the
new obstacles in the way. A piece with no place keeping them all (after :data:`TRIES` draws) is left
out. It draws from its own generator, so a dressed scene keeps the seed's instruments where they were.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from shapely.geometry import LineString, Point, Polygon

from biovln_ms.catalog import AssetSpec, Catalog
from biovln_ms.geometry.freespace import free_space, island_of
from biovln_ms.geometry.zones import rot2, yaw_facing
from biovln_ms.scene.rules import DRESSING_GAP, floor_polygon
from biovln_ms.scene.spec import ObjectSpec, SceneSpec, make_object

FRONT = (0.0, -1.0)  # model -Y: the front of every piece of dressing, as the asset generator builds it

#: pieces per room, in placing order (the eyewash is tried beside the sink first)
PER_ROOM: tuple[tuple[str, int], ...] = (
    ("lab_sink", 1),
    ("eyewash_station", 1),
    ("shelving_unit", 1),
    ("fire_extinguisher", 1),
    ("safety_poster", 2),
    ("lab_trolley", 1),
    ("lab_stool", 2),
)
#: on every bench and table (furniture with a support height)
PER_SUPPORT: tuple[tuple[str, int], ...] = (("glassware_rack", 1),)
#: rooms smaller than this (m^2) get posters and an extinguisher only (no floor-standing pieces)
MIN_FURNISHED_AREA = 15.0
#: a room gets PER_ROOM once per this much floor (m^2, rounded; the 8 x 6 m single room: once)
AREA_PER_SET = 48.0
TRIES = 30
DOOR_CLEARANCE = 1.0  # m from a doorway's centre: floor-standing pieces stay out, so doors stay open
STOOL_OFFSET = (0.30, 0.45)  # m from a bench's edge to a stool's centre


@dataclass(frozen=True)
class _Room:
    id: str
    polygon: Polygon


def _footprint(a: AssetSpec, xy: np.ndarray, yaw: float) -> Polygon:
    half = np.asarray(a.dimensions[:2], float) / 2
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float) * half
    return Polygon(corners @ rot2(yaw).T + xy)


class _Dresser:
    """The scene's geometry and what has been placed so far."""

    def __init__(self, spec: SceneSpec, cat: Catalog, radius: float) -> None:
        self.spec, self.cat, self.radius = spec, cat, radius
        self.floor = floor_polygon(spec)
        self.goals = spec.goal_objects()
        self.goal_zones = {g.id: g.placed().zone2().union(g.placed().zone3()) for g in self.goals}
        self.bodies = [o.placed().zone1() for o in spec.objects()]
        self.kept = {  # what dressing keeps DRESSING_GAP from: bodies that are not goals
            o.id: o.placed().zone1().buffer(DRESSING_GAP, join_style=2)
            for o in spec.furniture
            if not o.is_goal
        }
        self.doors = [Point(op.center) for op in spec.openings]
        self.placed: list[ObjectSpec] = []

    def fits(self, fp: Polygon, room: Polygon, support: str | None, obstacle: bool) -> bool:
        """``fp`` lies in ``room`` (a support's top for a table-top piece) and keeps the dressing rules (on
        ``support``, if any); ``obstacle``: also clear of the doors."""
        if not room.buffer(1e-6).contains(fp) or not self.floor.buffer(1e-6).contains(fp):
            return False
        if any(fp.intersection(z).area > 1e-6 for gid, z in self.goal_zones.items() if gid != support):
            return False
        if any(fp.intersection(z).area > 1e-6 for oid, z in self.kept.items() if oid != support):
            return False
        if obstacle and any(fp.distance(d) < DOOR_CLEARANCE for d in self.doors):
            return False
        return True

    def connected(self, fp: Polygon) -> bool:
        """Every goal stays on navigable floor, all on one island, with ``fp`` in the way too."""
        free = free_space(self.floor, [*self.bodies, fp], self.radius)
        islands = {island_of(free, g.goal) for g in self.goals}
        return None not in islands and len(islands) == 1

    def add(self, a: AssetSpec, xy: np.ndarray, yaw: float, z: float, room: str, support: str | None) -> None:
        n = sum(o.category == a.name for o in self.placed)
        obj = make_object(self.cat, f"{a.name}_{n}", a.name, xy, z, yaw, a.mount, room, support, None, False)
        self.placed.append(obj)
        self.bodies.append(obj.placed().zone1())
        self.kept[obj.id] = obj.placed().zone1().buffer(DRESSING_GAP, join_style=2)


def _room_walls(spec: SceneSpec, room: Polygon) -> list:
    """The walls along ``room``'s boundary: (start, unit direction, length, interior normal)."""
    out = []
    for w in spec.walls:
        seg = LineString([w.start, w.end])
        if seg.length > 0.3 and room.exterior.distance(seg.centroid) < 1e-6:
            d = (np.asarray(w.end) - np.asarray(w.start)) / seg.length
            out.append((np.asarray(w.start, float), d, seg.length, np.asarray(w.interior, float)))
    return out


def _wall_pose(a: AssetSpec, wall, along: float) -> tuple[np.ndarray, float]:
    start, d, _, interior = wall
    return start + d * along + interior * a.dimensions[1] / 2, yaw_facing(FRONT, interior)


def _place_wall(dr: _Dresser, a: AssetSpec, room: _Room, walls: list, rng, near: ObjectSpec | None) -> bool:
    obstacle = a.mount_height == 0.0
    for k in range(TRIES):
        if near is not None and k < TRIES // 2:  # beside ``near`` on its wall
            wall = min(
                walls, key=lambda w: LineString([w[0], w[0] + w[1] * w[2]]).distance(Point(near.position[:2]))
            )
            along0 = float(np.dot(np.asarray(near.position[:2]) - wall[0], wall[1]))
            side = 1.0 if rng.random() < 0.5 else -1.0
            along = along0 + side * ((near.size[0] + a.dimensions[0]) / 2 + rng.uniform(0.05, 0.4))
        else:
            usable = [w for w in walls if w[2] >= a.dimensions[0]]
            if not usable:
                return False
            lengths = np.array([w[2] for w in usable])
            wall = usable[int(rng.choice(len(usable), p=lengths / lengths.sum()))]
            along = rng.uniform(a.dimensions[0] / 2, wall[2] - a.dimensions[0] / 2)
        if not a.dimensions[0] / 2 <= along <= wall[2] - a.dimensions[0] / 2:
            continue
        xy, yaw = _wall_pose(a, wall, along)
        fp = _footprint(a, xy, yaw)
        if dr.fits(fp, room.polygon, None, obstacle) and dr.connected(fp):
            dr.add(a, xy, yaw, a.mount_height + a.dimensions[2] / 2, room.id, None)
            return True
    return False


def _place_floor(dr: _Dresser, a: AssetSpec, room: _Room, rng) -> bool:
    benches = [
        f
        for f in dr.spec.furniture
        if f.room == room.id and dr.cat.support_heights.get(f.category) is not None
    ]
    x0, y0, x1, y1 = room.polygon.bounds
    reach = math.hypot(*a.dimensions[:2]) / 2
    for k in range(TRIES):
        if a.name == "lab_stool" and benches and k < TRIES // 2:  # at a bench, where people sit
            b = benches[int(rng.integers(len(benches)))].placed()
            axis = int(rng.integers(2))
            sign = 1.0 if rng.random() < 0.5 else -1.0
            local = np.zeros(2)
            local[axis] = sign * (b.half_xy[axis] + rng.uniform(*STOOL_OFFSET))
            local[1 - axis] = rng.uniform(-1, 1) * max(b.half_xy[1 - axis] - 0.3, 0.0)
            xy = b.center_xy + rot2(b.yaw) @ local
            yaw = float(rng.uniform(-math.pi, math.pi))
        else:
            xy = np.array([rng.uniform(x0 + reach, x1 - reach), rng.uniform(y0 + reach, y1 - reach)])
            yaw = float(rng.integers(4)) * math.pi / 2 + math.radians(rng.uniform(-10, 10))
        fp = _footprint(a, xy, yaw)
        if dr.fits(fp, room.polygon, None, True) and dr.connected(fp):
            dr.add(a, xy, yaw, a.dimensions[2] / 2, room.id, None)
            return True
    return False


def _place_on(dr: _Dresser, a: AssetSpec, support: ObjectSpec, rng) -> bool:
    sp = support.placed()
    top = dr.cat.support_heights[support.category]
    surface = Polygon(sp.zone1_corners())
    for _ in range(TRIES):
        yaw = sp.yaw + float(rng.integers(4)) * math.pi / 2
        ext = np.abs(rot2(yaw - sp.yaw)) @ np.asarray(a.dimensions[:2], float) / 2 + 0.05
        lim = np.maximum(sp.half_xy - ext, 0.0)
        xy = sp.center_xy + rot2(sp.yaw) @ (rng.uniform(-1, 1, 2) * lim)
        fp = _footprint(a, xy, yaw)
        if dr.fits(fp, surface, support.id, False):
            dr.add(a, xy, yaw, top + a.dimensions[2] / 2, support.room, support.id)
            return True
    return False


def dress(spec: SceneSpec, cat: Catalog, rng: np.random.Generator, radius: float) -> list[ObjectSpec]:
    """The lab dressing of ``spec`` (see the module docstring), drawn from ``rng``."""
    dr = _Dresser(spec, cat, radius)
    for r in spec.rooms:
        if r.kind != "room":
            continue
        room = _Room(r.id, Polygon(r.polygon))
        walls = _room_walls(spec, room.polygon)
        furnished = room.polygon.area >= MIN_FURNISHED_AREA
        sets = max(1, round(room.polygon.area / AREA_PER_SET))
        for name, count in PER_ROOM:
            a = cat.get(name)
            if not furnished and (a.mount != "wall" or a.mount_height == 0.0):
                continue
            for _ in range(count * sets):
                if a.mount == "wall":
                    near = next((o for o in dr.placed if o.category == "lab_sink" and o.room == r.id), None)
                    _place_wall(dr, a, room, walls, rng, near if name == "eyewash_station" else None)
                else:
                    _place_floor(dr, a, room, rng)
        for f in spec.furniture:
            if f.room == r.id and cat.support_heights.get(f.category) is not None:
                for name, count in PER_SUPPORT:
                    for _ in range(count):
                        _place_on(dr, cat.get(name), f, rng)
    return dr.placed
