"""Instance-level English instructions for protocol episodes, and the rule-based resolver reading them.

An instruction names every visit's instrument by its category ("the refrigerator"); where the scene holds
several objects of that category, it singles out the meant one with a spatial relation computed from the
scene geometry and **verified unique**: the relation holds for the meant object and for no other object of
its category. Relations, tried in this order (the simplest unique one is used):

1. ``in <room>``: the object's room ("room_a" -> "room A", "room_3" -> "room 3", "hall" -> "the hall").
2. ``on <support>``: the bench or table it stands on (the spec's ``support`` field); the support is itself
   named by category, or by room, or by the compass extreme it holds ("the lab bench farthest east").
3. ``by the <north|south|east|west> wall``: the nearest side of the room's bounding box, within 1.5 m of the
   object's centre. Compass words are the floor frame: +y is north, +x is east.
4. ``nearest the door``: the object of its category closest to a doorway (scene openings), by >= 0.5 m.
5. ``to the <left|right> of <instrument>``: as seen by a person standing in front of the reference
   instrument, facing it (looking along minus its operational face). The reference is the only object of
   its category in the scene, in the same room, within 3 m; the offset along the left axis is >= 0.3 m.
6. ``farthest <north|south|east|west>``: the extreme object of its category along that axis, by >= 1 m.

Ambiguity is never silent: :func:`instruction` raises :class:`AmbiguousInstructionError` (one line) when a
visited object has no unique relation, and verifies its own text with :func:`resolve` before returning it.
Episode samplers use :func:`describable` / :func:`pick_instances`, which skip such objects (resample).

The wording comes from a small template grammar (openings, movement verbs, connectives, the protocol's
purposes woven in), drawn with a ``numpy.random.Generator``: the same seed gives the same text.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from shapely.geometry import Point, Polygon

from biovln_ms.catalog import load_catalog
from biovln_ms.protocols.library import Protocol, ProtocolError
from biovln_ms.scene.spec import ObjectSpec, SceneSpec

WALL_NEAR = 1.5  # m: an object whose centre is this close to a side of its room's box is "by" that wall
DOOR_MARGIN = 0.5  # m: "nearest the door" must beat the next object of the category by this much
SIDE_RANGE = 3.0  # m: the farthest a "left/right of" reference may be
SIDE_MIN = 0.3  # m: the least offset along the left axis for "left/right of"
EXTREME_MARGIN = 1.0  # m: "farthest <dir>" must beat the next object of the category by this much
COMPASS = {"north": (0.0, 1.0), "south": (0.0, -1.0), "east": (1.0, 0.0), "west": (-1.0, 0.0)}
RELATION_ORDER = ("room", "support", "wall", "door", "side", "extreme")


class AmbiguousInstructionError(ProtocolError):
    """No relation singles out the meant object, or an instruction does not resolve to exactly one object."""


@dataclass(frozen=True)
class Target:
    """One visit of an instruction: category, relation text used (None: unique category), object id."""

    category: str
    relation: str | None
    object_id: str


@dataclass(frozen=True)
class Instruction:
    text: str
    targets: tuple[Target, ...]

    @property
    def needs_relation(self) -> int:
        """How many targets needed a spatial relation (their category occurs more than once in the scene)."""
        return sum(t.relation is not None for t in self.targets)

    @property
    def object_ids(self) -> list[str]:
        return [t.object_id for t in self.targets]


# --- names ---------------------------------------------------------------------------------------
def spoken(category: str) -> str:
    """A category as said aloud: ``biosafety_cabinet`` -> ``biosafety cabinet``."""
    return category.replace("_", " ")


def room_name(room_id: str) -> str:
    m = re.fullmatch(r"room_?([A-Za-z0-9]+)", room_id)
    if m:
        tag = m.group(1)
        return f"room {tag.upper() if tag.isalpha() else tag}"
    return "the " + room_id.replace("_", " ")


def _xy(o: ObjectSpec) -> np.ndarray:
    return np.array(o.position[:2], dtype=float)


def _of_category(scene: SceneSpec, category: str) -> list[ObjectSpec]:
    return [o for o in scene.objects() if o.category == category]


def _extreme_dirs(obj: ObjectSpec, peers: Sequence[ObjectSpec]) -> list[str]:
    """The compass directions along which ``obj`` is the extreme of ``peers`` by EXTREME_MARGIN."""
    out = []
    for word, d in COMPASS.items():
        mine = float(_xy(obj) @ d)
        others = [float(_xy(p) @ d) for p in peers if p.id != obj.id]
        if others and mine - max(others) >= EXTREME_MARGIN:
            out.append(word)
    return out


def support_name(scene: SceneSpec, furniture_id: str) -> str | None:
    """A name that picks out one piece of furniture: by category, room, or compass extreme; None if none."""
    f = scene.get(furniture_id)
    peers = _of_category(scene, f.category)
    base = f"the {spoken(f.category)}"
    if len(peers) == 1:
        return base
    if sum(p.room == f.room for p in peers) == 1:
        return f"{base} in {room_name(f.room)}"
    dirs = _extreme_dirs(f, peers)
    return f"{base} farthest {dirs[0]}" if dirs else None


# --- relations -----------------------------------------------------------------------------------
def _room_poly(scene: SceneSpec, room_id: str) -> Polygon:
    return Polygon(next(r.polygon for r in scene.rooms if r.id == room_id))


def _wall_of(scene: SceneSpec, o: ObjectSpec) -> str | None:
    minx, miny, maxx, maxy = _room_poly(scene, o.room).bounds
    x, y = o.position[:2]
    dist = {"west": x - minx, "east": maxx - x, "south": y - miny, "north": maxy - y}
    word = min(dist, key=dist.get)
    return word if dist[word] <= WALL_NEAR else None


def _door_distance(scene: SceneSpec, o: ObjectSpec) -> float:
    p = Point(o.position[:2])
    return min((p.distance(Point(op.center)) for op in scene.openings), default=math.inf)


def _left_axis(ref: ObjectSpec) -> np.ndarray:
    view = -np.array(ref.face, dtype=float)  # a person in front of ref, facing it
    return np.array([-view[1], view[0]])


def relations(scene: SceneSpec, obj: ObjectSpec) -> dict[str, list[str]]:
    """Every relation text that holds for ``obj``, by kind (in :data:`RELATION_ORDER`); unique or not."""
    peers = _of_category(scene, obj.category)
    out: dict[str, list[str]] = {k: [] for k in RELATION_ORDER}
    out["room"].append(f"in {room_name(obj.room)}")
    if obj.support is not None:
        name = support_name(scene, obj.support)
        if name is not None:
            out["support"].append(f"on {name}")
    wall = _wall_of(scene, obj)
    if wall is not None:
        out["wall"].append(f"by the {wall} wall")
    mine = _door_distance(scene, obj)
    others = [_door_distance(scene, p) for p in peers if p.id != obj.id]
    if math.isfinite(mine) and (not others or min(others) - mine >= DOOR_MARGIN):
        out["door"].append("nearest the door")
    for ref in scene.objects():
        if ref.id == obj.id or ref.face is None or ref.room != obj.room or ref.category == obj.category:
            continue
        if len(_of_category(scene, ref.category)) != 1:
            continue
        offset = _xy(obj) - _xy(ref)
        if np.linalg.norm(offset) > SIDE_RANGE:
            continue
        along = float(offset @ _left_axis(ref))
        if abs(along) >= SIDE_MIN:
            out["side"].append(f"to the {'left' if along > 0 else 'right'} of the {spoken(ref.category)}")
    out["extreme"].extend(f"farthest {d}" for d in _extreme_dirs(obj, peers))
    return out


def _holding(scene: SceneSpec, obj: ObjectSpec) -> set[str]:
    return {t for texts in relations(scene, obj).values() for t in texts}


def unique_relation(scene: SceneSpec, object_id: str) -> str | None:
    """The simplest relation that singles out ``object_id`` among its category, ``""`` when the category
    occurs once (no relation needed), None when no relation is unique."""
    obj = scene.get(object_id)
    peers = [p for p in _of_category(scene, obj.category) if p.id != obj.id]
    if not peers:
        return ""
    taken = set().union(*(_holding(scene, p) for p in peers))
    for texts in relations(scene, obj).values():
        for text in texts:
            if text not in taken:
                return text
    return None


def describable(scene: SceneSpec, object_id: str) -> bool:
    """Whether an instruction can name ``object_id`` unambiguously."""
    return unique_relation(scene, object_id) is not None


def pick_instances(protocol: Protocol, scene: SceneSpec, rng: np.random.Generator) -> list[str]:
    """One admissible visit order of ``protocol`` as object ids, each drawn among the describable goal
    objects of its category (furniture that is no goal, and objects no relation singles out, are skipped:
    the documented resample, as the episode sampler's ``drawable_objects``)."""
    ids = []
    goals = {o.id for o in scene.goal_objects()}
    for visit in protocol.sample_order(rng):
        pool = [
            o.id for o in _of_category(scene, visit.category) if o.id in goals and describable(scene, o.id)
        ]
        if not pool:
            raise AmbiguousInstructionError(
                f"no {spoken(visit.category)} goal in scene '{scene.name}' can be named unambiguously",
                field="category",
                fix="use a scene where that instrument is a goal and occurs once, or stands apart from its "
                "twins",
            )
        ids.append(pool[int(rng.integers(len(pool)))])
    return ids


# --- the grammar ---------------------------------------------------------------------------------
OPENINGS = ("", "Please ", "For this run, ", "Okay, ")
VERBS = ("go to", "head to", "walk over to", "make your way to", "visit")
THEN = (", then ", "; after that, ", ". Next, ", ". Then ")
FINALLY = (", and finally ", ". Finally, ", "; lastly, ")
PURPOSE_LINKS = (" to ", " and ", None)  # None: the clause carries no purpose


def _purposes(protocol: Protocol, categories: Sequence[str]) -> list[str]:
    if not protocol.admits(list(categories)):
        raise ProtocolError(
            f"the visits {list(categories)} are not an admissible order of protocol '{protocol.id}'",
            field="visits",
            fix="draw the visits with pick_instances or protocol.sample_order",
        )
    out, i = [], 0
    for step in protocol.steps:
        chunk = categories[i : i + len(step.visits)]
        by_cat = {v.category: v.purpose for v in step.visits}
        out.extend(by_cat[c] for c in chunk)
        i += len(chunk)
    return out


def instruction(
    protocol: Protocol, scene: SceneSpec, visits: Sequence[str], rng: np.random.Generator
) -> Instruction:
    """The English instruction for visiting the objects ``visits`` (ids, in order) of ``scene`` under
    ``protocol``. Raises :class:`AmbiguousInstructionError` if a visited object cannot be singled out."""
    objs = [scene.get(i) for i in visits]
    purposes = _purposes(protocol, [o.category for o in objs])
    targets, clauses = [], []
    for n, (o, purpose) in enumerate(zip(objs, purposes, strict=True)):
        rel = unique_relation(scene, o.id)
        if rel is None:
            raise AmbiguousInstructionError(
                f"no relation singles out '{o.id}' among the {spoken(o.category)}s of scene '{scene.name}'",
                field="visits",
                fix="skip this object (pick_instances draws only describable ones)",
            )
        targets.append(Target(o.category, rel or None, o.id))
        phrase = f"the {spoken(o.category)}" + (f" {rel}" if rel else "")
        clause = f"{VERBS[int(rng.integers(len(VERBS)))]} {phrase}"
        link = PURPOSE_LINKS[int(rng.integers(len(PURPOSE_LINKS)))]
        if link is not None:
            clause += link + purpose.rstrip(".")
        if n == 0:
            opening = OPENINGS[int(rng.integers(len(OPENINGS)))]
            clauses.append(opening + clause)
        else:
            pool = FINALLY if n == len(objs) - 1 else THEN
            clauses.append(pool[int(rng.integers(len(pool)))] + clause)
    text = "".join(clauses)
    text = _sentence_case(text) + "."
    out = Instruction(text, tuple(targets))
    got = resolve(text, scene)
    if got != list(visits):
        raise AmbiguousInstructionError(
            f"the generated instruction reads back as {got}, not {list(visits)}",
            field="visits",
            fix="a purpose may name another instrument with a movement verb; reword that purpose",
        )
    return out


def _sentence_case(text: str) -> str:
    text = text[:1].upper() + text[1:]
    return re.sub(r"(\. )([a-z])", lambda m: m.group(1) + m.group(2).upper(), text)


# --- the resolver --------------------------------------------------------------------------------
_DIR = "north|south|east|west"
_END = r"(?= to | and |[,.;]|$)"
_REL = (
    rf"in (?:room [A-Za-z0-9]+|the [a-z0-9 ]+?)|on the [a-z0-9 ]+?|by the (?:{_DIR}) wall|nearest the door"
    rf"|to the (?:left|right) of the [a-z0-9 ]+?|farthest (?:{_DIR})"
)


def _target_regex(categories: Sequence[str]) -> re.Pattern:
    names = "|".join(re.escape(spoken(c)) for c in sorted(categories, key=len, reverse=True))
    verbs = "|".join(re.escape(v) for v in VERBS)
    return re.compile(rf"\b(?:{verbs}) the ({names})(?: ({_REL}))?{_END}", re.IGNORECASE)


def parse(text: str, categories: Sequence[str] | None = None) -> list[tuple[str, str | None]]:
    """The (category, relation text or None) targets of an instruction of the grammar, in order.
    ``categories``: the category vocabulary (default: the catalog's goal categories)."""
    if categories is None:
        categories = load_catalog().goal_categories()
    by_name = {spoken(c): c for c in categories}
    return [(by_name[m.group(1).lower()], m.group(2)) for m in _target_regex(categories).finditer(text)]


def resolve_target(scene: SceneSpec, category: str, relation: str | None) -> str:
    """The one object of ``category`` the relation holds for; anything else raises a one-line error."""
    peers = _of_category(scene, category)
    hits = [p.id for p in peers if relation is None or relation in _holding(scene, p)]
    if len(hits) != 1:
        what = f"the {spoken(category)}" + (f" {relation}" if relation else "")
        raise AmbiguousInstructionError(
            f"'{what}' matches {len(hits)} objects in scene '{scene.name}' ({', '.join(hits) or 'none'})",
            field="instruction",
            fix="name the object with a relation that holds for it alone",
        )
    return hits[0]


def resolve(
    instr: str | Instruction | Sequence[Target | tuple[str, str | None]], scene: SceneSpec
) -> list[str]:
    """The object ids an instruction (its text, an :class:`Instruction`, or (category, relation) targets)
    means in ``scene``, in visit order; an ambiguous or unknown reference raises one line."""
    if isinstance(instr, Instruction):
        instr = instr.text
    if isinstance(instr, str):
        pairs = parse(instr)
        if not pairs:
            raise AmbiguousInstructionError(
                "the instruction names no instrument", field="instruction", fix="use the instruction grammar"
            )
    else:
        pairs = [(t.category, t.relation) if isinstance(t, Target) else tuple(t) for t in instr]
    return [resolve_target(scene, c, r) for c, r in pairs]


__all__ = [
    "AmbiguousInstructionError",
    "Instruction",
    "Target",
    "describable",
    "instruction",
    "parse",
    "pick_instances",
    "relations",
    "resolve",
    "resolve_target",
    "room_name",
    "spoken",
    "support_name",
    "unique_relation",
]
