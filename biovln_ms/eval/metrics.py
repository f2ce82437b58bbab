"""Aggregate metrics of §4.2 from per-episode records: SR, SPL, DTG, steps, MCR, VRT (+ intervals).

SR: share of successful episodes (the paper's radius success, ``success``). Strict SR: share with
``strict_success`` (STOP within r, in Zone 3 and facing the face: issue 15 item 4); None when a record
that ran has no ``strict_success`` (results of an older version). SPL: mean of success * l_opt /
max(l, l_opt). DTG: mean final Euclidean distance over all episodes. Steps: mean actions over
successful episodes. MCR: mean over episodes of each trajectory's minimum clearance (robot centre to the
nearest instrument body, radius not subtracted). VRT: mean over episodes of the share of poses within
0.5 m of a body, in percent.

Every episode counts. An episode that failed to run (an ``error`` in its record, or a missing or
non-finite metric: ``record_error``) is a failure: success False, SPL and soft SPL 0, in SR, SPL and
their intervals. It has no final distance, trajectory or clearance, so DTG, steps, MCR, VRT and
collisions are means over the episodes that ran (``episodes - errors``); ``errors`` counts the rest.

Units (``UNITS``), the same in ``summary.json``, the report's ``measured.json`` and its tables: SR, strict
SR and VRT in percent, SPL and soft SPL in [0, 1], DTG and MCR in metres. Each ``*_ci95`` is a 95 %
interval in its metric's unit (``biovln_ms.eval.stats``): Wilson for SR and strict SR, a seeded
percentile bootstrap clipped to the metric's range for SPL, soft SPL, DTG, MCR and VRT.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Iterable

import numpy as np

from biovln_ms.eval.stats import BOOTSTRAP_RESAMPLES, BOOTSTRAP_SEED, bootstrap_interval, wilson_interval

UNITS = {
    "sr": "%",
    "strict_sr": "%",
    "spl": "fraction in [0, 1]",
    "soft_spl": "fraction in [0, 1]",
    "dtg": "m",
    "steps_success": "actions",
    "mcr": "m",
    "vrt": "% of poses",
    "collisions": "per episode",
}
INTERVALS = (
    "95 % intervals (*_ci95, in the metric's unit): Wilson score for SR and strict SR; percentile "
    f"bootstrap of the mean ({BOOTSTRAP_RESAMPLES} resamples, numpy default_rng seed {BOOTSTRAP_SEED}) "
    "clipped to the metric's range for SPL and soft SPL ([0, 1]), VRT ([0, 100] %), DTG and MCR (>= 0 m)"
)

METRICS = ("success", "spl", "soft_spl", "dtg", "steps", "mcr", "vrt")  # every record that ran has these
OPTIONAL_METRICS = ("collisions",)  # checked when present


def record_error(r: dict) -> str | None:
    """Why the record is an errored episode (its ``error``, or a missing or non-finite metric), else None."""
    if r.get("error"):
        return str(r["error"])
    for k in METRICS + OPTIONAL_METRICS:
        if k not in r:
            if k in OPTIONAL_METRICS:
                continue
            return f"metric '{k}' is missing"
        v = r[k]
        number = isinstance(v, (int, float)) and not isinstance(v, bool)
        if not (isinstance(v, bool) if k == "success" else number and math.isfinite(v)):
            return f"metric '{k}' is {v!r}"
    if "strict_success" in r and not isinstance(r["strict_success"], bool):
        return f"metric 'strict_success' is {r['strict_success']!r}"
    return None


def succeeded(r: dict) -> bool:
    """The episode's outcome, an errored episode being a failure."""
    return record_error(r) is None and bool(r["success"])


def _mean(xs: Iterable[float]) -> float:
    """Mean of validated values (nan when there are none); a non-finite one is a bug, not skipped."""
    v = np.asarray(list(xs), float)
    if not np.all(np.isfinite(v)):
        raise ValueError(f"non-finite value in a mean: {v[~np.isfinite(v)][:3].tolist()}")
    return float(v.mean()) if len(v) else math.nan


def _percent_interval(k: int | None, n: int) -> list[float]:
    """The Wilson interval of k successes in n, in percent (nan when k is unknown or n is 0)."""
    return [math.nan, math.nan] if k is None else [100.0 * x for x in wilson_interval(k, n)]


def aggregate(records: Iterable[dict]) -> dict:
    """The metrics of a set of episodes, errored ones included (see the module's docstring)."""
    records = list(records)
    ran = [r for r in records if record_error(r) is None]
    n = len(records)
    k = sum(bool(r["success"]) for r in ran)
    strict = None if any("strict_success" not in r for r in ran) else sum(r["strict_success"] for r in ran)
    spl = [float(r["spl"]) for r in ran] + [0.0] * (n - len(ran))
    soft_spl = [float(r["soft_spl"]) for r in ran] + [0.0] * (n - len(ran))
    dtg, mcr = [float(r["dtg"]) for r in ran], [float(r["mcr"]) for r in ran]
    vrt = [100.0 * float(r["vrt"]) for r in ran]  # a record's share of poses -> percent
    walls = [r["wall_time_s"] for r in records if isinstance(r.get("wall_time_s"), (int, float))]
    return {
        "episodes": n,
        "errors": n - len(ran),
        "successes": k,
        "sr": 100.0 * k / n if n else math.nan,
        "sr_ci95": _percent_interval(k, n),
        "strict_successes": strict,
        "strict_sr": 100.0 * strict / n if n and strict is not None else math.nan,
        "strict_sr_ci95": _percent_interval(strict, n),
        "spl": _mean(spl),
        "spl_ci95": list(bootstrap_interval(spl, 0.0, 1.0)),
        "soft_spl": _mean(soft_spl),
        "soft_spl_ci95": list(bootstrap_interval(soft_spl, 0.0, 1.0)),
        "dtg": _mean(dtg),
        "dtg_ci95": list(bootstrap_interval(dtg, 0.0)),
        "steps_success": _mean(r["steps"] for r in ran if r["success"]),
        "mcr": _mean(mcr),
        "mcr_ci95": list(bootstrap_interval(mcr, 0.0)),
        "vrt": _mean(vrt),
        "vrt_ci95": list(bootstrap_interval(vrt, 0.0, 100.0)),
        "collisions": _mean(r.get("collisions", 0) for r in ran),
        "wall_time_s": _mean(w for w in walls if math.isfinite(w)),  # timing, not a metric
    }


def aggregate_all(records: list[dict]) -> dict:
    """Overall, per category and per difficulty tier (errored episodes in each)."""
    by_cat, by_diff = defaultdict(list), defaultdict(list)
    for r in records:
        by_cat[r.get("object_category", "unknown")].append(r)
        by_diff[r.get("difficulty", "unknown")].append(r)
    return {
        "overall": aggregate(records),
        "per_category": {c: aggregate(v) for c, v in sorted(by_cat.items())},
        "per_difficulty": {d: aggregate(by_diff[d]) for d in ("easy", "medium", "hard") if d in by_diff},
    }
