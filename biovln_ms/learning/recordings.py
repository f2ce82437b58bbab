"""Recordings of ``eval --record`` (:class:`~biovln_ms.learning.recorder.TrajectoryRecorder` folders) read
back for export, checked and bounded: every entry validated, a file mapped and decompressed one episode at a
time up to ``MAX_ENTRY_BYTES``, frame paths kept inside the folder. One error line names the file, the
episode and the field of anything unreadable."""

from __future__ import annotations

import base64
import binascii
import json
import math
import mmap
import re
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from biovln_ms.errors import BioVLNError, describe_validation_error
from biovln_ms.io_utils import inside, regular_size
from biovln_ms.learning.recorder import RECORDER_VERSION
from biovln_ms.limits import Identifier
from biovln_ms.task_config import STOP, TURN_RIGHT

#: a recording file (one per eval worker); it is mapped and read one episode at a time
MAX_RECORDING_BYTES = 64 * 2**30
#: one episode's entry, decompressed (a full-mode step's 80 x 60 float16 depth is 12.8 kB of base64)
MAX_ENTRY_BYTES = 256 * 2**20
_READ_CHUNK = 2**20
_FIX_FOLDER = "give the folder of `biovln-ms eval --record DIR`"


class RecordingReadError(BioVLNError):
    """A recording folder that cannot be read back: missing, corrupt, out of bounds or mixed modes."""


class _Obs(BaseModel):
    model_config = ConfigDict(extra="ignore")
    position: list[float] = Field(min_length=3, max_length=3)
    heading: list[float] = Field(min_length=2, max_length=2)
    goal_position: list[float] = Field(min_length=2, max_length=2)
    rgb_path: str | None = None
    depth: str | None = None
    depth_shape: list[int] | None = Field(None, min_length=2, max_length=2)


class _Step(BaseModel):
    model_config = ConfigDict(extra="ignore")
    step_idx: int
    action: int = Field(ge=STOP, le=TURN_RIGHT)
    obs: _Obs
    dist_to_goal: float


class _Entry(BaseModel):
    model_config = ConfigDict(extra="ignore")
    recorder_version: Literal[RECORDER_VERSION]
    mode: Literal["full", "trace"]
    frame: Literal["z_up"]
    scene_id: Identifier
    episode_id: Identifier
    object_category: Identifier
    object_id: Identifier
    difficulty: str
    success: bool
    steps: list[_Step] = Field(min_length=1)


@dataclass
class Episode:
    """One recorded episode, checked: where it came from and its steps."""

    entry: _Entry
    source: Path
    root: Path = field(repr=False)

    @property
    def name(self) -> str:
        return f"{self.entry.scene_id}/{self.entry.episode_id}"

    @property
    def task(self) -> str:
        return f"navigate to the {self.entry.object_category.replace('_', ' ')}"


def _natural(text: str) -> tuple:
    """Sort key that orders ``ep2`` before ``ep10``."""
    return tuple((0, int(p), "") if p.isdigit() else (1, 0, p) for p in re.split(r"(\d+)", text) if p)


def read_episodes(folder: str | Path) -> list[Episode]:
    """Every episode of a recording folder, checked and in a fixed order (scene, then episode id): the
    same recording gives the same dataset whichever worker wrote which file. One error names the file,
    the episode and the field of anything that would not export."""
    folder = Path(folder)
    if not folder.is_dir():
        raise RecordingReadError("the recording folder is missing", source=str(folder), fix=_FIX_FOLDER)
    files = sorted(folder.glob("trajectories-*.jsonl.gz"))
    if not files:
        raise RecordingReadError(
            "no trajectories-*.jsonl.gz in the recording folder", source=str(folder), fix=_FIX_FOLDER
        )
    episodes, seen = [], {}
    for path in files:
        for k, raw in enumerate(_entries(path)):
            try:
                entry = _Entry.model_validate(raw)
            except ValidationError as e:
                loc, msg = describe_validation_error(e)
                raise RecordingReadError(
                    msg,
                    source=str(path),
                    field=f"entry {k}: {loc}",
                    fix="export recordings as eval writes them",
                ) from None
            ep = Episode(entry, path, folder)
            _check_steps(ep, k)
            if ep.name in seen:
                raise RecordingReadError(
                    f"episode {ep.name} is recorded twice (also in {seen[ep.name].name})",
                    source=str(path),
                    field=f"entry {k}",
                    fix="export the recording folder of one eval run",
                )
            seen[ep.name] = path
            episodes.append(ep)
    if not episodes:
        raise RecordingReadError(
            "the recording holds no complete episode", source=str(folder), fix=_FIX_FOLDER
        )
    modes = {ep.entry.mode for ep in episodes}
    if len(modes) > 1:
        raise RecordingReadError(
            "the recording mixes full and trace episodes",
            source=str(folder),
            field="mode",
            fix="export full and trace recordings separately",
        )
    return sorted(episodes, key=lambda ep: (_natural(ep.entry.scene_id), _natural(ep.entry.episode_id)))


def _members(path: Path) -> Iterator[tuple[int, int, bytes]]:
    """(offset, length, decompressed bytes) of each complete gzip member (one episode) of a recording file,
    each decompressed to at most ``MAX_ENTRY_BYTES``; the file is mapped, never read whole. A truncated last
    member (a run killed while writing) is skipped, as the trainers skip it; a corrupt one is an error."""
    regular_size(path, MAX_RECORDING_BYTES, "recording", error=RecordingReadError, fix=_FIX_FOLDER)
    if path.stat().st_size == 0:
        return
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        pos, k = 0, 0
        while pos < len(mm):
            data, end = _member(mm, pos, path, k)
            if data is None:
                return
            yield pos, end - pos, data
            pos, k = end, k + 1


def _entries(path: Path) -> Iterator[dict]:
    """The entries of one recording file, read one member at a time (:func:`_members`)."""
    k = 0
    for _, _, data in _members(path):
        for line in _text(data, path, k).splitlines():
            if line.strip():
                yield _entry_json(line, path, k)
                k += 1


def episode_members(path: Path) -> Iterator[tuple[int, int, dict]]:
    """(offset, length, entry) of each episode of a recording file, read as :func:`_members` reads them,
    for a reader that keeps only the offsets and loads an episode again later (:func:`read_member`)."""
    for offset, length, data in _members(path):
        k = f"at byte {offset}"  # how the messages name the entry
        yield offset, length, _entry_json(_text(data, path, k), path, k)


def read_member(path: Path, offset: int, length: int) -> dict:
    """The episode entry of the gzip member at ``offset`` (``length`` bytes) of :func:`episode_members`,
    decompressed within the same bound."""
    k = f"at byte {offset}"
    with open(path, "rb") as f:
        f.seek(offset)
        data, _ = _member(f.read(length), 0, path, k)
    if data is None:
        raise RecordingReadError(f"entry {k} is cut short", source=str(path), fix=_FIX_FOLDER)
    return _entry_json(_text(data, path, k), path, k)


def _text(data: bytes, path: Path, k: int | str) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise RecordingReadError(f"entry {k} is not UTF-8 text", source=str(path), fix=_FIX_FOLDER) from None


def _member(mm, pos: int, path: Path, k: int | str) -> tuple[bytes | None, int]:
    """The gzip member starting at ``pos`` of ``mm`` (a mapped file or bytes), decompressed in bounded
    steps, and where the next begins; (None, end) for a member cut short."""
    d = zlib.decompressobj(zlib.MAX_WBITS | 16)
    parts, size, start = [], 0, pos
    while not d.eof:
        if d.unconsumed_tail:
            buf = d.unconsumed_tail
        elif pos < len(mm):
            buf = mm[pos : pos + _READ_CHUNK]  # a copy: no pointer into the map outlives this call
            pos += len(buf)
        else:
            return None, pos
        try:
            part = d.decompress(buf, MAX_ENTRY_BYTES + 1 - size)
        except zlib.error as e:
            raise RecordingReadError(
                f"not a recording: the gzip member at byte {start} is corrupt ({e})",
                source=str(path),
                fix=_FIX_FOLDER,
            ) from None
        size += len(part)
        parts.append(part)
        if size > MAX_ENTRY_BYTES:
            raise RecordingReadError(
                f"entry {k} decompresses to more than {MAX_ENTRY_BYTES // 2**20} MiB",
                source=str(path),
                fix="export recordings as eval writes them",
            )
    return b"".join(parts), pos - len(d.unused_data)


def _entry_json(line: str, path: Path, k: int | str) -> dict:
    try:
        entry = json.loads(line)
    except ValueError as e:  # json.JSONDecodeError
        raise RecordingReadError(
            f"not a recording: entry {k} is not JSON ({str(e)[:80]})", source=str(path), fix=_FIX_FOLDER
        ) from None
    except RecursionError:
        raise RecordingReadError(f"entry {k} is nested too deeply", source=str(path)) from None
    if not isinstance(entry, dict):
        raise RecordingReadError("an entry is not a JSON object", source=str(path), field=f"entry {k}")
    return entry


def _check_steps(ep: Episode, k: int) -> None:
    full = ep.entry.mode == "full"
    for i, s in enumerate(ep.entry.steps):
        where = f"entry {k} ({ep.name}): steps[{i}]"
        if s.step_idx != i:
            raise RecordingReadError(
                f"step_idx is {s.step_idx}, expected {i}", source=str(ep.source), field=f"{where}.step_idx"
            )
        if full and s.obs.rgb_path is None:
            raise RecordingReadError(
                "a full-mode step without rgb_path",
                source=str(ep.source),
                field=f"{where}.obs.rgb_path",
                fix="export recordings as eval writes them",
            )
        if (s.obs.depth is None) != (s.obs.depth_shape is None):
            raise RecordingReadError(
                "depth and depth_shape come together",
                source=str(ep.source),
                field=f"{where}.obs",
                fix="export recordings as eval writes them",
            )
        values = [*s.obs.position, *s.obs.heading, *s.obs.goal_position, s.dist_to_goal]
        if not all(math.isfinite(v) for v in values):
            raise RecordingReadError("a pose or goal value is not finite", source=str(ep.source), field=where)


def rgb_frame(ep: Episode, i: int) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    rel = ep.entry.steps[i].obs.rgb_path
    field_ = f"{ep.name}: steps[{i}].obs.rgb_path"
    path = inside(
        ep.root,
        rel,
        what="frame",
        error=RecordingReadError,
        source=str(ep.source),
        field=field_,
        nested=True,
        fix="export the recording folder as eval wrote it",
    )
    try:
        with Image.open(path) as img:
            return np.asarray(img.convert("RGB"))
    except FileNotFoundError:
        raise RecordingReadError(
            f"frame {rel} is missing",
            source=str(ep.source),
            field=field_,
            fix="copy the recording folder with its images/",
        ) from None
    except (UnidentifiedImageError, Image.DecompressionBombError, OSError, ValueError) as e:
        raise RecordingReadError(
            f"frame {rel} is not a readable image ({e})", source=str(ep.source), field=field_
        ) from None


def depth_frame(ep: Episode, i: int) -> np.ndarray:
    obs = ep.entry.steps[i].obs
    h, w = obs.depth_shape
    field_ = f"{ep.name}: steps[{i}].obs.depth"
    try:
        raw = base64.b64decode(obs.depth, validate=True)
    except (binascii.Error, ValueError):
        raise RecordingReadError("depth is not base64", source=str(ep.source), field=field_) from None
    if h <= 0 or w <= 0 or len(raw) != 2 * h * w:
        raise RecordingReadError(
            f"depth holds {len(raw)} bytes, not float16 {h} x {w} (depth_shape)",
            source=str(ep.source),
            field=field_,
        )
    return np.frombuffer(raw, np.float16).reshape(h, w).astype(np.float32)
