"""The protocol library: lab workflows as ordered visits to the catalog's goal instruments.

A protocol is one JSON file (``biovln_ms/protocols/data/<id>.json``)::

    {"id": "sample_thaw_aliquot", "name": "...", "description": "...",
     "steps": [{"category": "refrigerator", "purpose": "..."},
               {"any_order": [{"category": "pipette", "purpose": "..."},
                              {"category": "cabinet", "purpose": "..."}]},
               {"category": "biosafety_cabinet", "purpose": "..."}]}

``steps`` run in the order given. A step is either one visit (``category`` + ``purpose``) or an
``any_order`` group of two or more visits to different categories, done in any order before the next
step. The number of visits K (group members counted one by one) is 2 to 5. Every category must be a goal
category of the catalog. Users add protocols with the same schema from their own folders
(``load_protocols(extra_dirs=...)`` or the ``BIOVLN_PROTOCOL_PATH`` environment variable); every
malformed file is refused with one line naming the file, the field and the fix, and so is a file over the
limits of :mod:`biovln_ms.limits` (1 MiB, nested 64 levels, 1,000 files in all; a FIFO or a folder named
``*.json`` is not read).
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator
from rapidfuzz import process as fuzz_process

from biovln_ms.catalog import load_catalog
from biovln_ms.constants import MAX_VISITS, MIN_VISITS
from biovln_ms.errors import BioVLNError, describe_validation_error
from biovln_ms.io_utils import parse_json, read_regular_file
from biovln_ms.limits import MAX_DESCRIPTION_LENGTH, MAX_ID_LENGTH, MAX_PROTOCOL_FILES, MAX_SMALL_FILE_BYTES

PROTOCOL_DIR = Path(__file__).resolve().parent / "data"
ENV_VAR = "BIOVLN_PROTOCOL_PATH"
MAX_LINE = 160
SCHEMA_DOC = "docs/guides/protocols.md"
_FIX = " FIX: "  # validators append the fix to their message after this marker


class ProtocolError(BioVLNError):
    """A malformed protocol file, a clash between protocols, or an unknown protocol id."""


def _goal_categories() -> list[str]:

    return load_catalog().goal_categories()


def _one_line(value: str, what: str) -> str:
    value = value.strip()
    if not value:
        raise ValueError(f"{what} is empty{_FIX}write one line of text")
    if "\n" in value or "\r" in value:
        raise ValueError(f"{what} spans several lines{_FIX}write it on one line")
    if len(value) > MAX_LINE:
        raise ValueError(f"{what} is {len(value)} characters{_FIX}shorten it to at most {MAX_LINE}")
    return value


def _goal_category(v: str) -> str:
    goals = _goal_categories()
    if v in goals:
        return v
    guess = fuzz_process.extractOne(v, goals)
    hint = f"; did you mean '{guess[0]}'?" if guess and guess[1] >= 70 else ""
    raise ValueError(
        f"unknown category '{v}'{hint}{_FIX}use a goal category of the catalog: {', '.join(goals)}"
    )


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Visit(_Strict):
    """One instrument visit: a catalog goal category and why the worker goes there."""

    category: str = Field(max_length=MAX_ID_LENGTH)
    purpose: str = Field(description="one line, as a lab worker would say it")

    @field_validator("category")
    @classmethod
    def _known(cls, v: str) -> str:
        return _goal_category(v)

    @field_validator("purpose")
    @classmethod
    def _line(cls, v: str) -> str:
        return _one_line(v, "the purpose")


class Step(_Strict):
    """One entry of ``steps``: a single visit (``category`` + ``purpose``) or an ``any_order`` group."""

    category: str | None = Field(default=None, max_length=MAX_ID_LENGTH)
    purpose: str | None = None
    any_order: tuple[Visit, ...] | None = None

    @field_validator("category")
    @classmethod
    def _known(cls, v: str | None) -> str | None:
        return None if v is None else _goal_category(v)

    @field_validator("purpose")
    @classmethod
    def _line(cls, v: str | None) -> str | None:
        return None if v is None else _one_line(v, "the purpose")

    @model_validator(mode="after")
    def _check(self) -> Step:
        if self.any_order is None:
            for key in ("category", "purpose"):
                if getattr(self, key) is None:
                    raise ValueError(
                        f"{key}: missing{_FIX}give both category and purpose, or an any_order list of visits"
                    )
            return self
        extra = [k for k in ("category", "purpose") if getattr(self, k) is not None]
        if extra:
            raise ValueError(
                f"any_order: a group cannot also have {' or '.join(extra)}"
                f"{_FIX}put each visit's category and purpose inside the group"
            )
        if len(self.any_order) < 2:
            raise ValueError(
                f"any_order: a group needs at least 2 visits{_FIX}write a single visit as an ordered step"
            )
        cats = [v.category for v in self.any_order]
        dup = next((c for c in cats if cats.count(c) > 1), None)
        if dup is not None:
            raise ValueError(
                f"any_order: '{dup}' appears twice in one group{_FIX}merge those visits into one"
            )
        return self

    @property
    def visits(self) -> tuple[Visit, ...]:
        if self.any_order is not None:
            return self.any_order
        return (Visit(category=self.category, purpose=self.purpose),)


class Protocol(_Strict):
    """A lab workflow: ordered steps, each a visit or an any-order group of visits."""

    id: str = Field(pattern=r"^[a-z][a-z0-9_]*$", max_length=MAX_ID_LENGTH)
    name: str
    description: str = Field(
        max_length=MAX_DESCRIPTION_LENGTH,
        description="why the workflow visits these instruments, in this order",
    )
    steps: tuple[Step, ...]

    @field_validator("name")
    @classmethod
    def _name_line(cls, v: str) -> str:
        return _one_line(v, "the name")

    @field_validator("description")
    @classmethod
    def _description(cls, v: str) -> str:
        if not v.strip():
            raise ValueError(f"the description is empty{_FIX}say in a sentence or two why these instruments")
        return v.strip()

    @field_validator("steps")
    @classmethod
    def _count(cls, v: tuple[Step, ...]) -> tuple[Step, ...]:
        k = sum(len(s.visits) for s in v)
        if not v:
            raise ValueError(f"no steps{_FIX}list {MIN_VISITS} to {MAX_VISITS} instrument visits")
        if not MIN_VISITS <= k <= MAX_VISITS:
            what = f"{k} visit{'' if k == 1 else 's'} (K = {k})"
            todo = "add visits" if k < MIN_VISITS else "split it into two protocols"
            raise ValueError(f"{what}{_FIX}a protocol has {MIN_VISITS} to {MAX_VISITS} visits: {todo}")
        return v

    @model_validator(mode="after")
    def _no_repeat(self) -> Protocol:
        for order in self._category_orders():
            for i, (a, b) in enumerate(itertools.pairwise(order)):
                if a == b:
                    raise ValueError(
                        f"steps: an admissible order visits '{a}' twice in a row (visits {i + 1} and {i + 2})"
                        f"{_FIX}merge those visits, or put another instrument between them"
                    )
        return self

    # --- queries ---------------------------------------------------------------------------------
    @property
    def k(self) -> int:
        """The number of visits (goals of an episode)."""
        return sum(len(s.visits) for s in self.steps)

    def visits(self) -> tuple[Visit, ...]:
        """Every visit in file order (an any-order group's members in the order written)."""
        return tuple(v for s in self.steps for v in s.visits)

    def categories(self) -> tuple[str, ...]:
        """The distinct categories the protocol visits, in file order: what a scene must contain."""
        return tuple(dict.fromkeys(v.category for v in self.visits()))

    def orders(self) -> list[tuple[Visit, ...]]:
        """Every admissible visit order, deterministic (groups permuted in the order written)."""
        per_step = [list(itertools.permutations(s.visits)) for s in self.steps]
        return [tuple(v for part in combo for v in part) for combo in itertools.product(*per_step)]

    def _category_orders(self) -> list[tuple[str, ...]]:
        return [tuple(v.category for v in order) for order in self.orders()]

    def admits(self, sequence: Sequence[str | Visit]) -> bool:
        """Whether visiting ``sequence`` (categories, or :class:`Visit` objects) in that order follows
        the protocol: every step's visits, a group's in any order, each step done before the next."""
        cats = [getattr(x, "category", x) for x in sequence]
        if len(cats) != self.k:
            return False
        i = 0
        for step in self.steps:
            want = sorted(v.category for v in step.visits)
            got = sorted(cats[i : i + len(want)])
            if got != want:
                return False
            i += len(want)
        return True

    def sample_order(self, rng) -> tuple[Visit, ...]:
        """One admissible order, drawn with ``rng`` (a ``numpy.random.Generator``): each any-order
        group shuffled, the steps kept in order."""
        out: list[Visit] = []
        for step in self.steps:
            vs = step.visits
            out.extend(vs[int(j)] for j in rng.permutation(len(vs)))
        return tuple(out)


class ProtocolLibrary:
    """The loaded protocols by id, in id order, with the file each came from."""

    def __init__(self, protocols: Iterable[tuple[Protocol, Path]]) -> None:
        items = sorted(protocols, key=lambda ps: ps[0].id)
        self._by_id = {p.id: p for p, _ in items}
        self._source = {p.id: src for p, src in items}

    def ids(self) -> list[str]:
        return list(self._by_id)

    def __iter__(self) -> Iterator[Protocol]:
        return iter(self._by_id.values())

    def __len__(self) -> int:
        return len(self._by_id)

    def __contains__(self, pid: object) -> bool:
        return pid in self._by_id

    def get(self, pid: str) -> Protocol:
        """The protocol ``pid``; an unknown id raises :class:`ProtocolError` with a suggestion."""
        if pid in self._by_id:
            return self._by_id[pid]
        guess = fuzz_process.extractOne(str(pid), self.ids()) if self._by_id else None
        hint = f"; did you mean '{guess[0]}'?" if guess and guess[1] >= 70 else ""
        raise ProtocolError(
            f"unknown protocol '{pid}'{hint}", field="protocol", fix=f"use one of: {', '.join(self.ids())}"
        )

    __getitem__ = get

    def source(self, pid: str) -> Path:
        """The JSON file protocol ``pid`` was read from."""
        self.get(pid)
        return self._source[pid]

    def categories(self) -> list[str]:
        """Every category some protocol visits, sorted."""
        return sorted({c for p in self for c in p.categories()})


# --- loading -------------------------------------------------------------------------------------
def _fix_for(err: ValidationError, field: str) -> str:
    first = err.errors()[0]
    kind = first["type"]
    last = field.rsplit(".", 1)[-1]
    if kind == "missing":
        return f"add '{last}'; the schema is in {SCHEMA_DOC}"
    if kind == "extra_forbidden":
        return f"remove '{last}' or correct its spelling; the schema is in {SCHEMA_DOC}"
    if kind == "string_pattern_mismatch":
        return "use lower-case letters, digits and underscores, starting with a letter"
    if kind in ("dict_type", "model_type") and field == "<root>":
        return "a protocol file holds one JSON object with id, name, description and steps"
    return f"see the protocol schema in {SCHEMA_DOC}"


def parse_protocol(obj: object, source: str = "<dict>") -> Protocol:
    """Validate one protocol (the parsed JSON object); errors are one-line :class:`ProtocolError`."""
    try:
        return Protocol.model_validate(obj)
    except ValidationError as e:
        field, msg = describe_validation_error(e)
        msg, _, fix = msg.partition(_FIX)
        raise ProtocolError(msg, source=source, field=field, fix=fix or _fix_for(e, field)) from None


def load_protocol_file(path: str | Path) -> Protocol:
    """Read and validate one protocol JSON file: a regular file of at most 1 MiB, UTF-8, nested at most 64
    levels (:mod:`biovln_ms.io_utils`), then the schema."""
    path = Path(path)
    raw = read_regular_file(
        path, MAX_SMALL_FILE_BYTES, "protocol", error=ProtocolError, fix="check the path and its permissions"
    )
    obj = parse_json(
        raw, str(path), "protocol", error=ProtocolError, fix="write the protocol as one JSON object"
    )
    return parse_protocol(obj, str(path))


def _env_dirs() -> list[Path]:
    return [Path(p) for p in os.environ.get(ENV_VAR, "").split(os.pathsep) if p]


def load_protocols(extra_dirs: Iterable[str | Path] = (), *, env: bool = True) -> ProtocolLibrary:
    """The shipped protocols plus every ``*.json`` in ``extra_dirs`` (and, with ``env``, the folders in
    ``BIOVLN_PROTOCOL_PATH``), ordered by id. A file that does not validate, a missing folder, or an id
    defined twice raises a one-line :class:`ProtocolError`."""
    folders = [PROTOCOL_DIR, *(Path(d) for d in extra_dirs), *(_env_dirs() if env else [])]
    seen: dict[str, Path] = {}
    read: set[Path] = set()  # resolved paths of the files read
    loaded: list[tuple[Protocol, Path]] = []
    count = 0
    for folder in folders:
        if not folder.is_dir():
            raise ProtocolError(
                "no such folder of protocols",
                source=str(folder),
                fix="give an existing folder of *.json files",
            )
        paths = []
        for path in folder.glob("*.json"):
            count += 1
            if count > MAX_PROTOCOL_FILES:
                raise ProtocolError(
                    f"more than {MAX_PROTOCOL_FILES:,} protocol files in the protocol folders",
                    source=str(folder),
                    fix="keep only the protocols in use in the folders given",
                )
            paths.append(path)
        for path in sorted(paths):
            real = path.resolve()
            if real in read:
                continue  # the same file named twice (a folder both passed and in the environment)
            read.add(real)
            protocol = load_protocol_file(path)
            if protocol.id in seen:
                raise ProtocolError(
                    f"id '{protocol.id}' is already defined by {seen[protocol.id]}",
                    source=str(path),
                    field="id",
                    fix="give this protocol another id",
                )
            seen[protocol.id] = path
            loaded.append((protocol, path))
    return ProtocolLibrary(loaded)
