"""Node names -> catalog categories (paper §3.4): normalisation and fuzzy matching.

A name is normalised by lower-casing, turning separators (space, '-', '.') into '_', and dropping
Blender's duplicate suffix (``.001``) and trailing indices (``_2``). It then matches a category when
the Levenshtein distance (rapidfuzz) to the category name, or to its display name normalised the same
way, is at most 2. Several categories within the distance with no single closest one is ambiguous:
reported, never guessed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from rapidfuzz.distance import Levenshtein

from biovln_ms.catalog import load_catalog

MAX_DISTANCE = 2
TARGET_PREFIX = "target_"


def normalise(name: str) -> str:
    s = name.strip().lower()
    s = re.sub(r"\.\d+$", "", s)  # Blender duplicates: "centrifuge.001"
    s = re.sub(r"[\s\-.]+", "_", s)
    s = re.sub(r"(_\d+)+$", "", s)  # trailing indices: "refrigerator_2"
    return s.strip("_")


@dataclass(frozen=True)
class Match:
    name: str
    key: str  # the normalised name that was matched
    category: str | None
    distance: int | None
    candidates: tuple[str, ...] = ()  # for ambiguous names: the tied categories

    @property
    def ambiguous(self) -> bool:
        return self.category is None and len(self.candidates) > 1


def _aliases() -> dict[str, str]:
    cat = load_catalog()
    out = {}
    for name in cat.names():
        out[name] = name
        out[normalise(cat.get(name).display_name)] = name
    return out


def match_category(name: str, strip_prefix: str | None = None) -> Match:
    """The catalog category a node name denotes (fuzzy, distance <= 2), or why none."""
    key = normalise(name)
    if strip_prefix and key.startswith(strip_prefix):
        key = key[len(strip_prefix) :]
    best: dict[str, int] = {}
    for alias, category in _aliases().items():
        d = Levenshtein.distance(key, alias, score_cutoff=MAX_DISTANCE)
        if d <= MAX_DISTANCE:
            best[category] = min(d, best.get(category, d))
    if not best:
        return Match(name, key, None, None)
    top = min(best.values())
    tied = tuple(sorted(c for c, d in best.items() if d == top))
    if len(tied) > 1:
        return Match(name, key, None, top, tied)
    return Match(name, key, tied[0], top)


def is_target_marker(name: str) -> bool:
    return normalise(name).startswith(TARGET_PREFIX)
