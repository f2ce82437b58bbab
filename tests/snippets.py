"""Shared machinery of the tests that run the documentation's code: README.md (test_readme_snippets.py)
and the pages under docs/ (test_docs.py).

- ``Page``: a Markdown file's fenced blocks, the ``biovln-ms`` lines of its ```bash blocks (comments
  dropped, ``\\`` joined), the usages of a "Command line" table and its inline ``biovln-ms ...`` spans.
- ``usage_to_argvs``: a usage such as ``biovln-ms scene map SPEC.json [--islands]`` as concrete argument
  lists (with every ``[...]`` part and without any, ``a|b`` expanded, ``PLACEHOLDERS`` filled).
- ``parse_cli``: resolve an argument list against the real CLI and convert its options with click's
  ``make_context``, without running anything.
- ``make_workspace``: a folder where the placeholder inputs are real files: ``DIR`` (the paper's datasets,
  a copy of the test session's default dataset, kept by ``dataset build --out DIR`` as up to date; so are
  the pages' ``data/biovln`` and ``data/biovln-fetch``),
  ``SPEC.json`` (its MS VAL scene), ``scene.glb`` / ``my_lab.glb`` (that scene exported), ``lab.json`` /
  ``my_lab.json`` (spec copies), ``map.yaml`` (a designer-name map). The cheap commands (``EXECUTED``) run
  there.
- ``run_python``: code blocks run by this interpreter in a subprocess from a given folder.
"""

from __future__ import annotations

import json
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import typer
from typer.core import TyperGroup

from biovln_ms.cli import app

ROOT = Path(__file__).resolve().parents[1]
PYTHON_TIMEOUT_S = 300
CLI_TIMEOUT_S = 180
PLACEHOLDERS: dict[str, list[str]] = {
    "CAT": ["refrigerator", "centrifuge"],
    "N": ["1000"],
    "M": ["frontier"],
    "S": ["ms_val"],
    "ID": ["0"],
    "NAME": ["refrigerator"],
    "F": ["model.zip"],
}
# Cheap commands: run in the workspace wherever they are documented. The rest (doctor, eval, record, report,
# train, demo, assets generate/preview, layout, lsat build-target) is parse-checked, plus ``--help``.
EXECUTED = {
    ("catalog",),
    ("scene", "templates"),
    ("scene", "generate"),
    ("scene", "validate"),
    ("scene", "map"),
    ("scene", "export"),
    ("dataset", "build"),
    ("dataset", "stats"),
    ("dataset", "show"),
    ("lsat", "import"),
    ("lsat", "export"),
    ("lsat", "blender-addon"),
    ("assets", "verify"),
}
OTHER_TOOLS = {"tensorboard"}  # bash lines that are neither `biovln-ms` nor `bash scripts/...`: not checked


@dataclass(frozen=True)
class Block:
    lang: str
    line: int  # the first line of the code, 1-based
    code: str


def fenced_blocks(text: str) -> list[Block]:
    """The fenced code blocks of a Markdown text, with their language and first line number."""
    blocks, lang, start, body = [], None, 0, []
    for i, line in enumerate(text.splitlines(), 1):
        if line.startswith("```"):
            if lang is None:
                lang, start, body = line[3:].strip(), i + 1, []
            else:
                blocks.append(Block(lang, start, "\n".join(body) + "\n"))
                lang = None
        elif lang is not None:
            body.append(line)
    return blocks


@dataclass(frozen=True)
class Page:
    """A Markdown file of the repository, named relative to its root (``README.md``, ``docs/index.md``)."""

    name: str

    @cached_property
    def text(self) -> str:
        return (ROOT / self.name).read_text()

    @cached_property
    def blocks(self) -> list[Block]:
        return fenced_blocks(self.text)

    def line_of(self, pos: int) -> int:
        return self.text.count("\n", 0, pos) + 1

    def bash_commands(self) -> list[tuple[int, str]]:
        """(line, command) of every command in the ```bash blocks, comments dropped, ``\\`` joined."""
        out = []
        for b in self.blocks:
            if b.lang != "bash":
                continue
            for i, line in enumerate(b.code.replace("\\\n", " ").splitlines()):
                words = shlex.split(line, comments=True)
                if words:
                    out.append((b.line + i, shlex.join(words)))
        return out

    def table_usages(self) -> list[tuple[int, str]]:
        """(line, usage) of a command table's first column: ``biovln-ms ...`` spans."""
        out = []
        for m in re.finditer(r"^\| `biovln-ms.*$", self.text, flags=re.MULTILINE):
            first_cell = re.split(r"(?<!\\)\|", m.group(0))[1]
            for span in re.findall(r"`([^`]+)`", first_cell):
                usage = span if span.startswith("biovln-ms") else f"biovln-ms {span}"
                out.append((self.line_of(m.start()), usage))
        return out

    def prose_spans(self) -> list[tuple[int, str]]:
        """(line, span) of inline ``biovln-ms ...`` code spans outside command tables and fenced blocks."""
        fenced = {n for b in self.blocks for n in range(b.line - 1, b.line + b.code.count("\n") + 1)}
        lines = self.text.splitlines()
        out = []
        for m in re.finditer(r"`(biovln-ms[^`]*)`", self.text):
            line = self.line_of(m.start())
            if line not in fenced and not lines[line - 1].startswith("| `biovln-ms"):
                out.append((line, " ".join(m.group(1).split())))
        return out

    def documented(self) -> list[tuple[int, list[str]]]:
        """(line, argv) of every documented full command line: table rows, then bash lines, in page order."""
        rows = [(n, argv) for n, usage in self.table_usages() for argv in usage_to_argvs(usage)]
        rows += [(n, shlex.split(cmd)[1:]) for n, cmd in self.bash_commands() if cmd.startswith("biovln-ms ")]
        return rows


def usage_to_argvs(usage: str) -> list[list[str]]:
    """Concrete argument lists of a usage line: with every ``[...]`` part and without any, ``a\\|b``
    (``a|b`` once unquoted) expanded, placeholders filled."""
    minimal = usage
    while (shorter := re.sub(r"\[[^\[\]]*\]", " ", minimal)) != minimal:
        minimal = shorter
    argvs: list[list[str]] = []
    for form in (usage.replace("[", " ").replace("]", " "), minimal):
        words = [w for w in shlex.split(form) if w != "..."]
        assert words[0] == "biovln-ms", usage
        expanded: list[list[str]] = [[]]
        for w in words[1:]:
            alternatives = [[a] for a in w.split("|")] if "|" in w else [PLACEHOLDERS.get(w, [w])]
            expanded = [[*argv, *alt] for argv in expanded for alt in alternatives]
        argvs += [a for a in expanded if a not in argvs]
    return argvs


def parse_cli(argv: list[str]) -> tuple[tuple[str, ...], typer.Context]:
    """Resolve ``argv`` against the real CLI and parse its options, without running anything."""
    cmd = typer.main.get_command(app)
    ctx = cmd.make_context("biovln-ms", list(argv))
    path: list[str] = []
    while isinstance(cmd, TyperGroup):
        args = [*ctx._protected_args, *ctx.args]
        if not args:
            break
        name, cmd, rest = cmd.resolve_command(ctx, args)
        path.append(name)
        ctx = cmd.make_context(name, rest, parent=ctx)
    return tuple(path), ctx


def command_path(argv: list[str]) -> tuple[str, ...]:
    """The subcommand ``argv`` names, or () when it does not parse (the parse test reports that)."""
    try:
        return parse_cli(argv)[0]
    except (typer.Exit, typer.TyperException):
        return ()


def parse_error(argv: list[str]) -> str | None:
    """Why ``argv`` does not parse as a ``biovln-ms`` command line, or None when it does."""
    try:
        path, _ = parse_cli(argv)
    except typer.Exit:  # an eager --help
        return None
    except typer.TyperException as e:  # click's UsageError: names the option or argument
        return f"`biovln-ms {shlex.join(argv)}` does not parse: {e}"
    return None if path else f"no subcommand in `biovln-ms {shlex.join(argv)}`"


def unknown_options(span: str) -> tuple[list[str], list[str]]:
    """The ``--options`` of an inline ``biovln-ms ...`` span its command does not have, and those it has."""
    cmd = typer.main.get_command(app)
    words = [w for w in shlex.split(span.replace("[", " ").replace("]", " "))[1:] if w != "..."]
    while isinstance(cmd, TyperGroup) and words and words[0] in cmd.commands:
        cmd = cmd.commands[words.pop(0)]
    known = {"--help"} | {o for p in cmd.params for o in (*p.opts, *p.secondary_opts) if o.startswith("-")}
    return [w for w in words if w.startswith("-") and w.split("=")[0] not in known], sorted(known)


def other_bash_line_error(command: str) -> str | None:
    """A bash line that is not a ``biovln-ms`` command must run a script that exists or a known tool."""
    words = shlex.split(command)
    if words[0] in ("bash", "python") and len(words) > 1:
        return None if (ROOT / words[1]).is_file() else f"{words[1]} does not exist"
    return None if words[0] in OTHER_TOOLS else f"unchecked tool in `{command}`"


def console_script() -> list[str]:
    exe = Path(sys.executable).with_name("biovln-ms")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "biovln_ms.cli"]


def run_cli(argv: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [*console_script(), *argv],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=CLI_TIMEOUT_S,
        check=False,
    )


def make_workspace(ws: Path) -> Path:
    """Fill ``ws`` with the placeholder inputs (see the module docstring)."""
    from biovln_ms.splits import ensure_default_dataset

    quiet = lambda *_: None  # noqa: E731
    shutil.copytree(ensure_default_dataset(echo=quiet), ws / "DIR")
    shutil.copytree(ws / "DIR", ws / "data" / "biovln")
    shutil.copytree(ensure_default_dataset(echo=quiet, robot="fetch"), ws / "data" / "biovln-fetch")
    for argv in (["dataset", "build", "--out", "DIR"], ["scene", "export", "SPEC.json", "-o", "scene.glb"]):
        if argv[0] == "scene":
            shutil.copy(ws / "DIR" / "scenes" / "lab_s154_v0.json", ws / "SPEC.json")
        r = run_cli(argv, ws)
        assert r.returncode == 0, f"workspace: biovln-ms {shlex.join(argv)}:\n{r.stdout}{r.stderr}"
    shutil.copy(ws / "scene.glb", ws / "my_lab.glb")
    for name in ("lab.json", "my_lab.json"):
        shutil.copy(ws / "SPEC.json", ws / name)
    (ws / "map.yaml").write_text("'Fridge*': refrigerator\n")  # an lsat import --names map
    return ws


_RUNNER = """\
import json, sys, traceback
page, blocks = sys.argv[1], json.load(open(sys.argv[2]))
namespace = {"__name__": "__main__"}
for b in blocks:
    code = "\\n" * (b["line"] - 1) + b["code"]  # tracebacks show the page's line numbers
    try:
        exec(compile(code, page, "exec"), namespace)
    except BaseException:
        traceback.print_exc()
        sys.exit(f"{page} line {b['line']}: this block failed")
"""


def run_python(page: str, blocks: list[Block], cwd: Path) -> subprocess.CompletedProcess:
    """Run ``blocks`` in order in one fresh interpreter, sharing one namespace (a page read top to
    bottom, like a notebook), from ``cwd``."""
    (cwd / "blocks.json").write_text(json.dumps([{"line": b.line, "code": b.code} for b in blocks]))
    (cwd / "run_blocks.py").write_text(_RUNNER)
    return subprocess.run(
        [sys.executable, "run_blocks.py", page, "blocks.json"],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=PYTHON_TIMEOUT_S,
        check=False,
    )
