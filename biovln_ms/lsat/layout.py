"""LLM-assisted layout design (paper Table 1): a description -> a structured layout request -> a spec.

The LLM (the same OpenAI-compatible ``JSONChatClient`` as LLM-Frontier) only turns words into a
``LayoutRequest``: data, validated by pydantic, never executed. Our own solver turns the request into
a one-off layout template (the room, furniture along the walls, one fixed slot per requested
instrument) and runs the procedural generator on it, so the result passes every rule the generator
enforces (Eq. 2-4, Zone 3 clear, goals navigable and mutually reachable) or fails with the rule that
could not be met. Offline, ``solve_layout`` takes the request directly (``biovln-ms layout solve
request.yaml``).

Request schema (YAML or JSON)::

    name: cell_culture_room            # optional
    room: {width: 8.0, depth: 6.0, height: 3.0}   # metres, 3-30 m
    furniture: {lab_bench: 1, lab_table: 1}        # along the walls; added when table-top instruments
                                                   # need one
    instruments:
      - {category: incubator, count: 2, wall: N}   # wall: N/E/S/W for wall instruments (optional)
      - {category: biosafety_cabinet}
      - {category: centrifuge}                     # table-top: on a bench or table
    seed: 0
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from biovln_ms.catalog import load_catalog
from biovln_ms.errors import BioVLNError, describe_validation_error
from biovln_ms.io_utils import parse_yaml, read_regular_file
from biovln_ms.limits import MAX_ID_LENGTH, MAX_SMALL_FILE_BYTES
from biovln_ms.llm.client import JSONChatClient
from biovln_ms.scene.generator import GenerationError, generate_scene
from biovln_ms.scene.spec import SceneSpec
from biovln_ms.scene.templates import Side, parse_template

WALL_MARGIN = 0.3  # m kept free at each end of a wall slot


class LayoutError(BioVLNError):
    """A layout request that is malformed or cannot be laid out."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class RoomRequest(_Strict):
    width: float = Field(ge=3.0, le=30.0, description="x extent (m)")
    depth: float = Field(ge=3.0, le=30.0, description="y extent (m)")
    height: float = Field(default=3.0, ge=2.2, le=6.0)


class InstrumentRequest(_Strict):
    category: str = Field(max_length=MAX_ID_LENGTH)
    count: int = Field(default=1, ge=1, le=4)
    wall: Side | None = None

    @field_validator("category")
    @classmethod
    def _known(cls, v: str) -> str:
        cat = load_catalog()
        if v not in cat:
            raise ValueError(f"unknown category '{v}' (known: {', '.join(cat.names())})")
        if cat.get(v).placement == "furniture":
            raise ValueError(f"'{v}' is furniture: ask for it under 'furniture'")
        return v


class FurnitureRequest(_Strict):
    lab_bench: int = Field(default=0, ge=0, le=2)
    lab_table: int = Field(default=0, ge=0, le=3)


class LayoutRequest(_Strict):
    name: str | None = Field(default=None, pattern=r"^[a-z][a-z0-9_]*$", max_length=MAX_ID_LENGTH)
    room: RoomRequest
    furniture: FurnitureRequest = FurnitureRequest()
    instruments: list[InstrumentRequest] = Field(min_length=1, max_length=12)
    seed: int = Field(default=0, ge=0, le=2**32 - 1)


def parse_request(obj, source: str = "<layout request>") -> LayoutRequest:
    if not isinstance(obj, dict):
        raise LayoutError(
            "a layout request must be a mapping", source=source, fix="see `biovln-ms layout solve --help`"
        )
    try:
        return LayoutRequest.model_validate(obj)
    except ValidationError as e:
        field, msg = describe_validation_error(e)
        raise LayoutError(
            msg, source=source, field=field, fix="see the request schema in biovln_ms/lsat/layout.py"
        ) from None


def load_request(path: str | Path) -> LayoutRequest:
    """Read and validate a request file (YAML or JSON): a regular file of at most 1 MiB, nested at most 64
    levels (:mod:`biovln_ms.io_utils`), plain data only, then the schema."""
    path = Path(path)
    raw = read_regular_file(
        path, MAX_SMALL_FILE_BYTES, "layout request", error=LayoutError, fix="write a request (YAML or JSON)"
    )
    return parse_request(
        parse_yaml(raw, str(path), "layout request", error=LayoutError, fix="fix the syntax"), str(path)
    )


# --- the solver ------------------------------------------------------------------------------------
def _furniture_slots(
    req: LayoutRequest, need_support: bool
) -> tuple[list[dict], list[str], dict[str, tuple]]:
    """Benches along the west wall, tables along the south (then north) wall; the walls they occupy."""
    cat = load_catalog()
    W, D = req.room.width, req.room.depth
    f = req.furniture
    n_bench, n_table = f.lab_bench, f.lab_table
    notes = []
    if need_support and n_bench + n_table == 0:
        n_table = 1
        notes.append("added a lab table to carry the table-top instruments")
    out, used = [], {}
    bw, bd = cat.get("lab_bench").dimensions[:2]
    for k in range(n_bench):
        if bd > D - 2 * WALL_MARGIN:
            raise LayoutError(
                f"a lab bench is {bd:.2f} m long; the room is {D:.2f} m deep",
                field="furniture.lab_bench",
                fix="make the room deeper (>= 6.6 m) or ask for lab tables instead",
            )
        side = ("W", "E")[k]
        x = bw / 2 if side == "W" else W - bw / 2
        out.append(
            {
                "id": f"bench_{k}",
                "category": "lab_bench",
                "room": "lab",
                "center": [x, D / 2],
                "face": [1.0, 0.0] if side == "W" else [-1.0, 0.0],
                "goal": True,
            }
        )
        used[side] = (0.0, D)
    tw, td = cat.get("lab_table").dimensions[:2]
    x0 = (bw if "W" in used else 0.0) + WALL_MARGIN
    x1 = W - (bw if "E" in used else 0.0) - WALL_MARGIN
    per_wall = max(1, int((x1 - x0) // (tw + 0.6)))
    for k in range(n_table):
        side = "S" if k < per_wall else "N"
        j = k if side == "S" else k - per_wall
        if j >= per_wall:
            raise LayoutError(
                f"{n_table} lab tables do not fit along the {W:.1f} m walls",
                field="furniture.lab_table",
                fix="ask for fewer tables or a wider room",
            )
        x = x0 + (j + 0.5) * (x1 - x0) / per_wall
        y = td / 2 if side == "S" else D - td / 2
        out.append(
            {
                "id": f"table_{k}",
                "category": "lab_table",
                "room": "lab",
                "center": [x, y],
                "face": [0.0, 1.0] if side == "S" else [0.0, -1.0],
                "goal": True,
            }
        )
        lo, hi = used.get(side, (x - tw / 2, x + tw / 2))
        used[side] = (min(lo, x - tw / 2), max(hi, x + tw / 2))
    return out, notes, used


def _wall_span(side: str, W: float, D: float, used: dict) -> list[float]:
    length = W if side in "NS" else D
    lo, hi = WALL_MARGIN, length - WALL_MARGIN
    if side in used:  # the free stretch beside the furniture on that wall
        a, b = used[side]
        left, right = (a - lo, hi - b)
        lo, hi = (lo, a) if left >= right else (b, hi)
    return [round(lo, 4), round(hi, 4)]


def request_template(req: LayoutRequest):
    """The one-off template of a request (fixed slots: every requested instrument is placed)."""

    cat = load_catalog()
    W, D = req.room.width, req.room.depth
    units = [(r, k) for r in req.instruments for k in range(r.count)]
    need_support = any(cat.get(r.category).placement == "table_top" for r, _ in units)
    furniture, notes, used = _furniture_slots(req, need_support)
    supports = [f["id"] for f in furniture]
    walls_free = [
        s
        for s in ("E", "N", "S", "W")
        if s not in used or _wall_span(s, W, D, used)[1] - _wall_span(s, W, D, used)[0] > 1.0
    ]
    slots, wall_turn, sup_turn = [], 0, 0
    for r, k in units:
        a = cat.get(r.category)
        sid = f"{r.category}_{k}"
        if a.placement == "wall":
            side = r.wall or walls_free[wall_turn % len(walls_free)]
            wall_turn += r.wall is None
            slots.append(
                {
                    "id": sid,
                    "placement": "wall",
                    "room": "lab",
                    "wall": side,
                    "span": _wall_span(side, W, D, used),
                    "categories": [r.category],
                    "fixed": True,
                }
            )
        elif a.placement == "table_top":
            slots.append(
                {
                    "id": sid,
                    "placement": "table_top",
                    "support": supports[sup_turn % len(supports)],
                    "span": [0.1, 0.9],
                    "categories": [r.category],
                    "fixed": True,
                }
            )
            sup_turn += 1
        else:
            m = 1.2
            slots.append(
                {
                    "id": sid,
                    "placement": "floor",
                    "room": "lab",
                    "region": [m, m, W - m, D - m],
                    "categories": [r.category],
                    "fixed": True,
                }
            )
    name = req.name or "layout"
    obj = {
        "name": name,
        "description": "solved from a layout request",
        "name_pattern": name + "_s{seed}",
        "wall_height": req.room.height,
        "rooms": [{"id": "lab", "kind": "room", "rect": [0.0, 0.0, W, D]}],
        "furniture": furniture,
        "slots": slots,
        "active_slots": [len(slots), len(slots)],
        "max_attempts": 600,
    }
    return parse_template(obj, "<layout request>"), notes


def solve_layout(req: LayoutRequest) -> tuple[SceneSpec, list[str]]:
    """A spec that passes every generator rule, and notes on what the solver added."""

    template, notes = request_template(req)
    try:
        return generate_scene(template, req.seed), notes
    except GenerationError as e:
        raise LayoutError(
            f"the request cannot be laid out: {e.message}",
            field="instruments",
            fix="a bigger room, fewer instruments, or other walls for them",
        ) from None


# --- the LLM front end -----------------------------------------------------------------------------
SYSTEM_PROMPT = """You turn a description of a biomedical laboratory into a JSON layout request.
Answer with one JSON object and nothing else, with these keys:
  "name": snake_case name (optional),
  "room": {"width": metres 3-30, "depth": metres 3-30, "height": metres 2.2-6},
  "furniture": {"lab_bench": 0-2, "lab_table": 0-3},
  "instruments": [{"category": one of the categories below, "count": 1-4, \
"wall": "N"|"E"|"S"|"W" (optional, wall instruments only)}],
  "seed": 0.
Instrument categories (placement): %s.
Pick a room size that fits the instruments with aisles of at least 1 m. Do not invent categories."""


def _categories_line() -> str:
    cat = load_catalog()
    return ", ".join(
        f"{n} ({cat.get(n).placement})" for n in cat.names() if cat.get(n).placement != "furniture"
    )


def suggest_request(description: str, client=None) -> LayoutRequest:
    """Ask the LLM for a layout request; its answer is validated data, never executed."""

    client = client or JSONChatClient()
    description = re.sub(r"\s+", " ", description).strip()[:2000]
    if not description:
        raise LayoutError(
            "empty description", field="description", fix='e.g. "a cell-culture room with two incubators"'
        )
    errors: list[str] = []

    def valid(obj: dict) -> bool:
        try:
            LayoutRequest.model_validate(obj)
            return True
        except ValidationError as e:
            errors.append(describe_validation_error(e)[1])
            return False

    answer = client.ask(SYSTEM_PROMPT % _categories_line(), description, validate=valid)
    if answer is None:
        why = errors[-1] if errors else f"the endpoint failed ({dict(client.stats.failure_kinds)})"
        raise LayoutError(
            f"the LLM gave no valid layout request: {why}",
            field="description",
            fix="rephrase, or write the request yourself and run `biovln-ms layout solve request.yaml`",
        )
    return LayoutRequest.model_validate(answer)


def request_json(req: LayoutRequest) -> str:
    return json.dumps(req.model_dump(mode="json"), indent=1) + "\n"
