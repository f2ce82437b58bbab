"""The learning guide's scene-count comparison (``benchmarks/ppo_scenes.py report``): run folders of
``biovln-ms train ppo`` and ``biovln-ms eval`` become a table whose cells are computed on the episodes
every run played, with McNemar's test on those pairs, and the curves and figure."""

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _run(
    folder: Path, dataset: str, outcomes: dict[str, list[bool]], seed: int = 0, split: str = "train"
) -> None:
    """A run folder as train ppo and eval write it: 2 envs, episodes ending every 100 steps."""
    folder.mkdir()
    config = {"split": split, "dataset": dataset, "seed": seed, "n_envs": 2, "scene_visit_episodes": 2}
    train = {"config": config, "timesteps": 2000, "steps_per_second": 50.0}
    (folder / "train.json").write_text(json.dumps(train))
    rows = ["timesteps,env,return,length,success,seconds"]
    rows += [f"{100 * (k + 1)},{k % 2},1.0,100,{float(k >= 10)},1.0" for k in range(20)]
    (folder / "episodes.csv").write_text("\n".join(rows) + "\n")
    for split, successes in outcomes.items():
        out = folder / "eval" / "ideal" / "ppo@opface-rl" / split
        out.mkdir(parents=True)
        records = [
            {"scene_id": "s", "episode_id": str(k), "success": ok, "spl": 0.5 * ok, "truncated": not ok}
            for k, ok in enumerate(successes)
        ]
        (out / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records))


def test_report_pairs_the_runs_episodes(held_out_dataset, tmp_path):
    dataset = held_out_dataset(train=6)
    # run a plays 12 episodes of ms_test, run b 10 (a killed eval): the cells use the 10 both played
    _run(tmp_path / "a", dataset, {"ms_test": [True] * 12})
    _run(tmp_path / "b", dataset, {"ms_test": [False] * 2 + [True] * 8})
    data, image = tmp_path / "data", tmp_path / "scenes.png"
    cmd = [sys.executable, str(ROOT / "benchmarks" / "ppo_scenes.py"), "report", "--steps", "2000"]
    cmd += ["--window", "500", "--data-out", str(data), "--image", str(image)]
    subprocess.run([*cmd, str(tmp_path / "a"), str(tmp_path / "b")], check=True, capture_output=True)
    table = json.loads((data / "ppo_scenes.json").read_text())
    a, b, p = table["rows"]  # the same seed twice: no row over seeds
    assert a[:6] == [
        "1 (1 single_room)",
        "0",
        "1",
        "20",
        "100",
        "50",
    ]  # one scene in the split, met; last quarter all successes
    assert a[6] == "100.0 [72, 100] / 0.50 (n 10)" and b[6] == "80.0 [49, 94] / 0.40 (n 10)"
    assert p[6] == "p = 0.5"  # 2 discordant pairs: the exact test
    assert set(a[7:]) == {"–"}  # no hard_test, no realistic runs
    curves = json.loads((data / "ppo_scenes_curves.json").read_text())["runs"]
    assert [pt[0] for pt in curves[0]["curve"]] == [500, 1000, 1500, 2000]
    assert curves[0]["eval"]["ideal"]["ms_test"]["mcnemar_p"] == 0.5
    assert image.read_bytes()[:4] == b"\x89PNG"


def test_report_averages_a_splits_seeds(held_out_dataset, tmp_path):
    """Runs of one training split with different seeds get a row of means (ranges) over them; a cell only
    some seeds have (realistic, say) is left out of it."""
    dataset = held_out_dataset(train=6)
    _run(tmp_path / "s0", dataset, {"ms_test": [True] * 10})
    _run(tmp_path / "s1", dataset, {"ms_test": [True] * 6 + [False] * 4}, seed=1)
    realistic = tmp_path / "s0" / "eval" / "realistic" / "ppo@opface-rl+realistic" / "ms_test"
    realistic.mkdir(parents=True)
    realistic.joinpath("episodes.jsonl").write_text(
        json.dumps({"scene_id": "s", "episode_id": "0", "success": True, "spl": 1.0, "truncated": False})
        + "\n"
    )
    data = tmp_path / "data"
    cmd = [sys.executable, str(ROOT / "benchmarks" / "ppo_scenes.py"), "report", "--steps", "2000"]
    cmd += ["--window", "500", "--data-out", str(data), "--image", str(tmp_path / "x.png")]
    subprocess.run([*cmd, str(tmp_path / "s0"), str(tmp_path / "s1")], check=True, capture_output=True)
    table = json.loads((data / "ppo_scenes.json").read_text())
    s0, s1, _, mean = table["rows"]
    assert (s0[1], s1[1]) == ("0", "1")
    assert s0[8] == "100.0 [21, 100] / 1.00 (n 1)" and s1[8] == "–"  # realistic: seed 0 only
    assert mean[0] == "1: mean (range) over 2 seeds" and mean[1] == "0, 1"
    assert mean[6] == "80.0 (60.0-100.0) / 0.40 (0.30-0.50)"  # SR and SPL over the seeds
    assert mean[8] == "–"


def test_report_tests_two_splits_over_their_seeds(held_out_dataset, tmp_path):
    """Two training splits with two seeds each: a mean row for each, Welch's t on their SRs across seeds,
    and a McNemar p below the table's precision shown as a bound."""
    from scipy.stats import ttest_ind

    dataset = held_out_dataset(train=6, other=6)
    outcomes = {"a0": [True] * 30, "b0": [False] * 30, "a1": [True] * 27 + [False] * 3}
    outcomes["b1"] = [True] * 6 + [False] * 24
    for name, ok in outcomes.items():
        split = "train" if name[0] == "a" else "other"
        _run(tmp_path / name, dataset, {"ms_test": ok}, seed=int(name[1]), split=split)
    data = tmp_path / "data"
    cmd = [sys.executable, str(ROOT / "benchmarks" / "ppo_scenes.py"), "report", "--steps", "2000"]
    cmd += ["--window", "500", "--data-out", str(data), "--image", str(tmp_path / "x.png")]
    folders = [str(tmp_path / n) for n in ("a0", "b0", "a1", "b1")]
    subprocess.run([*cmd, *folders], check=True, capture_output=True)
    rows = json.loads((data / "ppo_scenes.json").read_text())["rows"]
    mcnemar_row, mean_a, mean_b, welch = rows[4:]
    assert mcnemar_row[6] == "p < 0.0001"  # 30 discordant pairs, all one way
    assert mean_a[6].startswith("95.0 (90.0-100.0)") and mean_b[6].startswith("10.0 (0.0-20.0)")
    p = ttest_ind([100.0, 90.0], [0.0, 20.0], equal_var=False).pvalue
    assert welch[0] == "Welch's t over seeds (SR)" and welch[6] == f"p = {p:.2g}"
