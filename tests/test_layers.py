"""The layers (README "Layout") hold: import-linter's contracts in pyproject.toml, checked on the package
as it installs (``tasks/`` and ``agents/`` inside ``biovln_ms``, as the wheel maps them)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _installed_layout(dest: Path) -> Path:
    """Copy the Python sources as the wheel lays them out (grimp walks files, not the editable finder)."""
    pkg = dest / "biovln_ms"
    ignore = shutil.ignore_patterns("__pycache__", "*.glb", "*.obj", "*.png", "*.json", "*.urdf")
    shutil.copytree(ROOT / "biovln_ms", pkg, ignore=ignore)
    for name in ("tasks", "agents", "assets"):
        shutil.copytree(ROOT / name, pkg / name, ignore=ignore)
    return dest


def _lint(src: Path) -> subprocess.CompletedProcess:
    """import-linter on the copied sources (run from there, so the repo's own folders are not imported)."""
    lint = Path(sys.executable).with_name("lint-imports")
    return subprocess.run(
        [str(lint), "--config", str(ROOT / "pyproject.toml"), "--no-cache"],
        cwd=src,
        env={**os.environ, "PYTHONPATH": str(src)},
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def test_import_contracts_hold(tmp_path):
    r = _lint(_installed_layout(tmp_path))
    assert r.returncode == 0, r.stdout[-6000:] + r.stderr[-2000:]
    assert "3 kept, 0 broken" in r.stdout, r.stdout[-2000:]


def test_a_violation_is_caught(tmp_path):
    """The check is real: a geometry module importing the simulator layer breaks the first contract."""
    src = _installed_layout(tmp_path)
    bad = src / "biovln_ms" / "geometry" / "zones.py"
    bad.write_text(bad.read_text() + "\nfrom biovln_ms.sim import sapien_builder  # noqa\n")
    r = _lint(src)
    assert r.returncode != 0 and "biovln_ms.geometry.zones -> biovln_ms.sim" in r.stdout, r.stdout[-3000:]
