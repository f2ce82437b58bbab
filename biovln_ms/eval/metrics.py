"""Aggregate metrics of §4.2 from per-episode records: SR, SPL, DTG, steps, MCR, VRT (+ intervals).

SR: share of successful episodes (the paper's radius success, ``success``). Strict SR: share with
``strict_success`` (STOP within r, in Zone 3 and facing the face: issue 15 item 4); None when a record
that ran has no ``strict_success`` (results of an older version). SPL: mean of success * l_opt /
max(l, l_opt). DTG: mean final Euclidean distance over all episodes. Steps: mean actions over
successful episodes. MCR: mean over episodes of each trajectory's minimum clearance (robot centre to the
nearest instrument body, radius not subtracted). VRT: mean over episodes of the share of poses within
0.5 m of a body, in percent. Fetch runs (records with ``reachable``, issue 16 item 4): reach SR, the share
with ``reach_success`` (a success from which the gripper reaches the goal's interaction point), and the
share of successes that are reachable; None / NaN for runs without an arm.

Every episode counts. An episode that failed to run (an ``error`` in its record, or a missing or
non-finite metric: ``record_error``) is a failure: success False, SPL and soft SPL 0, in SR, SPL and
their intervals. It has no final distance, trajectory or clearance, so DTG, steps, MCR, VRT and
collisions are means over the episodes that ran (``episodes - errors``); ``errors`` counts the rest.

Units (``UNITS``), the same in ``summary.json``, the report's ``measured.json`` and its tables: SR, strict
SR and VRT in percent, SPL and soft SPL in [0, 1], DTG and MCR in metres. Each ``*_ci95`` is a 95 %
interval in its metric's unit (``biovln_ms.eval.stats``): Wilson for SR and strict SR, a seeded
percentile bootstrap clipped to the metric's range for SPL, soft SPL, DTG, MCR and VRT.

Protocol episodes (``BioVLN-Protocol-v0``, records with a ``protocol`` object) have their own metrics
(:func:`aggregate_protocol`, ``PROTOCOL_UNITS``): SR (every goal reached), progress, PPL, per-stage SR,
MCR, VRT, Zone-2 steps, steps, path length and wrong STOPs, the same rules for errored episodes.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Iterable

import numpy as np

from biovln_ms.constants import MAX_VISITS as MAX_STAGES
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
    "reach_sr": "%",
    "reachable_of_successes": "% of successes",
}
INTERVALS = (
    "95 % intervals (*_ci95, in the metric's unit): Wilson score for SR and strict SR; percentile "
    f"bootstrap of the mean ({BOOTSTRAP_RESAMPLES} resamples, numpy default_rng seed {BOOTSTRAP_SEED}) "
    "clipped to the metric's range for SPL and soft SPL ([0, 1]), VRT ([0, 100] %), DTG and MCR (>= 0 m)"
)

METRICS = ("success", "spl", "soft_spl", "dtg", "steps", "mcr", "vrt")  # every record that ran has these
OPTIONAL_METRICS = ("collisions",)  # checked when present
#: ... and those of a protocol episode (a record with a ``protocol`` object, BioVLN-Protocol-v0)
PROTOCOL_METRICS = ("success", "progress", "ppl", "steps", "mcr", "vrt", "zone2_steps", "path_length")
PROTOCOL_UNITS = {
    "sr": "% (every goal reached)",
    "progress": "fraction of goals reached, in [0, 1]",
    "ppl": "fraction in [0, 1]",
    "stage_sr": "% of the episodes with that many goals",
    "mcr": "m",
    "vrt": "% of poses",
    "zone2_steps": "steps per episode",
    "steps": "actions",
    "path_length": "m",
    "wrong_stops": "per episode",
}
PROTOCOL_INTERVALS = (
    "95 % intervals: Wilson score for SR and each stage's SR; percentile bootstrap of the mean "
    f"({BOOTSTRAP_RESAMPLES} resamples, seed {BOOTSTRAP_SEED}) clipped to the range for progress and PPL "
    "([0, 1]), VRT ([0, 100] %), MCR and Zone-2 steps (>= 0)"
)


def is_protocol(r: dict) -> bool:
    """Whether the record is a protocol episode's (it carries the episode's ``protocol`` object)."""
    return isinstance(r.get("protocol"), dict)


def required_metrics(r: dict) -> tuple[str, ...]:
    """The metrics a record that ran must hold: a protocol episode's, or a single-goal one's."""
    return PROTOCOL_METRICS if is_protocol(r) else METRICS


def record_error(r: dict) -> str | None:
    """Why the record is an errored episode (its ``error``, or a missing or non-finite metric), else None."""
    if r.get("error"):
        return str(r["error"])
    for k in required_metrics(r) + OPTIONAL_METRICS:
        if k not in r:
            if k in OPTIONAL_METRICS:
                continue
            return f"metric '{k}' is missing"
        v = r[k]
        number = isinstance(v, (int, float)) and not isinstance(v, bool)
        if not (isinstance(v, bool) if k == "success" else number and math.isfinite(v)):
            return f"metric '{k}' is {v!r}"
    for k in ("strict_success", "reachable", "reach_success"):
        if k in r and not isinstance(r[k], bool):
            return f"metric '{k}' is {r[k]!r}"
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
    """The metrics of a set of episodes, errored ones included (see the module's docstring); protocol
    episodes' by :func:`aggregate_protocol`."""
    records = list(records)
    if any(is_protocol(r) for r in records):
        return aggregate_protocol(records)
    ran = [r for r in records if record_error(r) is None]
    n = len(records)
    k = sum(bool(r["success"]) for r in ran)
    strict = None if any("strict_success" not in r for r in ran) else sum(r["strict_success"] for r in ran)
    fetch = bool(ran) and all("reachable" in r for r in ran)  # the reach check ran: Fetch (issue 16 item 4)
    reach = sum(r["reach_success"] for r in ran) if fetch else None
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
        "reach_successes": reach,
        "reach_sr": 100.0 * reach / n if n and reach is not None else math.nan,
        "reach_sr_ci95": _percent_interval(reach, n),
        "reachable_of_successes": 100.0 * reach / k if k and reach is not None else math.nan,
        "reachable_of_successes_ci95": _percent_interval(reach, k),
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


def aggregate_protocol(records: Iterable[dict]) -> dict:
    """The metrics of protocol episodes (units in ``PROTOCOL_UNITS``): SR (every goal reached), progress
    and PPL (means, an errored episode counting 0), per-stage SR (stage s: the episodes with at least s
    goals, the share whose s-th goal was reached, an errored one failing every stage), and, over the
    episodes that ran, MCR, VRT, Zone-2 steps, steps, path length, wrong STOPs and the share that ran out
    of their step budget."""
    records = list(records)
    ran = [r for r in records if record_error(r) is None]
    n = len(records)
    k = sum(bool(r["success"]) for r in ran)
    progress = [float(r["progress"]) for r in ran] + [0.0] * (n - len(ran))
    ppl = [float(r["ppl"]) for r in ran] + [0.0] * (n - len(ran))
    mcr, vrt = [float(r["mcr"]) for r in ran], [100.0 * float(r["vrt"]) for r in ran]
    zone2 = [float(r["zone2_steps"]) for r in ran]
    stage_n, stage_k = [0] * MAX_STAGES, [0] * MAX_STAGES
    for r in records:
        reached = r.get("stage_success", []) if record_error(r) is None else []
        for s in range(min(int(r["protocol"]["k"]), MAX_STAGES)):
            stage_n[s] += 1
            stage_k[s] += bool(s < len(reached) and reached[s])
    walls = [r["wall_time_s"] for r in records if isinstance(r.get("wall_time_s"), (int, float))]
    return {
        "episodes": n,
        "errors": n - len(ran),
        "successes": k,
        "sr": 100.0 * k / n if n else math.nan,
        "sr_ci95": _percent_interval(k, n),
        "progress": _mean(progress),
        "progress_ci95": list(bootstrap_interval(progress, 0.0, 1.0)),
        "ppl": _mean(ppl),
        "ppl_ci95": list(bootstrap_interval(ppl, 0.0, 1.0)),
        "stage_episodes": stage_n,
        "stage_sr": [100.0 * a / b if b else math.nan for a, b in zip(stage_k, stage_n)],
        "stage_sr_ci95": [_percent_interval(a, b) for a, b in zip(stage_k, stage_n)],
        "mcr": _mean(mcr),
        "mcr_ci95": list(bootstrap_interval(mcr, 0.0)),
        "vrt": _mean(vrt),
        "vrt_ci95": list(bootstrap_interval(vrt, 0.0, 100.0)),
        "zone2_steps": _mean(zone2),
        "zone2_steps_ci95": list(bootstrap_interval(zone2, 0.0)),
        "steps": _mean(r["steps"] for r in ran),
        "steps_success": _mean(r["steps"] for r in ran if r["success"]),
        "path_length": _mean(r["path_length"] for r in ran),
        "wrong_stops": _mean(r.get("wrong_stops", 0) for r in ran),
        "out_of_budget": _mean(100.0 * bool(r.get("out_of_budget")) for r in ran),
        "collisions": _mean(r.get("collisions", 0) for r in ran),
        "wall_time_s": _mean(w for w in walls if math.isfinite(w)),  # timing, not a metric
    }


def aggregate_all(records: list[dict]) -> dict:
    """Overall, per category and per difficulty tier (errored episodes in each); protocol episodes
    overall, per protocol, per number of goals K and per difficulty tier of the route."""
    if any(is_protocol(r) for r in records):
        by_protocol, by_k, by_diff = defaultdict(list), defaultdict(list), defaultdict(list)
        for r in records:
            by_protocol[r["protocol"]["id"]].append(r)
            by_k[str(r["protocol"]["k"])].append(r)
            by_diff[r.get("difficulty", "unknown")].append(r)
        return {
            "overall": aggregate_protocol(records),
            "per_protocol": {p: aggregate_protocol(v) for p, v in sorted(by_protocol.items())},
            "per_k": {k: aggregate_protocol(v) for k, v in sorted(by_k.items())},
            "per_difficulty": {
                d: aggregate_protocol(by_diff[d]) for d in ("easy", "medium", "hard") if d in by_diff
            },
        }
    by_cat, by_diff = defaultdict(list), defaultdict(list)
    for r in records:
        by_cat[r.get("object_category", "unknown")].append(r)
        by_diff[r.get("difficulty", "unknown")].append(r)
    return {
        "overall": aggregate(records),
        "per_category": {c: aggregate(v) for c, v in sorted(by_cat.items())},
        "per_difficulty": {d: aggregate(by_diff[d]) for d in ("easy", "medium", "hard") if d in by_diff},
    }
