"""Measured tables: the JSON files that the benchmark scripts (``benchmarks/*.py``) and the fuzz campaign
write into ``docs/data/``, and that the documentation renders when it is built (``docs/hooks.py``), so
no measured figure in the docs is typed by hand. ``biovln-ms report`` writes the evaluation's data
(``measured.json``, see ``biovln_ms.eval.report.summarize``) in its own schema.

A table file::

    {
      "title": "Env speed",
      "command": "python benchmarks/env_speed.py --steps 300 --resets 1000",   # what wrote it
      "machine": "2 CPU cores (x86_64); Vulkan: llvmpipe (cpu)",
      "written": "2026-11-23",
      "provenance": "...",          # optional: where the numbers come from when no script wrote them
      "columns": ["mode", "env steps/s", ...],
      "rows": [["640x480 RGB-D", "43", ...], ...],
      "notes": ["..."]              # optional lines under the table
    }

Cells are strings or numbers, as the script formatted them; ``null`` is shown as "–".
"""

from __future__ import annotations

import contextlib
import datetime
import json
import multiprocessing as mp
import os
import platform
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from biovln_ms.cluster import closing_vec_env
from biovln_ms.io_utils import atomic_write_text


def timed(fn, spent: dict, key: str):
    """``fn`` wrapped so that each call adds its seconds to ``spent[key]`` (a benchmark's own timer around
    one part of a step, without a profiler's overhead)."""

    def run(*args, **kwargs):
        t = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            spent[key] += time.perf_counter() - t

    return run


def in_fresh_process(fn, *args):
    """``fn(*args)`` in a spawned process, as a vector env's worker starts (nothing inherited from this
    one: no simulator state, no frozen objects); ``fn`` must be importable (a module-level function)."""
    with mp.get_context("spawn").Pool(1) as pool:
        return pool.apply(fn, args)


def vec_step_rate(vec, steps: int, n: int, actions: tuple[int, int] = (1, 4), seed: bool = False) -> float:
    """Env steps per second (all ``n`` sub-envs together) of a vector env over ``steps`` vector steps of
    random discrete actions in ``[actions[0], actions[1])`` (from 1: never STOP), after 20 warm-up steps.
    ``seed``: seed and reset it first as SB3 does (``vec.seed(0)``, ``vec.reset()``), and close it after;
    otherwise the caller has reset it and closes it."""
    with closing_vec_env(vec) if seed else contextlib.nullcontext():
        if seed:
            vec.seed(0)
            vec.reset()
        rng = np.random.default_rng(0)
        for _ in range(20):  # warm-up
            vec.step(rng.integers(*actions, n))
        t = time.perf_counter()
        for _ in range(steps):
            vec.step(rng.integers(*actions, n))
        return steps * n / (time.perf_counter() - t)


#: the busy step's comparison (``gym.make`` arguments): the ``busy_val`` episodes without their crowds and
#: with them, where a person collision does not end the episode, so both envs run the same episodes' lengths
BUSY_VAL_EMPTY = {"split": "busy_val", "people": 0}
BUSY_VAL_CROWDED = {"split": "busy_val", "person_collision_ends": False}

REQUIRED = ("title", "command", "machine", "columns", "rows")


def docs_data_dir() -> Path:
    """``docs/data`` of the source checkout this package runs from (benchmarks run from a checkout)."""
    return Path(__file__).resolve().parents[1] / "docs" / "data"


def source_commit() -> str | None:
    """The git commit of the package's source tree, when it runs from a checkout."""
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=Path(__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=5,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def machine(render_device: str | None = None) -> str:
    """A one-line description of this machine for a table's ``machine`` field."""
    text = f"{os.cpu_count()} CPU cores ({platform.machine()}), Python {platform.python_version()}"
    return f"{text}; Vulkan: {render_device}" if render_device else text


def write_table(
    path: str | Path,
    title: str,
    columns: list[str],
    rows: list[list],
    notes: list[str] = (),
    render_device: str | None = None,
    provenance: str | None = None,
    measured_on: str | None = None,
) -> Path:
    """Write a measured table; ``command`` is this process's command line, ``written`` today's date,
    ``provenance`` (optional) where rows this command did not measure come from, ``measured_on``
    (optional) the machine that measured them when it is not this one."""
    script = Path(sys.argv[0]).resolve()
    root = docs_data_dir().parents[1]
    name = script.relative_to(root).as_posix() if script.is_relative_to(root) else script.name
    data = {
        "title": title,
        "command": "python " + shlex.join([name, *sys.argv[1:]]),
        "machine": measured_on or machine(render_device),
        "written": datetime.date.today().isoformat(),
        **({"provenance": provenance} if provenance else {}),
        "columns": list(columns),
        "rows": [list(r) for r in rows],
        "notes": list(notes),
    }
    check_table(data, str(path))
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, dumps(data))
    print(f"wrote {path}")
    return Path(path)


def write_runs(path: str | Path, runs: list[dict], **head) -> Path:
    """Write measured runs (a learning guide's curves) as JSON: ``head`` (with this machine and today's
    date) and one line per run, so that a re-measured run diffs line by line."""
    head = {**head, "machine": machine(), "written": datetime.date.today().isoformat()}
    lines = ",\n  ".join(json.dumps(r, ensure_ascii=False) for r in runs)
    atomic_write_text(path, json.dumps(head)[:-1] + f', "runs": [\n  {lines}\n]}}\n')
    return Path(path)


def dumps(data: dict) -> str:
    """JSON with one line per field and per row, so that a re-measured table diffs row by row."""

    def one(v) -> str:
        return json.dumps(v, ensure_ascii=False)

    fields = [
        f" {one(k)}: [\n  " + ",\n  ".join(one(r) for r in v) + "\n ]"
        if k == "rows" and v
        else f" {one(k)}: {one(v)}"
        for k, v in data.items()
    ]
    return "{\n" + ",\n".join(fields) + "\n}\n"


def check_table(data: dict, source: str) -> dict:
    """``data`` if it is a measured table, else a ValueError naming the file and what is wrong."""
    missing = [k for k in REQUIRED if k not in data]
    if missing:
        raise ValueError(f"{source}: a measured table needs {', '.join(missing)}")
    width = len(data["columns"])
    for i, row in enumerate(data["rows"]):
        if len(row) != width:
            raise ValueError(f"{source}: row {i} has {len(row)} cells, the table {width} columns")
    return data


def load_table(path: str | Path) -> dict:
    return check_table(json.loads(Path(path).read_text()), str(path))


def _cell(v) -> str:
    if v is None:
        return "–"
    if isinstance(v, int) and not isinstance(v, bool):
        return f"{v:,}"
    return str(v).replace("|", "\\|")


def table_markdown(data: dict) -> str:
    """The table as Markdown, then its notes and one line saying what measured it, where and when."""
    lines = [
        "| " + " | ".join(data["columns"]) + " |",
        "|" + "---|" * len(data["columns"]),
        *("| " + " | ".join(_cell(c) for c in row) + " |" for row in data["rows"]),
        "",
    ]
    lines += [f"{n}" for n in data.get("notes", [])] + ([""] if data.get("notes") else [])
    source = f"`{data['command']}` on {data['machine']}" + (
        f", {data['written']}" if data.get("written") else ""
    )
    lines.append(f"*Measured by {source}.*" + (f" {data['provenance']}" if data.get("provenance") else ""))
    return "\n".join(lines)
