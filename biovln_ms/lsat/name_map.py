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

from pathlib import Path

from biovln_ms.catalog import load_catalog
from biovln_ms.errors import BioVLNError
from biovln_ms.lsat.names import NameMap, NameMapHit, match_category

_FIX_FORMAT = "write one 'node name: category' line per entry (category null: not an instrument)"


class NameMapError(BioVLNError):
    """A name map file that cannot be used."""


def _category(value: object, key: str, source: str) -> str | None:
    """A map value checked against the catalog; an unknown one is refused with the closest category."""
    cat = load_catalog()
    if value is None or (isinstance(value, str) and value in cat):
        return value
    guess = match_category(value).category if isinstance(value, str) else None
    hint = f"did you mean '{guess}'? " if guess else ""
    raise NameMapError(
        f"{value!r} is not a catalog category",
        source=source,
        field=key,
        fix=f"{hint}use one of {', '.join(cat.names())}, or null",
    )


def parse_name_map(obj: object, source: str) -> NameMap:
    """A name map from parsed YAML/JSON, validated: a mapping of text keys to categories or null."""
    if not isinstance(obj, dict) or not obj:
        raise NameMapError("a name map must be a non-empty mapping", source=source, fix=_FIX_FORMAT)
    entries = []
    for key, value in obj.items():
        if not isinstance(key, str) or not key.strip():
            raise NameMapError(
                "a node name must be non-empty text", source=source, field=str(key), fix="quote the name"
            )
        entries.append(NameMapHit(key.casefold(), _category(value, key, source)))
    return NameMap(source, tuple(entries))


def load_name_map(path: str | Path) -> NameMap:
    """Read and validate a name map file (YAML or JSON)."""
    import yaml

    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise NameMapError(
            f"cannot read the name map ({getattr(e, 'strerror', None) or e})",
            source=str(path),
            fix="pass an existing YAML or JSON file",
        ) from None
    try:
        obj = yaml.safe_load(text)  # plain data only
    except yaml.YAMLError as e:
        raise NameMapError(
            f"not valid YAML/JSON ({str(e).splitlines()[0]})", source=str(path), fix=_FIX_FORMAT
        ) from None
    return parse_name_map(obj, str(path))
