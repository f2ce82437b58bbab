"""Statistics of the paper's appendix: McNemar's test for paired methods, and 95 % intervals.

- Proportions (SR, strict SR): Wilson score interval (``wilson_interval``), exact at 0/n and n/n.
- Means of bounded quantities (SPL and soft SPL in [0, 1], VRT in [0, 100] %, MCR and DTG >= 0 m):
  percentile bootstrap of the mean (``bootstrap_interval``): ``BOOTSTRAP_RESAMPLES`` resamples of the
  episodes with replacement drawn by ``numpy.random.default_rng(BOOTSTRAP_SEED)``, so an interval is a
  function of the values alone (the same sample gives the same interval on every run and machine), the
  2.5th and 97.5th percentiles of the resampled means, clipped to the quantity's range (an all-zero VRT
  sample gives [0, 0], never a negative bound as a t interval would).
- Several McNemar tests at once: Holm's step-down adjustment (``holm``), which controls the
  family-wise error rate without assuming the tests independent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import stats

from biovln_ms.metrics.intervals import wilson_interval  # noqa: F401  (the statistics' API)


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


BOOTSTRAP_RESAMPLES = 2000
BOOTSTRAP_SEED = 0


def _finite_values(values: Sequence[float]) -> np.ndarray:
    v = np.asarray([math.nan if x is None else x for x in values], float)
    if not np.all(np.isfinite(v)):
        raise ValueError(f"non-finite value in a mean: {v[~np.isfinite(v)][:3].tolist()}")
    return v


def bootstrap_interval(
    values: Sequence[float],
    low: float | None = None,
    high: float | None = None,
    confidence: float = 0.95,
    resamples: int = BOOTSTRAP_RESAMPLES,
    seed: int = BOOTSTRAP_SEED,
) -> tuple[float, float]:
    """Percentile bootstrap interval of a mean, clipped to [``low``, ``high``] (None: unbounded).

    Deterministic: the resamples come from ``numpy.random.default_rng(seed)``, so the same values give
    the same interval. nan with fewer than two values (one value says nothing about its spread). A
    missing or non-finite value is an error (``ValueError``), as in ``mean_interval``."""
    v = _finite_values(values)
    n = len(v)
    if n < 2:
        return (math.nan, math.nan)
    rng = np.random.default_rng(seed)
    means = np.empty(resamples)
    rows = max(1, 1_000_000 // n)  # bounded memory for large samples
    for start in range(0, resamples, rows):
        k = min(rows, resamples - start)
        means[start : start + k] = v[rng.integers(0, n, size=(k, n))].mean(axis=1)
    alpha = (1 - confidence) / 2
    lo, hi = (float(x) for x in np.quantile(means, [alpha, 1 - alpha]))
    if low is not None:
        lo, hi = max(lo, low), max(hi, low)
    if high is not None:
        lo, hi = min(lo, high), min(hi, high)
    return (lo, hi)


def holm(p_values: Sequence[float]) -> list[float]:
    """Holm's step-down adjusted p-values (same order as given): the k-th smallest of m is multiplied
    by m - k + 1, made non-decreasing in that order, and capped at 1. A test is significant at level
    alpha, the family-wise error rate held at alpha, when its adjusted p-value is below alpha."""
    p = np.asarray(p_values, float)
    m = len(p)
    order = np.argsort(p, kind="stable")
    adjusted = np.empty(m)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        adjusted[i] = running
    return adjusted.tolist()


def mean_interval(values: Sequence[float], confidence: float = 0.95) -> tuple[float, float]:
    """Student-t interval of a mean (nan with fewer than two values). A missing or non-finite value is an
    error (``ValueError``), never silently left out: the caller decides what such a value means. It
    ignores a quantity's range (an all-but-zero VRT sample gets a negative bound), so the metrics use
    ``bootstrap_interval``."""
    v = _finite_values(values)
    if len(v) < 2:
        return (math.nan, math.nan)
    half = stats.t.ppf(0.5 + confidence / 2, len(v) - 1) * v.std(ddof=1) / math.sqrt(len(v))
    return (float(v.mean() - half), float(v.mean() + half))
