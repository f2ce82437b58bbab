"""Every command and snippet README.md shows is run, or at least parsed by the real CLI.

- ```python blocks: each is executed as a script by this interpreter in a subprocess, from a fresh
  temporary working directory (so repo-relative paths must work from anywhere), with a timeout.
- ```bash blocks: every ``biovln-ms ...`` line must parse: the command is resolved and its options
  and arguments are converted by click's ``make_context`` on the typer app, without invoking it
  (``train ppo --timesteps 200000`` is validated, not run). Other lines (``bash scripts/...``) must
  name a script that exists; ``tensorboard`` is not checked.
- The "Command line" table: each usage is turned into command lines (once with every optional
  ``[...]`` part, once without, ``ppo|a2c|sac`` expanded, ``CAT ...``, ``N``, ``M``, ``S``, ``ID``,
  ``NAME`` and ``F`` replaced by real values, see ``PLACEHOLDERS``) and parsed the same way.
- Cheap commands (``EXECUTED``: catalog, scene templates/generate/validate/map/export, dataset
  build/stats/show, lsat import/export/blender-addon, assets verify) from the table and the bash
  blocks are also run through the ``biovln-ms`` console script in a shared temporary folder where the
  placeholder inputs are real files the fixture makes: ``DIR`` (a dataset), ``SPEC.json`` (its MS VAL
  scene), ``scene.glb`` / ``my_lab.glb`` (that scene exported), ``lab.json`` / ``my_lab.json`` (spec
  copies). The rest (doctor, eval, record, report, train, demo, assets generate/preview, layout, lsat
  build-target) is parse-checked only, plus ``--help`` of every documented command.
- Inline ``biovln-ms ...`` spans in the prose: the subcommand must exist and every ``--option`` it
  names must be one of that command's options.
"""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
import typer
from typer.core import TyperGroup
from typer.testing import CliRunner

from biovln_ms.cli import app

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
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


@dataclass(frozen=True)
class Block:
    lang: str
    line: int
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


def _line_of(pos: int) -> int:
    return README.count("\n", 0, pos) + 1


def bash_commands() -> list[tuple[int, str]]:
    """(line, command) of every command in the ```bash blocks, comments dropped, ``\\`` joined."""
    out = []
    for b in fenced_blocks(README):
        if b.lang != "bash":
            continue
        for i, line in enumerate(b.code.replace("\\\n", " ").splitlines()):
            words = shlex.split(line, comments=True)
            if words:
                out.append((b.line + i, shlex.join(words)))
    return out


def table_usages() -> list[tuple[int, str]]:
    """(line, usage) of the "Command line" table's first column: ``biovln-ms ...`` spans."""
    out = []
    for m in re.finditer(r"^\| `biovln-ms.*$", README, flags=re.MULTILINE):
        first_cell = re.split(r"(?<!\\)\|", m.group(0))[1]
        for span in re.findall(r"`([^`]+)`", first_cell):
            out.append((_line_of(m.start()), span if span.startswith("biovln-ms") else f"biovln-ms {span}"))
    return out


def prose_spans() -> list[tuple[int, str]]:
    """(line, span) of inline ``biovln-ms ...`` code spans outside the table and the fenced blocks."""
    fenced = {n for b in fenced_blocks(README) for n in range(b.line - 1, b.line + b.code.count("\n") + 1)}
    out = []
    for m in re.finditer(r"`(biovln-ms[^`]*)`", README):
        line = _line_of(m.start())
        if line not in fenced and not README.splitlines()[line - 1].startswith("| `biovln-ms"):
            out.append((line, " ".join(m.group(1).split())))
    return out


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


def _documented() -> list[tuple[int, list[str]]]:
    """(line, argv) of every documented full command line: table rows, then bash lines, in README order."""
    rows = [(n, argv) for n, usage in table_usages() for argv in usage_to_argvs(usage)]
    rows += [(n, shlex.split(cmd)[1:]) for n, cmd in bash_commands() if cmd.startswith("biovln-ms ")]
    return rows


DOCUMENTED = _documented()


def _id(line: int, argv: list[str]) -> str:
    return f"L{line}:{' '.join(argv)[:60]}"


def test_readme_has_what_this_file_checks() -> None:
    langs = [b.lang for b in fenced_blocks(README)]
    assert langs.count("python") >= 3 and langs.count("bash") >= 5
    assert len(table_usages()) >= 20 and len(prose_spans()) >= 5


@pytest.mark.parametrize(
    "block", [b for b in fenced_blocks(README) if b.lang == "python"], ids=lambda b: f"L{b.line}"
)
def test_python_snippet_runs(block: Block, tmp_path: Path) -> None:
    script = tmp_path / "snippet.py"
    script.write_text(block.code)
    r = subprocess.run(
        [sys.executable, str(script)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=PYTHON_TIMEOUT_S,
        check=False,
    )
    assert r.returncode == 0, (
        f"README.md line {block.line}:\n{block.code}\n{r.stdout[-2000:]}{r.stderr[-4000:]}"
    )


@pytest.mark.parametrize(("line", "argv"), DOCUMENTED, ids=[_id(n, a) for n, a in DOCUMENTED])
def test_documented_command_parses(line: int, argv: list[str]) -> None:
    try:
        path, _ = parse_cli(argv)
    except typer.Exit:  # an eager --help
        return
    except typer.TyperException as e:  # click's UsageError: names the option or argument
        pytest.fail(f"README.md line {line}: `biovln-ms {shlex.join(argv)}` does not parse: {e}")
    assert path, f"README.md line {line}: no subcommand in `biovln-ms {shlex.join(argv)}`"


@pytest.mark.parametrize(
    "line, command",
    [c for c in bash_commands() if not c[1].startswith("biovln-ms ")],
    ids=lambda v: str(v) if isinstance(v, int) else v[:40],
)
def test_other_bash_lines_name_real_tools(line: int, command: str) -> None:
    words = shlex.split(command)
    if words[0] == "bash":
        assert (ROOT / words[1]).is_file(), f"README.md line {line}: {words[1]} does not exist"
    else:
        assert words[0] in {"tensorboard"}, f"README.md line {line}: unchecked tool in `{command}`"


def test_help_of_every_documented_command() -> None:
    runner = CliRunner()
    paths = sorted({parse_cli(argv)[0] for _, argv in DOCUMENTED})
    for path in paths:
        r = runner.invoke(app, [*path, "--help"])
        assert r.exit_code == 0 and "Usage" in r.output, (path, r.output)


@pytest.mark.parametrize(("line", "span"), prose_spans(), ids=[f"L{n}:{s[:50]}" for n, s in prose_spans()])
def test_prose_command_options_exist(line: int, span: str) -> None:
    cmd = typer.main.get_command(app)
    words = [w for w in shlex.split(span.replace("[", " ").replace("]", " "))[1:] if w != "..."]
    while isinstance(cmd, TyperGroup) and words and words[0] in cmd.commands:
        cmd = cmd.commands[words.pop(0)]
    known = {"--help"} | {o for p in cmd.params for o in (*p.opts, *p.secondary_opts) if o.startswith("-")}
    unknown = [w for w in words if w.startswith("-") and w.split("=")[0] not in known]
    assert not unknown, f"README.md line {line}: `{span}`: unknown option(s) {unknown}; known {sorted(known)}"


def _console_script() -> list[str]:
    exe = Path(sys.executable).with_name("biovln-ms")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "biovln_ms.cli"]


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder where the README's placeholder inputs are real files (see the module docstring)."""
    ws = tmp_path_factory.mktemp("readme")
    cli = _console_script()
    subprocess.run(
        [*cli, "dataset", "build", "--out", "DIR"],
        cwd=ws,
        check=True,
        capture_output=True,
        timeout=CLI_TIMEOUT_S,
    )
    shutil.copy(ws / "DIR" / "scenes" / "lab_s154_v0.json", ws / "SPEC.json")
    subprocess.run(
        [*cli, "scene", "export", "SPEC.json", "-o", "scene.glb"],
        cwd=ws,
        check=True,
        capture_output=True,
        timeout=CLI_TIMEOUT_S,
    )
    shutil.copy(ws / "scene.glb", ws / "my_lab.glb")
    for name in ("lab.json", "my_lab.json"):
        shutil.copy(ws / "SPEC.json", ws / name)
    return ws


def _executed() -> list:
    out = []
    for line, argv in DOCUMENTED:
        try:
            path = parse_cli(argv)[0]
        except (typer.Exit, typer.TyperException):  # reported by test_documented_command_parses
            path = ()
        if path in EXECUTED:
            marks = [pytest.mark.render] if "--render" in argv else []
            out.append(pytest.param(line, argv, marks=marks, id=_id(line, argv)))
    return out


@pytest.mark.parametrize(("line", "argv"), _executed())
def test_cheap_documented_command_runs(line: int, argv: list[str], workspace: Path) -> None:
    r = subprocess.run(
        [*_console_script(), *argv],
        cwd=workspace,
        capture_output=True,
        text=True,
        timeout=CLI_TIMEOUT_S,
        check=False,
    )
    assert r.returncode == 0, (
        f"README.md line {line}: `biovln-ms {shlex.join(argv)}`:\n{r.stdout[-2000:]}{r.stderr[-3000:]}"
    )
