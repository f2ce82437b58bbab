"""The VLFM detector comparison (benchmarks/vlfm_detectors.py): each failed episode traced to one outcome,
and two results folders compared on the episodes they share."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("vlfm_detectors", REPO / "benchmarks" / "vlfm_detectors.py")
vd = importlib.util.module_from_spec(spec)
sys.modules["vlfm_detectors"] = vd
spec.loader.exec_module(vd)


def _rec(i: int, success: bool, seen: bool = True, stopped: bool = True, dtg: float = 0.5, steps: int = 40):
    return {
        "scene_id": "lab_s1_v0",
        "episode_id": str(i),
        "success": success,
        "stopped": stopped,
        "dtg": dtg,
        "steps": steps,
        "noise": "ideal",
        "object_category": "centrifuge" if i % 2 else "incubator",
        "policy_stats": {"object_seen": seen},
    }


def test_each_failure_is_traced_to_one_outcome():
    assert vd.outcome(_rec(0, True)) == "success"
    assert vd.outcome(_rec(0, False, seen=False)) == "never detected"
    assert vd.outcome(_rec(0, False, stopped=False)) == "step limit"
    assert vd.outcome(_rec(0, False, dtg=vd.FAR + 0.1)) == "STOP far from the target"
    assert vd.outcome(_rec(0, False, dtg=vd.FAR - 0.1)) == "STOP near the target"
    far = {**_rec(0, False, dtg=4.0), "positions": [[0.0, 0.0], [3.0, 1.0]]}
    assert vd.outcome(far, [[3.5, 2.0]]) == "STOP at another instance"  # 1.1 m from the other's goal
    assert vd.outcome(far, [[3.0, 3.0]]) == "STOP far from the target"  # 2 m from it
    near = {**_rec(0, False, dtg=1.0), "positions": [[3.0, 1.0]]}
    assert vd.outcome(near, [[3.0, 1.0]]) == "STOP near the target"  # near the named one wins


@pytest.fixture(scope="module")
def two_centrifuges(tmp_path_factory):
    """A dataset of seed 150's MS DEV scene, which holds two centrifuges; each episode names one."""
    from biovln_ms.episodes.writer import SplitPlan, write_dataset
    from biovln_ms.scene.generator import generate_scene
    from biovln_ms.splits import FOUR_CATEGORIES

    scene = generate_scene("single_room", 150, required_categories=FOUR_CATEGORIES)
    root = tmp_path_factory.mktemp("twins") / "ds"
    write_dataset(root, [SplitPlan("ms_dev", [(scene, 12, False)])], progress=False)
    return root


def _manifest(run_split: Path, root: Path, **extra) -> None:
    run_split.mkdir(parents=True, exist_ok=True)
    (run_split / "manifest.json").write_text(
        json.dumps({"dataset": str(root), "robot": "biovln_base", **extra})
    )


def test_episodes_that_name_one_of_two_instances_are_found(tmp_path, two_centrifuges):
    """uncounted_goals reads the dataset a run's manifest names: an episode counts only the centrifuge it
    names, and the other's goal is the one the episodes naming that other centrifuge count."""
    from biovln_ms.episodes.dataset import EpisodeDataset

    run = tmp_path / "run" / "ms_dev"
    run.mkdir(parents=True)
    assert vd.uncounted_goals(run) is None  # no manifest: not checked
    _manifest(run, two_centrifuges)
    others = vd.uncounted_goals(run)
    episodes = list(EpisodeDataset(two_centrifuges).episodes("ms_dev"))
    named = {
        ep["object_id"]: ep["goals"][0]["eq1_goal"]
        for ep in episodes
        if ep["object_category"] == "centrifuge"
    }
    assert len(named) == 2, "both centrifuges named by some episode"
    for ep in episodes:
        key = f"{ep['scene_id']}/{ep['episode_id']}"
        if ep["object_category"] == "centrifuge":
            (other,) = [g for i, g in named.items() if i != ep["object_id"]]
            assert len(others[key]) == 1 and others[key][0] == pytest.approx(other)
        else:
            assert key not in others


def test_a_dataset_that_is_gone_or_changed_is_refused(tmp_path, two_centrifuges):
    run = tmp_path / "run" / "ms_dev"
    _manifest(run, tmp_path / "nowhere")
    with pytest.raises(vd.RunsError, match="is not a dataset folder here"):
        vd.uncounted_goals(run)
    _manifest(run, two_centrifuges, dataset_sha256="0" * 64)
    with pytest.raises(vd.RunsError, match="has changed since the run"):
        vd.uncounted_goals(run)
    other = tmp_path / "run" / "ms_val"
    _manifest(other, two_centrifuges)
    with pytest.raises(vd.RunsError, match="has no split 'ms_val'"):
        vd.uncounted_goals(other)


def test_a_stop_at_the_other_instance_is_its_own_outcome_in_the_comparison(tmp_path, two_centrifuges):
    """GT stops at the other centrifuge, the learned detector somewhere else: their outcomes differ."""
    from biovln_ms.episodes.dataset import EpisodeDataset

    eps = EpisodeDataset(two_centrifuges).episodes("ms_dev")
    ep = next(e for e in eps if e["object_category"] == "centrifuge")
    key = f"{ep['scene_id']}/{ep['episode_id']}"
    folders = {}
    for name in ("gt", "learned"):
        _manifest(tmp_path / name / "ms_dev", two_centrifuges)
        folders[name] = tmp_path / name
    (other,) = vd.uncounted_goals(folders["gt"] / "ms_dev")[key]
    base = {**_rec(0, False, dtg=4.0), "scene_id": ep["scene_id"], "episode_id": ep["episode_id"]}
    base["object_category"] = "centrifuge"
    at_other = {**base, "positions": [[0.0, 0.0], [other[0] + 0.3, other[1]]]}
    elsewhere = {**base, "positions": [[0.0, 0.0], [other[0] + 3.0, other[1] + 3.0]]}
    for name, rec in (("gt", at_other), ("learned", elsewhere)):
        (folders[name] / "ms_dev" / "episodes.jsonl").write_text(json.dumps(rec) + "\n")
    rows, traces, twins = vd.compare(folders["learned"], [folders["gt"]], PUBLISHED)
    gt_row, row = (dict(zip(vd.COLUMNS, r)) for r in rows)
    assert (gt_row["STOP at another instance"], gt_row["STOP far from the target"]) == (1, 0)
    assert (row["STOP at another instance"], row["STOP far from the target"]) == (0, 1)
    assert traces["ms_dev (ideal)"][key]["gt"] == "STOP at another instance"
    assert traces["ms_dev (ideal)"][key]["learned"] == "STOP far from the target"
    assert twins == {"ms_dev": (1, vd.Counter({"centrifuge": 1}))}


def _write(folder: Path, records: list[dict]) -> Path:
    (folder / "ms_test").mkdir(parents=True)
    (folder / "ms_test" / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records))
    return folder


PUBLISHED = {
    "vlfm_gt": {"ms_val": {"overall": {"episodes": 50, "sr": 92.0, "sr_ci95": [81.2, 96.8]}}},
}


def test_two_runs_are_compared_on_the_episodes_both_played(tmp_path):
    gt = _write(tmp_path / "gt", [_rec(i, True, steps=40) for i in range(6)])
    learned = [_rec(0, True, steps=60), _rec(1, True, steps=80), _rec(2, False, seen=False)]
    learned += [_rec(3, False, dtg=4.0), _rec(4, False, stopped=False)]  # episode 5: not played
    rows, traces, twins = vd.compare(_write(tmp_path / "learned", learned), [gt], PUBLISHED)
    gt_row, row = (dict(zip(vd.COLUMNS, r)) for r in rows)
    assert (gt_row["detector"], row["detector"]) == ("GT", "learned") and row["split"] == "ms_test"
    assert row["noise"] == "ideal"
    assert gt_row["n"] == row["n"] == 5
    assert gt_row["SR %"].startswith("100.0") and row["SR %"].startswith("40.0")
    assert (row["never detected"], row["STOP far from the target"], row["step limit"]) == (1, 1, 1)
    assert row["STOP near the target"] == 0 and gt_row["never detected"] == 0
    assert row["steps / GT's (median)"] == 1.75  # 1.5 and 2.0
    assert 0 < row["McNemar p"] <= 1 and gt_row["McNemar p"] is None
    assert row["paper SR %"] is gt_row["paper SR %"] is None  # the paper's VLFM has no MS TEST row
    assert set(traces["ms_test (ideal)"]) == {"lab_s1_v0/2", "lab_s1_v0/3", "lab_s1_v0/4"}
    assert row["STOP at another instance"] == 0 and twins == {}  # no manifest: not checked


def test_a_split_without_a_gt_run_stands_beside_the_published_one(tmp_path):
    learned = tmp_path / "learned"
    (learned / "ms_val").mkdir(parents=True)
    recs = [_rec(i, i < 3) for i in range(4)]
    (learned / "ms_val" / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    gt = _write(tmp_path / "gt", [_rec(0, True)])  # another split: no pair
    rows, traces, _ = vd.compare(learned, [gt], PUBLISHED)
    published, row = (dict(zip(vd.COLUMNS, r)) for r in rows)
    assert published["detector"] == "GT (published run)" and published["SR %"] == "92.0 [81.2, 96.8]"
    assert published["n"] == 50 and published["never detected"] is None
    assert row["detector"] == "learned" and row["SR %"].startswith("75.0") and row["McNemar p"] is None
    assert row["paper SR %"] == 38.0  # the paper's VLFM on MS VAL (its Table 5)
    assert traces == {}


def test_bad_folders_are_one_line_errors(tmp_path, capsys):
    gt = _write(tmp_path / "gt", [_rec(0, True)])
    other = _write(tmp_path / "realistic", [{**_rec(0, True), "noise": "realistic"}])
    rows, _, _ = vd.compare(other, [gt], PUBLISHED)  # another preset: not its pair
    assert [r[2] for r in rows] == ["learned"]
    elsewhere = _write(tmp_path / "elsewhere", [{**_rec(0, True), "episode_id": "99"}])
    with pytest.raises(vd.RunsError, match="share no episodes"):
        vd.compare(elsewhere, [gt], PUBLISHED)
    with pytest.raises(SystemExit):
        vd.main(["--learned", str(tmp_path / "nowhere")])
    assert "no such results folder" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        vd.main(["--learned", str(gt), "--published", str(tmp_path / "none.json")])
    assert "not the reproduction data" in capsys.readouterr().err


def test_the_changed_episodes_are_written_beside_the_table(tmp_path):
    gt = _write(tmp_path / "gt", [_rec(0, True, dtg=0.3), _rec(1, True)])
    learned = _write(tmp_path / "learned", [_rec(0, False, dtg=1.2, steps=50), _rec(1, True)])
    vd.main(["--learned", str(learned), "--gt", str(gt), "--data-out", str(tmp_path / "table.json")])
    episodes = json.loads((tmp_path / "table_episodes.json").read_text())
    assert episodes == {
        "ms_test (ideal)": {
            "lab_s1_v0/0": {
                "category": "incubator",
                "gt": "success",
                "learned": "STOP near the target",
                "dtg": [0.3, 1.2],
                "steps": [40, 50],
                "learned_detections": None,
            }
        }
    }


def _load_weights_script():
    spec_w = importlib.util.spec_from_file_location("vlfm_weights", REPO / "benchmarks" / "vlfm_weights.py")
    vw = importlib.util.module_from_spec(spec_w)
    spec_w.loader.exec_module(vw)
    return vw


def _split(folder: Path, split: str, successes: int, n: int, spec: str, never: int = 0) -> None:
    recs = [_rec(i, i < successes, seen=not (successes <= i < successes + never)) for i in range(n)]
    (folder / split).mkdir(parents=True)
    (folder / split / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    manifest = {"arguments": {"method_kwargs": {"detector": spec}}}
    (folder / split / "manifest.json").write_text(json.dumps(manifest))


def test_other_weights_are_set_beside_the_shipped_weights_runs(tmp_path):
    """benchmarks/vlfm_weights.py: a split's row holds the shipped weights' published SR, these weights' SR
    and traces, the difference and Fisher's exact p; a row per preset pools the splits; a folder must be of
    one weights file, and of the published run's episode count."""
    from scipy.stats import fisher_exact

    vw = _load_weights_script()
    weights = tmp_path / "w.safetensors"
    weights.write_bytes(b"weights")
    spec = f"trained:{weights}"
    run = tmp_path / "vlfm"
    _split(run, "ms_test", 30, 40, spec, never=4)
    _split(run, "ms_val", 20, 50, spec)
    cols = ["split", "noise", "detector", "n", "SR %"]
    shipped = [
        ["ms_test", "ideal", "learned", 40, "25.0 [x]"],
        ["ms_val", "ideal", "learned", 50, "66.2 [x]"],
    ]
    published = tmp_path / "published.json"
    published.write_text(json.dumps({"columns": cols, "rows": shipped}))
    assert vw.published_rows(published)[("ms_val", "ideal")][1] == 33  # 66.2 % of 50, rounded back
    rows, notes = vw.compare([run], vw.published_rows(published))
    test, val, pooled = (dict(zip(vw.COLUMNS, r)) for r in rows)
    assert test["split"] == "ms_test" and test["shipped weights: SR %"] == "25.0 [x]"
    assert test["these weights: SR %"].startswith("75.0 [") and test["difference (points)"] == 50.0
    assert (test["n (shipped)"], test["n (these)"], test["never detected"]) == (40, 40, 4)
    assert test["Fisher p"] == round(fisher_exact([[10, 30], [30, 10]]).pvalue, 3) < 0.001
    assert pooled["split"] == "all splits" and (pooled["n (shipped)"], pooled["n (these)"]) == (90, 90)
    assert pooled["Fisher p"] == round(fisher_exact([[43, 47], [50, 40]]).pvalue, 3)
    assert pooled["shipped weights: SR %"].startswith("47.8 [") and pooled["these weights: SR %"].startswith(
        "55.6"
    )
    assert notes == [f"vlfm: weights {vw.hashlib.sha256(b'weights').hexdigest()[:16]}"]
    _split(tmp_path / "short", "ms_test", 3, 9, spec)  # a run still going: refused, not compared
    with pytest.raises(vw.RunsError, match="9 episodes, the shipped weights' run 40"):
        vw.compare([tmp_path / "short"], vw.published_rows(published))
    _split(run, "two_room", 1, 2, "trained")
    with pytest.raises(vw.RunsError, match="2 detector specs"):
        vw.compare([run], vw.published_rows(published))
