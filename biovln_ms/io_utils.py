"""Atomic file writes (a crash never leaves a half-written file that later loads), an exclusive lock file
(one writer per folder), and the bounded reading of untrusted files: a regular file of at most a limit,
read in chunks, UTF-8, nested at most ``MAX_DATA_DEPTH`` levels (JSON or YAML), and paths built from data
kept inside their folder. Every refusal is one line of the caller's error class naming the file."""

from __future__ import annotations

import json
import os
import re
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path, PurePosixPath
from typing import BinaryIO, Iterator

import numpy as np

from biovln_ms.errors import BioVLNError
from biovln_ms.limits import MAX_DATA_DEPTH, MAX_YAML_NODES

READ_CHUNK = 2**20


_UMASK = os.umask(0o022)
os.umask(_UMASK)


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write to a temporary file in the same folder, fsync, then rename over ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; the result gets a normal file's mode
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def atomic_write_text(path: str | Path, text: str) -> Path:
    return atomic_write_bytes(path, text.encode())


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Save a matplotlib figure as PNG atomically and close it."""
    import io

    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())


class LockedError(BioVLNError):
    """Another live process holds the lock; ``holder`` is what it recorded (pid, host, started, command)."""

    def __init__(self, message: str, holder: dict, **kw) -> None:
        self.holder = holder
        super().__init__(message, **kw)


def _describe_holder(holder: dict) -> str:
    if not holder:
        return "a process that has not yet recorded itself"
    return (
        f"pid {holder.get('pid', '?')} on {holder.get('host', '?')}, started {holder.get('started', '?')}, "
        f"command: {holder.get('command', '?')}"
    )


@contextmanager
def exclusive_lock(path: str | Path, what: str = "writing here", fix: str | None = None) -> Iterator[dict]:
    """Hold an exclusive ``fcntl.flock`` on ``path`` (created if missing) for the ``with`` block.

    The file records the holder (pid, host, start time, command line); a second process fails at once
    with a ``LockedError`` naming it (``{pid}`` in ``fix`` becomes the holder's pid). The kernel drops
    the lock when its holder's process dies, so the file of a killed run is simply taken over. The
    descriptor is close-on-exec: spawned workers and subprocesses do not hold it (forked ones would)."""
    import fcntl
    import json
    import shlex
    import socket
    import sys
    from datetime import datetime

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666 & ~_UMASK)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                holder = json.loads(os.pread(fd, 65536, 0) or b"{}")
            except ValueError:
                holder = {}
            raise LockedError(
                f"another process is {what}: {_describe_holder(holder)}",
                holder,
                source=str(path),
                fix=fix.replace("{pid}", str(holder.get("pid", "PID"))) if fix else None,
            ) from None
        me = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "started": datetime.now().astimezone().isoformat(timespec="seconds"),
            "command": shlex.join(sys.argv),
        }
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(me).encode() + b"\n", 0)
        yield me
    finally:
        os.close(fd)  # releases the lock


# --- bounded reading of untrusted files --------------------------------------------------------------
def _show(value: object, limit: int = 60) -> str:
    """A user value for a message: repr, control characters escaped, at most ``limit`` characters."""
    text = ascii(value) if not repr(value).isprintable() else repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _size_text(limit: int) -> str:
    return f"{limit // 2**20} MiB" if limit >= 2**20 else f"{limit:,} bytes"


def regular_size(
    path: Path,
    limit: int,
    what: str,
    *,
    error: type[BioVLNError] = BioVLNError,
    source: str | None = None,
    fix: str | None = None,
    missing: str | None = None,
) -> int:
    """The size of ``path``, a regular file of at most ``limit`` bytes (never a FIFO or a device, which
    could block or never end); else one ``error`` (``missing``: its message for a file that is not there)."""
    src = source or str(path)
    try:
        st = path.stat()
    except FileNotFoundError:
        raise error(missing or f"the {what} is missing", source=src, fix=fix) from None
    except (OSError, ValueError) as e:
        raise error(f"cannot read the {what} ({e})", source=src, fix=fix) from None
    if not stat.S_ISREG(st.st_mode):
        raise error(f"the {what} is not a regular file", source=src, fix=fix)
    if st.st_size > limit:
        raise error(
            f"{what} is {st.st_size:,} bytes, more than the limit of {_size_text(limit)}", source=src, fix=fix
        )
    return st.st_size


def read_bounded(stream: BinaryIO, limit: int) -> bytes | None:
    """All of ``stream``, read in chunks, or None as soon as it is over ``limit`` bytes (a gzip bomb
    stops there)."""
    chunks, n = [], 0
    while chunk := stream.read(READ_CHUNK):
        n += len(chunk)
        if n > limit:
            return None
        chunks.append(chunk)
    return b"".join(chunks)


def read_regular_file(
    path: str | Path,
    limit: int,
    what: str,
    *,
    error: type[BioVLNError] = BioVLNError,
    fix: str | None = None,
) -> bytes:
    """The bytes of ``path``, a regular file of at most ``limit`` bytes. It is opened without blocking and
    checked on the open descriptor, so a FIFO or a device put in its place is refused, never waited on."""
    path = Path(path)
    src = str(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0))
    except FileNotFoundError:
        raise error(f"the {what} is missing", source=src, fix=fix) from None
    except (OSError, ValueError) as e:
        reason = e.strerror if isinstance(e, OSError) and e.strerror else str(e)
        raise error(f"cannot read the {what} ({reason})", source=src, fix=fix) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise error(f"the {what} is not a regular file", source=src, fix=fix)
        if st.st_size > limit:
            raise error(
                f"{what} is {st.st_size:,} bytes, more than the limit of {_size_text(limit)}",
                source=src,
                fix=fix,
            )
        with os.fdopen(fd, "rb", closefd=False) as f:
            raw = read_bounded(f, limit)
    except OSError as e:
        raise error(f"cannot read the {what} ({e.strerror or e})", source=src, fix=fix) from None
    finally:
        os.close(fd)
    if raw is None:
        raise error(f"{what} is larger than the limit of {_size_text(limit)}", source=src, fix=fix)
    return raw


_JSON_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)


def json_depth(raw: bytes) -> int:
    """The deepest ``[``/``{`` nesting of JSON text (brackets inside strings skipped), without parsing it."""
    b = np.frombuffer(_JSON_STRING.sub(b"", raw), np.uint8)
    step = np.zeros(len(b), np.int8)
    step[(b == ord("[")) | (b == ord("{"))] = 1
    step[(b == ord("]")) | (b == ord("}"))] = -1
    return int(np.cumsum(step, dtype=np.int32).max(initial=0))


def _utf8(
    raw: bytes, source: str, what: str, error: type[BioVLNError], fix: str | None, field: str | None = None
) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise error(
            f"{what} is not UTF-8 text (byte 0x{raw[e.start]:02x} at offset {e.start})",
            source=source,
            field=field,
            fix=fix,
        ) from None


def parse_json(
    raw: bytes,
    source: str,
    what: str,
    *,
    error: type[BioVLNError] = BioVLNError,
    fix: str | None = None,
    max_depth: int = MAX_DATA_DEPTH,
    field: str | None = None,
):
    """JSON of ``raw`` after the UTF-8 and depth checks; every failure is one ``error`` (naming ``field``
    when given: e.g. ``"file"`` for a whole file that is not what it should be)."""
    text = _utf8(raw, source, what, error, fix, field)
    depth = json_depth(raw)
    if depth > max_depth:
        raise error(
            f"{what} JSON is nested {depth} levels deep, more than the limit of {max_depth}",
            source=source,
            field=field,
            fix=fix,
        )
    try:
        return json.loads(text)
    except RecursionError:  # unreachable after the depth check; kept so no input gives a traceback
        raise error(f"{what} JSON is nested too deeply", source=source, field=field, fix=fix) from None
    except ValueError as e:  # JSONDecodeError, or an integer literal with too many digits
        where = f" at line {e.lineno} column {e.colno}" if isinstance(e, json.JSONDecodeError) else ""
        msg = e.msg if isinstance(e, json.JSONDecodeError) else str(e)
        raise error(f"{what} is not valid JSON{where}: {msg}", source=source, field=field, fix=fix) from None


def parse_yaml(
    raw: bytes,
    source: str,
    what: str,
    *,
    error: type[BioVLNError] = BioVLNError,
    fix: str | None = None,
    max_depth: int = MAX_DATA_DEPTH,
    max_nodes: int = MAX_YAML_NODES,
):
    """Plain data of YAML (or JSON) ``raw`` after the UTF-8 check, with at most ``max_depth`` nested
    collections and ``max_nodes`` nodes and no alias, checked on the parser's event stream before anything
    is built (the composer recurses, so deeper input would end in a RecursionError; an alias can stand for
    a tree of a billion values). Only standard tags: nothing is constructed but scalars, lists and
    mappings."""
    import yaml

    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    text = _utf8(raw, source, what, error, fix)
    if "\x00" in text:
        raise error(f"{what} holds a NUL character", source=source, fix=fix)
    depth = nodes = 0
    try:
        for event in yaml.parse(text, Loader=loader):
            if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
                depth += 1
                if depth > max_depth:
                    raise error(f"{what} is nested more than {max_depth} levels deep", source=source, fix=fix)
            elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
                depth -= 1
            if isinstance(event, yaml.AliasEvent):  # one alias can stand for a whole tree (billion laughs)
                raise error(f"{what} uses a YAML alias (*name)", source=source, fix="write the values out")
            if isinstance(event, yaml.NodeEvent):
                nodes += 1
                if nodes > max_nodes:
                    raise error(f"{what} has more than {max_nodes:,} values", source=source, fix=fix)
        return yaml.load(text, Loader=loader)  # the safe loader: plain data only
    except yaml.YAMLError as e:
        first = " ".join(str(e).split())[:160]
        raise error(f"{what} is not valid YAML/JSON ({first})", source=source, fix=fix) from None
    except (RecursionError, ValueError, OverflowError) as e:  # e.g. a date or a number out of range
        raise error(
            f"{what} holds a value YAML cannot read ({type(e).__name__})", source=source, fix=fix
        ) from None


# --- paths built from data ---------------------------------------------------------------------------
def inside(
    root: str | Path,
    *parts: str,
    what: str = "path",
    error: type[BioVLNError] = BioVLNError,
    source: str | None = None,
    field: str | None = None,
    fix: str | None = None,
    place: str | None = None,
    nested: bool = False,
) -> Path:
    """``root / parts...``, refused unless it stays inside ``root`` once resolved: no empty, absolute or
    ``..`` part, no NUL, no symbolic link leading out, and unless ``nested`` (a relative path such as a
    dataset's ``ms_val/content/x.json.gz``) each part one name, without ``/``. Every path built from data
    or from a name on the command line goes through here; a refusal is one ``error`` (``source``: the
    file that named the path, default ``root``; ``place``: how the message calls ``root``)."""
    root = Path(root)
    place = place or _show(str(root))
    fix = fix or "use a name of letters, digits, '_', '-' and '.'"

    def refuse(message: str) -> BioVLNError:
        return error(message, source=source or str(root), field=field, fix=fix)

    for part in parts:
        text = str(part)
        pure = PurePosixPath(text)
        if not text or text.strip() != text:
            raise refuse(f"{what} {_show(text)} is empty or padded with spaces")
        if "\x00" in text:
            raise refuse(f"{what} {_show(text)} holds a NUL character")
        if pure.is_absolute() or Path(text).is_absolute():
            raise refuse(f"absolute {what} {_show(text)}: it must stay inside {place}")
        if ".." in pure.parts:
            raise refuse(f"{what} {_show(text)} leads outside {place} ('..')")
        if not nested and len(pure.parts) != 1:
            raise refuse(f"{what} {_show(text)} is not one name (it holds '/')")
    path = root.joinpath(*map(str, parts))
    try:
        base, real = root.resolve(), path.resolve()
    except (OSError, RuntimeError, ValueError) as e:
        raise refuse(f"{what} {_show(str(path))} cannot be resolved ({e})") from None
    if real != base and not real.is_relative_to(base):
        raise refuse(
            f"{what} {_show(str(path))} leads outside {place} (a symbolic link to {_show(str(real))})"
        )
    return path
