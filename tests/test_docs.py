"""The documentation site (mkdocs.yml, docs/) builds in strict mode and every snippet in it runs.

- ``mkdocs build --strict`` into a temporary folder: broken links and anchors, pages missing from the
  nav, API pages whose modules cannot be found, an unknown ``{{ ... }}`` placeholder or a missing data
  file of ``docs/hooks.py`` all fail it.
- ```python blocks: each page's blocks run in order in one fresh interpreter sharing one namespace (a
  page is read top to bottom, like a notebook), from a temporary folder.
- ```bash blocks: every ``biovln-ms`` line parses against the real CLI; other lines name a script that
  exists (``tests/snippets.py``). Each page's cheap commands (``snippets.EXECUTED``) run in order in a
  copy of the README tests' workspace, and on the walkthrough pages (``WALKTHROUGH``: the quick start)
  every ``biovln-ms`` line runs, in order, evaluation and report included.
- A ```python block that imports a tool this project does not install (``EXTERNAL``: habitat-lab, ROS 2,
  Blender) is code for that tool's environment: it is compiled, not run, and left out of its page's run.
- Inline ``biovln-ms ...`` spans name options their command has.
- Every fenced block is ``python``, ``bash``, ``yaml`` (parsed) or ``text`` (a file listing): no code goes
  unchecked.
- The figures are the code's: the reproduction tables are the report's own, made from data of the report's
  ``measured.json`` schema; the pictures' generator (``docs/images/generate.py``) runs.
"""

from __future__ import annotations

import ast
import importlib.util
import json
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from snippets import (
    EXECUTED,
    ROOT,
    Page,
    command_path,
    make_workspace,
    other_bash_line_error,
    parse_error,
    run_cli,
    run_python,
    unknown_options,
)

PAGES = [Page(p.relative_to(ROOT).as_posix()) for p in sorted((ROOT / "docs").rglob("*.md"))]
WALKTHROUGH = {"docs/quickstart.md"}  # every biovln-ms line runs, not only the cheap ones
EXTERNAL = {"habitat": "habitat-lab", "habitat_sim": "habitat-sim", "rclpy": "ROS 2", "bpy": "Blender"}
BUILD_TIMEOUT_S = 300


def external_tool(code: str) -> str | None:
    """The tool of ``EXTERNAL`` a block imports when that tool is not installed here, else None."""
    for node in ast.walk(ast.parse(code)):
        names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
        names += [node.module] if isinstance(node, ast.ImportFrom) and node.module else []
        for name in names:
            root = name.split(".")[0]
            if root in EXTERNAL and importlib.util.find_spec(root) is None:
                return EXTERNAL[root]
    return None


def _runnable(page: Page) -> list:
    return [b for b in page.blocks if b.lang == "python" and external_tool(b.code) is None]


@pytest.mark.slow
def test_site_builds_in_strict_mode(tmp_path: Path) -> None:
    site = tmp_path / "site"
    r = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=BUILD_TIMEOUT_S,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        check=False,
    )
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-6000:]
    for page in ("index.html", "quickstart/index.html", "reproduction/index.html", "api/model/index.html"):
        assert (site / page).is_file(), page
    # the hook filled every placeholder: the measured tables are there, with their provenance
    reproduction = (site / "reproduction" / "index.html").read_text()
    assert "Table 5 layout" in reproduction and "Measured by" in reproduction
    benchmarks = (site / "benchmarks" / "index.html").read_text()
    assert "{{" not in benchmarks and benchmarks.count("Measured by") >= 8


def test_every_block_is_checked() -> None:
    langs = {(p.name, b.line): b.lang for p in PAGES for b in p.blocks}
    assert not {k: v for k, v in langs.items() if v not in ("python", "bash", "yaml", "text")}, langs
    assert list(langs.values()).count("python") >= 6 and list(langs.values()).count("bash") >= 8
    for p in PAGES:
        for b in p.blocks:
            if b.lang == "yaml":
                yaml.safe_load(b.code)
            elif b.lang == "python":
                compile(b.code, f"{p.name} line {b.line}", "exec")


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if _runnable(p)], ids=lambda p: p.name[5:])
def test_python_blocks_run(page: Page, tmp_path: Path) -> None:
    r = run_python(page.name, _runnable(page), tmp_path)
    assert r.returncode == 0, f"{page.name}:\n{r.stdout[-2000:]}{r.stderr[-4000:]}"


DOCUMENTED = [(p.name, n, argv) for p in PAGES for n, argv in p.documented()]


@pytest.mark.parametrize(
    ("page", "line", "argv"), DOCUMENTED, ids=[f"{p[5:]}:L{n}:{' '.join(a)[:50]}" for p, n, a in DOCUMENTED]
)
def test_documented_command_parses(page: str, line: int, argv: list[str]) -> None:
    error = parse_error(argv)
    assert error is None, f"{page} line {line}: {error}"


OTHER_LINES = [(p.name, n, c) for p in PAGES for n, c in p.bash_commands() if not c.startswith("biovln-ms ")]


@pytest.mark.parametrize(
    ("page", "line", "command"), OTHER_LINES, ids=[f"{p[5:]}:L{n}" for p, n, _ in OTHER_LINES]
)
def test_other_bash_lines_name_real_tools(page: str, line: int, command: str) -> None:
    error = other_bash_line_error(command)
    assert error is None, f"{page} line {line}: {error}"


SPANS = [(p.name, n, s) for p in PAGES for n, s in p.prose_spans()]


@pytest.mark.parametrize(("page", "line", "span"), SPANS, ids=[f"{p[5:]}:L{n}:{s[:40]}" for p, n, s in SPANS])
def test_prose_command_options_exist(page: str, line: int, span: str) -> None:
    unknown, known = unknown_options(span)
    assert not unknown, f"{page} line {line}: `{span}`: unknown option(s) {unknown}; known {known}"


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_workspace(tmp_path_factory.mktemp("docs"))


RUN = {
    p.name: [
        (n, argv) for n, argv in p.documented() if p.name in WALKTHROUGH or command_path(argv) in EXECUTED
    ]
    for p in PAGES
}


@pytest.mark.slow
@pytest.mark.parametrize("page", [name for name, cmds in RUN.items() if cmds])
def test_page_commands_run(page: str, workspace: Path, tmp_path: Path) -> None:
    ws = shutil.copytree(workspace, tmp_path / "ws")
    for line, argv in RUN[page]:
        r = run_cli(argv, ws)
        assert r.returncode == 0, (
            f"{page} line {line}: `biovln-ms {shlex.join(argv)}`:\n{r.stdout[-2000:]}{r.stderr[-3000:]}"
        )


def _records(successes: list[bool], category: str = "cabinet") -> list[dict]:
    return [
        {
            "scene_id": "lab_s154_v0",
            "episode_id": str(i),
            "object_category": category if i % 2 else "waste_bin",
            "difficulty": "easy",
            "success": ok,
            "spl": 0.9 * ok,
            "soft_spl": 0.9,
            "dtg": 0.5,
            "steps": 20 + i,
            "mcr": 0.6,
            "vrt": 0.1,
        }
        for i, ok in enumerate(successes)
    ]


def test_reproduction_tables_are_the_reports_own() -> None:
    """What ``biovln-ms report`` writes from records, the docs' hook writes from its data, through JSON."""
    from biovln_ms.eval.report import summarize, tables, tables_of

    runs = {
        ("frontier", "ms_val"): _records([True, True, False, True]),
        ("frontier@centroid", "ms_val"): _records([False, True, False, False]),
        ("bc", "ms_val"): _records([True, False, False, True]),
    }
    data = json.loads(json.dumps(summarize(runs)))
    assert tables_of(data) == tables(runs)
    committed = json.loads((ROOT / "docs" / "data" / "reproduction.json").read_text())
    assert set(committed["runs"]) >= {"frontier", "oracle", "random"} and committed["mcnemar"]
    assert all(
        parts.keys() == data["runs"]["bc"]["ms_val"].keys()
        for r in committed["runs"].values()
        for parts in r.values()
    )


def test_pictures_are_drawn_by_the_code(tmp_path: Path) -> None:
    r = subprocess.run(
        [
            sys.executable,
            str(ROOT / "docs" / "images" / "generate.py"),
            "--only",
            "map",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    assert (tmp_path / "lab_s150_v0_episode.png").stat().st_size > 10_000


#: README: the pitch, the two commands, one snippet and links; a guide: short enough to scan
MAX_README_BYTES = 6_000
MAX_GUIDE_BYTES = 15_000


def test_readme_and_guides_stay_short():
    sizes = {"README.md": (ROOT / "README.md").stat().st_size}
    assert sizes["README.md"] <= MAX_README_BYTES, sizes
    guides = sorted((ROOT / "docs").rglob("*.md"))
    long = {str(p.relative_to(ROOT)): n for p in guides if (n := p.stat().st_size) > MAX_GUIDE_BYTES}
    assert not long, f"pages over {MAX_GUIDE_BYTES:,} bytes: {long}"
