"""A designer's name map (``lsat import --names map.yaml``): node names -> catalog categories, winning
over the catalog's names and synonyms.

A YAML (or JSON) mapping; each key a node name or a glob pattern (``*``, ``?``, ``[...]``), compared
without regard to case; each value a catalog category, or null for "not an instrument" (the node and
its children are then left out, unreported)::

    Sterilgard III: biosafety_cabinet
    "Heracell*": incubator
    Bin_Shelf: null

A node name is looked up as written and without Blender's ``.001`` suffix: exact keys first, then the
patterns in file order. A marker (``target_Sterilgard III``) is looked up without its ``target_``.

This module reads and checks the file; the map itself (:class:`~biovln_ms.lsat.names.NameMap`) is rule 1
of the name matcher, so it lives with the matcher in :mod:`biovln_ms.lsat.names`, which suggests the
closest category for an unknown value here.
"""

from __future__ import annotations

import reprlib
from pathlib import Path

from biovln_ms.catalog import load_catalog
from biovln_ms.errors import BioVLNError
from biovln_ms.io_utils import parse_yaml, read_regular_file
from biovln_ms.limits import MAX_ID_LENGTH, MAX_NAME_LENGTH, MAX_NAME_MAP_ENTRIES, MAX_SMALL_FILE_BYTES
from biovln_ms.lsat.names import NameMap, NameMapHit, match_category

_SHORT = reprlib.Repr()  # a value in a message: a few items of two levels, whatever its size
_SHORT.maxlevel, _SHORT.maxlist, _SHORT.maxdict, _SHORT.maxstring = 2, 4, 4, 60
_FIX_FORMAT = "write one 'node name: category' line per entry (category null: not an instrument)"


class NameMapError(BioVLNError):
    """A name map file that cannot be used."""


def _category(value: object, key: str, source: str) -> str | None:
    """A map value checked against the catalog; an unknown one is refused with the closest category."""
    cat = load_catalog()
    if value is None or (isinstance(value, str) and value in cat):
        return value
    short = isinstance(value, str) and len(value) <= MAX_ID_LENGTH
    guess = match_category(value).category if short else None
    hint = f"did you mean '{guess}'? " if guess else ""
    raise NameMapError(
        f"{_SHORT.repr(value)} is not a catalog category",
        source=source,
        field=key,
        fix=f"{hint}use one of {', '.join(cat.names())}, or null",
    )


def parse_name_map(obj: object, source: str) -> NameMap:
    """A name map from parsed YAML/JSON, validated: a mapping of at most ``MAX_NAME_MAP_ENTRIES`` text keys
    (node names of at most ``MAX_NAME_LENGTH`` characters) to categories or null."""
    if not isinstance(obj, dict) or not obj:
        raise NameMapError("a name map must be a non-empty mapping", source=source, fix=_FIX_FORMAT)
    if len(obj) > MAX_NAME_MAP_ENTRIES:
        raise NameMapError(
            f"{len(obj):,} entries, more than the limit of {MAX_NAME_MAP_ENTRIES:,}",
            source=source,
            fix="map only the names the scene holds; a pattern ('Bench*') covers many",
        )
    entries = []
    for key, value in obj.items():
        if not isinstance(key, str) or not key.strip():
            raise NameMapError(
                "a node name must be non-empty text", source=source, field=str(key)[:80], fix="quote the name"
            )
        control = any(ord(c) < 32 or 127 <= ord(c) < 160 for c in key)
        if len(key) > MAX_NAME_LENGTH or control:
            raise NameMapError(
                "a node name with a control character"
                if control
                else f"a node name of {len(key):,} characters",
                source=source,
                field=ascii(key[:60]),
                fix=f"node names are one line of at most {MAX_NAME_LENGTH} characters",
            )
        entries.append(NameMapHit(key.casefold(), _category(value, key, source)))
    return NameMap(source, tuple(entries))


def load_name_map(path: str | Path) -> NameMap:
    """Read and validate a name map file (YAML or JSON): a regular file of at most 1 MiB, nested at most 64
    levels (:mod:`biovln_ms.io_utils`), plain data only."""
    path = Path(path)
    raw = read_regular_file(
        path, MAX_SMALL_FILE_BYTES, "name map", error=NameMapError, fix="pass an existing YAML or JSON file"
    )
    return parse_name_map(
        parse_yaml(raw, str(path), "name map", error=NameMapError, fix=_FIX_FORMAT), str(path)
    )
