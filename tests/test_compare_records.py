"""scripts/compare_records.py compare: record files told apart field by field, and the docs' table of runs."""

from __future__ import annotations

import gzip
import importlib.util
import json
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("compare_records", REPO / "scripts" / "compare_records.py")
cr = importlib.util.module_from_spec(spec)
spec.loader.exec_module(cr)


def _write(path: Path, records: dict, checkpoint: str = "c0") -> Path:
    data = {"dataset": {"manifest.json": "d0"}, "checkpoint": checkpoint, "records": records}
    with gzip.open(path, "wt") as f:
        json.dump(data, f)
    return path


def test_differences_are_named_by_run_and_field_and_tabled(tmp_path, capsys):
    ep = {"scene_id": "lab_s1_v0", "episode_id": "0", "success": True, "dtg": 0.4, "steps": 9}
    a = _write(tmp_path / "a.json.gz", {"oracle/ms_val": [ep], "frontier/ms_val": [ep]})
    assert cr.compare(a, a, data_out=tmp_path / "same.json") == 0
    same = json.loads((tmp_path / "same.json").read_text())
    assert [r[3] for r in same["rows"]] == ["identical"] * 2 and same["notes"][0].startswith("2 of 2")
    other = {"oracle/ms_val": [{**ep, "dtg": 0.5, "success": False}], "vlfm/ms_val": [ep]}
    b = _write(tmp_path / "b.json.gz", other, "c1")
    assert cr.compare(a, b, data_out=tmp_path / "diff.json") == 5  # 2 fields, 2 one-sided runs, checkpoint
    out = capsys.readouterr().out
    assert "oracle/ms_val lab_s1_v0/0 field 'dtg' differs" in out and "ppo checkpoint differs" in out
    rows = {r[0]: r for r in json.loads((tmp_path / "diff.json").read_text())["rows"]}
    assert rows["oracle/ms_val"][3] == "dtg, success" and rows["frontier/ms_val"][3] == "only in the first"
    assert rows["vlfm/ms_val"][3] == "only in the second"
