"""One progress line on stderr before a long first use: a process's first env with a colour camera on a
software renderer (no CUDA GPU) compiles SAPIEN's shaders and uploads the scene's textures in its first
render, which ``gym.make`` runs (about 25-45 s on 2 CPU cores; the next make takes about 2 s).

A line is said once per process and kind, through the ``biovln_ms.progress`` logger at INFO; worker
processes (``multiprocessing``'s: eval workers, vector-env sub-envs) leave it to their parent. Without a
logging configuration it goes to ``sys.stderr`` as it is when the line is said, and only when that is a
terminal (or a notebook), so pipes, log files and pytest's capture stay quiet. With one (handlers on the
root logger, as ``logging.basicConfig`` makes), it goes there when the root level lets INFO through.
``logging.getLogger("biovln_ms").setLevel(logging.WARNING)`` silences it either way.
"""

from __future__ import annotations

import logging
import multiprocessing
import sys

LOGGER = logging.getLogger("biovln_ms.progress")
PREFIX = "[biovln-ms] "
#: the kinds said in this process
_said: set[str] = set()


class _TerminalHandler(logging.Handler):
    """Writes a record to the current ``sys.stderr`` when a person is watching it (a terminal, a notebook)."""

    def emit(self, record: logging.LogRecord) -> None:
        stream = sys.stderr
        if logging_configured():  # the user's logging configuration shows it
            return
        try:
            if stream is None or not (stream.isatty() or "ipykernel" in sys.modules):
                return
            stream.write(PREFIX + self.format(record) + "\n")
            stream.flush()
        except Exception:  # a closed or odd stream: never fail an env for a progress line
            self.handleError(record)


_HANDLER = _TerminalHandler()
LOGGER.addHandler(_HANDLER)


def logging_configured() -> bool:
    """Whether the process has a logging configuration: handlers on the root logger (``basicConfig``'s,
    pytest's)."""
    return bool(logging.root.handlers)


def enabled() -> bool:
    """Whether progress lines are on: the level the user set on ``biovln_ms.progress`` or ``biovln_ms``
    decides (WARNING or above silences them), else the root logger's when logging is configured, else on."""
    if LOGGER.manager.disable >= logging.INFO:
        return False
    for name in ("biovln_ms.progress", "biovln_ms"):
        level = logging.getLogger(name).level
        if level != logging.NOTSET:
            return level <= logging.INFO
    return logging.root.level <= logging.INFO if logging_configured() else True


def say_once(kind: str, message: str) -> bool:
    """Say ``message`` unless a line of ``kind`` was said in this process; whether it was said now."""
    if kind in _said:
        return False
    _said.add(kind)
    if multiprocessing.parent_process() is not None or not enabled():
        return False
    record = LOGGER.makeRecord(LOGGER.name, logging.INFO, __file__, 0, message, (), None)
    LOGGER.handle(record)
    return True


def first_camera_render(obs_mode: str, software: bool) -> bool:
    """Before a process's first env whose observations hold colour: one line saying the wait, when it renders
    on the CPU (``software``). Whether it was said."""
    from mani_skill.envs.utils.observations import parse_obs_mode_to_struct

    if not software or not parse_obs_mode_to_struct(obs_mode).visual.rgb:
        return False
    return say_once(
        "colour camera",
        "first colour camera in this process: compiling SAPIEN's shaders on the CPU renderer "
        "(about 25-45 s, once per process; the next envs take about 2 s)",
    )
