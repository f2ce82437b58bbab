"""The benchmark datasets: Habitat-style ``json.gz`` per scene plus a validated manifest.

Layout of a dataset folder::

    manifest.json                   splits, robot, agent radius, catalog hash, generator versions, file hashes
    scenes/<scene>.json             the scene specs
    <split>/content/<scene>.json.gz {"episodes": [...]} per scene

A build writes into a sibling temporary folder (``.<name>.partial-<pid>``, locked while the build runs)
and renames it into place at the end, so a killed build never leaves a dataset that loads; the next
build into the same parent removes what a killed one left. Loading refuses a dataset made for another
robot, agent radius or catalog (Habitat's NaN-SPL trap; a manifest without a ``robot`` field predates it
and is the default robot's), any file whose hash does not match the manifest, any
path that leads outside the folder, and anything malformed or over the limits below or an episode's
(:mod:`biovln_ms.episodes.schema`) — always with one ``DatasetError`` naming the file and the field.

This module reads and validates; building a dataset (``SplitPlan``, ``write_dataset``) is
:mod:`biovln_ms.episodes.writer`.
"""

from __future__ import annotations

import gzip
import hashlib
import zlib
from collections import Counter
from pathlib import Path
from typing import Annotated, Iterator

from pydantic import Field, TypeAdapter, ValidationError, with_config
from typing_extensions import NotRequired, TypedDict

from biovln_ms.catalog import load_catalog
from biovln_ms.constants import SCENE_GENERATOR_VERSION
from biovln_ms.episodes.schema import EPISODES, STRICT, Count, Episode
from biovln_ms.errors import BioVLNError, describe_validation_error
from biovln_ms.io_utils import READ_CHUNK, inside, parse_json, read_bounded, regular_size
from biovln_ms.limits import ID_PATTERN, ID_RULE, Identifier
from biovln_ms.robot_specs import DEFAULT_ROBOT, robot_spec
from biovln_ms.scene.loading import load_spec
from biovln_ms.scene.rules import validate_spec
from biovln_ms.scene.spec import MAX_COORDINATE, MAX_JSON_DEPTH, SceneSpec, SceneSpecError  # noqa: F401
from biovln_ms.scene.spec import MAX_FILE_BYTES as MAX_SCENE_FILE_BYTES

#: 2: the lsat_target split and marker goals; 3: the Hard track (any instance); 4: protocol splits (ordered
#: multi-goal episodes with an instruction; a reader taking their goals for any-instance goals would be
#: wrong); 5: busy splits (episodes carrying their own crowd; a reader ignoring it runs an empty lab)
DATASET_FORMAT_VERSION = 5
EPISODE_GENERATOR_VERSION = 2  # 2: no trivial episodes (generator.MIN_START_GEODESIC_MARGIN)

# Limits (docs/guides/datasets.md), checked before parsing. The paper's datasets: a 29 kB
# manifest, episode files of at most 86 kB decompressed (~1.7 kB an episode), 1,669 episodes in a split.
MAX_MANIFEST_BYTES = 16 * 2**20
MAX_EPISODE_FILE_BYTES = 256 * 2**20  # decompressed (read in bounded chunks), and on disk
MAX_EPISODES_PER_SPLIT = 1_000_000
_REBUILD = "rebuild it: biovln-ms dataset build --out DIR"
_LISTED = " is missing (listed in the manifest)"


class DatasetError(BioVLNError):
    """A missing, incomplete, corrupt or mismatching dataset."""


def _oneline(text: str) -> str:
    """``text`` with control characters escaped, so an error stays one line."""
    return text if text.isprintable() else ascii(text)[1:-1]


def _schema_error(e: ValidationError, source: str, prefix: str = "") -> DatasetError:
    loc, msg = describe_validation_error(e)
    first = e.errors()[0]
    if first["type"] == "string_pattern_mismatch" and first.get("ctx", {}).get("pattern") == ID_PATTERN:
        msg = f"{_show(first['input'])} is not an id ({ID_RULE})"
    if prefix:
        loc = prefix if loc == "<root>" else (f"{prefix}{loc}" if loc.startswith("[") else f"{prefix}.{loc}")
    fix = (
        "use a finite number (NaN and Infinity are refused)"
        if e.errors()[0]["type"] == "finite_number"
        else _REBUILD
    )
    return DatasetError(_oneline(msg), source=source, field=_oneline(loc), fix=fix)


# --- the manifest's schema (validated only: loading returns the JSON object itself, unchanged; the episodes'
# schema is biovln_ms.episodes.schema's) ---------------------------------------------------------------
_SHA256 = Annotated[str, Field(pattern=r"^[0-9a-f]{64}$")]
_RelPath = Annotated[str, Field(min_length=1, max_length=4096)]


@with_config(STRICT)
class _SceneEntry(TypedDict):
    file: _RelPath
    sha256: _SHA256
    template: Identifier
    seed: int
    dressing: NotRequired[bool]  # generated with lab dressing; absent: without


@with_config(STRICT)
class _FileEntry(TypedDict):
    file: _RelPath
    sha256: _SHA256
    episodes: Count


@with_config(STRICT)
class _SplitEntry(TypedDict):
    description: NotRequired[str]
    scenes: list[Identifier]
    episodes: Count
    files: dict[Identifier, _FileEntry]
    missing: NotRequired[str | None]
    view_of: NotRequired[str | None]
    dressing: NotRequired[bool]  # its scenes have lab dressing; absent: they have none


@with_config(STRICT)
class _Manifest(TypedDict):
    robot: NotRequired[str]  # absent in manifests written before it: the default robot
    agent_radius: Annotated[float, Field(gt=0, le=MAX_COORDINATE)]
    catalog_sha256: str
    scene_generator_version: int
    episode_generator_version: int
    scenes: dict[Identifier, _SceneEntry]
    splits: dict[Identifier, _SplitEntry]


_MANIFEST = TypeAdapter(_Manifest)


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


# --- loading --------------------------------------------------------------------------------------
def _show(value: object, limit: int = 60) -> str:
    """A user value for an error message: repr, one line, at most ``limit`` characters."""
    text = _oneline(repr(value))
    return text if len(text) <= limit else text[: limit - 3] + "..."


class EpisodeDataset:
    """A validated dataset folder: splits, scene specs and episodes, for ``robot`` (None: any robot) and its
    footprint radius (``agent_radius``, when given, replaces the robot's; with ``robot=None`` and no
    ``agent_radius`` neither is checked).

    Every malformed, oversized or mismatching manifest or file, and every manifest path leading outside
    the folder (absolute, ``..``, or a symbolic link), raises one ``DatasetError`` naming the file and
    the field. Episodes are returned exactly as stored."""

    def __init__(
        self,
        root: str | Path,
        agent_radius: float | None = None,
        verify: bool = True,
        robot: str | None = DEFAULT_ROBOT,
    ) -> None:
        self.root = Path(root)
        mpath = self.root / "manifest.json"
        self._manifest_path = str(mpath)
        try:
            self._base = self.root.resolve()
            exists = mpath.exists()
        except (OSError, RuntimeError, ValueError) as e:
            raise DatasetError(f"cannot open the dataset folder ({e})", source=str(self.root)) from None
        if not exists:
            partial = list(self.root.parent.glob(f".{self.root.name}.partial-*"))
            hint = " (an interrupted build left a partial folder: run the build again)" if partial else ""
            raise DatasetError(
                f"no manifest.json{hint}",
                source=str(self.root),
                fix="build it: biovln-ms dataset build --out DIR",
            )
        self.manifest = m = self._read_manifest(mpath)
        if not m.get("complete"):
            raise DatasetError("the dataset is incomplete", source=str(mpath), fix="rebuild it")
        if m.get("format_version") != DATASET_FORMAT_VERSION:
            raise DatasetError(
                f"format_version {_show(m.get('format_version'))} is not {DATASET_FORMAT_VERSION}",
                source=str(mpath),
                field="format_version",
                fix="rebuild it with this version of biovln-ms",
            )
        try:
            _MANIFEST.validate_python(m)
        except ValidationError as e:
            raise _schema_error(e, str(mpath)) from None
        if robot is not None and self.robot != robot:
            raise DatasetError(
                f"built for robot '{_oneline(self.robot)}', not '{robot}' in use: its free space, geodesics "
                f"and starts are for another footprint (SPL would be wrong)",
                source=str(mpath),
                field="robot",
                fix=f"rebuild it for this robot: biovln-ms dataset build --robot {robot} --out DIR",
            )
        if agent_radius is None and robot is not None:
            agent_radius = robot_spec(robot).footprint_radius
        if agent_radius is not None and abs(m["agent_radius"] - agent_radius) > 1e-9:
            raise DatasetError(
                f"built for a {m.get('agent_radius')} m agent, not the {agent_radius} m agent in use: its "
                f"geodesic distances (hence SPL) would be wrong",
                source=str(mpath),
                field="agent_radius",
                fix="rebuild the dataset for this radius, or use the robot it was built for",
            )
        versions = {
            "scene_generator_version": SCENE_GENERATOR_VERSION,
            "episode_generator_version": EPISODE_GENERATOR_VERSION,
        }
        for key, want in versions.items():
            if m.get(key) != want:
                raise DatasetError(
                    f"made by {key.replace('_', ' ')} {m.get(key)}, this build is {want}: its scenes or "
                    f"episodes differ from what this version generates",
                    source=str(mpath),
                    field=key,
                    fix="rebuild it: biovln-ms dataset build --out DIR",
                )
        cat = load_catalog()
        if m.get("catalog_sha256") != cat.sha256:
            raise DatasetError(
                "built from another instrument catalog (goals and radii may differ)",
                source=str(mpath),
                field="catalog_sha256",
                fix="rebuild the dataset with the installed catalog",
            )
        self._goal_categories = frozenset(cat.goal_categories())
        self._check_splits()
        files = [(info, f"scenes.{name}", MAX_SCENE_FILE_BYTES) for name, info in m["scenes"].items()]
        for split, sinfo in m["splits"].items():
            for scene, info in sinfo["files"].items():
                files.append((info, f"splits.{split}.files.{scene}", MAX_EPISODE_FILE_BYTES))
        for info, entry, _ in files:  # every path inside the folder, even unverified
            self._resolve(info["file"], f"{entry}.file")
        if verify:
            for info, entry, limit in files:
                self._check(info["file"], info["sha256"], f"{entry}.file", limit)
        self._specs: dict[str, SceneSpec] = {}

    def _read_manifest(self, mpath: Path) -> dict:
        src = str(mpath)
        try:
            path = mpath.resolve()
        except (OSError, RuntimeError) as e:
            raise DatasetError(f"cannot resolve the manifest ({e})", source=src) from None
        if not path.is_relative_to(self._base):
            raise DatasetError(
                f"a symbolic link leading outside the dataset folder (to {_show(str(path))})",
                source=src,
                fix="copy the manifest into the dataset folder, or rebuild the dataset",
            )
        regular_size(path, MAX_MANIFEST_BYTES, "manifest", error=DatasetError, source=src, fix=_REBUILD)
        try:
            with path.open("rb") as f:
                raw = read_bounded(f, MAX_MANIFEST_BYTES)
        except OSError as e:
            raise DatasetError(f"cannot read the manifest ({e.strerror or e})", source=src) from None
        if raw is None:
            raise DatasetError(
                f"manifest is larger than the limit of {MAX_MANIFEST_BYTES // 2**20} MiB", source=src
            )
        m = parse_json(raw, src, "manifest", error=DatasetError, fix=_REBUILD)
        if not isinstance(m, dict):
            raise DatasetError(
                f"the manifest must be a JSON object, not {type(m).__name__}", source=src, fix=_REBUILD
            )
        return m

    def _check_splits(self) -> None:
        """Each split's scenes have files and manifest scenes; episode counts add up and keep the limit."""
        m = self.manifest
        for name, split in m["splits"].items():
            where = f"splits.{_oneline(name)}"

            def refuse(field: str, message: str, fix: str = _REBUILD) -> DatasetError:
                return DatasetError(message, source=self._manifest_path, field=field, fix=fix)

            total = 0
            if len(set(split["scenes"])) != len(split["scenes"]):
                twice = next(x for x in split["scenes"] if split["scenes"].count(x) > 1)
                raise refuse(f"{where}.scenes", f"scene {_show(twice)} is listed twice")
            for scene in split["scenes"]:
                if scene not in split["files"]:
                    raise refuse(f"{where}.files", f"no file for scene {_show(scene)} of {where}.scenes")
                total += split["files"][scene]["episodes"]
            for scene in split["files"]:
                if scene not in m["scenes"]:
                    raise refuse(f"{where}.files.{_oneline(scene)}", "scene not in the manifest's scenes")
            if total > MAX_EPISODES_PER_SPLIT:
                raise refuse(
                    f"{where}.episodes",
                    f"{total:,} episodes, more than the limit of {MAX_EPISODES_PER_SPLIT:,} per split",
                    "make several splits",
                )
            if split["episodes"] != total:
                raise refuse(
                    f"{where}.episodes", f"{split['episodes']:,} episodes, but its files hold {total:,}"
                )

    def _resolve(self, rel: str, entry: str) -> Path:
        """The real path of manifest entry ``entry`` (path ``rel``); refused unless inside the folder."""
        return inside(
            self._base,
            rel,
            error=DatasetError,
            source=self._manifest_path,
            field=_oneline(entry),
            fix="list files by their relative path inside the dataset folder, or rebuild it",
            place="the dataset folder",
            nested=True,
        ).resolve()

    def _check(self, rel: str, digest: str, entry: str, limit: int) -> None:
        path, src = self._resolve(rel, entry), str(self.root / rel)
        regular_size(
            path, limit, "file", error=DatasetError, source=src, fix=_REBUILD, missing="the file" + _LISTED
        )
        h, n = hashlib.sha256(), 0
        try:
            with path.open("rb") as f:
                while n <= limit and (chunk := f.read(READ_CHUNK)):
                    h.update(chunk)
                    n += len(chunk)
        except OSError as e:
            raise DatasetError(
                f"cannot read the file ({e.strerror or e})", source=src, fix=_REBUILD
            ) from None
        if h.hexdigest() != digest:
            raise DatasetError(
                "file does not match its hash in the manifest (corrupt or edited)",
                source=src,
                fix="rebuild the dataset",
            )

    @property
    def agent_radius(self) -> float:
        return self.manifest["agent_radius"]

    @property
    def robot(self) -> str:
        """The robot the dataset was built for (a manifest without the field predates it: the default)."""
        return self.manifest.get("robot", DEFAULT_ROBOT)

    def split_names(self) -> list[str]:
        return list(self.manifest["splits"])

    def split_info(self, split: str) -> dict:
        if split not in self.manifest["splits"]:
            raise DatasetError(
                f"unknown split '{split}'", field="split", fix=f"use one of: {', '.join(self.split_names())}"
            )
        info = self.manifest["splits"][split]
        if info.get("missing") and not info["files"]:
            raise DatasetError(f"split '{split}' is not built: {info['missing']}", field="split")
        return info

    def spec(self, scene: str) -> SceneSpec:
        if scene not in self._specs:
            if scene not in self.manifest["scenes"]:
                raise DatasetError(f"unknown scene '{scene}'", field="scene_id")
            rel = self.manifest["scenes"][scene]["file"]
            path, src = self._resolve(rel, f"scenes.{scene}.file"), str(self.root / rel)
            regular_size(
                path,
                MAX_SCENE_FILE_BYTES,
                "scene file",
                error=DatasetError,
                source=src,
                fix=_REBUILD,
                missing="the scene file" + _LISTED,
            )
            try:
                spec = validate_spec(load_spec(path), str(path))
            except SceneSpecError as e:
                raise DatasetError(e.message, source=src, field=e.field, fix=e.fix) from None
            if spec.name != scene:
                raise DatasetError(
                    f"holds scene {_show(spec.name)}, the manifest lists it as {_show(scene)}",
                    source=src,
                    field="name",
                    fix=_REBUILD,
                )
            self._specs[scene] = spec
        return self._specs[scene]

    def episodes(self, split: str) -> Iterator[Episode]:
        info = self.split_info(split)
        for scene in info["scenes"]:
            yield from self._read_episodes(split, scene, info["files"][scene])

    def _read_episodes(self, split: str, scene: str, entry: dict) -> list[Episode]:
        """The episodes of one file: bounded gunzip, JSON limits, schema, scene, category and unique ids."""
        rel = entry["file"]
        path, src = self._resolve(rel, f"splits.{split}.files.{scene}.file"), str(self.root / rel)
        regular_size(
            path,
            MAX_EPISODE_FILE_BYTES,
            "episode file",
            error=DatasetError,
            source=src,
            fix=_REBUILD,
            missing="the episode file" + _LISTED,
        )
        try:
            with path.open("rb") as f, gzip.GzipFile(fileobj=f, mode="rb") as g:
                raw = read_bounded(g, MAX_EPISODE_FILE_BYTES)
        except (OSError, EOFError, zlib.error) as e:
            raise DatasetError(
                f"not a readable gzip file ({_oneline(str(e))})", source=src, fix=_REBUILD
            ) from None
        if raw is None:
            raise DatasetError(
                f"decompresses to more than the limit of {MAX_EPISODE_FILE_BYTES // 2**20} MiB",
                source=src,
                fix=_REBUILD,
            )
        obj = parse_json(raw, src, "episode file", error=DatasetError, fix=_REBUILD)
        if not isinstance(obj, dict) or not isinstance(obj.get("episodes"), list):
            raise DatasetError(
                'must be a JSON object {"episodes": [...]}', source=src, field="episodes", fix=_REBUILD
            )
        eps = obj["episodes"]
        if len(eps) != entry["episodes"]:
            raise DatasetError(
                f"holds {len(eps):,} episodes, the manifest says {entry['episodes']:,}",
                source=src,
                field="episodes",
                fix=_REBUILD,
            )
        try:
            EPISODES.validate_python(eps)
        except ValidationError as e:
            raise _schema_error(e, src, "episodes") from None
        ids: set[str] = set()
        for i, ep in enumerate(eps):
            if ep["episode_id"] in ids:  # a run would play both and count one (results are keyed by id)
                raise DatasetError(
                    f"episode_id {_show(ep['episode_id'])} appears twice",
                    source=src,
                    field=f"episodes[{i}].episode_id",
                    fix=_REBUILD,
                )
            ids.add(ep["episode_id"])
            if ep["scene_id"] != scene:
                raise DatasetError(
                    f"{_show(ep['scene_id'])} in the episode file of scene {_show(scene)}",
                    source=src,
                    field=f"episodes[{i}].scene_id",
                    fix=_REBUILD,
                )
            if ep["object_category"] not in self._goal_categories:
                raise DatasetError(
                    f"{_show(ep['object_category'])} is not a goal category of the catalog",
                    source=src,
                    field=f"episodes[{i}].object_category",
                    fix=_REBUILD,
                )
            p = ep.get("protocol")
            if p is not None:
                counts = {len(ep["goals"]), len(p["purposes"]), len(p["relations"]), len(p["legs"])}
                if counts != {p["k"]}:
                    raise DatasetError(
                        f"k is {p['k']}, but goals, purposes, relations and legs hold {sorted(counts)}",
                        source=src,
                        field=f"episodes[{i}].protocol.k",
                        fix=_REBUILD,
                    )
        return eps

    def stats(self, split: str) -> dict:
        eps = list(self.episodes(split))
        diff = Counter(e["info"]["difficulty"] for e in eps)
        n = max(len(eps), 1)
        return {
            "scenes": len(self.split_info(split)["scenes"]),
            "episodes": len(eps),
            "categories": sorted({e["object_category"] for e in eps}),
            "difficulty": {k: round(100 * diff.get(k, 0) / n, 1) for k in ("easy", "medium", "hard")},
            "start_fallback": sum(e["info"]["start_clearance_fallback"] for e in eps),
            **({"protocol": _protocol_stats(eps)} if eps and "protocol" in eps[0] else {}),
            **({"people": _people_stats(eps)} if any("people" in e for e in eps) else {}),
        }


def _people_stats(eps: list[Episode]) -> dict:
    """People per episode and how often the goal's face is occupied, of a busy split's episodes: the share of
    episodes whose goal's face is occupied for part of the episode and the mean share of the step limit."""
    ps = [e["people"] for e in eps if "people" in e]
    occupied = [p["occupied_steps"] / p["steps"] for p in ps]
    return {
        "count": dict(sorted(Counter(p["count"] for p in ps).items())),
        "mean_count": round(sum(p["count"] for p in ps) / len(ps), 2),
        "occupied_episodes": round(100 * sum(o > 0 for o in occupied) / len(ps), 1),
        "occupied_steps": round(100 * sum(occupied) / len(ps), 1),
    }


def _protocol_stats(eps: list[Episode]) -> dict:
    """K, route lengths and spatial relations of a protocol split's episodes."""
    ps = [e["protocol"] for e in eps]
    routes = [p["route_length"] for p in ps]
    visits = sum(p["k"] for p in ps)
    return {
        "protocols": len({p["id"] for p in ps}),
        "k": dict(sorted(Counter(p["k"] for p in ps).items())),
        "mean_k": round(visits / len(ps), 2),
        "route_length": {
            "mean": round(sum(routes) / len(routes), 2),
            "min": round(min(routes), 2),
            "max": round(max(routes), 2),
        },
        "needs_relation": round(100 * sum(p["needs_relation"] > 0 for p in ps) / len(ps), 1),
        "relation_visits": round(100 * sum(p["needs_relation"] for p in ps) / visits, 1),
    }
