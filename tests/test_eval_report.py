"""The honest report: intervals in every table, episode counts in every cell, partial
runs labelled and kept out of the comparison with the paper, one unit convention, significance with
Holm's correction, and a figure called "hard" only for a hard episode. Pure data: no simulator."""

from __future__ import annotations

import json
import re

import pytest

from biovln_ms.eval import paper
from biovln_ms.eval.figures import hard_episodes, hard_figure_title
from biovln_ms.eval.paper_tables import (
    SPLIT_EPISODES,
    differences,
    mcnemar_table,
    other_measures_table,
    people_table,
    table5,
    table9,
    table10,
    table11,
)
from biovln_ms.eval.report import summarize, tables, tables_of
from biovln_ms.eval.stats import holm, wilson_interval


def _records(successes: list[bool], strict: list[bool] | None = None, difficulty: str = "easy") -> list[dict]:
    strict = strict if strict is not None else [False] * len(successes)
    return [
        {
            "scene_id": "lab_s154_v0",
            "episode_id": str(i),
            "object_category": "cabinet" if i % 2 else "waste_bin",
            "difficulty": difficulty,
            "geodesic_distance": 2.0 + i / 10,
            "success": ok,
            "strict_success": st,
            "spl": 0.9 * ok,
            "soft_spl": 0.8,
            "dtg": 0.5 if ok else 2.0,
            "steps": 20 + i,
            "mcr": 0.6,
            "vrt": 0.0,
            "collisions": 0,
        }
        for i, (ok, st) in enumerate(zip(successes, strict))
    ]


def _row(lines: list[str], start: str) -> str:
    return next(line for line in lines if line.startswith(start))


def _section(lines: list[str], heading: str) -> list[str]:
    """The lines of a table5/table10 block from its split's heading to the next blank line after the rows."""
    i = next(i for i, line in enumerate(lines) if line.startswith(heading))
    j = next(j for j in range(i + 2, len(lines)) if not lines[j])
    return lines[i:j]


def test_summary_units_intervals_and_strict_sr():
    ok = [True] * 30 + [False] * 20
    summ = summarize({("frontier", "ms_val"): _records(ok, [True] * 10 + [False] * 40)})
    assert summ["units"]["sr"] == "%" and summ["units"]["strict_sr"] == "%"
    assert summ["units"]["spl"].startswith("fraction in [0, 1]") and summ["units"]["vrt"].startswith("%")
    assert "Wilson" in summ["intervals"] and "bootstrap" in summ["intervals"]
    o = summ["runs"]["frontier"]["ms_val"]["overall"]
    assert o["sr"] == 60.0 and o["strict_sr"] == 20.0  # percent, both
    assert o["sr_ci95"] == pytest.approx([100 * x for x in wilson_interval(30, 50)])
    assert o["strict_sr_ci95"] == pytest.approx([100 * x for x in wilson_interval(10, 50)])
    assert 0 <= o["spl"] <= 1 and 0 <= o["spl_ci95"][0] <= o["spl_ci95"][1] <= 1  # SPL a fraction
    assert o["vrt"] == 0.0 and o["vrt_ci95"] == [0.0, 0.0]  # percent, never below 0
    json.dumps(summ, allow_nan=False)  # plain JSON: no NaN
    lines = table5(summ)
    row = _row(_section(lines, "**MS VAL**"), "| Frontier |")
    lo, hi = o["sr_ci95"]
    slo, shi = o["strict_sr_ci95"]
    assert row.startswith(
        f"| Frontier | 50 | 60.0 [{lo:.1f}, {hi:.1f}] (80.0) | 20.0 [{slo:.1f}, {shi:.1f}] |"
    )
    assert "| 0.0 [0.0, 0.0] |" in row  # VRT
    assert "| Method | n | SR % | strict SR % | SPL | MCR m | VRT % |" in lines
    t10 = _row(_section(table10(summ), "**MS VAL**"), "| Frontier |")
    assert "| 20.0 [" in t10 and "(114.5); n=30 |" in t10  # strict SR; steps over the 30 successes


def test_a_partial_run_is_labelled_and_not_compared_with_the_paper():
    runs = {
        ("oracle", "ms_val"): _records([True] * 5),  # 5 of 50: partial, 100 % vs the paper's 76 %
        ("random", "ms_val"): _records([True] * 40 + [False] * 10),  # all 50: 80 % vs the paper's 22 %
    }
    summ = summarize(runs)
    assert SPLIT_EPISODES == {
        **{"ms_dev": 160, "ms_val": 50, "ms_test": 120, "two_room": 50, "lsat_target": 40},
        **{"hard_val": 160, "hard_test": 160},
    }
    oracle, rnd = summ["runs"]["oracle"]["ms_val"], summ["runs"]["random"]["ms_val"]
    assert (oracle["partial"], oracle["split_episodes"]) == (True, 50)
    assert (rnd["partial"], rnd["split_episodes"]) == (False, 50)
    t5 = _section(table5(summ), "**MS VAL** (full split: 50 episodes)")
    assert _row(t5, "| Oracle |").startswith("| Oracle | partial (5/50) | 100.0 [")
    assert _row(t5, "| Random |").startswith("| Random | 50 | 80.0 [")
    assert _row(table11(summ), "| Difficulty |").count("partial") == 0  # frontier did not run
    prose = "\n".join(differences(summ))
    assert "Random on MS VAL: SR 80.0 % vs 22.0 % in the paper" in prose  # a full run is compared
    assert "Oracle on MS VAL: SR" not in prose  # a partial run is not
    assert (
        "Not compared with the paper (partial runs" in prose and "Oracle on MS VAL: partial (5/50)" in prose
    )
    # the dataset's own split sizes replace the benchmark's: 5 of a 5-episode split is the whole split
    whole = summarize(runs, {"ms_val": 5})["runs"]["oracle"]["ms_val"]
    assert not whole["partial"] and whole["split_episodes"] == 5
    assert "partial" not in _row(_section(tables(runs, {"ms_val": 5})[0], "**MS VAL**"), "| Oracle |")


def test_every_cell_of_the_breakdowns_shows_its_episode_count():
    runs = {("frontier", "ms_dev"): _records([True] * 3 + [False] * 2, difficulty="medium")}
    summ = summarize(runs)
    head = _row(table11(summ), "| Difficulty |")
    assert "Frontier MS DEV: partial (5/160)" in head
    medium = _row(table11(summ), "| medium |")
    lo, hi = (100 * x for x in wilson_interval(3, 5))
    assert f"| 60.0 [{lo:.1f}, {hi:.1f}] (84.4); n=5 |" in medium
    assert _row(table11(summ), "| hard |").startswith("| hard | – (66.7) |")  # no hard episode: –, not 0


def test_mcnemar_marks_the_pairs_that_differ_after_holms_correction():
    n = 60
    frontier = [False] * 3 + [True] * 12 + [False] * 45
    runs = {
        ("random", "ms_val"): _records([True] * 3 + [False] * 57),
        ("oracle", "ms_val"): _records([True] * n),
        ("zone3_oracle", "ms_val"): _records([True] * n),  # the same outcomes as oracle: p = 1
        # vs random: 12 wins, 3 losses: raw p 0.039 < 0.05, but 0.078 after Holm over the six tests
        ("frontier", "ms_val"): _records(frontier),
    }
    summ = summarize(runs, {"ms_val": n})  # a 60-episode split: every run whole
    tests = {(t["a"], t["b"]): t for t in summ["mcnemar"]}
    assert len(tests) == 6
    raw = [t["p"] for t in summ["mcnemar"]]
    assert [t["p_holm"] for t in summ["mcnemar"]] == pytest.approx(holm(raw))
    rf = tests[("random", "frontier")]
    assert (rf["n01"], rf["n10"]) == (12, 3) and rf["p"] == pytest.approx(0.0389, abs=5e-4)
    assert rf["p_holm"] == pytest.approx(2 * rf["p"])  # the fifth smallest of six: times 2
    assert rf["p"] < 0.05 <= rf["p_holm"] and not rf["significant"]  # significant before Holm only
    assert tests[("oracle", "zone3_oracle")]["p_holm"] == 1.0
    assert not tests[("oracle", "zone3_oracle")]["significant"]
    for pair in (("random", "oracle"), ("random", "zone3_oracle"), ("oracle", "frontier")):
        assert tests[pair]["significant"] and tests[pair]["p_holm"] < 0.05, pair
    assert rf["sr_b_ci95"] == pytest.approx([100 * x for x in wilson_interval(12, n)])
    lines = mcnemar_table(summ)
    assert any("Holm's step-down correction over all 6 McNemar tests" in line for line in lines)
    lo, hi = rf["sr_b_ci95"]
    alo, ahi = (100 * x for x in wilson_interval(3, n))
    row = _row(lines, "| Random | Frontier |")
    sr_a, sr_b = f"5.0 [{alo:.1f}, {ahi:.1f}]", f"20.0 [{lo:.1f}, {hi:.1f}]"
    assert row.startswith(f"| Random | Frontier | MS VAL | 60 | {sr_a} | {sr_b} | 12 | 3 | χ² (cc) |")
    assert row.endswith(f"| {rf['p']:.3f} | {rf['p_holm']:.3f} | no | – |")
    assert _row(lines, "| Random | Oracle |").endswith("| **yes** | – |")
    assert _row(lines, "| Oracle | 3-Zone Oracle |").endswith("| 1.000 | 1.000 | no | – |")


def test_table9_shows_holm_and_the_centroid_runs_partial_label():
    runs = {
        ("frontier", "ms_val"): _records([True] * 10),
        ("frontier@centroid", "ms_val"): _records([False] * 9 + [True]),
    }
    summ = summarize(runs)
    row = _row(table9(summ), "| MS VAL")
    t = summ["mcnemar"][0]
    assert t["p_holm"] == t["p"]  # one test: nothing to adjust
    assert row.startswith("| MS VAL (10; partial (10/50)) | 10.0 [1.8, 40.4] | 100.0 [72.2, 100.0] | -90.0 |")
    assert f"| {t['p']:.3f} | {t['p_holm']:.3f} | **yes** |" in row
    assert row.endswith(
        f"| {' / '.join(str(x) for x in paper.TABLE9['Frontier']['ms_val'][:2])} / -18.0 / 0.035 |"
    )


def test_tables_survive_json_and_the_seeded_reproduction_data_renders():
    runs = {
        ("frontier", "ms_val"): _records([True, True, False, True]),
        ("frontier@centroid", "ms_val"): _records([False, True, False, False]),
    }
    assert tables_of(json.loads(json.dumps(summarize(runs)))) == tables(runs)
    from pathlib import Path

    data = json.loads((Path(__file__).parents[1] / "docs" / "data" / "reproduction.json").read_text())
    assert data["schema"] == 2 and data["units"]["sr"] == "%"
    text = "\n".join(line for block in tables_of(data) for line in block)
    assert "| Frontier | 160 | 100.0 [97.7, 100.0] (74.4) |" in text  # MS DEV (the paper's 74.4)
    assert not re.search(r"partial \(\d+/\d+\)", text)  # every committed run covered its split
    assert "| MS DEV (160) | 99.4 [96.5, 99.9] | 100.0 [97.7, 100.0] | -0.6 |" in text


def _hard(rec: dict, geodesic: float) -> dict:
    return dict(rec, difficulty="hard", geodesic_distance=geodesic, method="frontier")


def test_a_figure_is_called_hard_only_for_a_hard_episode():
    easy = _records([True] * 3)
    hard = _hard(easy[0], 6.8)
    assert hard_figure_title(hard, True).startswith("Hard episode lab_s154_v0/0 (geodesic 6.8 m): success")
    title = hard_figure_title(easy[2], False)
    assert "Hard episode" not in title and title.startswith("No hard episode (geodesic > 6 m) in these runs")
    assert "the longest, easy episode lab_s154_v0/2 (geodesic 2.2 m)" in title and "failure" in title
    # the picker: hard episodes when there are any (even when a medium one is longer), else the longest
    medium = dict(easy[1], difficulty="medium", geodesic_distance=7.5)
    picked, any_hard = hard_episodes({("frontier", "ms_val"): [easy[2], medium, hard]}, 2)
    assert any_hard and picked == [hard]
    picked, any_hard = hard_episodes({("frontier", "ms_val"): easy, ("oracle", "ms_val"): [hard]}, 2)
    assert not any_hard and picked == [easy[2], easy[1]]  # frontier's only; oracle's hard one is not drawn
    errored = dict(hard, error="boom")
    assert hard_episodes({("frontier", "ms_val"): [errored]}, 2) == ([], False)  # no trajectory to draw


def test_the_benchmark_table_ranks_every_method_under_each_preset_and_tests_the_noise():
    from biovln_ms.eval.paper_tables import benchmark_table

    n = 40
    runs = {
        ("oracle", "hard_val"): _records([True] * n, difficulty="hard"),
        ("oracle+realistic", "hard_val"): _records([True] * n, difficulty="hard"),
        ("frontier", "hard_val"): _records([True] * 30 + [False] * 10, difficulty="hard"),
        ("frontier+realistic", "hard_val"): _records([True] * 10 + [False] * 30, difficulty="hard"),
    }
    summ = summarize(runs, {"hard_val": n})
    pairs = {(t["a"], t["b"]) for t in summ["mcnemar"]}
    # within a preset, and each method against itself under noise
    assert pairs == {
        ("oracle", "frontier"),
        ("oracle+realistic", "frontier+realistic"),
        ("oracle+realistic", "oracle"),
        ("frontier+realistic", "frontier"),
    }
    lines = benchmark_table(summ)
    block = _section(lines, "**Hard VAL**")
    assert "(full split: 40 episodes)" in block[0]
    assert _row(block, "| Oracle (privileged) | ideal | 40 | 100.0").count("|") == 9
    assert _row(block, "| Frontier | realistic | 40 | 25.0 [")
    assert [r.split(" | ")[1] for r in block[4:]] == ["ideal", "realistic", "ideal", "realistic"]
    noise = _row(mcnemar_table(summ), "| Frontier (realistic) | Frontier | Hard VAL | 40 |")
    assert "| 20 | 0 |" in noise and "**yes**" in noise  # n01: realistic fails where ideal succeeds
    assert SPLIT_EPISODES["hard_val"] == SPLIT_EPISODES["hard_test"] == 160


def test_the_people_table_shows_busy_runs_beside_their_empty_lab_sr():
    people = {
        "min_person_distance": 0.6,
        "personal_space_rate": 20.0,
        "person_collisions": 0,
        "robot_wait_time": 5.0,
        "people_wait_time": 1.5,
        "occupied_stop": False,
        "mcr_people": 0.4,
        "vrt_people": 30.0,
    }
    busy = [{**r, **people} for r in _records([True] * 3 + [False])]
    summ = summarize(
        {
            ("frontier@opface-busy", "busy_val"): busy,
            ("frontier", "ms_val"): _records([True] * 4),
            ("ppo@opface-rl-busy", "busy_test"): busy[:2],  # the RL methods' variant with people
            ("ppo", "ms_val"): _records([True, False]),  # the suite names its ideal run by the method
        }
    )
    lines = people_table(summ)
    assert _row(lines, "| PPO | ideal | busy_test | 2 | 100.0").endswith("| 50.0 [9.5, 90.5] / – |")
    head, row = _row(lines, "| Method"), _row(lines, "| Frontier | ideal | busy_val")
    assert "min. person distance m" in head and head.endswith("empty lab SR % |")
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[4].startswith("75.0") and cells[6].startswith("0.600")
    assert cells[-1].startswith("100.0") and cells[-1].endswith(" / –")  # ms_val, and hard_val not run
    other = "\n".join(other_measures_table(summ))
    assert "min. person distance" not in other  # shown once, in the people table
    for label in ("people waiting", "MCR (people too)", "VRT (people too)"):  # people as obstacles too
        assert label in head and label not in other
    assert people_table(summarize({("frontier", "ms_val"): _records([True])})) == []
