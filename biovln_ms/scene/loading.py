"""Reading a scene spec: the file's limits (size, UTF-8, nesting), the counts, then the schema.

The types and their limits are :mod:`biovln_ms.scene.spec`'s. Loading gives a well-formed spec, not yet a
valid lab: its consistency with the catalog and the layout rules are
:func:`biovln_ms.scene.rules.validate_spec`'s, which every reader of a user's or a dataset's spec calls
next (the generator checks its own drafts' rules itself).
"""

from __future__ import annotations

import json
from pathlib import Path

from pydantic import ValidationError

from biovln_ms.errors import describe_validation_error
from biovln_ms.scene.spec import (
    MAX_FILE_BYTES,
    MAX_JSON_DEPTH,
    MAX_OBJECTS,
    MAX_OPENINGS,
    MAX_ROOMS,
    MAX_WALLS,
    SCHEMA_VERSION,
    SceneSpec,
    SceneSpecError,
    json_depth,
)

_COUNT_LIMITS = {"rooms": MAX_ROOMS, "walls": MAX_WALLS, "openings": MAX_OPENINGS}
_BOUNDS_FIX = "lengths are positive and coordinates within 10 km (docs: scenes and templates, The spec)"
_LIMIT_FIXES = {  # pydantic error type -> fix, for the errors the limits raise
    "finite_number": "use a finite number (NaN and Infinity are refused)",
    "greater_than": _BOUNDS_FIX,
    "greater_than_equal": _BOUNDS_FIX,
    "less_than_equal": _BOUNDS_FIX,
    "too_long": "see the limits in the docs (scenes and templates, The spec)",
}


def _check_counts(obj: dict, source: str) -> None:
    """Refuse oversized lists before the schema and the geometry see them."""
    sizes = {k: len(v) for k, v in obj.items() if isinstance(v, list)}
    limits = {**_COUNT_LIMITS, "furniture": MAX_OBJECTS, "instruments": MAX_OBJECTS, "dressing": MAX_OBJECTS}
    for key, limit in limits.items():
        if sizes.get(key, 0) > limit:
            raise SceneSpecError(
                f"{sizes[key]} {key}, more than the limit of {limit}",
                source=source,
                field=key,
                fix="split the lab into several scenes",
            )
    n_objects = sizes.get("furniture", 0) + sizes.get("instruments", 0) + sizes.get("dressing", 0)
    if n_objects > MAX_OBJECTS:
        raise SceneSpecError(
            f"{n_objects} objects (furniture + instruments + dressing), more than the limit of {MAX_OBJECTS}",
            source=source,
            field="instruments",
            fix="split the lab into several scenes",
        )


def parse_spec(obj: dict, source: str = "<scene spec>") -> SceneSpec:
    """The spec of a JSON object: version, list sizes, then the schema (no layout rule: ``validate_spec``).
    Every problem raises ``SceneSpecError`` naming the field."""
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
    _check_counts(obj, source)
    try:
        return SceneSpec.model_validate(obj)
    except ValidationError as e:
        field, msg = describe_validation_error(e)
        fix = _LIMIT_FIXES.get(e.errors()[0]["type"])
        raise SceneSpecError(msg, source=source, field=field, fix=fix) from None


def load_spec(path: str | Path) -> SceneSpec:
    """Read a spec file: size, UTF-8 and nesting limits first, then ``parse_spec``."""
    path = Path(path)
    src = str(path)

    def refuse(message: str, fix: str) -> SceneSpecError:
        return SceneSpecError(message, source=src, field="file", fix=fix)

    try:
        with path.open("rb") as f:
            raw = f.read(MAX_FILE_BYTES + 1)
    except OSError as e:
        raise SceneSpecError(f"cannot read the scene spec ({e.strerror})", source=src) from None
    if len(raw) > MAX_FILE_BYTES:
        raise refuse(
            f"larger than the limit of {MAX_FILE_BYTES // 2**20} MiB", "is this a scene spec? regenerate it"
        )
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise refuse(
            f"not UTF-8 text (byte 0x{raw[e.start]:02x} at offset {e.start})", "save the spec as UTF-8 JSON"
        ) from None
    depth = json_depth(raw)
    if depth > MAX_JSON_DEPTH:
        raise refuse(
            f"JSON nested {depth} levels deep, more than the limit of {MAX_JSON_DEPTH}",
            "a scene spec nests a few levels; regenerate it",
        )
    try:
        obj = json.loads(text)
    except RecursionError:  # unreachable after the depth check; kept so no input gives a traceback
        raise refuse("JSON nested too deeply", "regenerate the spec") from None
    except ValueError as e:  # JSONDecodeError, or an integer literal with too many digits
        where = f" at line {e.lineno} column {e.colno}" if isinstance(e, json.JSONDecodeError) else ""
        msg = e.msg if isinstance(e, json.JSONDecodeError) else str(e)
        raise refuse(f"not valid JSON{where}: {msg}", "fix the JSON syntax, or regenerate the spec") from None
    return parse_spec(obj, src)
