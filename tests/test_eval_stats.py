import math

import numpy as np
import pytest

from biovln_ms.eval.aggregate import UNITS, aggregate, aggregate_all, record_error
from biovln_ms.eval.stats import (
    BOOTSTRAP_SEED,
    bootstrap_interval,
    holm,
    mcnemar,
    mean_interval,
    wilson_interval,
)


def paired(n01, n10, n11=50, n00=10):
    a = [False] * n01 + [True] * n10 + [True] * n11 + [False] * n00
    b = [True] * n01 + [False] * n10 + [True] * n11 + [False] * n00
    return a, b


@pytest.mark.parametrize("n01,n10,p_paper", [(20, 16, 0.619), (8, 6, 0.791), (16, 12, 0.572), (5, 3, 0.727)])
def test_mcnemar_reproduces_the_papers_table16(n01, n10, p_paper):
    r = mcnemar(*paired(n01, n10))
    assert (r.n01, r.n10) == (n01, n10)
    assert r.p_value == pytest.approx(p_paper, abs=0.003)
    assert r.exact == (n01 + n10 < 10)


def test_mcnemar_formula_and_edge_cases():
    r = mcnemar(*paired(30, 10))
    assert r.statistic == pytest.approx((20 - 1) ** 2 / 40)
    assert mcnemar([True, False], [True, False]).p_value == 1.0
    with pytest.raises(ValueError, match="differ in length"):
        mcnemar([True], [True, False])


def test_intervals():
    lo, hi = wilson_interval(40, 50)
    assert lo < 0.8 < hi and 0 <= lo and hi <= 1
    assert wilson_interval(0, 10)[0] == 0.0
    lo, hi = mean_interval([1.0, 2.0, 3.0])
    assert lo < 2.0 < hi
    assert all(math.isnan(x) for x in mean_interval([1.0]))


def _rec(success, spl, dtg, steps, mcr, vrt, cat="cabinet", diff="easy"):
    return dict(
        success=success,
        spl=spl,
        soft_spl=spl,
        dtg=dtg,
        steps=steps,
        mcr=mcr,
        vrt=vrt,
        object_category=cat,
        difficulty=diff,
        collisions=0,
        wall_time_s=1.0,
    )


def test_aggregate_follows_section_4_2():
    recs = [
        _rec(True, 0.8, 0.2, 10, 0.6, 0.0),
        _rec(False, 0.0, 3.0, 500, 0.3, 0.5, "refrigerator", "hard"),
        _rec(True, 1.0, 0.1, 20, 0.9, 0.1),
    ]
    a = aggregate(recs)
    assert a["sr"] == pytest.approx(200 / 3)
    assert a["spl"] == pytest.approx(0.6)
    assert a["dtg"] == pytest.approx(3.3 / 3)  # all episodes
    assert a["steps_success"] == pytest.approx(15)  # successful ones only
    assert a["mcr"] == pytest.approx(0.6) and a["vrt"] == pytest.approx(20.0)
    full = aggregate_all(recs + [dict(error="boom", object_category="cabinet", difficulty="easy")])
    assert full["overall"]["errors"] == 1 and full["overall"]["episodes"] == 4  # it counts, as a failure
    assert full["overall"]["sr"] == 50.0 and full["overall"]["spl"] == pytest.approx(1.8 / 4)
    assert full["overall"]["dtg"] == pytest.approx(3.3 / 3)  # over the episodes that ran
    assert set(full["per_category"]) == {"cabinet", "refrigerator"}
    assert full["per_difficulty"]["hard"]["sr"] == 0.0


# --- intervals in the metric's range, exact at the ends, deterministic --------------------------------
@pytest.mark.parametrize("n", [1, 7, 50, 160])
def test_wilson_is_exact_at_none_and_all(n):
    lo, hi = wilson_interval(0, n)
    assert lo == 0.0 and 0.0 < hi < 1.0
    lo, hi = wilson_interval(n, n)
    assert hi == 1.0 and 0.0 < lo < 1.0
    z2 = 1.959963984540054**2
    assert wilson_interval(0, n)[1] == pytest.approx(z2 / (n + z2))  # closed form at 0/n
    assert wilson_interval(n, n)[0] == pytest.approx(n / (n + z2))
    with pytest.raises(ValueError):
        wilson_interval(n + 1, n)


def test_bootstrap_is_clipped_to_the_range_and_an_all_zero_sample_gives_zero():
    assert bootstrap_interval([0.0] * 40, 0.0, 100.0) == (0.0, 0.0)  # an all-zero VRT: [0, 0]
    assert bootstrap_interval([1.0] * 40, 0.0, 1.0) == (1.0, 1.0)  # every SPL 1
    # a t interval of a sample mostly at 0 reaches below 0; the bootstrap, clipped, never does
    vrt = [0.0] * 18 + [30.0, 45.0]
    assert mean_interval(vrt)[0] < 0
    lo, hi = bootstrap_interval(vrt, 0.0, 100.0)
    assert lo == 0.0 and 0.0 < hi < 100.0
    # the bounds clip: an interval that would lie outside [low, high] is pushed inside
    assert bootstrap_interval([0.2, 0.4, 0.3], low=0.35)[0] == 0.35
    assert bootstrap_interval([0.2, 0.4, 0.3], high=0.25)[1] == 0.25
    lo, hi = bootstrap_interval([0.9, 1.0, 0.95, 1.0, 0.99], 0.0, 1.0)
    assert 0.9 <= lo <= hi <= 1.0


def test_bootstrap_is_deterministic_and_agrees_with_the_normal_theory_for_a_large_sample():
    rng = np.random.default_rng(7)
    v = rng.uniform(0, 1, 400).tolist()
    a = bootstrap_interval(v, 0.0, 1.0)
    assert a == bootstrap_interval(v, 0.0, 1.0)  # same values, same interval
    assert a != bootstrap_interval(v, 0.0, 1.0, seed=BOOTSTRAP_SEED + 1)  # the seed is what fixes it
    t_lo, t_hi = mean_interval(v)
    assert a[0] == pytest.approx(t_lo, abs=0.006) and a[1] == pytest.approx(t_hi, abs=0.006)
    assert a[0] < float(np.mean(v)) < a[1]
    assert all(math.isnan(x) for x in bootstrap_interval([0.5]))  # one value: no spread to resample
    with pytest.raises(ValueError, match="non-finite"):
        bootstrap_interval([0.1, math.nan])


def test_holm_step_down_adjustment():
    assert holm([0.01, 0.04, 0.03, 0.005]) == pytest.approx([0.03, 0.06, 0.06, 0.02])
    assert holm([0.5, 0.9]) == pytest.approx([1.0, 1.0])  # capped at 1
    assert holm([0.02]) == [0.02] and holm([]) == []
    # never below the raw p, and monotone in the raw p's order
    p = [0.001, 0.2, 0.013, 0.04, 0.04, 0.7]
    adj = holm(p)
    assert all(a >= r for a, r in zip(adj, p))
    order = sorted(range(len(p)), key=p.__getitem__)
    assert [adj[i] for i in order] == sorted(adj)


def test_aggregate_units_and_intervals_stay_in_range():
    recs = [_rec(i % 2 == 0, 0.9 * (i % 2 == 0), 0.2 + i % 2, 10, 0.3 + 0.1 * i, 0.0) for i in range(10)]
    for i, r in enumerate(recs):
        r["strict_success"] = bool(r["success"] and i % 4 == 0)  # episodes 0, 4, 8
    a = aggregate(recs)
    assert a["sr"] == 50.0 and a["successes"] == 5  # SR in percent
    assert [round(x, 6) for x in a["sr_ci95"]] == [round(100 * x, 6) for x in wilson_interval(5, 10)]
    assert a["strict_successes"] == 3 and a["strict_sr"] == 30.0
    assert a["strict_sr_ci95"] == pytest.approx([100 * x for x in wilson_interval(3, 10)])
    assert 0.0 <= a["spl_ci95"][0] <= a["spl"] <= a["spl_ci95"][1] <= 1.0  # SPL in [0, 1]
    assert a["vrt"] == 0.0 and a["vrt_ci95"] == [0.0, 0.0]  # no pose in Zone 2: [0, 0], not below
    assert a["mcr_ci95"][0] >= 0.0 and a["dtg_ci95"][0] >= 0.0
    assert a["soft_spl_ci95"][0] <= a["soft_spl"] <= a["soft_spl_ci95"][1]
    recs[0]["vrt"] = 0.5  # a record's share of poses, reported in percent
    assert aggregate(recs)["vrt"] == pytest.approx(5.0)
    assert 0.0 <= aggregate(recs)["vrt_ci95"][0] and aggregate(recs)["vrt_ci95"][1] <= 100.0
    assert set(UNITS) >= {"sr", "strict_sr", "spl", "vrt"} and UNITS["sr"] == UNITS["vrt"][0] == "%"


def test_strict_sr_is_unknown_for_older_records_and_a_non_boolean_is_an_error():
    old = aggregate([_rec(True, 0.9, 0.2, 10, 0.6, 0.0)] * 3)
    assert old["strict_successes"] is None and math.isnan(old["strict_sr"])
    assert all(math.isnan(x) for x in old["strict_sr_ci95"])
    bad = dict(_rec(True, 0.9, 0.2, 10, 0.6, 0.0), strict_success="yes")
    assert record_error(bad) == "metric 'strict_success' is 'yes'"
    errored = aggregate([dict(_rec(True, 1.0, 0.1, 5, 0.6, 0.0), strict_success=True), {"error": "boom"}])
    assert errored["strict_sr"] == 50.0  # an errored episode is a strict failure too
