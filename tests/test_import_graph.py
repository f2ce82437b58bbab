"""The import graph of ``biovln_ms`` has no cycle between modules, and its modules import each other at
module level unless the imported module is heavy.

grimp reads every import, those inside functions included, so a cycle hidden by a function-level import is
still a cycle here. A function-level import of a package module is kept only where it spares a process a
heavy dependency: the imported module pulls torch, SAPIEN/ManiSkill, Stable-Baselines3, matplotlib, Numba
or imageio at its own module level (checked below, so the allow-list cannot go stale), or the importer is a
light process that imports each command's code when the command runs."""

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

import networkx as nx
import pytest

ROOT = Path(__file__).resolve().parents[1]
#: where each part of the installed package lives in the repo (pyproject's package-dir)
SOURCES = {
    "biovln_ms": ROOT / "biovln_ms",
    "biovln_ms.tasks": ROOT / "tasks",
    "biovln_ms.agents": ROOT / "agents",
    "biovln_ms.assets": ROOT / "assets",
}
HEAVY_PACKAGES = {
    "torch",
    "sapien",
    "mani_skill",
    "stable_baselines3",
    "matplotlib",
    "numba",
    "imageio",
    "ray",
}

#: imported modules (and their submodules) that may be imported inside a function: each is heavy
ALLOWED_TARGETS = {
    "biovln_ms.tasks": "the ManiSkill envs: SAPIEN, ManiSkill and torch",
    "biovln_ms.sim": "scene building: SAPIEN and ManiSkill",
    "biovln_ms.learning": "training and checkpoints: torch and Stable-Baselines3",
    "biovln_ms.wrappers": "gymnasium wrappers of ManiSkill envs",
    "biovln_ms.render.video": "video writing: imageio and matplotlib",
    "biovln_ms.scene.topdown": "top-down maps drawn with matplotlib",
    "biovln_ms.bridges.nav2": "Nav2 map previews drawn with matplotlib",
    "biovln_ms.eval.report": "the report: its figures drawn with matplotlib",
    "biovln_ms.eval.figures": "report figures drawn with matplotlib",
    "biovln_ms.eval.learned": "learned-method checkpoints: Stable-Baselines3",
    "biovln_ms.sensor_noise_kernels": "Numba kernels, a third of a second to import",
    "biovln_ms.perception.render_frames": "the detector's frames rendered with SAPIEN and torch",
}
#: importers that are light processes: each command imports its code when it runs
LIGHT_IMPORTERS = {
    # with every command's imports at module level (trimesh, scipy, every command's models), even
    # `biovln-ms --help` would pay for all of them
    "biovln_ms.cli": "the command line (the package and its command modules)",
    # the evaluation driver hands episodes to worker processes; it never builds an env or a policy itself
    "biovln_ms.eval.harness": "the evaluation driver",
}

_GRAPH_SCRIPT = """
import json, sys
import grimp
g = grimp.build_graph("biovln_ms", include_external_packages=False, cache_dir=None)
print(json.dumps(sorted([m, i] for m in g.modules for i in g.find_modules_directly_imported_by(m))))
"""


def _module_files() -> dict[str, Path]:
    """Module name -> source file, as the wheel lays the package out."""
    out = {}
    for prefix, base in SOURCES.items():
        for f in sorted(base.rglob("*.py")):
            parts = [p for p in f.relative_to(base).with_suffix("").parts if p != "__init__"]
            if "__pycache__" in f.parts or "blender_addon" in parts or "examples" in parts:
                continue
            out[".".join([prefix, *parts])] = f
    return out


@pytest.fixture(scope="module")
def edges(tmp_path_factory) -> list[tuple[str, str]]:
    """Every direct import between package modules, from grimp on a copy laid out as the wheel installs it
    (grimp walks files, not the editable finder that maps ``tasks/`` and ``agents/``)."""
    dest = tmp_path_factory.mktemp("installed")
    for name, f in _module_files().items():
        target = dest.joinpath(*name.split("."))
        target = target / "__init__.py" if f.name == "__init__.py" else target.with_suffix(".py")
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(f.read_bytes())
    for d in dest.rglob("*"):
        if d.is_dir() and not (d / "__init__.py").exists():
            (d / "__init__.py").write_text("")  # folders without Python sources (assets) are packages too
    r = subprocess.run(
        [sys.executable, "-c", _GRAPH_SCRIPT],
        cwd=dest,
        env={**os.environ, "PYTHONPATH": str(dest), "PYTHONSAFEPATH": "1"},
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    return [tuple(e) for e in json.loads(r.stdout)]


def test_no_import_cycle_between_modules(edges):
    graph = nx.DiGraph(edges)
    cycles = []
    for component in nx.strongly_connected_components(graph):
        if len(component) > 1:
            cycle = nx.find_cycle(graph.subgraph(component))
            cycles.append(" -> ".join([a for a, _ in cycle] + [cycle[0][0]]))
    assert not cycles, "import cycles:\n" + "\n".join(sorted(cycles))


def _imports(tree: ast.AST, modules: dict[str, Path], in_function: bool):
    """(line, imported module) of each import of a package module, inside function bodies or outside them
    (``if TYPE_CHECKING:`` blocks left out)."""

    def visit(node, inside):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                continue
            here = inside or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            if inside == in_function:
                if isinstance(child, ast.Import):
                    for a in child.names:
                        yield child.lineno, a.name
                elif isinstance(child, ast.ImportFrom) and child.module and child.level == 0:
                    subs = [f"{child.module}.{a.name}" for a in child.names]
                    found = [s for s in subs if s in modules]
                    for target in found or [child.module]:
                        yield child.lineno, target
            yield from visit(child, here)

    yield from visit(tree, False)


def _heavy_modules(modules: dict[str, Path]) -> dict[str, set[str]]:
    """Module -> the heavy packages it imports at module level, directly or through package modules."""
    direct = {}
    for name, f in modules.items():
        found = {t for _, t in _imports(ast.parse(f.read_text()), modules, in_function=False)}
        parents = {".".join(name.split(".")[:i]) for i in range(1, name.count(".") + 1)}
        direct[name] = found | (parents & modules.keys())
    heavy = {}
    for name in modules:
        seen, stack = set(), [name]
        while stack:
            m = stack.pop()
            if m not in seen:
                seen.add(m)
                if m in direct:
                    stack += direct[m]
                    stack += [".".join(m.split(".")[:i]) for i in range(1, m.count(".") + 1)]
        heavy[name] = {m.split(".")[0] for m in seen} & HEAVY_PACKAGES
    return heavy


def _under(name: str, prefixes) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def test_function_level_imports_are_of_heavy_modules_only():
    modules = _module_files()
    heavy = _heavy_modules(modules)
    wrong = []
    for name, f in modules.items():
        if _under(name, LIGHT_IMPORTERS):
            continue
        for line, target in _imports(ast.parse(f.read_text()), modules, in_function=True):
            if target.startswith("biovln_ms") and not (_under(target, ALLOWED_TARGETS) and heavy.get(target)):
                wrong.append(f"{f.relative_to(ROOT)}:{line} imports {target} inside a function")
    assert not wrong, "import these at module level (they are light):\n" + "\n".join(wrong)


def test_the_allowed_targets_are_heavy():
    """Each allow-listed module (or every module of an allow-listed package) pulls a heavy dependency."""
    modules = _module_files()
    heavy = _heavy_modules(modules)
    for prefix in ALLOWED_TARGETS:
        members = [m for m in modules if _under(m, [prefix])]
        assert members, f"{prefix} is no module of the package"
        assert any(heavy[m] for m in members), f"{prefix} imports nothing heavy: drop it from the allow-list"


@pytest.mark.parametrize(
    "module, heavy",
    [
        ("biovln_ms.eval.methods", {"torch", "scipy", "sapien", "mani_skill"}),
        ("biovln_ms.perception.detector_specs", {"torch", "scipy", "sapien", "mani_skill"}),
        ("biovln_ms.eval.harness", {"torch", "sapien", "mani_skill"}),
    ],
)
def test_the_method_registry_and_the_driver_load_no_model(module, heavy):
    """The evaluation driver checks each method's inputs (weights' headers, model folders) before handing
    episodes to workers and never loads a model itself: the registry and the spec checks pull in neither
    torch nor SciPy nor SAPIEN, the harness no torch or SAPIEN."""
    loaded = "{m.split('.')[0] for m in sys.modules}"
    code = f"import sys, {module}\nprint(sorted({loaded} & set({sorted(heavy)})))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out
