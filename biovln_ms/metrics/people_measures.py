"""Human-aware measures of an env with people (``gym.make(..., people=N)``; docs/guides/people.md).

They read :class:`~biovln_ms.people.body.PeopleStep` (``StepState.people``) and are reported only by envs
with people (:func:`biovln_ms.people.crowd.people_config` adds them), so their metrics are ``when_recorded``:
the summaries of runs without people have none of them. Conventions:

* ``person_distance``: the robot's body to the nearest person's body (0 at contact); ``min_person_distance``
  its minimum over the episode (the start included);
* ``personal_space_rate``: the share of poses (the start included, as VRT) with ``person_distance`` below
  :data:`PERSONAL_SPACE`;
* ``person_collision``: the step's move was cut at a person's body; ``person_collisions`` counts them;
* ``robot_wait_time``: seconds of steps (each :func:`~biovln_ms.people.crowd.step_seconds` long) in which the
  robot's centre stayed put, not at a STOP, with a person within :data:`WAIT_DISTANCE`;
  ``people_wait_time``: person-seconds people stood waiting because the robot was in their way;
* ``mcr_people`` / ``vrt_people``: MCR and VRT with people counted as obstacles (the robot's centre to the
  nearest instrument's or person's body, the 0.5 m threshold), beside the unchanged ``mcr`` / ``vrt``;
* ``occupied_stop``: the episode's STOP came with a person's body in the goal's Zone 3 (any goal's; in a
  protocol, the goal asked for at that STOP): the face could not be operated (what fails ``strict_success``
  with people);
* ``people_fail``: a STOP that is not the variant's success, or, with ``person_collision_ends``, a person
  collision (the fail measure of the single-goal variants with people); ``protocol_people_fail`` the same
  for the protocol env (its ``protocol_fail``, or a person collision).
"""

from __future__ import annotations

import numpy as np

from biovln_ms.geometry.zones import SAFETY_THRESHOLD
from biovln_ms.metrics.measures import (
    Aggregate,
    Measure,
    Metric,
    MinClearance,
    _once,
    _zone3_occupied,
    rate,
    register_measure,
)

#: m between the robot's body and a person's below which a pose is in their personal space
PERSONAL_SPACE = 0.5
#: m: a robot standing still with a person this near (body to body) is waiting for them
WAIT_DISTANCE = 1.0
#: m: the robot's centre moved less than this in a step: it stayed put
STILL = 0.01


def _centre_distance(s, idx) -> np.ndarray:
    """The robot's centre to the nearest person's body, once per step for the measures that read it."""
    return _once(s, idx, "person_centre_distance", lambda: s.people.centre_distance(s.position, idx))


def _metric(key: str, label: str, unit: str, **kw) -> Metric:
    """An optional end-of-episode metric with one mean, recorded only by envs with people."""
    return Metric(key, required=False, when_recorded=True, aggregates=(Aggregate(key, label, unit, **kw),))


@register_measure
class PersonDistance(Measure):
    uuid = "person_distance"

    def compute(self, ctx, s, m, idx):
        return s.people.body_gap(_centre_distance(s, idx))


@register_measure
class PersonCollision(Measure):
    uuid = "person_collision"
    dtype = bool

    def reset(self, ctx, s, m, idx):
        self.value[idx] = False

    def compute(self, ctx, s, m, idx):
        return s.people.hit[idx]


@register_measure
class MinPersonDistance(Measure):
    """The minimum of ``person_distance`` over the episode."""

    uuid = "min_person_distance"
    metric = _metric("min_person_distance", "min. person distance", "m")
    dependencies = ("person_distance",)

    def reset(self, ctx, s, m, idx):
        self.value[idx] = m["person_distance"][idx]

    def update(self, ctx, s, m, idx):
        self.value[idx] = np.minimum(self.value[idx], m["person_distance"][idx])


class _PoseShare(Measure):
    """The share of poses (the start included) where ``_violates`` holds."""

    state_names = ("value", "poses", "violations")

    def __init__(self, n, cfg):
        super().__init__(n, cfg)
        self.poses = np.zeros(n, dtype=np.int64)
        self.violations = np.zeros(n, dtype=np.int64)

    def _violates(self, s, m, idx) -> np.ndarray:
        raise NotImplementedError

    def reset(self, ctx, s, m, idx):
        self.poses[idx] = 0
        self.violations[idx] = 0
        self.update(ctx, s, m, idx)

    def update(self, ctx, s, m, idx):
        self.poses[idx] += 1
        self.violations[idx] += self._violates(s, m, idx)
        self.value[idx] = self.violations[idx] / self.poses[idx]


@register_measure
class PersonalSpaceRate(_PoseShare):
    uuid = "personal_space_rate"
    metric = _metric(
        "personal_space_rate", "personal-space rate", "% of poses", scale=100.0, bounds=(0.0, 100.0)
    )
    dependencies = ("person_distance",)

    def _violates(self, s, m, idx):
        return m["person_distance"][idx] < PERSONAL_SPACE


@register_measure
class PersonCollisions(Measure):
    uuid = "person_collisions"
    metric = _metric("person_collisions", "person collisions", "per episode", bounds=None)
    dtype = np.int64
    dependencies = ("person_collision",)

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0

    def update(self, ctx, s, m, idx):
        self.value[idx] += m["person_collision"][idx]


@register_measure
class RobotWaitTime(Measure):
    uuid = "robot_wait_time"
    metric = _metric("robot_wait_time", "robot waiting", "s per episode", bounds=None)
    dependencies = ("person_distance", "stopped")
    state_names = ("value", "last")

    def __init__(self, n, cfg):
        super().__init__(n, cfg)
        self.last = np.zeros((n, 2))

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0.0
        self.last[idx] = s.position[idx]

    def update(self, ctx, s, m, idx):
        near = m["person_distance"][idx] < WAIT_DISTANCE
        if near.any():  # else nobody waits: the common step skips the rest
            d = s.position[idx] - self.last[idx]
            still = (np.hypot(d[:, 0], d[:, 1]) < STILL) & ~m["stopped"][idx]
            self.value[idx] += np.where(still & near, s.people.seconds, 0.0)
        self.last[idx] = s.position[idx]


@register_measure
class PeopleWaitTime(Measure):
    uuid = "people_wait_time"
    metric = _metric("people_wait_time", "people waiting", "person-s per episode", bounds=None)

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0.0

    def update(self, ctx, s, m, idx):
        self.value[idx] += s.people.people_wait[idx]


@register_measure
class ObstacleDistance(Measure):
    """The robot's centre to the nearest instrument's or person's body (``clearance`` with people)."""

    uuid = "clearance_people"
    dependencies = ("clearance",)

    def compute(self, ctx, s, m, idx):
        return np.minimum(m["clearance"][idx], _centre_distance(s, idx))


@register_measure
class MinClearancePeople(MinClearance):
    """MCR with people counted as obstacles."""

    uuid = "mcr_people"
    metric = _metric("mcr_people", "MCR (people too)", "m")
    dependencies = ("clearance_people",)


@register_measure
class ViolationRatePeople(_PoseShare):
    """VRT with people counted as obstacles."""

    uuid = "vrt_people"
    metric = _metric("vrt_people", "VRT (people too)", "% of poses", scale=100.0, bounds=(0.0, 100.0))
    dependencies = ("clearance_people",)

    def _violates(self, s, m, idx):
        return m["clearance_people"][idx] < SAFETY_THRESHOLD


@register_measure
class OccupiedStop(Measure):
    """A STOP with a person's body in the goal's Zone 3, over the episode: any goal's (a category's
    instances), or in a protocol the goal asked for at that STOP (``subgoal_index`` before the step)."""

    uuid = "occupied_stop"
    dtype = bool
    metric = Metric(
        "occupied_stop",
        required=False,
        when_recorded=True,
        aggregates=(rate("occupied_stop", "STOP at an occupied face"),),
    )
    dependencies = ("stopped",)
    after = ("subgoal_index",)  # a protocol's: updated first, so ``goal`` follows it
    state_names = ("value", "goal")

    def __init__(self, n, cfg):
        super().__init__(n, cfg)
        self.goal = np.zeros(n, dtype=np.int64)  # a protocol's goal asked for, before this step

    def reset(self, ctx, s, m, idx):
        self.value[idx] = False
        self.goal[idx] = 0

    def update(self, ctx, s, m, idx):
        stopped = m["stopped"][idx]
        protocol = "subgoal_index" in m.measures
        if stopped.any():  # the Zone 3 test only at a STOP
            occupied = _zone3_occupied(ctx, s, idx)
            if protocol:  # the goal asked for at this STOP (the last once every goal is done)
                col = np.minimum(self.goal[idx], ctx.num_goals[idx] - 1)
                occupied = occupied[np.arange(len(col)), col]
            else:
                occupied = occupied.any(axis=1)
            self.value[idx] |= stopped & occupied
        if protocol:
            self.goal[idx] = m["subgoal_index"][idx]


@register_measure
class PeopleFail(Measure):
    """A STOP that is not the variant's success, or (``person_collision_ends``) a person collision."""

    uuid = "people_fail"
    dtype = bool
    dependencies = ("stopped", "success", "strict_success", "person_collision")

    def compute(self, ctx, s, m, idx):
        wrong_stop = m["stopped"][idx] & ~m[self.cfg.success_measure][idx]
        return wrong_stop | (m["person_collision"][idx] & bool(self.cfg.person_collision_ends))


@register_measure
class ProtocolPeopleFail(Measure):
    """The protocol's fail (``protocol_fail``), or (``person_collision_ends``) a person collision."""

    uuid = "protocol_people_fail"
    dtype = bool
    dependencies = ("protocol_fail", "person_collision")

    def compute(self, ctx, s, m, idx):
        return m["protocol_fail"][idx] | (m["person_collision"][idx] & bool(self.cfg.person_collision_ends))
