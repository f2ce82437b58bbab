"""Fetch's reach at STOP as a metric: the measure that needs no simulator (the reach check itself,
``reachable``, is in :mod:`biovln_ms.sim.reach`), so evaluation aggregates Fetch runs without SAPIEN."""

from __future__ import annotations

import numpy as np

from biovln_ms.metrics.measures import Measure, Metric, rate, register_measure

#: what info adds for Fetch (the cylinder has no arm: the keys are absent)
REACH_MEASURES = ("reachable", "reach_success")


@register_measure
class ReachSuccess(Measure):
    """A successful STOP (within a goal's radius) from which the gripper reaches that goal's interaction
    point."""

    uuid = "reach_success"
    metric = Metric(
        "reach_success",
        required=False,
        aggregates=(
            rate("reach_sr", "reach SR", count="reach_successes", known_without_runs=False),
            rate("reachable_of_successes", "reachable successes", unit="% of successes", over="successes"),
        ),
    )
    dtype = bool
    dependencies = ("success", "reachable")

    def compute(self, ctx, s, m, idx):
        rows = np.arange(ctx.n)[idx]
        goal = m.measures["reachable"].goal[rows]
        j = np.maximum(goal, 0)
        d = np.hypot(*(ctx.goals[rows, j] - s.position[rows]).T)
        return m["success"][idx] & m["reachable"][idx] & (goal >= 0) & (d <= ctx.radii[rows, j])
