"""Layout templates as data (the paper's config.py / config_two_room.py, one JSON file each).

A template lists floor rectangles (rooms, corridors, doorway passages), fixed furniture and
instrument slots. Packaged templates live in ``biovln_ms/scene/templates/``; users add their own
with :func:`register_template` (a path or a dict) or by putting JSON files in a folder named by the
``BIOVLN_TEMPLATE_PATH`` environment variable — the generator is never edited.

Such a folder may hold other JSON (scene specs, episodes): a file there is a template by its content, a
JSON object with the keys ``TEMPLATE_KEYS``. Any other file, and a template that does not load, is skipped
with a one-line warning naming it, so one stray file never stops a command that needs no template of it.
"""

from __future__ import annotations

import importlib.util
import json
import logging
import os
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from biovln_ms.catalog import load_catalog
from biovln_ms.errors import BioVLNError, describe_validation_error

TEMPLATE_DIR = Path(__file__).resolve().parent / "templates"
#: the keys that make a JSON file in a BIOVLN_TEMPLATE_PATH folder a template (no scene spec has slots)
TEMPLATE_KEYS = ("rooms", "slots", "active_slots")
Side = Literal["N", "S", "E", "W"]
log = logging.getLogger(__name__)


class TemplateError(BioVLNError):
    """A malformed or unknown layout template."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class RoomRect(_Strict):
    id: str
    kind: Literal["room", "corridor", "passage"] = "room"
    rect: tuple[float, float, float, float] = Field(description="x0, y0, x1, y1 of the inner floor")

    @model_validator(mode="after")
    def _order(self) -> RoomRect:
        x0, y0, x1, y1 = self.rect
        if not (x1 > x0 and y1 > y0):
            raise ValueError("rect: must be [x0, y0, x1, y1] with x1 > x0 and y1 > y0")
        return self


class FurnitureSlot(_Strict):
    """Fixed furniture: centre on the floor and the world direction its operational face points."""

    id: str
    category: str
    room: str
    center: tuple[float, float]
    face: tuple[float, float]
    goal: bool = False


class InstrumentSlot(_Strict):
    id: str
    placement: Literal["wall", "table_top", "floor"]
    categories: list[str] = Field(min_length=1)
    room: str | None = None
    wall: Side | None = Field(default=None, description="wall slots: which wall of the room")
    span: tuple[float, float] | None = Field(
        default=None,
        description="wall: world interval along the wall; table_top: fraction interval along the support",
    )
    support: str | None = Field(default=None, description="table_top slots: furniture id")
    region: tuple[float, float, float, float] | None = Field(
        default=None, description="floor slots: x0, y0, x1, y1"
    )
    fixed: bool = Field(default=False, description="always active (e.g. every slot of two_room)")

    @model_validator(mode="after")
    def _by_placement(self) -> InstrumentSlot:
        need = {
            "wall": ("room", "wall", "span"),
            "table_top": ("support", "span"),
            "floor": ("room", "region"),
        }[self.placement]
        for key in need:
            if getattr(self, key) is None:
                raise ValueError(f"{key}: required for a {self.placement} slot")
        return self


class Template(_Strict):
    name: str = Field(pattern=r"^[a-z][a-z0-9_]*$")
    description: str = ""
    name_pattern: str = "{template}_s{seed}_v0"
    wall_height: float = Field(default=3.24, gt=0)
    rooms: list[RoomRect] = Field(min_length=1)
    furniture: list[FurnitureSlot] = []
    slots: list[InstrumentSlot] = Field(min_length=1)
    active_slots: tuple[int, int]
    yaw_jitter_deg: float = Field(
        default=30.0, ge=0, le=180, description="floor instruments: face-to-centre jitter"
    )
    max_attempts: int = Field(default=400, ge=1)

    @model_validator(mode="after")
    def _refs(self) -> Template:

        cat = load_catalog()
        rooms = {r.id for r in self.rooms}
        furn = {f.id for f in self.furniture}
        lo, hi = self.active_slots
        if not (1 <= lo <= hi <= len(self.slots)):
            raise ValueError(
                f"active_slots: [{lo}, {hi}] must satisfy 1 <= min <= max <= {len(self.slots)} slots"
            )
        if sum(s.fixed for s in self.slots) > hi:
            raise ValueError("active_slots: fewer than the number of fixed slots")
        for i, f in enumerate(self.furniture):
            if f.room not in rooms:
                raise ValueError(f"furniture[{i}].room: '{f.room}' is not a room id")
            if f.category not in cat:
                raise ValueError(f"furniture[{i}].category: unknown '{f.category}'")
        for i, s in enumerate(self.slots):
            if s.room is not None and s.room not in rooms:
                raise ValueError(f"slots[{i}].room: '{s.room}' is not a room id")
            if s.support is not None and s.support not in furn:
                raise ValueError(f"slots[{i}].support: '{s.support}' is not a furniture id")
            for c in s.categories:
                if c not in cat:
                    raise ValueError(
                        f"slots[{i}].categories: unknown '{c}' (known: {', '.join(cat.names())})"
                    )
                if cat.get(c).placement != s.placement:
                    raise ValueError(
                        f"slots[{i}].categories: '{c}' is a {cat.get(c).placement} asset, not {s.placement}"
                    )
        ids = [s.id for s in self.slots] + [f.id for f in self.furniture]
        if len(set(ids)) != len(ids):
            raise ValueError("slots/furniture: ids must be unique")
        return self

    def scene_name(self, seed: int) -> str:
        return self.name_pattern.format(template=self.name, seed=seed)

    def categories(self) -> set[str]:
        """Every category a scene of this template can hold: its furniture's and its slots'."""
        return {f.category for f in self.furniture} | {c for s in self.slots for c in s.categories}


_REGISTRY: dict[str, Template] = {}
_BUILTIN_LOADED = False
_SKIPPED: dict[str, str] = {}  # file in a BIOVLN_TEMPLATE_PATH folder -> why it was not loaded


def parse_template(obj: dict, source: str) -> Template:
    try:
        return Template.model_validate(obj)
    except ValidationError as e:
        field, msg = describe_validation_error(e)
        raise TemplateError(msg, source=source, field=field) from None


def load_template_file(path: str | Path) -> Template:
    path = Path(path)
    try:
        obj = json.loads(path.read_text())
    except OSError as e:
        raise TemplateError(f"cannot read ({e.strerror})", source=str(path)) from None
    except json.JSONDecodeError as e:
        raise TemplateError(f"not valid JSON at line {e.lineno}: {e.msg}", source=str(path)) from None
    return parse_template(obj, str(path))


def _package_tasks_dir() -> Path | None:
    """The installed ``biovln_ms.tasks`` folder (the repo's ``tasks/``), found without importing it."""
    spec = importlib.util.find_spec("biovln_ms.tasks")
    locations = list(spec.submodule_search_locations or []) if spec else []
    return Path(locations[0]) if locations else None


def resolve_template_path(path: str | Path) -> Path:
    """``path`` if it exists from the current directory; else a relative path is looked up in the
    installed package: ``tasks/examples/cold_room.json`` under ``biovln_ms/tasks/`` (the repo's
    ``tasks/``), then ``cold_room.json`` under ``biovln_ms/tasks/examples/``. Raises a one-line
    :class:`TemplateError` naming the file and the fix when none exists."""
    path = Path(path)
    if path.exists() or path.is_absolute():
        return path
    tasks_dir = _package_tasks_dir()
    candidates = []
    if tasks_dir is not None:
        if path.parts[:1] == ("tasks",):
            candidates.append(tasks_dir.joinpath(*path.parts[1:]))
        candidates.append(tasks_dir / "examples" / path)
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    where = f"{Path.cwd()}" + (f" and the package's {tasks_dir}" if tasks_dir is not None else "")
    raise TemplateError(
        f"no such template file (looked in {where})",
        source=str(path),
        fix="give the JSON file's path from the current directory, or an absolute path",
    )


def register_template(template: Template | dict | str | Path, override: bool = False) -> Template:
    """Add a template (object, dict or JSON path) to the registry under its name.

    A relative path that does not exist from the current directory is resolved against the installed
    package (:func:`resolve_template_path`), so the documented
    ``register_template("tasks/examples/cold_room.json")`` works from any working directory.
    """
    if isinstance(template, dict):
        template = parse_template(template, "<dict>")
    elif not isinstance(template, Template):
        template = load_template_file(resolve_template_path(template))
    if template.name in _REGISTRY and not override and _REGISTRY[template.name] != template:
        raise TemplateError(
            f"a different template named '{template.name}' is already registered",
            fix="pick another name or pass override=True",
        )
    _REGISTRY[template.name] = template
    return template


def _register_user_file(path: Path) -> None:
    """Register ``path`` from a BIOVLN_TEMPLATE_PATH folder when its content is a template; anything else
    (another kind of JSON, a broken template, a name already taken) is skipped with a one-line warning."""
    try:
        obj = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        why = f"not readable JSON ({getattr(e, 'strerror', None) or e})"
    else:
        if isinstance(obj, dict) and all(k in obj for k in TEMPLATE_KEYS):
            try:
                register_template(parse_template(obj, str(path)))
                return
            except TemplateError as e:
                why = f"not a valid template: {e.message}" + (f" (field '{e.field}')" if e.field else "")
        else:
            keys = ", ".join(f"'{k}'" for k in TEMPLATE_KEYS)
            why = f"not a layout template (a template has {keys}; is it a scene spec?)"
    _SKIPPED[str(path)] = why
    log.warning("BIOVLN_TEMPLATE_PATH: skipped %s: %s", path, why)


def _load_builtin() -> None:
    """The packaged templates, then the template files in the BIOVLN_TEMPLATE_PATH folders."""
    global _BUILTIN_LOADED
    if _BUILTIN_LOADED:
        return
    _BUILTIN_LOADED = True
    for path in sorted(TEMPLATE_DIR.glob("*.json")):
        register_template(path)
    for folder in filter(None, os.environ.get("BIOVLN_TEMPLATE_PATH", "").split(os.pathsep)):
        for path in sorted(p for p in Path(folder).glob("*.json") if p.is_file()):
            _register_user_file(path)


def template_names() -> list[str]:
    _load_builtin()
    return sorted(_REGISTRY)


def get_template(name: str | Template) -> Template:
    if isinstance(name, Template):
        return name
    _load_builtin()
    if name not in _REGISTRY:
        skipped = f"; skipped from BIOVLN_TEMPLATE_PATH: {', '.join(_SKIPPED)}" if _SKIPPED else ""
        raise TemplateError(
            f"unknown template '{name}'",
            field="template",
            fix=f"use one of: {', '.join(sorted(_REGISTRY))}{skipped}",
        )
    return _REGISTRY[name]
