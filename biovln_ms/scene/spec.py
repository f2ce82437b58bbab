"""The versioned scene spec (JSON): rooms, walls, openings, furniture and instruments.

World frame: Z up, metres, yaw in radians (CCW about Z). Every placed object carries the numbers of
the three-zone model (paper §3.2): operational face as a world unit vector, d_half, approach
distance (delta), success radius and the Eq. 1 goal.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from biovln_ms.catalog import Catalog
from biovln_ms.errors import BioVLNError
from biovln_ms.geometry.zones import PlacedInstrument, goal_position, rot2, wrap_angle
from biovln_ms.io_utils import atomic_write_text, json_depth  # noqa: F401 (json_depth: re-exported)
from biovln_ms.limits import MAX_DATA_DEPTH, Identifier

SCHEMA_VERSION = 1

# Limits (docs/guides/scenes-and-templates.md), checked before any geometry work. The templates use at
# most 7 rooms, 28 walls, 6 openings and 13 objects (41 with lab dressing); a spec file is ~15 kB. Names
# and ids are ``Identifier``s (biovln_ms.limits): they become file names, YAML and Markdown.
MAX_FILE_BYTES = 16 * 2**20
MAX_JSON_DEPTH = MAX_DATA_DEPTH
MAX_ROOMS = 64
MAX_POLYGON_VERTICES = 256
MAX_WALLS = 512
MAX_OPENINGS = 256
MAX_OBJECTS = 512  # furniture + instruments + dressing
MAX_COORDINATE = 1e4  # m, as the glTF reader (biovln_ms.lsat.gltf): farther is a units error, not a lab
MIN_WALL_LENGTH = 1e-6  # m: shorter is a degenerate (zero-length) wall
UNIT_TOL = 1e-4  # |v| of a unit vector (face, wall interior, opening normal)

Coord = Annotated[float, Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
Length = Annotated[float, Field(gt=0, le=MAX_COORDINATE)]
Vec2 = tuple[Coord, Coord]
Vec3 = tuple[Coord, Coord, Coord]
Size3 = tuple[Length, Length, Length]


DESIGNER_TEMPLATE = "lsat"  # the ``template`` of designer-authored scenes imported from GLB


class SceneSpecError(BioVLNError):
    """A malformed or invalid scene spec."""


class _Strict(BaseModel):
    # allow_inf_nan=False: every float field, in tuples and lists too, refuses NaN and +-inf.
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def _unit(v: Vec2 | None) -> Vec2 | None:
    if v is not None and abs(math.hypot(*v) - 1.0) > UNIT_TOL:
        raise ValueError("must be a unit vector")
    return v


def _simple_polygon(v: list[Vec2]) -> list[Vec2]:
    from shapely.geometry import Polygon

    poly = Polygon(v)
    if not poly.is_valid or poly.area <= 0:
        raise ValueError("must be a simple polygon with a positive area (no self-crossing, no repeats)")
    return v


class RoomSpec(_Strict):
    """A floor region (room, corridor or doorway passage): inner floor polygon, counter-clockwise."""

    id: Identifier
    kind: Literal["room", "corridor", "passage"]
    polygon: list[Vec2] = Field(min_length=3, max_length=MAX_POLYGON_VERTICES)
    height: Length
    _check = field_validator("polygon")(lambda cls, v: _simple_polygon(v))


class WallSpec(_Strict):
    """A wall segment on the boundary of the floor; ``interior`` is the unit normal into the room."""

    id: Identifier
    start: Vec2
    end: Vec2
    interior: Vec2
    thickness: Length
    height: Length
    _check = field_validator("interior")(lambda cls, v: _unit(v))

    @model_validator(mode="after")
    def _length(self) -> "WallSpec":
        if math.dist(self.start, self.end) < MIN_WALL_LENGTH:
            raise ValueError("end: the wall has zero length (start == end)")
        return self


class OpeningSpec(_Strict):
    """A doorway where two floor regions meet."""

    id: Identifier
    rooms: tuple[Identifier, Identifier]
    center: Vec2
    width: Length
    normal: Vec2
    _check = field_validator("normal")(lambda cls, v: _unit(v))


class ObjectSpec(_Strict):
    """A placed instrument or piece of furniture."""

    id: Annotated[Identifier, Field(pattern=r"^[A-Za-z0-9_\-]+$")]
    category: Identifier
    position: Vec3
    yaw: float
    size: Size3
    placement: Literal["wall", "table_top", "floor", "furniture"]
    room: Identifier
    support: Identifier | None = None
    slot: Identifier | None = None
    is_goal: bool = True
    face: Vec2 | None
    d_half: Length | None = None
    approach_distance: Annotated[float, Field(ge=0, le=MAX_COORDINATE)] | None = None
    success_radius: Length | None = None
    goal: Vec2 | None = None
    goal_source: Literal["marker"] | None = None  # None: Eq. 1; "marker": a designer's target_* marker (LSAT)

    _check = field_validator("face")(lambda cls, v: _unit(v))

    @model_validator(mode="after")
    def _goal_fields(self) -> "ObjectSpec":
        if self.is_goal:
            for key in ("face", "d_half", "approach_distance", "success_radius", "goal"):
                if getattr(self, key) is None:
                    raise ValueError(f"{key}: required for a goal object")
        return self

    def placed(self) -> PlacedInstrument:
        """The zone-model view of this object (model face recovered from the world face and yaw)."""
        model_face = None
        if self.face is not None:
            c, s = math.cos(-self.yaw), math.sin(-self.yaw)
            fx, fy = self.face
            model_face = (round(c * fx - s * fy, 9), round(s * fx + c * fy, 9))
        return PlacedInstrument(
            center=self.position,
            yaw=self.yaw,
            size=self.size,
            model_face=model_face,
            d_half=self.d_half or 0.0,
            approach_distance=self.approach_distance or 0.0,
            name=self.id,
            category=self.category,
        )


def make_object(
    cat: Catalog,
    obj_id: str,
    category: str,
    xy: Sequence[float],
    z: float,
    yaw: float,
    placement: str,
    room: str,
    support: str | None,
    slot: str | None,
    is_goal: bool,
) -> ObjectSpec:
    """The spec of catalog asset ``category`` placed at (``xy``, ``z``, ``yaw``): its size from the catalog
    and, for a goal (``is_goal``), the three-zone numbers and the Eq. 1 goal in the world frame. The
    generator, the lab dressing and the LSAT importer all place objects through it."""
    a = cat.get(category)
    yaw = wrap_angle(yaw)
    face = None if a.face_vector is None else tuple(float(v) for v in rot2(yaw) @ a.face_vector)
    goal = None
    if is_goal:
        goal = tuple(float(v) for v in goal_position(xy, face, a.d_half, a.approach_distance))
    return ObjectSpec(
        id=obj_id,
        category=category,
        position=(float(xy[0]), float(xy[1]), float(z)),
        yaw=float(yaw),
        size=tuple(a.dimensions),
        placement=placement,
        room=room,
        support=support,
        slot=slot,
        is_goal=is_goal,
        face=face,
        d_half=a.d_half if is_goal else None,
        approach_distance=a.approach_distance if is_goal else None,
        success_radius=a.success_radius if is_goal else None,
        goal=goal,
    )


class SceneSpec(_Strict):
    schema_version: Literal[1]
    name: Identifier
    template: Identifier
    seed: int
    generator_version: int
    robot_radius: Length = Field(description="radius the layout rules were checked for")
    catalog_sha256: Annotated[str, Field(max_length=64)]
    rooms: list[RoomSpec] = Field(min_length=1, max_length=MAX_ROOMS)
    walls: list[WallSpec] = Field(max_length=MAX_WALLS)
    openings: list[OpeningSpec] = Field(max_length=MAX_OPENINGS)
    furniture: list[ObjectSpec] = Field(max_length=MAX_OBJECTS)
    instruments: list[ObjectSpec] = Field(min_length=1, max_length=MAX_OBJECTS)
    # lab dressing: non-goal objects; absent from the JSON when empty, so undressed specs keep
    # their bytes
    dressing: list[ObjectSpec] = Field(default_factory=list, max_length=MAX_OBJECTS)

    @model_validator(mode="after")
    def _ids(self) -> "SceneSpec":
        if len(self.objects()) > MAX_OBJECTS:
            raise ValueError(
                f"instruments: more than {MAX_OBJECTS} objects (furniture + instruments + dressing)"
            )
        ids = [o.id for o in self.objects()]
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ValueError(f"instruments/furniture: duplicate ids {dup}")
        room_ids = {r.id for r in self.rooms}
        furn = {f.id for f in self.furniture}
        for key, objs in (
            ("furniture", self.furniture),
            ("instruments", self.instruments),
            ("dressing", self.dressing),
        ):
            for i, o in enumerate(objs):
                if o.room not in room_ids:
                    raise ValueError(f"{key}[{i}].room: '{o.room}' is not a room id ({sorted(room_ids)})")
                if o.support is not None and o.support not in furn:
                    raise ValueError(f"{key}[{i}].support: '{o.support}' is not a furniture id")
        return self

    def objects(self) -> list[ObjectSpec]:
        """Every placed object: furniture, instruments and lab dressing (all of them bodies in the way)."""
        return [*self.furniture, *self.instruments, *self.dressing]

    def goal_objects(self) -> list[ObjectSpec]:
        """Everything an episode can target: instruments and goal furniture."""
        return [o for o in self.objects() if o.is_goal]

    def get(self, object_id: str) -> ObjectSpec:
        for o in self.objects():
            if o.id == object_id:
                return o
        raise SceneSpecError(
            f"no object '{object_id}' in scene '{self.name}'",
            fix=f"use one of: {', '.join(o.id for o in self.objects())}",
        )

    def to_json(self) -> str:
        """Canonical JSON: sorted keys, fixed float formatting (byte-identical for the same spec)."""
        data = _round(self.model_dump(mode="json"))
        if not data["dressing"]:
            del data["dressing"]
        for key in ("furniture", "instruments", "dressing"):
            for o in data.get(key, []):
                if o.get("goal_source") is None:
                    o.pop("goal_source", None)  # absent for Eq. 1 goals: procedural specs keep their bytes
        return json.dumps(data, indent=1, sort_keys=True) + "\n"


def _round(obj, nd: int = 6):
    if isinstance(obj, float):
        v = round(obj, nd)
        return 0.0 if v == 0 else v
    if isinstance(obj, dict):
        return {k: _round(v, nd) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_round(v, nd) for v in obj]
    return obj


def save_spec(spec: SceneSpec, path: str | Path) -> Path:
    atomic_write_text(Path(path), spec.to_json())
    return Path(path)
