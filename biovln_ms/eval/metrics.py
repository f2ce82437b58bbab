"""Aggregate metrics of §4.2 from per-episode records: SR, SPL, DTG, steps, MCR, VRT (+ intervals).

SR: share of successful episodes. SPL: mean of success * l_opt / max(l, l_opt). DTG: mean final
Euclidean distance over all episodes. Steps: mean actions over successful episodes. MCR: mean over
episodes of each trajectory's minimum clearance (robot centre to the nearest instrument body, radius
not subtracted). VRT: mean over episodes of the share of poses within 0.5 m of a body, in percent.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Iterable

import numpy as np

from biovln_ms.eval.stats import mean_interval, wilson_interval


def _mean(xs) -> float:
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    return float(np.mean(xs)) if xs else math.nan


def aggregate(records: Iterable[dict]) -> dict:
    recs = [r for r in records if not r.get("error")]
    n = len(recs)
    succ = [bool(r["success"]) for r in recs]
    k = sum(succ)
    out = {
        "episodes": n,
        "errors": 0,
        "sr": 100.0 * k / n if n else math.nan,
        "sr_ci95": [100.0 * x for x in wilson_interval(k, n)],
        "spl": _mean(r["spl"] for r in recs),
        "spl_ci95": list(mean_interval([r["spl"] for r in recs])),
        "soft_spl": _mean(r["soft_spl"] for r in recs),
        "dtg": _mean(r["dtg"] for r in recs),
        "dtg_ci95": list(mean_interval([r["dtg"] for r in recs])),
        "steps_success": _mean(r["steps"] for r in recs if r["success"]),
        "mcr": _mean(r["mcr"] for r in recs),
        "mcr_ci95": list(mean_interval([r["mcr"] for r in recs])),
        "vrt": 100.0 * _mean(r["vrt"] for r in recs),
        "vrt_ci95": [100.0 * x for x in mean_interval([r["vrt"] for r in recs])],
        "collisions": _mean(r.get("collisions", 0) for r in recs),
        "wall_time_s": _mean(r.get("wall_time_s") for r in recs),
    }
    return out


def aggregate_all(records: list[dict]) -> dict:
    """Overall, per category and per difficulty tier."""
    ok = [r for r in records if not r.get("error")]
    by_cat, by_diff = defaultdict(list), defaultdict(list)
    for r in ok:
        by_cat[r["object_category"]].append(r)
        by_diff[r["difficulty"]].append(r)
    overall = aggregate(ok)
    overall["errors"] = len(records) - len(ok)
    return {
        "overall": overall,
        "per_category": {c: aggregate(v) for c, v in sorted(by_cat.items())},
        "per_difficulty": {d: aggregate(by_diff[d]) for d in ("easy", "medium", "hard") if d in by_diff},
    }
