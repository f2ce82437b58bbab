"""Atomic file writes (a crash never leaves a half-written file that later loads) and an exclusive
lock file (one writer per folder)."""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from biovln_ms.errors import BioVLNError


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
