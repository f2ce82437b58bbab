"""Reading a scene spec: the file's limits (size, UTF-8, nesting), the counts, then the schema.

The types and their limits are :mod:`biovln_ms.scene.spec`'s. Loading gives a well-formed spec, not yet a
valid lab: its consistency with the catalog and the layout rules are
:func:`biovln_ms.scene.rules.validate_spec`'s, which every reader of a user's or a dataset's spec calls
next (the generator checks its own drafts' rules itself).
"""

from __future__ import annotations

from pathlib import Path

from pydantic import ValidationError

from biovln_ms.errors import describe_validation_error
from biovln_ms.io_utils import parse_json
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

    try:
        with path.open("rb") as f:
            raw = f.read(MAX_FILE_BYTES + 1)
    except OSError as e:
        raise SceneSpecError(f"cannot read the scene spec ({e.strerror})", source=src) from None
    if len(raw) > MAX_FILE_BYTES:
        raise SceneSpecError(
            f"larger than the limit of {MAX_FILE_BYTES // 2**20} MiB",
            source=src,
            field="file",
            fix="is this a scene spec? regenerate it",
        )
    obj = parse_json(
        raw,
        src,
        "the scene spec",
        error=SceneSpecError,
        field="file",
        fix="save the spec as UTF-8 JSON with valid syntax (a spec nests a few levels), or regenerate it",
        max_depth=MAX_JSON_DEPTH,
    )
    return parse_spec(obj, src)
