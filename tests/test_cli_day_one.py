"""Day-one defects a new user hit, each pinned by a test: ``--require a b``, the README's
``register_template("tasks/examples/cold_room.json")`` from any folder, and ``gym.make("BioVLN-LabScene-v0",
specs=[...])`` with the default obs mode."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from biovln_ms.cli import app
from biovln_ms.errors import BioVLNError

runner = CliRunner()


def _generate(tmp_path: Path, name: str, *require_args: str) -> dict:
    out = tmp_path / name
    r = runner.invoke(app, ["scene", "generate", "--seed", "3", *require_args, "-o", str(out)])
    assert r.exit_code == 0, r.output
    return json.loads(out.read_text())


@pytest.mark.parametrize(
    "require_args",
    [
        ("--require", "refrigerator", "centrifuge", "waste_bin"),  # as the README shows
        ("--require", "refrigerator,centrifuge", "--require", "waste_bin"),  # commas, and repeated
        ("--require", "refrigerator centrifuge waste_bin"),  # one quoted word
        ("--require=refrigerator", "centrifuge", "waste_bin"),
    ],
)
def test_require_takes_several_categories(tmp_path: Path, require_args: tuple[str, ...]) -> None:
    repeated = _generate(
        tmp_path,
        "repeated.json",
        "--require",
        "refrigerator",
        "--require",
        "centrifuge",
        "--require",
        "waste_bin",
    )
    assert {"refrigerator", "centrifuge", "waste_bin"} <= {o["category"] for o in repeated["instruments"]}
    assert _generate(tmp_path, "listed.json", *require_args) == repeated


def test_require_stops_at_the_next_option(tmp_path: Path) -> None:
    """Options after the categories still parse; a category word never swallows them."""
    spec = _generate(
        tmp_path, "a.json", "--require", "refrigerator", "centrifuge", "--template", "single_room"
    )
    assert spec["template"] == "single_room"
    assert {"refrigerator", "centrifuge"} <= {o["category"] for o in spec["instruments"]}
    r = runner.invoke(app, ["scene", "generate", "--seed", "3", "--require", "-o", str(tmp_path / "b.json")])
    assert r.exit_code == 2  # a usage error, not a scene without its categories


def test_require_unknown_category_is_one_line(tmp_path: Path) -> None:
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "biovln_ms.cli",
            "scene",
            "generate",
            "--seed",
            "3",
            "--require",
            "refrigerator",
            "fridge",
            "-o",
            str(tmp_path / "x.json"),
        ],
        capture_output=True,
        text=True,
        check=False,
        cwd=tmp_path,
    )
    assert r.returncode == 2, r.stderr
    assert "unknown instrument 'fridge'" in r.stderr and "Traceback" not in r.stderr


def _run_python(code: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True, check=False, timeout=300
    )


def test_register_template_readme_path_from_any_folder(tmp_path: Path) -> None:
    code = (
        "from biovln_ms.scene.templates import register_template\n"
        "from biovln_ms.scene.generator import generate_scene\n"
        "register_template('tasks/examples/cold_room.json')\n"
        "register_template('cold_room.json')\n"
        "print(generate_scene('cold_room', seed=3).name)\n"
    )
    r = _run_python(code, tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["cold_room_s3_v0"]


def test_register_template_own_file_wins_and_unknown_is_named(tmp_path: Path, monkeypatch) -> None:
    from biovln_ms.scene.templates import TemplateError, register_template, resolve_template_path

    monkeypatch.chdir(tmp_path)
    mine = tmp_path / "tasks" / "examples" / "cold_room.json"
    mine.parent.mkdir(parents=True)
    mine.write_text("{}")
    assert resolve_template_path("tasks/examples/cold_room.json") == Path("tasks/examples/cold_room.json")
    with pytest.raises(TemplateError) as e:
        register_template("tasks/examples/no_such_room.json")
    msg = str(e.value)
    assert "\n" not in msg and "tasks/examples/no_such_room.json" in msg and "no such template file" in msg
    assert "fix:" in msg


@pytest.mark.render
def test_lab_scene_env_readme_call_default_obs_mode() -> None:
    """``gym.make("BioVLN-LabScene-v0", specs=[...])`` as the README writes it: ManiSkill's default obs
    mode ("state") read the absent robot's proprioception and crashed."""
    import gymnasium as gym

    import biovln_ms  # noqa: F401
    from biovln_ms.scene.generator import generate_scene

    spec = generate_scene("single_room", 150)
    env = gym.make("BioVLN-LabScene-v0", specs=[spec])
    try:
        assert env.unwrapped.obs_mode == "state"
        obs, _ = env.reset(seed=0)
        assert obs.numel() == 0  # no robot, no task state
        env.step(None)
        assert env.unwrapped.scene_builder.built[0].objects.keys() == {o.id for o in spec.objects()}
    finally:
        env.close()
    env = gym.make("BioVLN-LabScene-v0", specs=[spec], obs_mode="state_dict")
    try:
        obs, _ = env.reset(seed=0)
        assert obs == {"agent": {}, "extra": {}}
    finally:
        env.close()
    with pytest.raises(BioVLNError, match="field 'obs_mode'.*pointcloud"):
        gym.make("BioVLN-LabScene-v0", specs=[spec], obs_mode="pointcloud")
