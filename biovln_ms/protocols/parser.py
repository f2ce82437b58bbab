"""The rule-based reader of protocol instructions: the grammar of :mod:`biovln_ms.protocols.instructions`
read in reverse, into the ordered targets an agent must visit.

An instruction is a sequence of clauses, each opened by a movement verb at a clause start (the text's
start, or after ``,`` ``;`` ``.`` and sequence words such as "then", "next", "after that", "finally",
"lastly", "please", "okay", "for this run"), then ``the`` and an instrument's name, then optionally one
relation phrase, then optionally a purpose (after "to" or "and"), which is never read for targets:

* names: a category as said aloud ("biosafety cabinet"), its catalog display name without the bracketed
  part ("storage cabinet", "co2 incubator") or a catalog synonym ("fridge", "bsc"); the longest name wins;
* relations (:data:`~biovln_ms.protocols.instructions.RELATION_ORDER`): ``in room B`` / ``in the hall``,
  ``on the <support> [in <room> | farthest <dir>]``, ``by the <dir> wall``, ``nearest the door``,
  ``to the <left|right> of the <name>``, ``farthest <dir>``.

Each target is a :class:`ParsedTarget`: the category and a structured :class:`Relation` whose ``text`` is
the grammar's own wording ("in room B"), so the parse of a generated instruction equals its
``Instruction.targets`` exactly. Case and spacing do not matter: the text is read through the vocabulary's
tokenizer, so the ``instruction`` token sensor decoded back to words parses the same. Anything the grammar
cannot read raises :class:`InstructionParseError`, one line naming the words and the fix.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

from biovln_ms.catalog import load_catalog
from biovln_ms.errors import CatalogError
from biovln_ms.protocols.instructions import COMPASS, VERBS, spoken
from biovln_ms.protocols.library import ProtocolError
from biovln_ms.protocols.vocabulary import tokenize

#: movement verbs of the grammar, and a few more a person may write
EXTRA_VERBS = ("walk to", "move to", "proceed to", "navigate to", "return to", "go over to", "approach")
#: words that may stand between a clause boundary and its verb
SEQUENCE_WORDS = frozenset(
    "then next after that finally lastly and first now please okay for this run also".split()
)
BOUNDARIES = frozenset(",;.:")
#: what may follow a target's name or relation: a purpose link, or the clause's end
LINKS = frozenset({"to", "and"}) | BOUNDARIES
SIDES = ("left", "right")
_ROOM_TAG = re.compile(r"[a-z0-9]+")
_FIX = (
    "write each visit as '<verb> the <instrument> [relation]', e.g. 'go to the centrifuge in room B', with a "
    "relation among: in room X, on the <bench>, by the <north|south|east|west> wall, nearest the door, "
    "to the <left|right> of the <instrument>, farthest <direction>"
)


class InstructionParseError(ProtocolError):
    """An instruction, or a relation phrase, the grammar cannot read."""


@dataclass(frozen=True)
class Relation:
    """A spatial relation singling out one object of a category (see the module docstring).

    ``kind`` is one of ``room``, ``support``, ``wall``, ``door``, ``side``, ``extreme``; ``direction`` a
    compass word (wall, extreme) or left / right (side); ``room`` a spoken room ("room B", "the hall");
    ``category`` the reference instrument (side) or the support's category (support), and ``support``
    how that support is singled out (a room or extreme relation, or None when it is unique)."""

    kind: str
    direction: str | None = None
    room: str | None = None
    category: str | None = None
    support: Relation | None = None

    @property
    def text(self) -> str:
        """The grammar's wording of the relation."""
        if self.kind == "room":
            return f"in {self.room}"
        if self.kind == "support":
            return f"on the {spoken(self.category)}" + (f" {self.support.text}" if self.support else "")
        if self.kind == "wall":
            return f"by the {self.direction} wall"
        if self.kind == "door":
            return "nearest the door"
        if self.kind == "side":
            return f"to the {self.direction} of the {spoken(self.category)}"
        return f"farthest {self.direction}"

    @property
    def room_ordinal(self) -> int | None:
        """A numbered or lettered room's place in the lab's order (``room A``, ``room 1``: 0), else None."""
        if self.kind != "room" or not self.room.startswith("room "):
            return None
        tag = self.room[5:]
        if tag.isdigit():
            return int(tag) - 1
        if len(tag) == 1 and tag.isalpha():
            return ord(tag.upper()) - ord("A")
        return None


@dataclass(frozen=True)
class ParsedTarget:
    """One visit of an instruction: the category and how the meant object is singled out (None: the
    category occurs once)."""

    category: str
    relation: Relation | None = None

    @property
    def relation_text(self) -> str | None:
        return None if self.relation is None else self.relation.text

    def pair(self) -> tuple[str, str | None]:
        """(category, relation text), as ``Instruction.targets`` holds them."""
        return self.category, self.relation_text


@cache
def lexicon(categories: tuple[str, ...] | None = None) -> dict[tuple[str, ...], str]:
    """Token sequence of a name -> category: each category as said aloud, then its catalog display name
    (without a bracketed part) and synonyms; a display name or synonym two categories share is left out.
    ``categories``: the category vocabulary (default: the catalog's goal categories)."""

    catalog = load_catalog()
    cats = tuple(catalog.goal_categories()) if categories is None else categories
    names = {tuple(tokenize(spoken(c))): c for c in cats}
    extra: dict[tuple[str, ...], set[str]] = {}
    for c in cats:
        try:
            asset = catalog.get(c)
        except CatalogError:  # a category the catalog lacks (a vocabulary of the caller's): its spoken name
            continue
        display = re.sub(r"\(.*?\)", "", asset.display_name)
        for name in (display, *asset.synonyms):
            toks = tuple(tokenize(name))
            if toks and toks not in names:
                extra.setdefault(toks, set()).add(c)
    names.update({k: next(iter(v)) for k, v in extra.items() if len(v) == 1})
    return names


class _Reader:
    """A cursor over an instruction's tokens."""

    def __init__(self, tokens: list[str], names: dict[tuple[str, ...], str]) -> None:
        self.t, self.names = tokens, names
        self.longest = max((len(k) for k in names), default=1)

    def at(self, i: int, *words: str) -> bool:
        return tuple(self.t[i : i + len(words)]) == words

    def name(self, i: int) -> tuple[str, int] | None:
        """The category named at ``i`` (longest name first) and the index after it."""
        for n in range(min(self.longest, len(self.t) - i), 0, -1):
            cat = self.names.get(tuple(self.t[i : i + n]))
            if cat is not None:
                return cat, i + n
        return None

    def ends(self, i: int) -> bool:
        """The clause's target part ends at ``i``: a purpose link, a boundary or the text's end."""
        return i >= len(self.t) or self.t[i] in LINKS

    def room(self, i: int) -> tuple[str, int] | None:
        """``room <tag>`` or ``the <words>`` (up to a link) at ``i``: the spoken room and the index after."""
        if self.at(i, "room") and i + 1 < len(self.t) and _ROOM_TAG.fullmatch(self.t[i + 1]):
            tag = self.t[i + 1]
            return f"room {tag.upper() if tag.isalpha() else tag}", i + 2
        if self.at(i, "the"):
            j = i + 1
            while j < len(self.t) and self.t[j] not in LINKS:
                j += 1
            if j > i + 1:
                return "the " + " ".join(self.t[i + 1 : j]), j
        return None

    def relation(self, i: int, nested: bool = False) -> tuple[Relation, int] | None:
        """The relation phrase at ``i`` and the index after it; ``nested``: a support's own (room or
        extreme only)."""
        t = self.t
        if self.at(i, "in"):
            got = self.room(i + 1)
            if got:
                return Relation("room", room=got[0]), got[1]
        if self.at(i, "farthest") and i + 1 < len(t) and t[i + 1] in COMPASS:
            return Relation("extreme", direction=t[i + 1]), i + 2
        if nested:
            return None
        if self.at(i, "on", "the"):
            got = self.name(i + 2)
            if got:
                inner = self.relation(got[1], nested=True)
                end = inner[1] if inner else got[1]
                return Relation("support", category=got[0], support=inner[0] if inner else None), end
        if self.at(i, "by", "the") and i + 3 < len(t) and t[i + 2] in COMPASS and t[i + 3] == "wall":
            return Relation("wall", direction=t[i + 2]), i + 4
        if self.at(i, "nearest", "the", "door"):
            return Relation("door"), i + 3
        if self.at(i, "to", "the") and i + 4 < len(t) and t[i + 2] in SIDES and t[i + 3] == "of":
            if t[i + 4] == "the":
                got = self.name(i + 5)
                if got:
                    return Relation("side", direction=t[i + 2], category=got[0]), got[1]
        return None


@cache
def _verbs() -> tuple[tuple[str, ...], ...]:
    return tuple(sorted({tuple(tokenize(v)) for v in (*VERBS, *EXTRA_VERBS)}, key=len, reverse=True))


def _clause_start(tokens: list[str], i: int) -> bool:
    """Whether a verb at ``i`` opens a clause: only sequence words lie between it and a boundary."""
    j = i - 1
    while j >= 0 and tokens[j] in SEQUENCE_WORDS:
        j -= 1
    return j < 0 or tokens[j] in BOUNDARIES


def parse_targets(text: str, categories: Sequence[str] | None = None) -> list[ParsedTarget]:
    """The ordered targets of an instruction (see the module docstring); ``categories``: the category
    vocabulary (default: the catalog's goal categories). Raises :class:`InstructionParseError`."""
    tokens = tokenize(text)
    r = _Reader(tokens, lexicon(None if categories is None else tuple(categories)))
    out: list[ParsedTarget] = []
    i = 0
    while i < len(tokens):
        verb = next((v for v in _verbs() if r.at(i, *v)), None)
        if verb is None or not _clause_start(tokens, i):
            i += 1
            continue
        j = i + len(verb)
        if not r.at(j, "the"):
            i = j
            continue
        got = r.name(j + 1)
        if got is None:
            raise InstructionParseError(
                f"'{' '.join(tokens[i : j + 4])} ...' names no instrument the catalog knows",
                field="instruction",
                fix=_FIX,
            )
        category, k = got
        rel, found = None, r.relation(k)
        if found is not None and r.ends(found[1]):
            rel, k = found
        elif not r.ends(k):
            raise InstructionParseError(
                f"cannot read '{' '.join(tokens[k : k + 6])}' after 'the {spoken(category)}'",
                field="instruction",
                fix=_FIX,
            )
        out.append(ParsedTarget(category, rel))
        i = k
    if not out:
        raise InstructionParseError(
            "the instruction names no instrument to visit", field="instruction", fix=_FIX
        )
    return out


def parse_relation(text: str, categories: Sequence[str] | None = None) -> Relation:
    """One relation phrase ("by the north wall"), as the grammar writes it; raises
    :class:`InstructionParseError` for anything else."""
    tokens = tokenize(text)
    r = _Reader(tokens, lexicon(None if categories is None else tuple(categories)))
    found = r.relation(0) if tokens else None
    if found is None or found[1] != len(tokens):
        raise InstructionParseError(f"'{text}' is not a relation of the grammar", field="relation", fix=_FIX)
    return found[0]


__all__ = [
    "InstructionParseError",
    "ParsedTarget",
    "Relation",
    "lexicon",
    "parse_relation",
    "parse_targets",
]
