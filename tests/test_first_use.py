"""First use is not silent: building a default dataset (minutes, once per machine) says so before it starts,
then names its stages, with a progress bar when asked; the table of one-time costs the envs guide shows is
a measured one."""

from __future__ import annotations

from pathlib import Path

from biovln_ms.episodes.writer import SplitPlan
from biovln_ms.measured import docs_data_dir, load_table
from biovln_ms.scene.generator import generate_scene
from biovln_ms.splits import FOUR_CATEGORIES


def test_a_default_dataset_build_says_so_first_then_names_its_stages(tmp_path, monkeypatch, capsys):
    from biovln_ms import splits

    monkeypatch.setenv("BIOVLN_DATA_DIR", str(tmp_path / "data"))
    events: list[str] = []

    def paper_splits(robot):  # the real one generates 47 scenes; the stages are the same
        events.append("generating")
        spec = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
        return [SplitPlan("ms_val", [(spec, 3, False)])]

    monkeypatch.setattr(splits, "paper_splits", paper_splits)
    root = splits.ensure_default_dataset(echo=events.append, progress=True)
    assert root == tmp_path / "data" and (root / "manifest.json").is_file()
    said, stage, generated, built = events
    assert said.startswith("[biovln-ms] building the biovln_base benchmark dataset in ")
    assert "first use" in said and "once per machine" in said and "BIOVLN_DATA_DIR" in said
    assert stage == "generating"  # announced before the slow part starts
    assert generated.startswith("[biovln-ms] scenes generated: 1 in ") and "(1 files)" in generated
    assert built.startswith("[biovln-ms] dataset built in ")
    assert "dataset scenes" in capsys.readouterr().err  # the bar, with its time left
    events.clear()
    assert splits.ensure_default_dataset(echo=events.append) == root and events == []  # built once


def test_the_first_use_table_measures_every_obs_mode_and_robot():
    table = load_table(docs_data_dir() / "benchmarks" / "first_use.json")
    what = [row[0] for row in table["rows"]]
    assert {"`state`", "`rgbd`", "`depth`"} <= set(what)
    assert {"biovln_base's default dataset", "fetch's default dataset"} <= set(what)
    assert all(" s (" in cell and "CPU)" in cell for row in table["rows"] for cell in row[1:3])
    assert Path(table["command"].split()[1]).as_posix() == "benchmarks/first_use.py"


def test_concurrent_first_uses_build_the_default_dataset_once(tmp_path, monkeypatch):
    """Two processes' (here threads') first uses: one builds, the other waits for it and loads its build."""
    import threading

    from biovln_ms import splits

    monkeypatch.setenv("BIOVLN_DATA_DIR", str(tmp_path / "data"))
    builds: list[int] = []

    def paper_splits(robot):
        builds.append(1)
        spec = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
        return [SplitPlan("ms_val", [(spec, 2, False)])]

    monkeypatch.setattr(splits, "paper_splits", paper_splits)
    roots: list[Path] = []
    threads = [
        threading.Thread(target=lambda: roots.append(splits.ensure_default_dataset(echo=lambda _: None)))
        for _ in range(2)
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=300)
    assert len(roots) == 2 and roots[0] == roots[1] and (roots[0] / "manifest.json").is_file()
    assert builds == [1]
