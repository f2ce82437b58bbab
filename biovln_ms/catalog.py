"""The instrument catalog: one source of truth for every asset's numbers (paper Table 2).

The data lives in ``assets/catalog.json``; this module validates it and gives typed access.
"""

from __future__ import annotations

import colorsys
import hashlib
import json
import os
import re
from functools import lru_cache
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    field_validator,
    model_validator,
)
from rapidfuzz import process as fuzz_process

from biovln_ms.errors import CatalogError, describe_validation_error
from biovln_ms.paths import CATALOG_PATH

#: Environment variable naming a catalog file to use instead of the packaged one (a catalog grown by an
#: instrument of one's own; ``load_catalog()`` reads it when called without a path).
CATALOG_ENV = "BIOVLN_CATALOG"
OVERLAY_ENV = "BIOVLN_CATALOG_OVERLAY"
Face = Literal["+X", "-X", "+Y", "-Y"]
Placement = Literal["wall", "table_top", "floor", "furniture"]
Mount = Literal["wall", "table_top", "floor"]

#: Model-space unit vectors of the four operational-face labels.
FACE_VECTORS: dict[str, tuple[float, float]] = {
    "+X": (1.0, 0.0),
    "-X": (-1.0, 0.0),
    "+Y": (0.0, 1.0),
    "-Y": (0.0, -1.0),
}
#: The paper's ten goal categories, in catalog order: first in ``Catalog.goal_categories()`` and so at
#: indices 0-9 of the ``objectgoal`` one-hot and the semantic sensor; the other goal categories
#: follow them, so the one-hot only grows at its end (a policy trained on a shorter one-hot is refused with
#: a one-line error, never fed a shifted one).
PAPER_GOAL_CATEGORIES = (
    "refrigerator",
    "incubator",
    "centrifuge",
    "mini_centrifuge",
    "pipette",
    "cabinet",
    "waste_bin",
    "biosafety_cabinet",
    "lab_bench",
    "lab_table",
)
#: Tolerance between a printed d_half and half the printed dimension along the face axis
#: (the paper's d_half values come from Blender vertex analysis and differ by up to 7 mm).
D_HALF_TOLERANCE = 0.01
_WORD_BREAKS = re.compile(r"(?<=[a-z])(?=[A-Z])|(?<=[A-Z])(?=[A-Z][a-z])|(?<=\D)(?=\d)|(?<=\d)(?=\D)")


def name_tokens(text: str) -> tuple[str, ...]:
    """The lower-cased words of a name: split at separators, camel case and digits, numbers dropped
    (``WasteBin.003`` -> waste, bin; ``Centrifuge 5424R`` -> centrifuge, r; ``CO2 Incubator`` -> co,
    incubator)."""
    words = (w for chunk in re.findall(r"[^\W_]+", text) for w in _WORD_BREAKS.split(chunk))
    return tuple(w.lower() for w in words if w and not w.isdigit())


def derived_map_color(name: str) -> str:
    """A colour for ``name`` on top-down maps when its catalog entry gives none: a hue from the name's
    SHA-256 at fixed saturation and value, so it is the same on every machine and run."""
    hue = int.from_bytes(hashlib.sha256(name.encode()).digest()[:2], "big") / 65536
    return "#" + "".join(f"{round(c * 255):02x}" for c in colorsys.hsv_to_rgb(hue, 0.65, 0.8))


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class InteractionPoint(_Strict):
    """Where a manipulator acts on a goal category: a point in the asset's model space
    (metres, origin at the bbox centre, as ``dimensions``), inside its bounds on its operational face's
    side."""

    label: str = Field(min_length=1)  # what is there: "door handle", "sash opening"
    point: tuple[float, float, float]
    rationale: str = Field(min_length=1)  # one line: why this point


class AssetSpec(_Strict):
    """One catalog asset: dimensions in model space (x, y, z metres), origin at the bbox centre."""

    name: str = Field(pattern=r"^[a-z][a-z0-9_]*$")
    display_name: str
    dimensions: tuple[float, float, float]
    placement: Placement
    face: Face | None
    d_half: float | None = Field(default=None, gt=0)
    approach_distance: float | None = Field(default=None, ge=0.5, le=0.9)
    success_radius: float | None = Field(default=None, ge=0.8, le=1.3)
    goal_category: bool = False
    collision: Literal["box", "coacd"] = "box"
    support_height: float | None = Field(default=None, gt=0)
    synonyms: tuple[str, ...] = ()  # other names designers give it: lower-case words, no digits
    rationale: str = ""
    interaction: InteractionPoint | None = None  # goal categories: where a manipulator acts on it
    mount: Mount | None = None  # lab dressing only: how the generator places it (its front is model -Y)
    mount_height: float = Field(
        default=0.0, ge=0.0, le=3.0
    )  # lab dressing on a wall: its bottom above the floor
    map_color: str | None = Field(default=None, pattern=r"^#[0-9a-f]{6}$")  # top-down maps; None: derived
    _zone2_clearance: float | None = PrivateAttr(default=None)  # set by the CatalogFile holding the asset

    @field_validator("dimensions")
    @classmethod
    def _positive(cls, v: tuple[float, float, float]) -> tuple[float, float, float]:
        if not all(np.isfinite(x) and x > 0 for x in v):
            raise ValueError("every dimension must be a positive finite number of metres")
        return v

    @field_validator("synonyms")
    @classmethod
    def _words(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        for syn in v:
            if not re.fullmatch(r"[a-z]+( [a-z]+)*", syn):
                raise ValueError(f"'{syn}' must be lower-case words separated by single spaces, no digits")
        return v

    @property
    def phrases(self) -> set[tuple[str, ...]]:
        """The word sequences that name this asset: its name, display name and synonyms."""
        return {p for p in map(name_tokens, (self.name, self.display_name, *self.synonyms)) if p}

    @model_validator(mode="after")
    def _consistent(self) -> AssetSpec:
        if self.face is None:
            if self.placement != "furniture":
                raise ValueError(
                    f"face: only furniture may have no operational face (placement={self.placement})"
                )
            if self.goal_category:
                raise ValueError("goal_category: an asset without an operational face cannot be a goal")
            if self.interaction is not None:
                raise ValueError("interaction: an asset without an operational face has no interaction point")
            return self
        for key in ("d_half", "approach_distance", "success_radius"):
            if getattr(self, key) is None:
                raise ValueError(f"{key}: required for an asset with an operational face")
        axis = 0 if self.face[1] == "X" else 1
        half = self.dimensions[axis] / 2.0
        if abs(self.d_half - half) > D_HALF_TOLERANCE:
            raise ValueError(
                f"d_half: {self.d_half} is not half the {self.face[1]} dimension ({half:.3f}) within "
                f"{D_HALF_TOLERANCE} m"
            )
        if self.interaction is not None:
            p = np.asarray(self.interaction.point, float)
            if not np.all(np.isfinite(p)) or np.any(np.abs(p) > np.asarray(self.dimensions) / 2 + 1e-9):
                raise ValueError(
                    f"interaction: point {list(self.interaction.point)} lies outside the asset's bounds "
                    f"(+-{[round(d / 2, 4) for d in self.dimensions]})"
                )
            if float(p[:2] @ self.face_vector) <= 0.0:
                raise ValueError(
                    f"interaction: point {list(self.interaction.point)} is not on the {self.face} side"
                )
        return self

    @property
    def color(self) -> str:
        """Its category's colour on top-down maps: ``map_color``, else :func:`derived_map_color`."""
        return self.map_color or derived_map_color(self.name)

    @property
    def face_vector(self) -> np.ndarray | None:
        """Model-space unit normal of the operational face, or None."""
        return None if self.face is None else np.array(FACE_VECTORS[self.face])

    @property
    def face_width(self) -> float:
        """Horizontal width of the operational face (the footprint side parallel to it)."""
        if self.face is None:
            return max(self.dimensions[:2])
        return self.dimensions[1] if self.face[1] == "X" else self.dimensions[0]

    @property
    def height(self) -> float:
        return self.dimensions[2]

    @property
    def zone2_clearance(self) -> float:
        """epsilon_c of Eq. 2 from the catalog this asset came from (the packaged one for a stand-alone
        asset)."""
        return load_catalog().zone2_clearance if self._zone2_clearance is None else self._zone2_clearance


class RoomShellPiece(_Strict):
    name: str
    dimensions: tuple[float, float, float]


class RoomInner(_Strict):
    dimensions: tuple[float, float, float]
    source: str = ""


class CatalogFile(_Strict):
    schema_version: Literal[1]
    source: str = ""
    zone2_clearance: float = Field(gt=0)
    rules: dict[str, str] = {}
    support_heights: dict[str, float]
    room_inner: RoomInner
    assets: list[AssetSpec]
    room_shell: list[RoomShellPiece] = []
    dressing: list[AssetSpec] = []  # non-goal objects the generator adds on request (lab dressing)

    @model_validator(mode="after")
    def _dressing(self) -> CatalogFile:
        for i, a in enumerate(self.assets):
            if a.mount is not None or a.mount_height:
                raise ValueError(f"assets[{i}].mount: only lab dressing (the 'dressing' list) is mounted")
        for i, a in enumerate(self.dressing):
            if a.mount is None or a.goal_category or a.face is not None or a.placement != "furniture":
                raise ValueError(
                    f"dressing[{i}]: lab dressing needs a mount, placement 'furniture', no face and no goal"
                )
            if a.mount != "wall" and a.mount_height:
                raise ValueError(f"dressing[{i}].mount_height: only wall dressing hangs above the floor")
        return self

    @model_validator(mode="after")
    def _unique(self) -> CatalogFile:
        names = [a.name for a in [*self.assets, *self.dressing]] + [p.name for p in self.room_shell]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"assets: duplicate names {dup}")
        owner: dict[tuple[str, ...], str] = {}
        for i, a in enumerate(self.assets):
            for p in sorted(a.phrases):
                if owner.setdefault(p, a.name) != a.name:
                    raise ValueError(
                        f"assets[{i}].synonyms: '{' '.join(p)}' already names '{owner[p]}' (a name must say "
                        "one category)"
                    )
        for furn, h in self.support_heights.items():
            if furn not in {a.name for a in self.assets}:
                raise ValueError(f"support_heights: '{furn}' is not an asset")
            if h <= 0:
                raise ValueError(f"support_heights.{furn}: must be positive")
        return self

    @model_validator(mode="after")
    def _stamp_clearance(self) -> CatalogFile:
        """Each asset carries this catalog's epsilon_c (Eq. 2) into the geometry built from it."""
        for a in [*self.assets, *self.dressing]:
            a._zone2_clearance = self.zone2_clearance
        return self


class Catalog:
    """Typed, validated view of ``catalog.json``."""

    def __init__(self, data: CatalogFile, raw_bytes: bytes, source: Path) -> None:
        self.data = data
        self.source = source
        self.sha256 = hashlib.sha256(raw_bytes).hexdigest()
        self._assets = {a.name: a for a in data.assets}
        self._dressing = {a.name: a for a in data.dressing}
        self._phrases = {p: a.name for a in data.assets for p in a.phrases}

    @property
    def zone2_clearance(self) -> float:
        """The Zone-2 safety clearance epsilon_c of Eq. 2, in metres."""
        return self.data.zone2_clearance

    @property
    def support_heights(self) -> dict[str, float]:
        return dict(self.data.support_heights)

    @property
    def room_shell(self) -> list[RoomShellPiece]:
        return list(self.data.room_shell)

    def names(self) -> list[str]:
        """The assets' names (lab dressing excluded: see ``dressing``)."""
        return list(self._assets)

    def assets(self) -> list[AssetSpec]:
        return list(self._assets.values())

    def dressing(self) -> list[AssetSpec]:
        """The lab dressing: non-goal objects only the generator places (on request), never named by an
        LSAT import or a protocol; ``get`` finds them too."""
        return list(self._dressing.values())

    def phrases(self) -> dict[tuple[str, ...], str]:
        """Word sequence (``name_tokens``) -> the asset it names: names, display names and synonyms."""
        return dict(self._phrases)

    def goal_categories(self) -> list[str]:
        return [a.name for a in self._assets.values() if a.goal_category]

    def __contains__(self, name: object) -> bool:
        """An asset's name (lab dressing excluded, as from ``names``)."""
        return name in self._assets

    def get(self, name: str) -> AssetSpec:
        """The asset (or lab dressing) called ``name``; an unknown name raises CatalogError listing the
        known ones."""
        try:
            return self._assets[name] if name in self._assets else self._dressing[name]
        except (KeyError, TypeError):
            known = sorted([*self._assets, *self._dressing])
            guess = fuzz_process.extractOne(str(name), known)
            hint = f" Did you mean '{guess[0]}'?" if guess and guess[1] >= 70 else ""
            raise CatalogError(
                f"unknown instrument '{name}'.{hint} Known: {', '.join(known)}",
                source=str(self.source),
                field="name",
            ) from None

    __getitem__ = get

    def to_json_list(self) -> list[dict]:
        """The catalog as the plain objects `biovln-ms catalog --json` prints."""
        return [a.model_dump(mode="json") for a in self._assets.values()]


def load_catalog(path: str | Path | None = None) -> Catalog:
    """Load and validate a catalog file (default: the file ``$BIOVLN_CATALOG`` names, else the packaged
    ``assets/catalog.json``), with the overlays ``$BIOVLN_CATALOG_OVERLAY`` names (``os.pathsep``-separated
    JSON files ``{"assets": [...]}``: your instruments added to it; a name it has already is refused)."""
    if path is None:
        overlays = tuple(filter(None, os.environ.get(OVERLAY_ENV, "").split(os.pathsep)))
        return _default_catalog(os.environ.get(CATALOG_ENV) or None, overlays)
    return _load(Path(path))


@lru_cache(maxsize=4)
def _default_catalog(override: str | None = None, overlays: tuple[str, ...] = ()) -> Catalog:
    return _load(CATALOG_PATH if override is None else Path(override), tuple(Path(o) for o in overlays))


def _read_json(path: Path, what: str) -> tuple[bytes, object]:
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise CatalogError(
            f"cannot read the {what} ({e.strerror})",
            source=str(path),
            fix="reinstall biovln-ms or pass an existing catalog file",
        ) from None
    try:
        return raw, json.loads(raw)
    except json.JSONDecodeError as e:
        raise CatalogError(
            f"not valid JSON at line {e.lineno} column {e.colno}: {e.msg}", source=str(path)
        ) from None


def _overlay(obj: object, raw: bytes, path: Path) -> tuple[object, bytes]:
    """The catalog object with an overlay file's ``assets`` appended (and its bytes in the digest)."""
    more, extra = _read_json(path, "catalog overlay")
    if not isinstance(extra, dict) or set(extra) != {"assets"} or not isinstance(extra["assets"], list):
        raise CatalogError(
            "an overlay is an object with one key, 'assets' (a list of asset entries)",
            source=str(path),
            field="assets",
            fix='write {"assets": [{...}, ...]} with entries as in the packaged catalog.json',
        )
    taken = {a.get("name") for a in obj["assets"] if isinstance(a, dict)}
    for i, a in enumerate(extra["assets"]):
        if isinstance(a, dict) and a.get("name") in taken:
            raise CatalogError(
                f"assets[{i}]: the catalog already has an instrument named {a['name']!r}",
                source=str(path),
                field=f"assets[{i}].name",
                fix="choose another name (an overlay adds instruments; it does not replace them)",
            )
    return {**obj, "assets": [*obj["assets"], *extra["assets"]]}, raw + b"\n" + more


def _load(path: Path, overlays: tuple[Path, ...] = ()) -> Catalog:
    raw, obj = _read_json(path, "catalog")
    if overlays and not (isinstance(obj, dict) and isinstance(obj.get("assets"), list)):
        raise CatalogError("the catalog has no 'assets' list", source=str(path), field="assets")
    for overlay in overlays:
        obj, raw = _overlay(obj, raw, overlay)
    try:
        data = CatalogFile.model_validate(obj)
    except ValidationError as e:
        field, msg = describe_validation_error(e)
        raise CatalogError(
            msg,
            source=", ".join(map(str, (path, *overlays))),
            field=field,
            fix="correct that value (see the 'rules' section of the packaged catalog.json)",
        ) from None
    return Catalog(data, raw, path)
