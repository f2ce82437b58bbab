import math

import pytest

from biovln_ms.eval.metrics import aggregate, aggregate_all
from biovln_ms.eval.stats import mcnemar, mean_interval, wilson_interval


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
