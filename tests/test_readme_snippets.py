"""Every command and snippet README.md shows is run, or at least parsed by the real CLI (the machinery is
``tests/snippets.py``, shared with ``tests/test_docs.py`` for the pages under docs/).

- ```python blocks: each is executed as a script by this interpreter in a subprocess, from a fresh
  temporary working directory (so repo-relative paths must work from anywhere), with a timeout.
- ```bash blocks: every ``biovln-ms ...`` line must parse: the command is resolved and its options
  and arguments are converted by click's ``make_context`` on the typer app, without invoking it
  (``train ppo --timesteps 200000`` is validated, not run). Other lines (``bash scripts/...``) must
  name a script that exists; ``tensorboard`` is not checked.
- The "Command line" table lives on ``docs/cli.md``, which README links and ``tests/test_docs.py``
  checks: each usage is turned into command lines (once with every optional ``[...]`` part, once
  without, ``ppo|a2c|sac`` expanded, ``CAT ...``, ``N``, ``M``, ``S``, ``ID``, ``NAME`` and ``F``
  replaced by real values, see ``snippets.PLACEHOLDERS``) and parsed the same way.
- Cheap commands (``snippets.EXECUTED``: catalog, scene templates/generate/validate/map/export, dataset
  build/stats/show, lsat import/export/blender-addon, assets verify) from the table and the bash
  blocks are also run through the ``biovln-ms`` console script in a shared temporary folder where the
  placeholder inputs are real files (``snippets.make_workspace``). The rest (doctor, eval, record,
  report, train, demo, assets generate/preview, layout, lsat build-target) is parse-checked only, plus
  ``--help`` of every documented command.
- Inline ``biovln-ms ...`` spans in the prose: the subcommand must exist and every ``--option`` it
  names must be one of that command's options.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest
from typer.testing import CliRunner

from biovln_ms.cli import app
from snippets import (
    EXECUTED,
    Page,
    command_path,
    make_workspace,
    other_bash_line_error,
    parse_cli,
    parse_error,
    run_cli,
    run_python,
    unknown_options,
)

README = Page("README.md")
DOCUMENTED = README.documented()


def _id(line: int, argv: list[str]) -> str:
    return f"L{line}:{' '.join(argv)[:60]}"


def test_readme_has_what_this_file_checks() -> None:
    langs = [b.lang for b in README.blocks]
    assert langs.count("python") >= 1 and langs.count("bash") >= 1
    # the command table lives on docs/cli.md, linked from here; tests/test_docs.py checks it the same way
    assert "(docs/cli.md)" in README.text and len(Page("docs/cli.md").table_usages()) >= 20


@pytest.mark.parametrize(
    "block", [b for b in README.blocks if b.lang == "python"], ids=lambda b: f"L{b.line}"
)
@pytest.mark.slow
def test_python_snippet_runs(block, tmp_path: Path) -> None:
    r = run_python(README.name, [block], tmp_path)
    assert r.returncode == 0, (
        f"README.md line {block.line}:\n{block.code}\n{r.stdout[-2000:]}{r.stderr[-4000:]}"
    )


@pytest.mark.parametrize(("line", "argv"), DOCUMENTED, ids=[_id(n, a) for n, a in DOCUMENTED])
def test_documented_command_parses(line: int, argv: list[str]) -> None:
    error = parse_error(argv)
    assert error is None, f"README.md line {line}: {error}"


@pytest.mark.parametrize(
    "line, command",
    [c for c in README.bash_commands() if not c[1].startswith("biovln-ms ")],
    ids=lambda v: str(v) if isinstance(v, int) else v[:40],
)
def test_other_bash_lines_name_real_tools(line: int, command: str) -> None:
    error = other_bash_line_error(command)
    assert error is None, f"README.md line {line}: {error}"


def test_help_of_every_documented_command() -> None:
    runner = CliRunner()
    paths = sorted({parse_cli(argv)[0] for _, argv in DOCUMENTED})
    for path in paths:
        r = runner.invoke(app, [*path, "--help"])
        assert r.exit_code == 0 and "Usage" in r.output, (path, r.output)


@pytest.mark.parametrize(
    ("line", "span"), README.prose_spans(), ids=[f"L{n}:{s[:50]}" for n, s in README.prose_spans()]
)
def test_prose_command_options_exist(line: int, span: str) -> None:
    unknown, known = unknown_options(span)
    assert not unknown, f"README.md line {line}: `{span}`: unknown option(s) {unknown}; known {known}"


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder where the README's placeholder inputs are real files (see the module docstring)."""
    return make_workspace(tmp_path_factory.mktemp("readme"))


def _executed() -> list:
    out = []
    for line, argv in DOCUMENTED:
        if command_path(argv) in EXECUTED:
            marks = [pytest.mark.render] if "--render" in argv else []
            out.append(pytest.param(line, argv, marks=marks, id=_id(line, argv)))
    return out


@pytest.mark.parametrize(("line", "argv"), _executed())
def test_cheap_documented_command_runs(line: int, argv: list[str], workspace: Path) -> None:
    r = run_cli(argv, workspace)
    assert r.returncode == 0, (
        f"README.md line {line}: `biovln-ms {shlex.join(argv)}`:\n{r.stdout[-2000:]}{r.stderr[-3000:]}"
    )
