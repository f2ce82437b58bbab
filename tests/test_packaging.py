"""`pip wheel .` gives a wheel that installs into a fresh venv and works from any directory."""

import ast
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(out),
            str(ROOT),
        ],
        check=True,
    )
    (whl,) = out.glob("biovln_ms-*.whl")
    return whl


def test_no_code_imports_tasks_or_agents_by_their_folder_names():
    """``tasks/`` and ``agents/`` are ``biovln_ms.tasks`` and ``biovln_ms.agents``; imported as top-level
    ``tasks`` / ``agents`` (possible from the repository root) a module would load a second time, with
    registries of its own."""
    found = []
    folders = ("biovln_ms", "tasks", "agents", "assets", "tests", "benchmarks", "scripts", "docs")
    paths = [*ROOT.glob("*.py"), *(p for f in folders for p in (ROOT / f).rglob("*.py"))]
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module or ""]
            else:
                continue
            if any(n.split(".")[0] in ("tasks", "agents") for n in names):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not found, f"imports of top-level tasks/agents: {found}"


def test_wheel_maps_tasks_and_agents_into_the_package(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names if not n.endswith(".dist-info/") and ".dist-info" not in n}
    assert tops == {"biovln_ms"}, f"top-level modules in the wheel: {tops}"
    assert "biovln_ms/tasks/__init__.py" in names and "biovln_ms/agents/__init__.py" in names
    assert "biovln_ms/assets/catalog.json" in names
    assert "biovln_ms/assets/refrigerator.glb" in names
    assert "biovln_ms/assets/collision/waste_bin.obj" in names
    # every module and data file of the source tree is in the wheel (no package forgotten)
    for folder, prefix in (
        ("biovln_ms", "biovln_ms"),
        ("tasks", "biovln_ms/tasks"),
        ("agents", "biovln_ms/agents"),
    ):
        for f in (ROOT / folder).rglob("*"):
            if f.is_file() and f.suffix in {".py", ".json", ".urdf"} and "__pycache__" not in f.parts:
                rel = f"{prefix}/{f.relative_to(ROOT / folder).as_posix()}"
                assert rel in names, f"{rel} missing from the wheel"


def test_wheel_installs_and_works_from_another_directory(wheel, tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py = venv / "bin" / "python"
    # Dependencies come from the running environment (a plain path entry: its .pth files, such as
    # an editable install's finder, are not processed), biovln_ms only from the wheel.
    purelib = sysconfig.get_paths()["purelib"]
    new_purelib = subprocess.run(
        [str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    Path(new_purelib, "deps.pth").write_text(purelib + "\n")
    subprocess.run(
        [str(py), "-m", "pip", "install", "-q", "--no-deps", "--force-reinstall", str(wheel)], check=True
    )
    code = (
        "import biovln_ms, biovln_ms.paths as p; from biovln_ms.assetgen.generate import verify_assets; "
        "assert 'site-packages' in biovln_ms.__file__, biovln_ms.__file__; "
        "assert verify_assets(p.ASSET_DIR) == [], verify_assets(p.ASSET_DIR); print('ok', p.ASSET_DIR)"
    )
    r = subprocess.run([str(py), "-c", code], cwd=tmp_path, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    r = subprocess.run(
        [str(venv / "bin" / "biovln-ms"), "catalog", "--json"], cwd=tmp_path, capture_output=True, text=True
    )
    assert r.returncode == 0 and '"refrigerator"' in r.stdout, r.stderr
    r = subprocess.run(
        [
            str(venv / "bin" / "biovln-ms"),
            "scene",
            "generate",
            "--template",
            "two_room",
            "--seed",
            "1",
            "-o",
            str(tmp_path / "s.json"),
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
