"""BIOVLN_TEMPLATE_PATH: a folder of templates that also holds other JSON (a scene spec, a list, a broken
file) loads its templates and skips the rest with a one-line warning naming each file."""

import json
import logging
import shutil
from pathlib import Path

import pytest

from biovln_ms.scene import templates
from biovln_ms.scene.templates import TemplateError, get_template, template_names

EXAMPLES = Path(__file__).resolve().parents[1] / "tasks" / "examples"


@pytest.fixture
def template_folder(tmp_path, monkeypatch):
    """A BIOVLN_TEMPLATE_PATH folder with a template, a scene spec, a JSON list, invalid JSON and a broken
    template; the registry starts empty so that the folder is read again."""
    folder = tmp_path / "my_templates"
    folder.mkdir()
    shutil.copy(EXAMPLES / "cold_room.json", folder / "cold_room.json")
    spec = {"schema_version": 1, "name": "lab", "rooms": [], "walls": [], "instruments": []}
    (folder / "lab_s1_v0.json").write_text(json.dumps(spec))
    (folder / "episodes.json").write_text("[1, 2, 3]")
    (folder / "draft.json").write_text("{not json")
    broken = json.loads((EXAMPLES / "cold_room.json").read_text())
    broken |= {"name": "broken", "active_slots": [9, 9]}
    (folder / "broken.json").write_text(json.dumps(broken))
    monkeypatch.setenv("BIOVLN_TEMPLATE_PATH", str(folder))
    monkeypatch.setattr(templates, "_REGISTRY", {})
    monkeypatch.setattr(templates, "_SKIPPED", {}, raising=False)
    monkeypatch.setattr(templates, "_BUILTIN_LOADED", False)
    return folder


def test_only_templates_load_and_every_other_json_is_one_warning(template_folder, caplog):
    with caplog.at_level(logging.WARNING, logger="biovln_ms.scene.templates"):
        names = template_names()
    assert "cold_room" in names and "single_room" in names and "broken" not in names
    lines = [r.getMessage() for r in caplog.records]
    assert all("\n" not in line for line in lines)
    skipped = {Path(line.split("skipped ", 1)[1].split(": ", 1)[0]).name: line for line in lines}
    assert sorted(skipped) == ["broken.json", "draft.json", "episodes.json", "lab_s1_v0.json"]
    assert "not a layout template" in skipped["lab_s1_v0.json"] and "'slots'" in skipped["lab_s1_v0.json"]
    assert "not readable JSON" in skipped["draft.json"]
    assert "not a valid template" in skipped["broken.json"] and "active_slots" in skipped["broken.json"]
    with pytest.raises(TemplateError, match=r"unknown template 'broken'.*skipped from BIOVLN_TEMPLATE_PATH"):
        get_template("broken")


def test_scene_generate_runs_beside_a_scene_spec_in_the_template_folder(template_folder, tmp_path):
    from typer.testing import CliRunner

    from biovln_ms.cli import app

    out = tmp_path / "cold.json"
    args = ["scene", "generate", "--template", "cold_room", "--seed", "1", "-o", str(out)]
    r = CliRunner().invoke(app, args)
    assert r.exit_code == 0, r.output
    assert json.loads(out.read_text())["template"] == "cold_room"
