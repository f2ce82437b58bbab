"""The versioned scene spec (JSON): rooms, walls, openings, furniture and instruments.

World frame: Z up, metres, yaw in radians (CCW about Z). Every placed object carries the numbers of
the three-zone model (paper §3.2): operational face as a world unit vector, d_half, approach
distance (delta), success radius and the Eq. 1 goal.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from biovln_ms.errors import BioVLNError, describe_validation_error
from biovln_ms.geometry.zones import PlacedInstrument
from biovln_ms.io_utils import atomic_write_text

SCHEMA_VERSION = 1
Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]


DESIGNER_TEMPLATE = "lsat"  # the ``template`` of designer-authored scenes imported from GLB


class SceneSpecError(BioVLNError):
    """A malformed or invalid scene spec."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


def _finite(v):
    if not all(math.isfinite(x) for x in np.ravel(v)):
        raise ValueError("must be finite numbers")
    return v


class RoomSpec(_Strict):
    """A floor region (room, corridor or doorway passage): inner floor polygon, counter-clockwise."""

    id: str
    kind: Literal["room", "corridor", "passage"]
    polygon: list[Vec2] = Field(min_length=3)
    height: float = Field(gt=0)
    _check = field_validator("polygon")(lambda cls, v: _finite(v))


class WallSpec(_Strict):
    """A wall segment on the boundary of the floor; ``interior`` is the unit normal into the room."""

    id: str
    start: Vec2
    end: Vec2
    interior: Vec2
    thickness: float = Field(gt=0)
    height: float = Field(gt=0)


class OpeningSpec(_Strict):
    """A doorway where two floor regions meet."""

    id: str
    rooms: tuple[str, str]
    center: Vec2
    width: float = Field(gt=0)
    normal: Vec2


class ObjectSpec(_Strict):
    """A placed instrument or piece of furniture."""

    id: str = Field(pattern=r"^[A-Za-z0-9_\-]+$")
    category: str
    position: Vec3
    yaw: float
    size: Vec3
    placement: Literal["wall", "table_top", "floor", "furniture"]
    room: str
    support: str | None = None
    slot: str | None = None
    is_goal: bool = True
    face: Vec2 | None
    d_half: float | None = None
    approach_distance: float | None = None
    success_radius: float | None = None
    goal: Vec2 | None = None
    goal_source: Literal["marker"] | None = None  # None: Eq. 1; "marker": a designer's target_* marker (LSAT)

    _check = field_validator("position", "size")(lambda cls, v: _finite(v))

    @model_validator(mode="after")
    def _goal_fields(self) -> "ObjectSpec":
        if self.is_goal:
            for key in ("face", "d_half", "approach_distance", "success_radius", "goal"):
                if getattr(self, key) is None:
                    raise ValueError(f"{key}: required for a goal object")
            if abs(math.hypot(*self.face) - 1.0) > 1e-4:
                raise ValueError("face: must be a unit vector")
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


class SceneSpec(_Strict):
    schema_version: Literal[1]
    name: str
    template: str
    seed: int
    generator_version: int
    robot_radius: float = Field(gt=0, description="radius the layout rules were checked for")
    catalog_sha256: str
    rooms: list[RoomSpec] = Field(min_length=1)
    walls: list[WallSpec]
    openings: list[OpeningSpec]
    furniture: list[ObjectSpec]
    instruments: list[ObjectSpec] = Field(min_length=1)

    @model_validator(mode="after")
    def _ids(self) -> "SceneSpec":
        ids = [o.id for o in self.objects()]
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ValueError(f"instruments/furniture: duplicate ids {dup}")
        room_ids = {r.id for r in self.rooms}
        furn = {f.id for f in self.furniture}
        for key, objs in (("furniture", self.furniture), ("instruments", self.instruments)):
            for i, o in enumerate(objs):
                if o.room not in room_ids:
                    raise ValueError(f"{key}[{i}].room: '{o.room}' is not a room id ({sorted(room_ids)})")
                if o.support is not None and o.support not in furn:
                    raise ValueError(f"{key}[{i}].support: '{o.support}' is not a furniture id")
        return self

    def objects(self) -> list[ObjectSpec]:
        return [*self.furniture, *self.instruments]

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
        for key in ("furniture", "instruments"):
            for o in data[key]:
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


def parse_spec(obj: dict, source: str = "<scene spec>", check_rules: bool = True) -> SceneSpec:
    """Validate a spec object: schema, then consistency with the catalog and the layout rules."""
    if not isinstance(obj, dict):
        raise SceneSpecError("a scene spec must be a JSON object", source=source)
    version = obj.get("schema_version")
    if version != SCHEMA_VERSION:
        raise SceneSpecError(
            f"schema_version {version!r} is not supported (this build reads {SCHEMA_VERSION})",
            source=source,
            field="schema_version",
            fix="regenerate the spec with this version",
        )
    try:
        spec = SceneSpec.model_validate(obj)
    except ValidationError as e:
        field, msg = describe_validation_error(e)
        raise SceneSpecError(msg, source=source, field=field) from None
    if check_rules:
        from biovln_ms.scene.rules import DESIGNER_RULES, check_consistency, check_layout

        for problems in (check_consistency(spec), check_layout(spec)):
            if spec.template == DESIGNER_TEMPLATE:  # designer-authored (LSAT): only the rules it must keep
                problems = [p for p in problems if p.rule in DESIGNER_RULES]
            if problems:
                p = problems[0]
                more = f" (+{len(problems) - 1} more)" if len(problems) > 1 else ""
                raise SceneSpecError(
                    f"{p.message}{more}", source=source, field=p.field, fix=f"rule: {p.rule}"
                )
    return spec


def load_spec(path: str | Path, check_rules: bool = True) -> SceneSpec:
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as e:
        raise SceneSpecError(f"cannot read the scene spec ({e.strerror})", source=str(path)) from None
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as e:
        raise SceneSpecError(
            f"not valid JSON at line {e.lineno} column {e.colno}: {e.msg}", source=str(path)
        ) from None
    return parse_spec(obj, str(path), check_rules)


def save_spec(spec: SceneSpec, path: str | Path) -> Path:
    atomic_write_text(Path(path), spec.to_json())
    return Path(path)
