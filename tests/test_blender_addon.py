"""The Blender add-on, headless in the `bpy` wheel's Python (.venv-blender, scripts/install_blender.sh):
installed from its zip through Blender's add-on mechanism, its three operators used on the LSAT
Target scene. Without that environment the test is skipped (the library path is tested in test_lsat)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from biovln_ms.lsat.designer_scene import target_glb_path
from biovln_ms.scene.loading import parse_spec
from biovln_ms.scene.rules import validate_spec

ROOT = Path(__file__).resolve().parents[1]
BLENDER_PY = Path(os.environ.get("BIOVLN_BLENDER_PYTHON", ROOT / ".venv-blender" / "bin" / "python"))


def test_addon_zip_holds_the_addon_package(tmp_path):
    """The zip Blender installs: the add-on's package at its root, every module, the same bytes each time."""
    import zipfile

    from biovln_ms.lsat.addon_zip import ADDON_DIR

    out = tmp_path / "addon.zip"
    cmd = [sys.executable, "-m", "biovln_ms.cli", "lsat", "blender-addon", "-o", str(out)]
    subprocess.run(cmd, check=True, capture_output=True)
    names = zipfile.ZipFile(out).namelist()
    assert "biovln_lsat/__init__.py" in names
    assert sorted(names) == sorted(f"biovln_lsat/{f.name}" for f in ADDON_DIR.glob("*.py"))
    again = tmp_path / "again.zip"
    cmd = [sys.executable, "-m", "biovln_ms.cli", "lsat", "blender-addon", "-o", str(again)]
    subprocess.run(cmd, check=True, capture_output=True)
    assert out.read_bytes() == again.read_bytes()


@pytest.mark.skipif(not BLENDER_PY.exists(), reason="no Blender Python (run scripts/install_blender.sh)")
def test_addon_panel_operators_headless(tmp_path):
    subprocess.run(
        [sys.executable, "-m", "biovln_ms.cli", "lsat", "blender-addon", "-o", str(tmp_path / "addon.zip")],
        check=True,
        capture_output=True,
    )
    r = subprocess.run(
        [
            str(BLENDER_PY),
            str(ROOT / "tests" / "blender" / "addon_session.py"),
            str(tmp_path / "addon.zip"),
            str(target_glb_path()),
            str(tmp_path / "out"),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    line = next((x for x in r.stdout.splitlines() if x.startswith("BIOVLN_RESULT ")), None)
    assert line, r.stdout[-2000:] + r.stderr[-2000:]
    res = json.loads(line.removeprefix("BIOVLN_RESULT "))
    assert res["enabled"] and res["panel"] and len(res["imported_markers"]) == 6
    assert res["add_marker"] == ["FINISHED"]
    assert res["new_marker"][:2] == pytest.approx([5.5, 3.439], abs=1e-3)  # Eq. 1 in front of the stand
    assert res["check_bad"] == ["CANCELLED"] and res["check_good"] == ["FINISHED"]
    assert res["import_export"] == ["FINISHED"] and res["coverage"].startswith(
        "8 instruments, 6 marker goals"
    )
    spec = validate_spec(
        parse_spec(json.loads((tmp_path / "out" / "scene.json").read_text()))
    )  # Blender's own GLB, re-imported
    assert len(spec.goal_objects()) == 8
    for suffix in ("report.md", "goals.json", "lsat.json", "usda"):
        assert (tmp_path / "out" / f"scene.{suffix}").is_file(), suffix
