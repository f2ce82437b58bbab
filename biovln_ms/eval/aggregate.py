"""Aggregate metrics (paper §4.2) from per-episode records, as each measure declares them.

A measure's :class:`~biovln_ms.metrics.measures.Metric` names its key in the record and its aggregates
(:class:`~biovln_ms.metrics.measures.Aggregate`): SR and strict SR are rates, SPL, DTG, MCR and VRT means,
per-stage SR a rate per goal position. Nothing here names a metric: a new registered measure with a
metric reaches ``summary.json`` and the report as it is.

Every episode counts. An episode that failed to run (an ``error`` in its record, or a missing or
non-finite metric: :func:`record_error`) is a failure: its aggregates ``over="all"`` count it as 0 (SR,
SPL, progress), the others are means over the episodes that ran (``episodes - errors``). Each ``*_ci95``
is a 95 % interval in its metric's unit (``biovln_ms.eval.stats``): Wilson for rates, a seeded percentile
bootstrap clipped to the metric's range for means.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Iterable

import numpy as np

import biovln_ms.metrics.protocol_measures  # noqa: F401  (registers the protocol measures' metrics)
import biovln_ms.metrics.reach_measures  # noqa: F401  (registers Fetch's reach metric)
import biovln_ms.metrics.people_measures  # noqa: F401  (registers the human-aware metrics of people=)
from biovln_ms.constants import MAX_VISITS as MAX_STAGES
from biovln_ms.eval.stats import BOOTSTRAP_RESAMPLES, BOOTSTRAP_SEED, bootstrap_interval, wilson_interval
from biovln_ms.metrics.measures import OUTCOME, Aggregate, Metric, measure_names, measure_type
from biovln_ms.variants import VARIANTS


def is_protocol(r: dict) -> bool:
    """Whether the record is a protocol episode's (it carries the episode's ``protocol`` object)."""
    return isinstance(r.get("protocol"), dict)


def _kind_measures(protocol: bool) -> tuple[str, ...]:
    """The measures of the first registered variant of that kind (single-goal or protocol)."""
    cfg = next(c for c in VARIANTS.values() if c.protocol == protocol)
    return tuple(dict.fromkeys(cfg.measures + (cfg.success_measure,)))


def _metrics(names: Iterable[str]) -> dict[str, tuple[Metric, type]]:
    """record key -> (metric, measure class) of the named measures that have one, the first per key."""
    out: dict[str, tuple[Metric, type]] = {}
    for name in names:
        cls = measure_type(name)
        if cls.metric is not None and cls.metric.key not in out:
            out[cls.metric.key] = (cls.metric, cls)
    return out


def kind_metrics(protocol: bool) -> dict[str, tuple[Metric, type]]:
    """The metrics every record of that kind holds (its variant's measures), then the registered ones of
    neither kind (a robot's, a user's), by record key."""
    own = _metrics(_kind_measures(protocol))
    kinds = set(_kind_measures(True) + _kind_measures(False))
    extra = _metrics(n for n in measure_names() if n not in kinds)
    return own | {k: v for k, v in extra.items() if k not in own}


def units(protocol: bool = False) -> dict[str, str]:
    """Aggregate key -> unit, for every metric records of that kind may hold."""
    return {a.key: a.unit for m, _ in kind_metrics(protocol).values() for a in m.aggregates}


def _range(bounds: tuple[float, float | None]) -> str:
    lo, hi = bounds
    return f">= {lo:g}" if hi is None else f"[{lo:g}, {hi:g}]"


def intervals(protocol: bool = False) -> str:
    """What the ``*_ci95`` intervals are, for the metrics of that kind."""
    aggs = [a for m, _ in kind_metrics(protocol).values() for a in m.aggregates]
    wilson = [a.label for a in aggs if a.interval == "wilson"]
    boot = [f"{a.label} ({_range(a.bounds)})" for a in aggs if a.interval == "bootstrap"]
    return (
        f"95 % intervals (*_ci95, in the metric's unit): Wilson score for {', '.join(wilson)}; percentile "
        f"bootstrap of the mean ({BOOTSTRAP_RESAMPLES} resamples, numpy default_rng seed {BOOTSTRAP_SEED}) "
        f"clipped to the metric's range for {', '.join(boot)}"
    )


UNITS = units(False)
PROTOCOL_UNITS = units(True)
INTERVALS = intervals(False)
PROTOCOL_INTERVALS = intervals(True)


def _scalar(metric: Metric, cls: type) -> bool:
    """Whether the record holds one number for it (checked by :func:`record_error`)."""
    return metric.at in ("end", "count") and cls.shape == ()


def required_metrics(r: dict) -> tuple[str, ...]:
    """The metrics a record that ran must hold: those its kind's measures require."""
    own = _metrics(_kind_measures(is_protocol(r)))
    return tuple(k for k, (m, cls) in own.items() if m.required and _scalar(m, cls))


def record_error(r: dict) -> str | None:
    """Why the record is an errored episode (its ``error``, or a missing or non-finite metric), else None."""
    if r.get("error"):
        return str(r["error"])
    required = required_metrics(r)
    for key, (metric, cls) in kind_metrics(is_protocol(r)).items():
        if not _scalar(metric, cls):
            continue
        if key not in r:
            if key in required:
                return f"metric '{key}' is missing"
            continue
        v = r[key]
        if metric.at == "end" and np.dtype(cls.dtype) == np.bool_:
            ok = isinstance(v, bool)
        else:
            ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
        if not ok:
            return f"metric '{key}' is {v!r}"
    return None


def succeeded(r: dict) -> bool:
    """The episode's outcome, an errored episode being a failure."""
    return record_error(r) is None and bool(r[OUTCOME])


def _mean(xs: Iterable[float]) -> float:
    """Mean of validated values (nan when there are none); a non-finite one is a bug, not skipped."""
    v = np.asarray(list(xs), float)
    if not np.all(np.isfinite(v)):
        raise ValueError(f"non-finite value in a mean: {v[~np.isfinite(v)][:3].tolist()}")
    return float(v.mean()) if len(v) else math.nan


def _percent_interval(k: int | None, n: int) -> list[float]:
    """The Wilson interval of k successes in n, in percent (nan when k is unknown or n is 0)."""
    return [math.nan, math.nan] if k is None else [100.0 * x for x in wilson_interval(k, n)]


def _values(a: Aggregate, key: str, rows: list[dict]) -> list | None:
    """The rows' values of ``key`` (a missing one as ``a.missing``); None when one is unknown."""
    vals = [r.get(key, a.missing) for r in rows]
    return None if any(v is None for v in vals) else vals


def _aggregate(a: Aggregate, key: str, records: list[dict], ran: list[dict], wins: list[dict]) -> dict:
    """The entries of one aggregate (its value, interval and count) over a set of records."""
    n = len(records)
    ci = a.interval_key
    if a.how == "stages":
        ok = {id(r) for r in ran}
        stage_n, stage_k = [0] * MAX_STAGES, [0] * MAX_STAGES
        for r in records:
            reached = r.get(key, []) if id(r) in ok else []
            for s in range(min(int(r["protocol"]["k"]), MAX_STAGES)):
                stage_n[s] += 1
                stage_k[s] += bool(s < len(reached) and reached[s])
        return {
            a.count: stage_n,
            a.key: [a.scale * k / m if m else math.nan for k, m in zip(stage_k, stage_n)],
            ci: [_percent_interval(k, m) for k, m in zip(stage_k, stage_n)],
        }
    if a.how == "rate":
        vals = _values(a, key, ran)
        k = None if vals is None or (not ran and not a.known_without_runs) else sum(bool(v) for v in vals)
        m = len(wins) if a.over == "successes" else n
        out = {a.key: a.scale * k / m if m and k is not None else math.nan, ci: _percent_interval(k, m)}
        return out | ({a.count: k} if a.count else {})
    rows = wins if a.over == "successes" else ran
    vals = _values(a, key, rows)
    if vals is None:
        return {a.key: math.nan} | ({ci: [math.nan, math.nan]} if ci else {})
    values = [a.scale * float(v) for v in vals] + ([0.0] * (n - len(ran)) if a.over == "all" else [])
    out = {a.key: _mean(values)}
    return out | ({ci: list(bootstrap_interval(values, *a.bounds))} if ci else {})


def aggregate(records: Iterable[dict]) -> dict:
    """Every aggregate of the records' metrics over a set of episodes, errored ones included (see the
    module's docstring), with the episode and error counts and the mean wall time."""
    records = list(records)
    ran = [r for r in records if record_error(r) is None]
    wins = [r for r in ran if r[OUTCOME]]
    out: dict = {"episodes": len(records), "errors": len(records) - len(ran)}
    for metric, _ in kind_metrics(any(is_protocol(r) for r in records)).values():
        if metric.when_recorded and not any(metric.key in r for r in records):
            continue
        for a in metric.aggregates:
            out.update(_aggregate(a, metric.key, records, ran, wins))
    walls = [r["wall_time_s"] for r in records if isinstance(r.get("wall_time_s"), (int, float))]
    out["wall_time_s"] = _mean(w for w in walls if math.isfinite(w))  # timing, not a metric
    return out


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
            "overall": aggregate(records),
            "per_protocol": {p: aggregate(v) for p, v in sorted(by_protocol.items())},
            "per_k": {k: aggregate(v) for k, v in sorted(by_k.items())},
            "per_difficulty": {d: aggregate(by_diff[d]) for d in ("easy", "medium", "hard") if d in by_diff},
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
