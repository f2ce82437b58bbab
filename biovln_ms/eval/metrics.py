"""Aggregate metrics of §4.2 from per-episode records: SR, SPL, DTG, steps, MCR, VRT (+ intervals).

SR: share of successful episodes. SPL: mean of success * l_opt / max(l, l_opt). DTG: mean final
Euclidean distance over all episodes. Steps: mean actions over successful episodes. MCR: mean over
episodes of each trajectory's minimum clearance (robot centre to the nearest instrument body, radius
not subtracted). VRT: mean over episodes of the share of poses within 0.5 m of a body, in percent.

Every episode counts. An episode that failed to run (an ``error`` in its record, or a missing or
non-finite metric: ``record_error``) is a failure: success False, SPL and soft SPL 0, in SR, SPL and
their intervals. It has no final distance, trajectory or clearance, so DTG, steps, MCR, VRT and
collisions are means over the episodes that ran (``episodes - errors``); ``errors`` counts the rest.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Iterable

import numpy as np

from biovln_ms.eval.stats import mean_interval, wilson_interval

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


def aggregate(records: Iterable[dict]) -> dict:
    """The metrics of a set of episodes, errored ones included (see the module's docstring)."""
    records = list(records)
    ran = [r for r in records if record_error(r) is None]
    n = len(records)
    k = sum(bool(r["success"]) for r in ran)
    spl = [float(r["spl"]) for r in ran] + [0.0] * (n - len(ran))
    soft_spl = [float(r["soft_spl"]) for r in ran] + [0.0] * (n - len(ran))
    walls = [r["wall_time_s"] for r in records if isinstance(r.get("wall_time_s"), (int, float))]
    return {
        "episodes": n,
        "errors": n - len(ran),
        "sr": 100.0 * k / n if n else math.nan,
        "sr_ci95": [100.0 * x for x in wilson_interval(k, n)],
        "spl": _mean(spl),
        "spl_ci95": list(mean_interval(spl)),
        "soft_spl": _mean(soft_spl),
        "dtg": _mean(r["dtg"] for r in ran),
        "dtg_ci95": list(mean_interval([r["dtg"] for r in ran])),
        "steps_success": _mean(r["steps"] for r in ran if r["success"]),
        "mcr": _mean(r["mcr"] for r in ran),
        "mcr_ci95": list(mean_interval([r["mcr"] for r in ran])),
        "vrt": 100.0 * _mean(r["vrt"] for r in ran),
        "vrt_ci95": [100.0 * x for x in mean_interval([r["vrt"] for r in ran])],
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
