"""The report's table specifications: each table is a list of measures, and shows their aggregates
(:class:`~biovln_ms.metrics.measures.Aggregate`) with their intervals and counts. The one module besides
the measures that names metrics; the aggregation (:mod:`biovln_ms.eval.aggregate`) names none."""

from __future__ import annotations

import math

import biovln_ms.metrics.people_measures  # noqa: F401  (registers the measures the tables name)
import biovln_ms.metrics.protocol_measures  # noqa: F401
import biovln_ms.metrics.reach_measures  # noqa: F401
from biovln_ms.metrics.measures import Aggregate, measure_type

#: a single-goal run's rows by category and difficulty tier
BREAKDOWN_MEASURES = ("success", "strict_success", "spl")
#: a Fetch run's reach table (its records hold the reach check at STOP)
REACH_MEASURES = ("success", "reach_success")
#: a protocol run's rows by number of goals K
PROTOCOL_BREAKDOWN_MEASURES = ("protocol_success", "progress", "ppl")
#: what the standard tables show of a run's overall aggregates; the "other measures" table shows the rest
STANDARD_MEASURES = (
    "success",
    "strict_success",
    "spl",
    "soft_spl",
    "distance_to_goal",
    "steps",
    "path_length",
    "mcr",
    "vrt",
    "collisions",
    "reach_success",
    "protocol_success",
    "progress",
    "ppl",
    "stage_success",
    "zone2_steps",
    "wrong_stop",
    "out_of_budget",
)


#: the people table's columns: a busy run's success and its human-aware measures (docs/guides/people.md)
PEOPLE_TABLE_MEASURES = (
    "success",
    "strict_success",
    "min_person_distance",
    "personal_space_rate",
    "person_collisions",
    "robot_wait_time",
    "people_wait_time",
    "occupied_stop",
    "mcr_people",
    "vrt_people",
)


#: the one-line summary `biovln-ms eval` and `train` print, of a single-goal and of a protocol run
HEADLINE_MEASURES = ("success", "spl", "distance_to_goal", "mcr", "vrt")
PROTOCOL_HEADLINE_MEASURES = ("protocol_success", "progress", "ppl", "mcr", "vrt")


def headline(summary: dict) -> str:
    """A run's headline metrics in one line (``SR 40.0%, SPL 0.312, DTG 1.204 m, ...``), each in its unit,
    from ``summary.json``'s content."""
    names = PROTOCOL_HEADLINE_MEASURES if "per_protocol" in summary else HEADLINE_MEASURES
    cells = []
    for name in names:
        a = measure_type(name).metric.aggregates[0]
        v = summary["overall"].get(a.key)
        if a.unit.startswith("%"):
            cells.append(f"{a.label} {fmt(v, 1)}%")
        else:
            cells.append(f"{a.label} {fmt(v, 3)}" + ("" if a.unit.startswith("fraction") else f" {a.unit}"))
    return ", ".join(cells)


def _aggregate_keys(a: Aggregate) -> tuple[str, ...]:
    """The entries one aggregate adds to a summary: its count, value and interval."""
    return tuple(k for k in (a.count, a.key, a.interval_key) if k)


def table_keys(measures: tuple[str, ...]) -> tuple[str, ...]:
    """What a table of these measures reads of an aggregate: the episode counts, then each measure's
    aggregates with their intervals and counts."""
    keys = ["episodes", "errors"]
    for name in measures:
        for a in measure_type(name).metric.aggregates:
            keys += [k for k in _aggregate_keys(a) if k not in keys]
    return tuple(keys)


def fmt(v, nd=1) -> str:
    """A table cell's number, or a dash when it is unknown."""
    return "–" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{nd}f}"
