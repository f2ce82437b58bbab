"""Statistics of the paper's appendix: McNemar's test for paired methods, and 95 % intervals."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class McNemarResult:
    n00: int
    n01: int  # A fails, B succeeds
    n10: int  # A succeeds, B fails
    n11: int
    statistic: float | None  # continuity-corrected chi-square (None for the exact test)
    p_value: float
    exact: bool


def mcnemar(success_a: Sequence[bool], success_b: Sequence[bool]) -> McNemarResult:
    """Two-sided McNemar test on paired outcomes (appendix "McNemar Test Formulation").

    chi2 = (|n01 - n10| - 1)^2 / (n01 + n10) with one degree of freedom; when n01 + n10 < 10 the
    exact binomial test is used instead.
    """
    a = np.asarray(success_a, bool)
    b = np.asarray(success_b, bool)
    if a.shape != b.shape:
        raise ValueError(f"paired outcomes differ in length ({len(a)} vs {len(b)})")
    n01 = int(np.sum(~a & b))
    n10 = int(np.sum(a & ~b))
    n00 = int(np.sum(~a & ~b))
    n11 = int(np.sum(a & b))
    n = n01 + n10
    if n == 0:
        return McNemarResult(n00, n01, n10, n11, None, 1.0, True)
    if n < 10:
        p = float(stats.binomtest(min(n01, n10), n, 0.5, alternative="two-sided").pvalue)
        return McNemarResult(n00, n01, n10, n11, None, min(p, 1.0), True)
    chi2 = (abs(n01 - n10) - 1) ** 2 / n
    return McNemarResult(n00, n01, n10, n11, chi2, float(stats.chi2.sf(chi2, 1)), False)


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a proportion (well behaved near 0 and 1, unlike the normal one)."""
    if n == 0:
        return (math.nan, math.nan)
    z = stats.norm.ppf(0.5 + confidence / 2)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return (max(0.0, centre - half), min(1.0, centre + half))


def mean_interval(values: Sequence[float], confidence: float = 0.95) -> tuple[float, float]:
    """Student-t interval of a mean (nan with fewer than two values). A missing or non-finite value is an
    error (``ValueError``), never silently left out: the caller decides what such a value means."""
    v = np.asarray([math.nan if x is None else x for x in values], float)
    if not np.all(np.isfinite(v)):
        raise ValueError(f"non-finite value in a mean: {v[~np.isfinite(v)][:3].tolist()}")
    if len(v) < 2:
        return (math.nan, math.nan)
    half = stats.t.ppf(0.5 + confidence / 2, len(v) - 1) * v.std(ddof=1) / math.sqrt(len(v))
    return (float(v.mean() - half), float(v.mean() + half))
