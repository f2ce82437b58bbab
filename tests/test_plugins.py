"""Extension from outside the package: a plugin module registers a success rule, a variant, a sensor, a
method and a template; they reach gym.make, evaluation (spawned workers included), the report and the CLI's
lists, and the strict facing angle is configuration."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from biovln_ms.errors import BioVLNError
from biovln_ms.plugins import load_plugins
from biovln_ms.task_config import NavTaskConfig
from test_measures import GOAL, ctx, state

EXAMPLE = Path(__file__).resolve().parents[1] / "tasks" / "examples" / "lab_plugin.py"


@pytest.fixture(scope="module")
def plugin(tmp_path_factory) -> str:
    """The example plugin as a user's own file, outside the package, loaded in this process."""
    path = tmp_path_factory.mktemp("user") / "my_lab.py"
    shutil.copy(EXAMPLE, path)
    load_plugins([str(path)])
    return str(path)


def test_the_strict_facing_angle_is_configuration():
    from biovln_ms.metrics.measure_set import MeasureSet
    from biovln_ms.metrics.measures import BatchContext

    facing = {}
    for deg in (30.0, 15.0):
        m, b = (
            MeasureSet(("facing_face", "strict_success"), 1, cfg=NavTaskConfig(strict_facing_deg=deg)),
            BatchContext(1),
        )
        b.set(0, ctx())
        yaw = math.pi / 2 + math.radians(20)  # 20 degrees off the face's inward normal
        m.reset(b, state([GOAL], [yaw]))
        m.update(b, state([GOAL], [yaw], stopped=[True], commanded=[0.0], moved=[0.0]))
        facing[deg] = (bool(m["facing_face"][0]), bool(m["strict_success"][0]))
    assert facing == {30.0: (True, True), 15.0: (False, False)}


@pytest.mark.slow
def test_a_plugin_variant_method_and_measure_run_in_eval_and_the_report(plugin, tmp_path):
    from biovln_ms.eval.harness import EvalConfig, evaluate
    from biovln_ms.eval.paper_tables import other_measures_table
    from biovln_ms.eval.report import load_runs, summarize

    cfg = EvalConfig(method="stop_at_once", split="ms_val", out=str(tmp_path), max_episodes=2, workers=2)
    assert cfg.plugins == [plugin] and cfg.env_id == "MyLab-Zone3Facing-v0"
    cfg.camera = (64, 48)
    summary = evaluate(cfg, progress=False, echo=lambda *_: None)  # spawned workers load the plugin
    records = [json.loads(line) for line in (cfg.run_dir / "episodes.jsonl").read_text().splitlines()]
    assert len(records) == 2 and all("error" not in r for r in records)
    assert all(
        r["zone3_facing_success"] is False and r["success"] is False and r["steps"] == 1 for r in records
    )
    assert summary["overall"]["zone3_facing_sr"] == 0.0
    assert json.loads((cfg.run_dir / "manifest.json").read_text())["arguments"]["plugins"] == [plugin]
    table = "\n".join(other_measures_table(summarize(load_runs(tmp_path))))
    assert "Stop at once" in table and "Zone-3 facing SR" in table


def test_a_plugin_sensor_and_template_reach_the_env(plugin):
    import gymnasium as gym

    from biovln_ms.scene.templates import template_names

    assert "my_single_room" in template_names()
    env = gym.make("MyLab-Zone3Facing-v0", template="my_single_room", scene_seed=3, obs_mode="state_dict")
    try:
        obs, info = env.reset(seed=0)
        yaw = float(info["agent_pose"][0, 2])
        assert np.allclose(
            obs["extra"]["heading_vector"][0].numpy(), [math.cos(yaw), math.sin(yaw)], atol=1e-6
        )
        assert env.unwrapped.cfg.strict_facing_deg == 15.0 and env.unwrapped.cfg.success_measure == (
            "zone3_facing_success"
        )
        _, _, terminated, _, info = env.step(0)
        assert bool(terminated) and "zone3_facing_success" in info
    finally:
        env.close()


@pytest.mark.slow
def test_the_cli_lists_what_a_plugin_registers(plugin):
    from typer.testing import CliRunner

    from biovln_ms.cli import app

    cmd = [sys.executable, "-m", "biovln_ms.cli", "--plugin", plugin, "list", "methods"]
    assert "stop_at_once" in subprocess.run(cmd, capture_output=True, text=True, check=True).stdout

    def run(what: str) -> str:  # the same command in this process (the plugin is loaded once per process)
        r = CliRunner().invoke(app, ["--plugin", plugin, "list", what])
        assert r.exit_code == 0, r.output
        return r.output

    assert "MyLab-Zone3Facing-v0" in run("variants").split()
    assert "zone3_facing_success -> zone3_facing_success" in run("measures")
    assert "my_single_room" in run("templates").split()


def test_a_broken_plugin_is_one_line(tmp_path):
    bad = tmp_path / "broken.py"
    bad.write_text("raise RuntimeError('my bug')\n")
    with pytest.raises(BioVLNError, match="cannot load plugin .*RuntimeError: my bug"):
        load_plugins([str(bad)])
    r = subprocess.run(
        [sys.executable, "-m", "biovln_ms.cli", "--plugin", str(bad), "list"], capture_output=True, text=True
    )
    assert r.returncode == 2 and "Traceback" not in r.stderr and "my bug" in r.stderr


def test_a_catalog_overlay_adds_instruments_and_refuses_a_taken_name(tmp_path, monkeypatch):
    from biovln_ms.catalog import CatalogError, load_catalog

    base = load_catalog()
    entry = {**base.get("centrifuge").model_dump(mode="json", exclude_none=True), "name": "sonicator"}
    entry.update(display_name="Sonicator", synonyms=["ultrasonic bath"])
    overlay = tmp_path / "my_instruments.json"
    overlay.write_text(json.dumps({"assets": [entry]}))
    monkeypatch.setenv("BIOVLN_CATALOG_OVERLAY", str(overlay))
    cat = load_catalog()
    assert "sonicator" in cat and cat.names()[:-1] == base.names() and cat.sha256 != base.sha256
    assert cat.phrases()[("ultrasonic", "bath")] == "sonicator"
    taken = tmp_path / "taken.json"
    taken.write_text(json.dumps({"assets": [{**entry, "name": "centrifuge"}]}))
    monkeypatch.setenv("BIOVLN_CATALOG_OVERLAY", str(taken))
    with pytest.raises(CatalogError, match="already has an instrument named 'centrifuge'"):
        load_catalog()
