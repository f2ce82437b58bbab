import json
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from biovln_ms.cli import app

runner = CliRunner()


@pytest.mark.parametrize(
    "args",
    [
        [],
        ["doctor"],
        ["demo"],
        ["catalog"],
        ["assets"],
        ["assets", "generate"],
        ["assets", "verify"],
        ["assets", "preview"],
    ],
)
def test_help_on_every_command(args):
    r = runner.invoke(app, [*args, "--help"])
    assert r.exit_code == 0, r.output
    assert "Usage" in r.output


def test_catalog_json():
    r = runner.invoke(app, ["catalog", "--json"])
    assert r.exit_code == 0
    rows = json.loads(r.output)
    assert {row["name"] for row in rows} >= {"refrigerator", "waste_bin", "biosafety_cabinet"}


def test_console_script_turns_errors_into_one_line(tmp_path):
    bad = tmp_path / "c.json"
    bad.write_text("[]")
    exe = [sys.executable, "-m", "biovln_ms.cli"]
    r = subprocess.run([*exe, "catalog", "--path", str(bad)], capture_output=True, text=True)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    assert str(bad) in r.stderr
    r = subprocess.run(
        [*exe, "assets", "generate", "--only", "fridge", "-o", str(tmp_path / "a")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "unknown instrument 'fridge'" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.render
def test_doctor_reports_versions_and_device():
    r = runner.invoke(app, ["doctor"])
    assert r.exit_code == 0, r.output
    for key in ("python", "sapien", "mani-skill", "torch", "gymnasium", "vulkan device", "render probe"):
        assert key in r.output
