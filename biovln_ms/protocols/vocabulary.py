"""The versioned token vocabulary of protocol instructions (``BioVLN-Protocol-v0``'s ``instruction`` sensor).

A vocabulary file (``biovln_ms/protocols/vocabulary_v<N>.json``) is one JSON object::

    {"version": 1,
     "tokenizer": "...",            the rule below, in words
     "max_tokens": 256,             the fixed length of an encoded instruction (padded with <pad>)
     "max_text_bytes": 1024,        the fixed length of the UTF-8 text sensor (padded with NUL bytes)
     "tokens": ["<pad>", "<unk>", ",", ".", ...]}   a token's id is its index

Tokenizer: the text lower-cased; a token is a run of ASCII letters and digits, or any single other
non-space character (``"Then, go to room B."`` -> ``then , go to room b .``). Ids 0 and 1 are ``<pad>`` and
``<unk>`` (a word the vocabulary lacks); the rest are sorted. :func:`build_vocabulary` makes the token list
deterministically from the instruction grammar (:mod:`biovln_ms.protocols.instructions`: openings, verbs,
connectives, relation words, compass words), the room names of the shipped scene templates, single letters
and digits (room tags), the catalog's names and the purposes of the shipped protocols. A shipped file is
never rewritten: when the grammar, templates or protocols change, the next version's file is written beside
it (``python -m biovln_ms.protocols.vocabulary``) and :data:`VOCABULARY_VERSION` moves to it.

The category part follows the catalog instead: the words of the catalog's names that a version's file lacks
(a new instrument's) get the ids after the file's last token, sorted (:func:`load_vocabulary`). A new
instrument so needs no new file, and the ids of a file's tokens never change.
"""

from __future__ import annotations

import json
import re
import string
from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import numpy as np

from biovln_ms.catalog import load_catalog
from biovln_ms.io_utils import atomic_write_text
from biovln_ms.protocols import instructions as g
from biovln_ms.protocols.instructions import spoken
from biovln_ms.protocols.library import ProtocolError, load_protocols
from biovln_ms.scene.templates import get_template, template_names

VOCABULARY_VERSION = 2  # 2: with the molecular-biology categories
VOCABULARY_DIR = Path(__file__).resolve().parent
PAD, UNK = "<pad>", "<unk>"
MAX_TOKENS = 256
MAX_TEXT_BYTES = 1024
TOKENIZER = (
    "lower-case the text; a token is a run of ASCII letters and digits, or one other non-space character"
)
_TOKEN = re.compile(r"[a-z0-9]+|[^\sa-z0-9]")
#: relation words of the grammar beyond its tables (instructions.relations)
_RELATION_WORDS = "in room the hall on by wall nearest door to left right of farthest"


class InstructionTooLongError(ProtocolError):
    """An instruction does not fit the vocabulary's fixed token or byte length."""


def tokenize(text: str) -> list[str]:
    """The tokens of ``text`` (see the module docstring)."""
    return _TOKEN.findall(text.lower())


def vocabulary_path(version: int = VOCABULARY_VERSION) -> Path:
    return VOCABULARY_DIR / f"vocabulary_v{version}.json"


@dataclass(frozen=True)
class Vocabulary:
    """Tokens by id, with the fixed encoded lengths of this version."""

    version: int
    tokens: tuple[str, ...]
    max_tokens: int = MAX_TOKENS
    max_text_bytes: int = MAX_TEXT_BYTES
    _ids: dict[str, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.tokens[:2] != (PAD, UNK) or len(set(self.tokens)) != len(self.tokens):
            raise ProtocolError(
                f"vocabulary v{self.version} must start with {PAD}, {UNK} and hold each token once",
                field="tokens",
                fix="rebuild it with build_vocabulary()",
            )
        object.__setattr__(self, "_ids", {t: i for i, t in enumerate(self.tokens)})

    def __len__(self) -> int:
        return len(self.tokens)

    def unknown(self, text: str) -> list[str]:
        """The tokens of ``text`` this vocabulary lacks (encoded as ``<unk>``)."""
        return [t for t in tokenize(text) if t not in self._ids]

    def encode(self, text: str) -> np.ndarray:
        """(max_tokens,) int32 token ids of ``text``, padded with 0 (``<pad>``); unknown tokens are 1."""
        ids = [self._ids.get(t, 1) for t in tokenize(text)]
        if len(ids) > self.max_tokens:
            raise InstructionTooLongError(
                f"the instruction has {len(ids)} tokens, more than the {self.max_tokens} of vocabulary "
                f"v{self.version}",
                field="instruction",
                fix="shorten the protocol's purposes",
            )
        out = np.zeros(self.max_tokens, np.int32)
        out[: len(ids)] = ids
        return out

    def decode(self, ids: Iterable[int]) -> str:
        """The tokens of ``ids`` joined by spaces, padding dropped (for logs and tests)."""
        return " ".join(self.tokens[int(i)] for i in ids if int(i) != 0)

    def encode_text(self, text: str) -> np.ndarray:
        """(max_text_bytes,) uint8: the UTF-8 bytes of ``text``, padded with NUL."""
        raw = text.encode("utf-8")
        if len(raw) > self.max_text_bytes:
            raise InstructionTooLongError(
                f"the instruction is {len(raw)} UTF-8 bytes, more than the {self.max_text_bytes} of "
                f"vocabulary v{self.version}",
                field="instruction",
                fix="shorten the protocol's purposes",
            )
        out = np.zeros(self.max_text_bytes, np.uint8)
        out[: len(raw)] = np.frombuffer(raw, np.uint8)
        return out

    def to_json(self) -> str:
        return (
            json.dumps(
                {
                    "version": self.version,
                    "tokenizer": TOKENIZER,
                    "max_tokens": self.max_tokens,
                    "max_text_bytes": self.max_text_bytes,
                    "tokens": list(self.tokens),
                },
                indent=1,
            )
            + "\n"
        )


def decode_text(data) -> str:
    """The instruction text of an ``instruction_text`` sensor row (UTF-8 bytes padded with NUL)."""
    raw = bytes(np.asarray(data, dtype=np.uint8).reshape(-1).tolist())
    return raw.rstrip(b"\x00").decode("utf-8")


def _grammar_words() -> set[str]:
    """The words of the grammar, the templates' room names and the shipped protocols' purposes."""

    texts = [*g.OPENINGS, *g.VERBS, *g.THEN, *g.FINALLY, *(p for p in g.PURPOSE_LINKS if p)]
    texts += [_RELATION_WORDS, *g.COMPASS, *string.ascii_lowercase, *string.digits]
    texts += [g.room_name(r.id) for name in template_names() for r in get_template(name).rooms]
    texts += [v.purpose for p in load_protocols(env=False) for v in p.visits()]
    return {t for text in texts for t in tokenize(text)}


def category_words(names: Iterable[str] | None = None) -> set[str]:
    """The words of category names as instructions say them (default: the catalog's names)."""

    return {
        t for name in (load_catalog().names() if names is None else names) for t in tokenize(spoken(name))
    }


def _grown(tokens: tuple[str, ...], words: set[str]) -> tuple[str, ...]:
    """``tokens`` followed by the ``words`` they lack, sorted (their ids follow the last token's)."""
    return (*tokens, *sorted(words.difference(tokens)))


def build_vocabulary(version: int = VOCABULARY_VERSION) -> Vocabulary:
    """The vocabulary the current grammar, templates, shipped protocols and catalog make: sorted, but for
    the catalog's words that ``version``'s shipped file lacks, which follow as :func:`load_vocabulary`
    appends them (a version not written yet holds every catalog word sorted in)."""
    cats = category_words()
    held = set(_shipped_vocabulary(version).tokens) if vocabulary_path(version).exists() else cats
    return Vocabulary(version, _grown((PAD, UNK, *sorted(_grammar_words() | (cats & held))), cats))


def load_vocabulary(version: int = VOCABULARY_VERSION) -> Vocabulary:
    """The shipped vocabulary file of ``version``, grown by the catalog's words the file lacks."""

    return _catalog_vocabulary(version, tuple(load_catalog().names()))


@cache
def _catalog_vocabulary(version: int, names: tuple[str, ...]) -> Vocabulary:
    shipped = _shipped_vocabulary(version)
    tokens = _grown(shipped.tokens, category_words(names))
    if tokens == shipped.tokens:
        return shipped
    return Vocabulary(shipped.version, tokens, shipped.max_tokens, shipped.max_text_bytes)


@cache
def _shipped_vocabulary(version: int) -> Vocabulary:
    path = vocabulary_path(version)
    try:
        obj = json.loads(path.read_text(encoding="utf-8"))
        return Vocabulary(int(obj["version"]), tuple(obj["tokens"]), obj["max_tokens"], obj["max_text_bytes"])
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ProtocolError(
            f"cannot read vocabulary v{version} ({type(e).__name__}: {e})",
            source=str(path),
            fix="reinstall biovln-ms; a new version is written with python -m biovln_ms.protocols.vocabulary",
        ) from None


def write_vocabulary(version: int = VOCABULARY_VERSION) -> Path:
    """Write :func:`build_vocabulary` as the file of ``version``; an existing file is never replaced."""
    path = vocabulary_path(version)
    if path.exists():
        raise ProtocolError(
            f"vocabulary v{version} is already shipped",
            source=str(path),
            fix=f"write the next version: python -m biovln_ms.protocols.vocabulary {version + 1}",
        )
    return atomic_write_text(path, build_vocabulary(version).to_json())


if __name__ == "__main__":
    import sys

    print(write_vocabulary(int(sys.argv[1]) if len(sys.argv) > 1 else VOCABULARY_VERSION))
