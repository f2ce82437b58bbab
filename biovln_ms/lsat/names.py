"""Node names -> catalog categories (paper §3.4), as designers really name them.

The first rule that decides wins:

1. the user's name map (``lsat import --names``, ``biovln_ms.lsat.name_map``);
2. words: the name's words (``catalog.name_tokens``: separators, camel case and digits split, numbers
   dropped) hold a category's name, display name or catalog synonym as consecutive words
   (``Refrigerator_large``, ``Fridge_02``, ``BSC-2``, ``Centrifuge 5424R``). A phrase inside a longer
   matching one does not count (``Biosafety Cabinet`` is no storage ``cabinet``); of two categories whose
   phrases are both in the name, the more specific wins: the one with a phrase holding all the other's
   matched words (``BSC cabinet``: a biosafety cabinet, whose name holds ``cabinet``); phrases of several
   categories otherwise are ambiguous; a part word after the phrase names a part, not an instrument
   (``cabinet_door``, ``Bin_Shelf``);
3. fuzzy: the normalised name (lower case, separators -> ``_``, Blender's ``.001`` and trailing ``_2``
   dropped) within Levenshtein distance 2 of a category's name or display name, for typos
   (``target_refrigerater``). Several categories at the same smallest distance are ambiguous.

Ambiguous names are reported, never guessed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from fnmatch import fnmatchcase
from typing import NamedTuple

from rapidfuzz.distance import Levenshtein

from biovln_ms.catalog import load_catalog, name_tokens

MAX_DISTANCE = 2
TARGET_PREFIX = "target_"
#: parts on an operational face: a child so named tells the importer which side the face is on
FACE_PART_WORDS = ("door", "handle", "display", "keypad", "panel", "sash", "screen", "control")
#: words that, after a category phrase, make a name a part's (``fridge door``), not an instrument's
PART_WORDS = frozenset(
    {*FACE_PART_WORDS, "controls", "lid", "drawer", "shelf", "hinge", "knob", "pedal", "leg"}
)


class NameMapHit(NamedTuple):
    key: str  # the map's key that named the node
    category: str | None  # None: not an instrument


@dataclass(frozen=True)
class NameMap:
    """A designer's name map (rule 1), as :mod:`biovln_ms.lsat.name_map` reads it from a file: node names
    or glob patterns -> catalog categories (None: not an instrument)."""

    source: str
    entries: tuple[NameMapHit, ...]  # keys case-folded, in file order

    def lookup(self, name: str) -> NameMapHit | None:
        """The entry naming ``name`` (exact keys before patterns), or None."""
        forms = {name.casefold(), re.sub(r"\.\d+$", "", name).casefold()}
        exact = next((e for e in self.entries if e.key in forms), None)
        return exact or next((e for e in self.entries if any(fnmatchcase(f, e.key) for f in forms)), None)


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
    how: str = ""  # "name map", "words", "fuzzy", "part" (a part's name: no category), "" (no match)
    set_aside: tuple[str, ...] = ()  # categories the name also holds, less specific than ``category``

    @property
    def ambiguous(self) -> bool:
        return self.category is None and len(self.candidates) > 1


def _fuzzy_aliases() -> dict[str, str]:
    cat = load_catalog()
    out = {}
    for name in cat.names():
        out[name] = name
        out[normalise(cat.get(name).display_name)] = name
    return out


def _by_words(name: str, key: str) -> Match | None:
    """The category whose phrase the name's words hold (rule 2), or None when no phrase matches."""
    words = name_tokens(name)
    spans = [
        (i, i + len(p), category)
        for p, category in load_catalog().phrases().items()
        for i in range(len(words) - len(p) + 1)
        if words[i : i + len(p)] == p
    ]
    kept = [
        s
        for s in spans
        if not any(o[0] <= s[0] and s[1] <= o[1] and o[1] - o[0] > s[1] - s[0] for o in spans)
    ]
    if not kept:
        return None
    found = {c for _, _, c in kept}
    general = _less_specific({c: [tuple(words[i:e]) for i, e, k in kept if k == c] for c in found})
    if general == found:  # each names the other more specifically: none wins
        general = set()
    categories = tuple(sorted(found - general))
    if len(categories) > 1:
        return Match(name, key, None, 0, categories, "words")
    if PART_WORDS.intersection(words[max(e for _, e, _ in kept) :]):
        return Match(name, key, None, None, (), "part")
    return Match(name, key, categories[0], 0, (), "words", tuple(sorted(general)))


def _holds(phrase: tuple[str, ...], part: tuple[str, ...]) -> bool:
    """Whether ``part`` is consecutive words of ``phrase``."""
    return any(phrase[i : i + len(part)] == part for i in range(len(phrase) - len(part) + 1))


def _less_specific(matched: dict[str, list[tuple[str, ...]]]) -> set[str]:
    """The categories of ``matched`` (category -> its phrases found in a name) that another one found
    there names more specifically: each of their found phrases lies inside one of its catalog phrases
    (``cabinet`` inside ``biosafety cabinet``)."""
    by_category: dict[str, list[tuple[str, ...]]] = {}
    for phrase, category in load_catalog().phrases().items():
        by_category.setdefault(category, []).append(phrase)
    return {
        c
        for c, found in matched.items()
        for d in matched
        if d != c and all(any(_holds(p, f) for p in by_category[d]) for f in found)
    }


def _by_distance(name: str, key: str) -> Match:
    """The category within Levenshtein distance 2 of the normalised name (rule 3)."""
    best: dict[str, int] = {}
    for alias, category in _fuzzy_aliases().items():
        d = Levenshtein.distance(key, alias, score_cutoff=MAX_DISTANCE)
        if d <= MAX_DISTANCE:
            best[category] = min(d, best.get(category, d))
    if not best:
        return Match(name, key, None, None)
    top = min(best.values())
    tied = tuple(sorted(c for c, d in best.items() if d == top))
    if len(tied) > 1:
        return Match(name, key, None, top, tied, "fuzzy")
    return Match(name, key, tied[0], top, (), "fuzzy")


def _strip_prefix(name: str, prefix: str) -> str:
    """``name`` without ``prefix`` (case and separator insensitive: ``Target Fridge`` -> ``Fridge``), as
    written otherwise."""
    return re.sub(rf"(?i)^\s*{re.escape(prefix.rstrip('_'))}[\s_\-.]*", "", name)


def match_category(name: str, strip_prefix: str | None = None, names: NameMap | None = None) -> Match:
    """The catalog category a node name denotes, or why none (see the module docstring);
    ``strip_prefix`` (a marker's ``target_``) is dropped first. A name the map sends to null comes back
    with no category and ``how == "name map"``."""
    raw = _strip_prefix(name, strip_prefix) if strip_prefix else name
    key = normalise(raw)
    if names is not None and (hit := names.lookup(raw)) is not None:
        return Match(name, key, hit.category, 0, (), "name map")
    return _by_words(raw, key) or _by_distance(name, key)


def is_target_marker(name: str) -> bool:
    return normalise(name).startswith(TARGET_PREFIX)
