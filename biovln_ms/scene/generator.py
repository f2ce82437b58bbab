"""The deterministic procedural generator: ``generate_scene(template, seed) -> SceneSpec``.

The seed decides which slots are active, which instrument fills each, and where along its slot it
sits (the paper's "small jitter"). Attempt k of a seed draws from ``numpy.random.default_rng([seed,
k])`` (PCG64: the same numbers on every machine); a layout that breaks a rule of
:mod:`biovln_ms.scene.rules` moves on to the next attempt, and past ``max_attempts`` the generator
raises :class:`GenerationError` naming the rule and the instruments.

With ``dressing=True`` each layout also gets its lab dressing (:mod:`biovln_ms.scene.dressing`), drawn from
its own generator (``default_rng([seed, k, DRESSING_STREAM])``): the instruments stand where the undressed
scene has them unless dressing that layout breaks a rule (the next attempt is then taken), and the scene's
name ends in ``_dressed``. Without it the spec is the one this generator has always written.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from typing import Sequence

import numpy as np
from shapely.geometry import LineString, Point, Polygon, box
from shapely.ops import unary_union

from biovln_ms.catalog import Catalog, load_catalog
from biovln_ms.constants import ROBOT_RADIUS, SCENE_GENERATOR_VERSION, SUPPORT_EDGE_MARGIN, WALL_THICKNESS
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.zones import placement_z, rot2, yaw_facing
from biovln_ms.scene.dressing import dress
from biovln_ms.scene.rules import Violation, check_layout
from biovln_ms.scene.loading import parse_spec
from biovln_ms.scene.spec import ObjectSpec, OpeningSpec, RoomSpec, SceneSpec, WallSpec, make_object
from biovln_ms.scene.templates import InstrumentSlot, Template, TemplateError, get_template

WALL_INTERIOR = {"S": (0.0, 1.0), "N": (0.0, -1.0), "W": (1.0, 0.0), "E": (-1.0, 0.0)}
DRESSING_STREAM = 0x64726573  # "dres": the dressing's random stream, apart from the layout's
DRESSED_SUFFIX = "_dressed"


class GenerationError(BioVLNError):
    """No attempt of a seed satisfied every layout rule."""


def _rect_polygon(rect: Sequence[float]) -> list[tuple[float, float]]:
    x0, y0, x1, y1 = rect
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def build_rooms(t: Template) -> tuple[list[RoomSpec], list[WallSpec], list[OpeningSpec]]:
    """Floor regions, the walls along the boundary of their union, and openings where they touch."""
    return rooms_from_rects([(r.id, r.kind, r.rect) for r in t.rooms], t.wall_height)


def rooms_from_rects(
    rects: Sequence[tuple[str, str, Sequence[float]]],
    wall_height: float,
) -> tuple[list[RoomSpec], list[WallSpec], list[OpeningSpec]]:
    """Rooms of axis-aligned rectangles (id, kind, (x0, y0, x1, y1)), walls along their union, openings."""
    rooms = [
        RoomSpec(id=rid, kind=kind, polygon=_rect_polygon(rect), height=wall_height)
        for rid, kind, rect in rects
    ]
    floor = unary_union([box(*rect) for _, _, rect in rects]).simplify(0)
    polys = list(getattr(floor, "geoms", [floor]))
    walls = []
    for poly in polys:
        for k, ring in enumerate([poly.exterior, *poly.interiors]):
            coords = list(ring.coords)
            # The floor lies left of a CCW exterior ring (k == 0) and right of a CCW hole ring.
            floor_on_left = ring.is_ccw == (k == 0)
            for a, b in zip(coords[:-1], coords[1:]):
                dx, dy = b[0] - a[0], b[1] - a[1]
                n = math.hypot(dx, dy)
                if n < 1e-9:
                    continue
                interior = (-dy / n, dx / n) if floor_on_left else (dy / n, -dx / n)
                walls.append(
                    WallSpec(
                        id=f"wall_{len(walls)}",
                        start=a,
                        end=b,
                        interior=interior,
                        thickness=WALL_THICKNESS,
                        height=wall_height,
                    )
                )
    openings = []
    for i, (ida, _, ra) in enumerate(rects):
        for idb, _, rb in rects[i + 1 :]:
            shared = box(*ra).intersection(box(*rb))
            if shared.length > 0 and shared.area < 1e-9 and isinstance(shared, LineString):
                (x0, y0), (x1, y1) = shared.coords[0], shared.coords[-1]
                normal = (0.0, 1.0) if abs(y1 - y0) < 1e-9 else (1.0, 0.0)
                openings.append(
                    OpeningSpec(
                        id=f"opening_{len(openings)}",
                        rooms=(ida, idb),
                        center=((x0 + x1) / 2, (y0 + y1) / 2),
                        width=shared.length,
                        normal=normal,
                    )
                )
    return rooms, walls, openings


def _world_extent(size: Sequence[float], yaw: float) -> np.ndarray:
    return np.abs(rot2(yaw)) @ np.asarray(size[:2], float)


def _room_rect(t: Template, room_id: str) -> tuple[float, float, float, float]:
    return next(r.rect for r in t.rooms if r.id == room_id)


def _place_wall(cat, t, slot: InstrumentSlot, category, rng) -> tuple[np.ndarray, float, float]:
    a = cat.get(category)
    interior = WALL_INTERIOR[slot.wall]
    yaw = yaw_facing(a.face_vector, interior)
    ext = _world_extent(a.dimensions, yaw)
    x0, y0, x1, y1 = _room_rect(t, slot.room)
    along_axis = 0 if slot.wall in ("N", "S") else 1
    lo, hi = slot.span[0] + ext[along_axis] / 2, slot.span[1] - ext[along_axis] / 2
    if hi < lo:
        raise TemplateError(
            f"slot '{slot.id}' spans {slot.span[1] - slot.span[0]:.2f} m, too short for '{category}' "
            f"({ext[along_axis]:.2f} m along the wall)",
            field="slots.span",
        )
    along = rng.uniform(lo, hi)
    wall_coord = {"S": y0, "N": y1, "W": x0, "E": x1}[slot.wall]
    normal = wall_coord + interior[1 - along_axis] * ext[1 - along_axis] / 2
    xy = np.empty(2)
    xy[along_axis] = along
    xy[1 - along_axis] = normal
    return xy, a.dimensions[2] / 2, yaw


def _place_table_top(
    cat, t, slot: InstrumentSlot, category, rng, furniture: dict[str, ObjectSpec], floor
) -> tuple[np.ndarray, float, float]:
    a = cat.get(category)
    sup = furniture[slot.support]
    top = cat.support_heights.get(sup.category)
    if top is None:
        raise TemplateError(
            f"slot '{slot.id}': '{sup.category}' has no support height", field="slots.support"
        )
    sp = sup.placed()
    half = sp.half_xy
    long_axis = int(np.argmax(half))
    frac = rng.uniform(*slot.span)
    local = np.zeros(2)
    local[long_axis] = (frac - 0.5) * 2 * half[long_axis]
    local[1 - long_axis] = rng.uniform(-0.9, 0.9) * half[1 - long_axis]
    best = None
    for axis in (0, 1):
        for sgn in (-1.0, 1.0):
            n_local = np.zeros(2)
            n_local[axis] = sgn
            normal = rot2(sup.yaw) @ n_local
            mid = sp.center_xy + normal * half[axis]
            if not floor.contains(Point(*(mid + normal * 0.3))):
                continue  # against a wall: not a free edge
            dist = half[axis] - abs(local[axis])
            if best is None or dist < best[0] - 1e-9:
                best = (dist, axis, sgn, normal)
    if best is None:
        raise TemplateError(f"slot '{slot.id}': support '{sup.id}' has no free edge", field="slots.support")
    _, axis, sgn, normal = best
    yaw = yaw_facing(a.face_vector, normal)
    ext = _world_extent(a.dimensions, yaw)
    depth = abs(normal[0]) * ext[0] + abs(normal[1]) * ext[1]
    width = abs(normal[1]) * ext[0] + abs(normal[0]) * ext[1]
    edge_len = 2 * half[1 - axis]
    along = np.clip(local[1 - axis], -edge_len / 2 + width / 2, edge_len / 2 - width / 2)
    new_local = np.zeros(2)
    new_local[1 - axis] = along
    new_local[axis] = sgn * (half[axis] - SUPPORT_EDGE_MARGIN - depth / 2)
    xy = sp.center_xy + rot2(sup.yaw) @ new_local
    return xy, placement_z(top, 0.0, -a.dimensions[2] / 2), yaw


def _place_floor(cat, t, slot: InstrumentSlot, category, rng) -> tuple[np.ndarray, float, float]:
    a = cat.get(category)
    x0, y0, x1, y1 = slot.region
    rx0, ry0, rx1, ry1 = _room_rect(t, slot.room)
    centre = np.array([(rx0 + rx1) / 2, (ry0 + ry1) / 2])
    pos = np.array([rng.uniform(x0, x1), rng.uniform(y0, y1)])
    to_centre = centre - pos
    jitter = math.radians(rng.uniform(-t.yaw_jitter_deg, t.yaw_jitter_deg))
    yaw = yaw_facing(a.face_vector, to_centre / max(np.linalg.norm(to_centre), 1e-9)) + jitter
    ext = _world_extent(a.dimensions, yaw)
    lo = np.array([x0, y0]) + ext / 2
    hi = np.array([x1, y1]) - ext / 2
    xy = np.clip(pos, np.minimum(lo, hi), np.maximum(lo, hi))
    return xy, a.dimensions[2] / 2, yaw


def _choose_slots(t: Template, rng, required: Sequence[str]) -> list[tuple[InstrumentSlot, str]]:
    """Active slots with their categories: fixed slots, one slot per required category, then random ones."""
    lo, hi = t.active_slots
    n_fixed = sum(s.fixed for s in t.slots)
    k = int(rng.integers(max(lo, len(required), n_fixed), max(hi, len(required), n_fixed) + 1))
    chosen: dict[str, str] = {}
    for cat_name in required:
        options = [s for s in t.slots if s.id not in chosen and cat_name in s.categories]
        if not options:
            raise TemplateError(
                f"no free slot of template '{t.name}' accepts required category '{cat_name}'",
                field="required_categories",
            )
        fixed_opts = [s for s in options if s.fixed]
        pick = fixed_opts[0] if fixed_opts else options[int(rng.integers(len(options)))]
        chosen[pick.id] = cat_name
    for s in t.slots:
        if s.fixed and s.id not in chosen:
            chosen[s.id] = s.categories[int(rng.integers(len(s.categories)))]
    rest = [s for s in t.slots if s.id not in chosen]
    order = rng.permutation(len(rest))
    for i in order[: max(0, k - len(chosen))]:
        s = rest[int(i)]
        chosen[s.id] = s.categories[int(rng.integers(len(s.categories)))]
    return [(s, chosen[s.id]) for s in t.slots if s.id in chosen]


def _attempt(
    t: Template,
    seed: int,
    attempt: int,
    cat: Catalog,
    required: Sequence[str],
    radius: float,
    rooms,
    walls,
    openings,
    floor,
    dressing: bool = False,
) -> tuple[SceneSpec, list[Violation]]:
    rng = np.random.default_rng([seed, attempt])
    furniture: dict[str, ObjectSpec] = {}
    for f in t.furniture:
        a = cat.get(f.category)
        yaw = yaw_facing(a.face_vector, f.face) if a.face_vector is not None else 0.0
        furniture[f.id] = make_object(
            cat, f.id, f.category, f.center, a.dimensions[2] / 2, yaw, "furniture", f.room, None, None, f.goal
        )
    instruments = []
    counts: Counter = Counter()
    for slot, category in _choose_slots(t, rng, required):
        if slot.placement == "wall":
            xy, z, yaw = _place_wall(cat, t, slot, category, rng)
            room, support = slot.room, None
        elif slot.placement == "table_top":
            xy, z, yaw = _place_table_top(cat, t, slot, category, rng, furniture, floor)
            room, support = furniture[slot.support].room, slot.support
        else:
            xy, z, yaw = _place_floor(cat, t, slot, category, rng)
            room, support = slot.room, None
        obj_id = f"{category}_{counts[category]}"
        counts[category] += 1
        instruments.append(
            make_object(cat, obj_id, category, xy, z, yaw, slot.placement, room, support, slot.id, True)
        )
    spec = SceneSpec(
        schema_version=1,
        name=t.scene_name(seed),
        template=t.name,
        seed=seed,
        generator_version=SCENE_GENERATOR_VERSION,
        robot_radius=radius,
        catalog_sha256=cat.sha256,
        rooms=rooms,
        walls=walls,
        openings=openings,
        furniture=list(furniture.values()),
        instruments=instruments,
    )
    # Round-trip through canonical JSON so the returned spec is exactly what a saved file loads as.
    spec = parse_spec(json.loads(spec.to_json()))
    violations = check_layout(spec)
    if dressing and not violations:
        pieces = dress(spec, cat, np.random.default_rng([seed, attempt, DRESSING_STREAM]), radius)
        data = json.loads(spec.to_json())
        data.update(name=spec.name + DRESSED_SUFFIX, dressing=[o.model_dump(mode="json") for o in pieces])
        spec = parse_spec(json.loads(SceneSpec.model_validate(data).to_json()))
        violations = check_layout(spec)
    return spec, violations


def generate_scene(
    template: str | Template,
    seed: int,
    required_categories: Sequence[str] = (),
    robot_radius: float = ROBOT_RADIUS,
    catalog: Catalog | None = None,
    dressing: bool = False,
) -> SceneSpec:
    """Generate the scene of ``seed``: byte-identical spec JSON for the same inputs on any machine;
    ``dressing`` adds the lab dressing (see the module docstring)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise GenerationError(
            f"seed {seed!r} is not a non-negative integer", field="seed", fix="use a seed >= 0"
        )
    t = get_template(template)
    cat = catalog or load_catalog()
    for c in required_categories:
        cat.get(c)
    rooms, walls, openings = build_rooms(t)
    floor = unary_union([Polygon(r.polygon) for r in rooms])
    tally: Counter = Counter()
    last: list[Violation] = []
    for attempt in range(t.max_attempts):
        spec, violations = _attempt(
            t, seed, attempt, cat, required_categories, robot_radius, rooms, walls, openings, floor, dressing
        )
        if not violations:
            return spec
        last = violations
        tally.update(v.rule for v in violations)
    rule, n = tally.most_common(1)[0]
    examples = "; ".join(v.message for v in last[:3])
    raise GenerationError(
        f"seed {seed} of template '{t.name}': no layout in {t.max_attempts} attempts satisfied every rule; "
        f"most often broken: '{rule}' ({n}x); last attempt: {examples}",
        field="seed",
        fix="try another seed, widen the template's slots, or relax required_categories",
    )
