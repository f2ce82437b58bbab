"""Per-step and per-episode measures, each a small named unit with its dependencies (habitat-lab style).

A :class:`MeasureSet` resets and updates registered measures in dependency order from a
:class:`StepState` (the robot's planar pose plus what the task knows) and exposes their values as
an ``info`` dict. Conventions (paper §4.2):

* ``clearance`` is the planar distance from the robot's centre (the agent position, as Habitat and
  the paper record trajectories) to the nearest instrument body (Zone 1); the robot radius is NOT
  subtracted, so a robot touching a body reads ``clearance == radius``. MCR and VRT use the same value.
* ``zone2_violation``: the robot's centre is inside some instrument's Zone 2.
* ``facing_instrument``: the target's centre lies within half the camera's horizontal field of view.
* ``collisions``: steps whose commanded forward motion was cut short by contact (moved < 90 %).
* SPL = success * l_opt / max(l, l_opt); soft SPL = (1 - d_T / d_0) * l_opt / max(l, l_opt) with geodesic
  d_T at the end and d_0 at the start; DTG = final Euclidean distance; VRT = fraction of steps
  (the start included) with clearance < 0.5 m; MCR = minimum clearance over the trajectory.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, ClassVar

import numpy as np
from biovln_ms.geometry.zones import SAFETY_THRESHOLD, InstrumentArray, PlacedInstrument


@dataclass
class EpisodeContext:
    """What the measures know about the episode (fixed at reset)."""

    goal: np.ndarray
    success_radius: float
    target: PlacedInstrument
    instruments: list[PlacedInstrument]
    geodesic: Callable[[np.ndarray], float]
    start_geodesic: float
    hfov: float
    array: InstrumentArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.array = InstrumentArray(self.instruments)


@dataclass
class StepState:
    """The robot after an action."""

    position: np.ndarray
    yaw: float
    action: int | None
    stopped: bool
    commanded_forward: float = 0.0
    moved_forward: float = 0.0


class Measure:
    uuid: ClassVar[str]
    dependencies: ClassVar[tuple[str, ...]] = ()
    episode_end_only: ClassVar[bool] = False

    def reset(self, ctx: EpisodeContext, state: StepState, m: "MeasureSet") -> None:
        self.update(ctx, state, m)

    def update(self, ctx: EpisodeContext, state: StepState, m: "MeasureSet") -> None:
        raise NotImplementedError

    value: object = None


_REGISTRY: dict[str, type[Measure]] = {}


def register_measure(cls: type[Measure]) -> type[Measure]:
    if cls.uuid in _REGISTRY and _REGISTRY[cls.uuid] is not cls:
        raise ValueError(f"measure '{cls.uuid}' is already registered")
    _REGISTRY[cls.uuid] = cls
    return cls


def measure_names() -> list[str]:
    return list(_REGISTRY)


@register_measure
class DistanceToGoal(Measure):
    uuid = "distance_to_goal"

    def update(self, ctx, state, m):
        self.value = float(np.linalg.norm(state.position - ctx.goal))


@register_measure
class GeodesicDistanceToGoal(Measure):
    uuid = "geodesic_distance_to_goal"

    def update(self, ctx, state, m):
        self.value = float(ctx.geodesic(state.position))


@register_measure
class Clearance(Measure):
    uuid = "clearance"

    def update(self, ctx, state, m):
        self.value = ctx.array.clearance(state.position)


@register_measure
class Zone2Violation(Measure):
    uuid = "zone2_violation"

    def update(self, ctx, state, m):
        self.value = ctx.array.in_zone2(state.position)


@register_measure
class InZone3(Measure):
    uuid = "in_zone3"

    def reset(self, ctx, state, m):
        self._zone = None
        if ctx.target.model_face is not None:
            corners = ctx.target.zone3_corners()
            centre = corners.mean(axis=0)
            u, v = corners[1] - corners[0], corners[3] - corners[0]
            self._zone = (centre, u / np.linalg.norm(u), v / np.linalg.norm(v), np.linalg.norm(u) / 2, np.linalg.norm(v) / 2)
        self.update(ctx, state, m)

    def update(self, ctx, state, m):
        if self._zone is None:
            self.value = False
            return
        c, u, v, hu, hv = self._zone
        d = state.position - c
        self.value = bool(abs(d @ u) <= hu + 1e-9 and abs(d @ v) <= hv + 1e-9)


@register_measure
class FacingInstrument(Measure):
    uuid = "facing_instrument"

    def update(self, ctx, state, m):
        d = ctx.target.center_xy - state.position
        bearing = math.atan2(d[1], d[0]) - state.yaw
        bearing = (bearing + math.pi) % (2 * math.pi) - math.pi
        self.value = abs(bearing) <= ctx.hfov / 2


@register_measure
class Collisions(Measure):
    uuid = "collisions"

    def reset(self, ctx, state, m):
        self.value = 0

    def update(self, ctx, state, m):
        if state.commanded_forward > 0 and state.moved_forward < 0.9 * state.commanded_forward:
            self.value += 1


@register_measure
class Success(Measure):
    uuid = "success"
    dependencies = ("distance_to_goal",)

    def update(self, ctx, state, m):
        self.value = bool(state.stopped and m["distance_to_goal"] <= ctx.success_radius)


@register_measure
class Steps(Measure):
    uuid = "steps"

    def reset(self, ctx, state, m):
        self.value = 0

    def update(self, ctx, state, m):
        self.value += 1


@register_measure
class PathLength(Measure):
    uuid = "path_length"

    def reset(self, ctx, state, m):
        self._last = state.position.copy()
        self.value = 0.0

    def update(self, ctx, state, m):
        self.value += float(np.linalg.norm(state.position - self._last))
        self._last = state.position.copy()


@register_measure
class MinClearance(Measure):
    """MCR: the minimum clearance over the trajectory so far."""

    uuid = "mcr"
    dependencies = ("clearance",)

    def reset(self, ctx, state, m):
        self.value = m["clearance"]

    def update(self, ctx, state, m):
        self.value = min(self.value, m["clearance"])


@register_measure
class ViolationRate(Measure):
    """VRT: fraction of trajectory poses (start included) within 0.5 m of an instrument body."""

    uuid = "vrt"
    dependencies = ("clearance",)

    def reset(self, ctx, state, m):
        self._n = 1
        self._k = int(m["clearance"] < SAFETY_THRESHOLD)
        self.value = float(self._k)

    def update(self, ctx, state, m):
        self._n += 1
        self._k += int(m["clearance"] < SAFETY_THRESHOLD)
        self.value = self._k / self._n


@register_measure
class SPL(Measure):
    uuid = "spl"
    dependencies = ("success", "path_length")

    def reset(self, ctx, state, m):
        self.value = 0.0

    def update(self, ctx, state, m):
        l_opt = ctx.start_geodesic
        self.value = float(m["success"]) * l_opt / max(m["path_length"], l_opt, 1e-9)


@register_measure
class SoftSPL(Measure):
    uuid = "soft_spl"
    dependencies = ("geodesic_distance_to_goal", "path_length")

    def reset(self, ctx, state, m):
        self.value = 0.0

    def update(self, ctx, state, m):
        d0 = max(ctx.start_geodesic, 1e-9)
        progress = max(0.0, 1.0 - m["geodesic_distance_to_goal"] / d0) if math.isfinite(m["geodesic_distance_to_goal"]) else 0.0
        self.value = progress * ctx.start_geodesic / max(m["path_length"], ctx.start_geodesic, 1e-9)


STEP_INFO = ("success", "distance_to_goal", "geodesic_distance_to_goal", "clearance", "zone2_violation", "in_zone3",
             "facing_instrument", "collisions")
END_INFO = ("spl", "soft_spl", "mcr", "vrt", "steps", "path_length")


@dataclass
class MeasureSet:
    """Registered measures, updated in dependency order."""

    names: tuple[str, ...] = STEP_INFO + END_INFO
    measures: dict[str, Measure] = field(default_factory=dict)

    def __post_init__(self):
        order: list[str] = []

        def visit(n: str, stack: tuple = ()):
            if n in order:
                return
            if n not in _REGISTRY:
                raise KeyError(f"unknown measure '{n}'; registered: {', '.join(_REGISTRY)}")
            if n in stack:
                raise ValueError(f"measure dependency cycle: {' -> '.join(stack + (n,))}")
            for d in _REGISTRY[n].dependencies:
                visit(d, stack + (n,))
            order.append(n)

        for n in self.names:
            visit(n)
        self.measures = {n: _REGISTRY[n]() for n in order}

    def __getitem__(self, name: str):
        return self.measures[name].value

    def reset(self, ctx: EpisodeContext, state: StepState) -> None:
        for meas in self.measures.values():
            meas.reset(ctx, state, self)

    def update(self, ctx: EpisodeContext, state: StepState) -> None:
        for meas in self.measures.values():
            meas.update(ctx, state, self)

    def info(self) -> dict:
        return {n: self.measures[n].value for n in self.names}
