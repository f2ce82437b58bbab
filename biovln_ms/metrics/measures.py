"""Per-step and per-episode measures, batched over ``num_envs`` (habitat-lab's measures, ManiSkill's tensors).

A :class:`~biovln_ms.metrics.measure_set.MeasureSet` resets (rows ``env_idx``) and updates registered
measures in dependency order from a :class:`StepState` (the robots' planar poses and commands, arrays with a
leading ``num_envs`` dimension) and a :class:`BatchContext` (each sub-env's episode), and exposes their
values as an ``info`` dict of torch tensors on the env's device. Reward, success and fail are measures
too; the task config names which.

The bookkeeping is NumPy on the host, whatever the simulation backend: the geometry that differs per
scene (geodesics, clearance, Zone 2) is host-side anyway (shapely, visibility graphs), so the poses come
to the host once a step; a NumPy operation on a few rows costs a quarter of a torch one on the CPU, and
a measure update is a handful of them. Torch appears only at the boundary,
:class:`~biovln_ms.metrics.measure_set.MeasureSet` (``info``, tensors, state dicts), so evaluation reads the
declarations without loading torch. Conventions (paper §4.2):

* ``clearance`` is the planar distance from the robot's centre (the agent position, as Habitat and
  the paper record trajectories) to the nearest instrument body (Zone 1); the robot radius is NOT
  subtracted, so a robot touching a body reads ``clearance == radius``. MCR and VRT use the same value.
* ``zone2_violation``: the robot's centre is inside some instrument's Zone 2.
* ``facing_instrument``: the target's centre lies within half the camera's horizontal field of view.
* ``strict_success`` (operational success, this platform's rule beside the paper's radius rule): a
  successful STOP (within r) that also stands in Zone 3 and faces the operational face, the heading within
  ``strict_facing_deg`` (30 by default) of the face's inward normal ``-f`` (``facing_face``); with people
  (:mod:`biovln_ms.people`), that Zone 3 free of them. ``success`` (the radius rule) ignores people.
* ``collisions``: steps whose commanded forward motion was cut short by contact (moved < 90 %).
* SPL = success * l_opt / max(l, l_opt); soft SPL = (1 - d_T / d_0) * l_opt / max(l, l_opt) with geodesic
  d_T at the end and d_0 at the start; DTG = final Euclidean distance; VRT = fraction of steps
  (the start included) with clearance < 0.5 m; MCR = minimum clearance over the trajectory.
* ``nav_reward`` is Eq. 5: (d_{t-1} - d_t) - step penalty + success bonus * success - safety penalty.

Geometry that differs per scene is queried per sub-env; everything else is one array operation over the
batch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, ClassVar, Protocol

import numpy as np

from biovln_ms.geometry.zones import SAFETY_THRESHOLD, InstrumentArray, PlacedInstrument
from biovln_ms.people.body import PERSON_RADIUS, PeopleStep
from biovln_ms.task_config import NavTaskConfig

F64 = np.float64
#: m: Zone 3 includes its boundary within this; the Eq. 1 goal lies on its outer edge and the physics keeps
#: poses in float32 (a robot stopped exactly at the goal reads up to ~1e-6 m outside it)
ZONE3_TOLERANCE = 1e-5


@dataclass
class EpisodeContext:
    """What the measures know about one sub-env's episode (fixed at reset). ``goal``, ``success_radius``
    and ``target`` are the episode's first goal; ``other_goals`` the further instances of its category
    when any instance counts (ObjectNav's rule), each (goal, radius, instrument). ``geodesic`` is the
    distance to the nearest goal."""

    goal: np.ndarray
    success_radius: float
    target: PlacedInstrument
    instruments: list[PlacedInstrument]
    geodesic: Callable[[np.ndarray], float]
    start_geodesic: float
    hfov: float
    other_goals: tuple[tuple[np.ndarray, float, PlacedInstrument], ...] = ()
    array: InstrumentArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.array = InstrumentArray(self.instruments)

    @property
    def goals(self) -> list[tuple[np.ndarray, float, PlacedInstrument]]:
        return [(self.goal, self.success_radius, self.target), *self.other_goals]


class BatchContext:
    """The episodes of ``n`` sub-envs, with the per-env numbers the batched measures need as arrays. Goal
    arrays have a second axis over an episode's goals (``k``, grown to the most any episode has; unused
    slots are masked by ``goal_ok``)."""

    def __init__(self, n: int) -> None:
        self.n, self.k = n, 0
        self.episodes: list[EpisodeContext | None] = [None] * n
        self.goal = np.zeros((n, 2))  # the first goal (the pointgoal sensors' and the logs')
        self.start_geodesic, self.hfov = np.zeros(n), np.zeros(n)
        self._grow(1)

    def _grow(self, k: int) -> None:
        """Room for ``k`` goals per episode."""
        if k <= self.k:
            return
        n, old = self.n, self.k
        new = {
            "goals": np.zeros((n, k, 2)),
            "radii": np.zeros((n, k)),
            "goal_ok": np.zeros((n, k), dtype=bool),
            "target_centres": np.zeros((n, k, 2)),
            "zone3": np.zeros((n, k, 8)),  # centre (2), unit axes u, v (2 + 2), half extents (2)
            "face": np.zeros((n, k, 2)),  # operational face normal f (zero: none)
            "has_zone3": np.zeros((n, k), dtype=bool),
        }
        for name, arr in new.items():
            if old:
                arr[:, :old] = getattr(self, name)
            setattr(self, name, arr)
        self.k = k

    def set(self, i: int, ctx: EpisodeContext) -> None:
        """Sub-env ``i`` starts the episode ``ctx``."""
        self.episodes[i] = ctx
        goals = ctx.goals
        self._grow(len(goals))
        self.goal[i], self.start_geodesic[i], self.hfov[i] = ctx.goal, ctx.start_geodesic, ctx.hfov
        self.goal_ok[i] = False
        for j, (goal, radius, target) in enumerate(goals):
            self.goal_ok[i, j] = True
            self.goals[i, j], self.radii[i, j], self.target_centres[i, j] = goal, radius, target.center_xy
            self.has_zone3[i, j] = target.model_face is not None
            self.face[i, j] = 0.0 if target.face is None else target.face
            if target.model_face is not None:
                corners = target.zone3_corners()
                u, v = corners[1] - corners[0], corners[3] - corners[0]
                lu, lv = np.linalg.norm(u), np.linalg.norm(v)
                self.zone3[i, j] = np.concatenate([corners.mean(axis=0), u / lu, v / lv, [lu / 2, lv / 2]])

    def episode(self, i: int) -> EpisodeContext:
        ctx = self.episodes[i]
        if ctx is None:
            raise RuntimeError(f"sub-env {i} has no episode: reset it first")
        return ctx


@dataclass
class StepState:
    """The robots after an action (or at reset), each field with a leading ``num_envs`` dimension."""

    position: np.ndarray  # (N, 2) float64
    yaw: np.ndarray  # (N,) float64
    stopped: np.ndarray  # (N,) bool
    commanded_forward: np.ndarray  # (N,) float64
    moved_forward: np.ndarray  # (N,) float64
    people: PeopleStep | None = None  # an env with people: where they are (biovln_ms.people)
    #: per-goal arrays several measures share, computed once per (quantity, rows) (see :func:`_once`)
    cache: dict = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def at_rest(cls, pose: np.ndarray, people: PeopleStep | None = None) -> "StepState":
        """The state at reset: pose (N, 3), no command."""
        pose = np.asarray(pose, F64)
        zeros = np.zeros(len(pose))
        return cls(pose[:, :2], pose[:, 2], np.zeros(len(pose), dtype=bool), zeros, zeros, people)


@dataclass(frozen=True)
class Aggregate:
    """One number of a run's summary, made from a metric's values in the episode records.

    ``how``: ``"rate"`` (the share of episodes where the value is true, with a Wilson interval),
    ``"mean"`` (with a seeded bootstrap interval clipped to ``bounds``; no interval when ``bounds`` is
    None) or ``"stages"`` (a per-goal vector: the share of episodes with at least s goals that reached the
    s-th). ``over``: ``"all"`` episodes (an errored one counts as a failure, or 0), only those that
    ``"ran"``, or the ``"successes"`` (a rate among successful episodes)."""

    key: str  # its name in summary.json and the report's data
    label: str  # its heading in tables
    unit: str
    how: str = "mean"
    over: str = "ran"
    scale: float = 1.0  # record value -> unit (100: a share in percent)
    bounds: tuple[float, float | None] | None = (0.0, None)
    count: str | None = None  # a rate's episode count, reported beside it ("successes")
    missing: float | None = None  # the value of a record without the metric (None: the aggregate is unknown)
    known_without_runs: bool = True  # a rate: 0 when no episode ran (False: unknown)

    @property
    def interval(self) -> str | None:
        """Its 95 % interval: ``"wilson"`` for a rate (per stage too), ``"bootstrap"`` for a mean with
        ``bounds``, None for a mean without."""
        return "wilson" if self.how != "mean" else None if self.bounds is None else "bootstrap"

    @property
    def interval_key(self) -> str | None:
        """The summary key of its interval (``sr_ci95``), None when it has none."""
        return f"{self.key}_ci95" if self.interval else None


@dataclass(frozen=True)
class Metric:
    """How evaluation records a measure in an episode's record (``key``) and aggregates it.

    ``at``: ``"end"`` records the value at the episode's end; ``"trace"`` every step's value (the reset
    included); ``"count"`` the number of actions after which it was true; ``"steps"`` those actions'
    numbers. A record of a run must hold a ``required`` metric; an optional one is checked when present.
    A per-goal measure (``shape`` (K,)) is recorded for the episode's goals only."""

    key: str
    at: str = "end"
    required: bool = True
    aggregates: tuple[Aggregate, ...] = ()
    #: True: a set of records none of which holds it has none of its aggregates (a measure that only some
    #: envs report, such as the people's, is absent from the summaries of the others)
    when_recorded: bool = False


#: the record key of an episode's outcome: every variant's success measure is recorded under it
OUTCOME = "success"
FRACTION = "fraction in [0, 1]"


def rate(key: str, label: str, **kw) -> Aggregate:
    """The share of episodes (in percent) where a metric is true."""
    return Aggregate(
        key, label, kw.pop("unit", "%"), "rate", kw.pop("over", "all"), 100.0, (0.0, 100.0), **kw
    )


class Values(Protocol):
    """What a measure reads of the others (a :class:`~biovln_ms.metrics.measure_set.MeasureSet`): ``m[name]``,
    their live values, and ``m.measures``, the measure objects."""

    measures: dict[str, "Measure"]

    def __getitem__(self, name: str) -> np.ndarray: ...


class Measure:
    """One named value per sub-env (a NumPy array with a leading ``num_envs`` dimension). ``compute`` gives
    rows ``idx``; accumulating measures override ``reset``/``update``. ``state_names`` are the arrays a
    state dict saves and restores. ``metric`` (None: only in ``info``) is how evaluation records and
    aggregates it: records, ``summary.json``, the report and the docs' metric table derive from it."""

    uuid: ClassVar[str]
    metric: ClassVar[Metric | None] = None
    dependencies: ClassVar[tuple[str, ...]] = ()
    #: measures updated before this one when the task has them (an order, not a need)
    after: ClassVar[tuple[str, ...]] = ()
    dtype: ClassVar[type] = F64
    shape: ClassVar[tuple[int, ...]] = ()
    state_names: ClassVar[tuple[str, ...]] = ("value",)
    exact_info: ClassVar[bool] = False  # True: info keeps float64 (poses); else floats as float32

    def __init__(self, n: int, cfg: NavTaskConfig) -> None:
        self.cfg = cfg
        self.value = np.zeros((n, *self.shape), dtype=self.dtype)

    def compute(self, ctx: BatchContext, s: StepState, m: "Values", idx: "Rows") -> np.ndarray:
        raise NotImplementedError

    def reset(self, ctx: BatchContext, s: StepState, m: "Values", idx: "Rows") -> None:
        self.value[idx] = self.compute(ctx, s, m, idx)

    def update(self, ctx: BatchContext, s: StepState, m: "Values", idx: "Rows") -> None:
        self.value[idx] = self.compute(ctx, s, m, idx)


_REGISTRY: dict[str, type[Measure]] = {}


def register_measure(cls: type[Measure]) -> type[Measure]:
    """Register a measure class under its ``uuid``. Registering a class of the same module and name again
    (a re-run notebook cell, a reloaded module) replaces it; another class under a taken uuid is an error."""
    old = _REGISTRY.get(cls.uuid)
    if old is not None and (old.__module__, old.__qualname__) != (cls.__module__, cls.__qualname__):
        raise ValueError(f"measure '{cls.uuid}' is already registered by {old.__module__}.{old.__qualname__}")
    _REGISTRY[cls.uuid] = cls
    return cls


def measure_names() -> list[str]:
    return list(_REGISTRY)


def measure_type(name: str) -> type[Measure]:
    """The measure class registered as ``name``."""
    if name not in _REGISTRY:
        raise KeyError(f"unknown measure '{name}'; registered: {', '.join(_REGISTRY)}")
    return _REGISTRY[name]


Rows = np.ndarray | slice  # the sub-envs a measure call touches: an index array, or all of them


class SceneQueryMeasure(Measure):
    """A value of the robot's position read from its own sub-env's scene geometry (numpy / shapely), queried
    again only for sub-envs whose position changed since the last query (a turn keeps it)."""

    state_names = ("value", "at")

    def __init__(self, n: int, cfg: NavTaskConfig) -> None:
        super().__init__(n, cfg)
        self.at = np.full((n, 2), math.nan)  # where each value was queried

    def query(self, ctx: EpisodeContext, p: np.ndarray):
        raise NotImplementedError

    def reset(self, ctx, s, m, idx):
        self.at[idx] = math.nan
        self.update(ctx, s, m, idx)

    def update(self, ctx, s, m, idx):
        pos, at = s.position[idx], self.at[idx]
        changed = (pos[:, 0] != at[:, 0]) | (pos[:, 1] != at[:, 1])  # NaN (never queried) differs
        if not changed.any():
            return
        todo = np.arange(ctx.n)[idx][changed]
        for i in todo.tolist():
            self.value[i] = self.query(ctx.episode(i), s.position[i])
        self.at[todo] = s.position[todo]


def _once(s: StepState, idx: Rows, name: str, compute: Callable[[], np.ndarray]) -> np.ndarray:
    """``compute()`` for this step's rows ``idx``, shared by the measures that need it (the state and the
    rows object are the same for every measure of one update)."""
    key = (name, id(idx))
    if key not in s.cache:
        s.cache[key] = compute()
    return s.cache[key]


def _any_goal(a: np.ndarray) -> np.ndarray:
    """(N,) whether any goal's column of (N, k) ``a`` holds (one goal: its column, the common case)."""
    return a[:, 0] if a.shape[1] == 1 else a.any(axis=1)


def _goal_distances(ctx: BatchContext, s: StepState, idx: Rows) -> np.ndarray:
    """(N, k) Euclidean distances to each goal (inf for unused slots)."""

    def compute() -> np.ndarray:
        d = ctx.goals[idx] - s.position[idx][:, None, :]
        return np.where(ctx.goal_ok[idx], np.hypot(d[..., 0], d[..., 1]), np.inf)

    return _once(s, idx, "distances", compute)


def _in_zone3(ctx: BatchContext, s: StepState, idx: Rows) -> np.ndarray:
    """(N, k) whether the robot's centre is in each goal's Zone 3."""

    def compute() -> np.ndarray:
        z = ctx.zone3[idx]
        d = s.position[idx][:, None, :] - z[..., 0:2]
        du = d[..., 0] * z[..., 2] + d[..., 1] * z[..., 3]
        dv = d[..., 0] * z[..., 4] + d[..., 1] * z[..., 5]
        tol = ZONE3_TOLERANCE
        return ctx.has_zone3[idx] & (np.abs(du) <= z[..., 6] + tol) & (np.abs(dv) <= z[..., 7] + tol)

    return _once(s, idx, "in_zone3", compute)


def _facing_face(ctx: BatchContext, s: StepState, idx: Rows, cfg: NavTaskConfig) -> np.ndarray:
    """(N, k) whether the heading is within ``cfg.strict_facing_deg`` of each goal's inward face normal."""

    def compute() -> np.ndarray:
        f, yaw = ctx.face[idx], s.yaw[idx][:, None]
        cos = -(np.cos(yaw) * f[..., 0] + np.sin(yaw) * f[..., 1])
        return ctx.has_zone3[idx] & (cos >= math.cos(math.radians(cfg.strict_facing_deg)) - 1e-12)

    return _once(s, idx, "facing_face", compute)


def _zone3_occupied(ctx: BatchContext, s: StepState, idx: Rows) -> np.ndarray:
    """(N, k) whether a person's body overlaps each goal's Zone 3 (``s.people`` given)."""

    def compute() -> np.ndarray:
        z = ctx.zone3[idx][:, :, None, :]  # (n, k, 1, 8)
        d = s.people.positions[idx][:, None, :, :] - z[..., 0:2]  # (n, k, P, 2)
        du = np.abs(d[..., 0] * z[..., 2] + d[..., 1] * z[..., 3]) - z[..., 6]
        dv = np.abs(d[..., 0] * z[..., 4] + d[..., 1] * z[..., 5]) - z[..., 7]
        near = np.hypot(np.maximum(du, 0.0), np.maximum(dv, 0.0)) < PERSON_RADIUS
        return ctx.has_zone3[idx] & near.any(axis=2)

    return _once(s, idx, "zone3_occupied", compute)


@register_measure
class DistanceToGoal(Measure):
    """To the nearest goal (the episode's one, or any instance of its category)."""

    uuid = "distance_to_goal"
    metric = Metric("dtg", aggregates=(Aggregate("dtg", "DTG", "m"),))

    def compute(self, ctx, s, m, idx):
        d = _goal_distances(ctx, s, idx)
        return d[:, 0] if d.shape[1] == 1 else d.min(axis=1)


@register_measure
class GeodesicDistanceToGoal(SceneQueryMeasure):
    uuid = "geodesic_distance_to_goal"

    def query(self, c, p):
        return float(c.geodesic(p))


@register_measure
class Clearance(SceneQueryMeasure):
    uuid = "clearance"
    metric = Metric("clearance", at="trace", required=False)

    def query(self, c, p):
        return c.array.clearance(p)


@register_measure
class Zone2Violation(SceneQueryMeasure):
    uuid = "zone2_violation"
    metric = Metric("zone2", at="trace", required=False)
    dtype = bool

    def query(self, c, p):
        return c.array.in_zone2(p)


@register_measure
class InZone3(Measure):
    """In a goal's Zone 3."""

    uuid = "in_zone3"
    dtype = bool

    def compute(self, ctx, s, m, idx):
        return _any_goal(_in_zone3(ctx, s, idx))


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to [-pi, pi)."""
    return np.remainder(a + math.pi, 2 * math.pi) - math.pi


@register_measure
class FacingInstrument(Measure):
    uuid = "facing_instrument"
    dtype = bool

    def compute(self, ctx, s, m, idx):
        d = ctx.target_centres[idx] - s.position[idx][:, None, :]
        bearing = wrap_angle(np.arctan2(d[..., 1], d[..., 0]) - s.yaw[idx][:, None])
        return _any_goal(ctx.goal_ok[idx] & (np.abs(bearing) <= ctx.hfov[idx][:, None] / 2))


@register_measure
class FacingFace(Measure):
    """The robot looks at a goal's operational face: its heading within ``strict_facing_deg`` of ``-f``."""

    uuid = "facing_face"
    dtype = bool

    def compute(self, ctx, s, m, idx):
        return _any_goal(_facing_face(ctx, s, idx, self.cfg))


@register_measure
class StrictSuccess(Measure):
    """Operational success: STOP within a goal's radius, in that goal's Zone 3, facing its face; with
    people, that Zone 3 free of them (an instrument whose face is occupied cannot be operated)."""

    uuid = "strict_success"
    metric = Metric(
        "strict_success",
        required=False,
        aggregates=(rate("strict_sr", "strict SR", count="strict_successes"),),
    )
    dtype = bool
    dependencies = ("stopped",)

    def compute(self, ctx, s, m, idx):
        within = _goal_distances(ctx, s, idx) <= ctx.radii[idx]
        at = within & _in_zone3(ctx, s, idx) & _facing_face(ctx, s, idx, self.cfg)
        if s.people is not None and at.any():  # the people's test only where the rest holds
            at &= ~_zone3_occupied(ctx, s, idx)
        return m["stopped"][idx] & _any_goal(at)


@register_measure
class StrictFailedStop(Measure):
    """STOP that is not an operational success (the strict variant's fail measure)."""

    uuid = "strict_failed_stop"
    dtype = bool
    dependencies = ("stopped", "strict_success")

    def compute(self, ctx, s, m, idx):
        return m["stopped"][idx] & ~m["strict_success"][idx]


@register_measure
class Collisions(Measure):
    uuid = "collisions"
    metric = Metric(
        "collisions",
        required=False,
        aggregates=(Aggregate("collisions", "collisions", "per episode", bounds=None, missing=0.0),),
    )
    dtype = np.int64

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0

    def update(self, ctx, s, m, idx):
        cmd, moved = s.commanded_forward[idx], s.moved_forward[idx]
        self.value[idx] += (cmd > 0) & (moved < 0.9 * cmd)


@register_measure
class Stopped(Measure):
    uuid = "stopped"
    metric = Metric("stopped", required=False)
    dtype = bool

    def compute(self, ctx, s, m, idx):
        return s.stopped[idx]


@register_measure
class Success(Measure):
    """STOP within a goal's success radius (the paper's rule)."""

    uuid = "success"
    metric = Metric(OUTCOME, aggregates=(rate("sr", "SR", count="successes"),))
    dtype = bool
    dependencies = ("stopped",)

    def compute(self, ctx, s, m, idx):
        return m["stopped"][idx] & _any_goal(_goal_distances(ctx, s, idx) <= ctx.radii[idx])


@register_measure
class FailedStop(Measure):
    """STOP outside the success radius: the episode ends as a failure."""

    uuid = "failed_stop"
    dtype = bool
    dependencies = ("stopped", "success")

    def compute(self, ctx, s, m, idx):
        return m["stopped"][idx] & ~m["success"][idx]


@register_measure
class Steps(Measure):
    uuid = "steps"
    metric = Metric(
        "steps",
        aggregates=(
            Aggregate("steps", "steps", "actions", bounds=None),
            Aggregate("steps_success", "steps (successes)", "actions", over="successes", bounds=None),
        ),
    )
    dtype = np.int64

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0

    def update(self, ctx, s, m, idx):
        self.value[idx] += 1


@register_measure
class PathLength(Measure):
    uuid = "path_length"
    metric = Metric(
        "path_length", required=False, aggregates=(Aggregate("path_length", "path length", "m", bounds=None),)
    )
    state_names = ("value", "last")

    def __init__(self, n, cfg):
        super().__init__(n, cfg)
        self.last = np.zeros((n, 2))

    def reset(self, ctx, s, m, idx):
        self.last[idx] = s.position[idx]
        self.value[idx] = 0.0

    def update(self, ctx, s, m, idx):
        d = s.position[idx] - self.last[idx]
        self.value[idx] += np.hypot(d[:, 0], d[:, 1])
        self.last[idx] = s.position[idx]


@register_measure
class MinClearance(Measure):
    """MCR: the minimum clearance over the trajectory so far."""

    uuid = "mcr"
    metric = Metric("mcr", aggregates=(Aggregate("mcr", "MCR", "m"),))
    dependencies = ("clearance",)

    def reset(self, ctx, s, m, idx):
        self.value[idx] = m[self.dependencies[0]][idx]  # the clearance measure it minimises

    def update(self, ctx, s, m, idx):
        self.value[idx] = np.minimum(self.value[idx], m[self.dependencies[0]][idx])


@register_measure
class ViolationRate(Measure):
    """VRT: fraction of trajectory poses (start included) within 0.5 m of an instrument body."""

    uuid = "vrt"
    metric = Metric(
        "vrt", aggregates=(Aggregate("vrt", "VRT", "% of poses", scale=100.0, bounds=(0.0, 100.0)),)
    )
    dependencies = ("clearance",)
    state_names = ("value", "poses", "violations")

    def __init__(self, n, cfg):
        super().__init__(n, cfg)
        self.poses = np.zeros(n, dtype=np.int64)
        self.violations = np.zeros(n, dtype=np.int64)

    def reset(self, ctx, s, m, idx):
        self.poses[idx] = 0
        self.violations[idx] = 0
        self.update(ctx, s, m, idx)

    def update(self, ctx, s, m, idx):
        self.poses[idx] += 1
        self.violations[idx] += m["clearance"][idx] < SAFETY_THRESHOLD
        self.value[idx] = self.violations[idx] / self.poses[idx]


def _efficiency(ctx: BatchContext, m: "Values", idx: Rows) -> np.ndarray:
    """l_opt / max(l, l_opt) (the path-length factor of SPL and soft SPL)."""
    l_opt = ctx.start_geodesic[idx]
    return l_opt / np.maximum(np.maximum(m["path_length"][idx], l_opt), 1e-9)


@register_measure
class SPL(Measure):
    uuid = "spl"
    metric = Metric("spl", aggregates=(Aggregate("spl", "SPL", FRACTION, over="all", bounds=(0.0, 1.0)),))
    dependencies = ("success", "path_length")

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0.0

    def compute(self, ctx, s, m, idx):
        return m["success"][idx] * _efficiency(ctx, m, idx)


@register_measure
class SoftSPL(Measure):
    uuid = "soft_spl"
    metric = Metric(
        "soft_spl", aggregates=(Aggregate("soft_spl", "soft SPL", FRACTION, over="all", bounds=(0.0, 1.0)),)
    )
    dependencies = ("geodesic_distance_to_goal", "path_length")

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0.0

    def compute(self, ctx, s, m, idx):
        d = m["geodesic_distance_to_goal"][idx]
        d0 = np.maximum(ctx.start_geodesic[idx], 1e-9)
        progress = np.maximum(1.0 - d / d0, 0.0)  # an unreachable goal (d = inf) makes no progress
        return progress * _efficiency(ctx, m, idx)


@register_measure
class NavReward(Measure):
    """Eq. 5. The success bonus is paid once, at a successful STOP ("a sparse success bonus"): paying
    1[d_t < r] every step, as printed, would reward hovering inside the radius. The safety penalty is
    flat below 0.5 m clearance, or proportional (1 - clearance / 0.5) in the RL variant."""

    uuid = "nav_reward"
    dependencies = ("distance_to_goal", "success", "clearance")
    state_names = ("value", "previous_distance")

    def __init__(self, n, cfg):
        super().__init__(n, cfg)
        self.previous_distance = np.zeros(n)

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0.0
        self.previous_distance[idx] = m["distance_to_goal"][idx]

    def update(self, ctx, s, m, idx):
        c = self.cfg
        d, clearance = m["distance_to_goal"][idx], m["clearance"][idx]
        unsafe = clearance < SAFETY_THRESHOLD
        scale = (1.0 - clearance / SAFETY_THRESHOLD) if c.proportional_safety else 1.0
        safety = np.where(unsafe, c.safety_penalty * scale, 0.0)
        self.value[idx] = (
            (self.previous_distance[idx] - d) - c.step_penalty + c.success_bonus * m["success"][idx] - safety
        )
        self.previous_distance[idx] = d


@register_measure
class AgentPose(Measure):
    """The robot's planar pose (x, y, yaw) in the world frame: for evaluation logs, not for policies."""

    uuid = "agent_pose"
    shape = (3,)
    exact_info = True

    def compute(self, ctx, s, m, idx):
        return np.concatenate([s.position[idx], s.yaw[idx, None]], axis=1)


@register_measure
class GoalPosition(Measure):
    """The task's goal (x, y) in the world frame: for evaluation logs, not for policies."""

    uuid = "goal_position"
    shape = (2,)
    exact_info = True

    def compute(self, ctx, s, m, idx):
        return ctx.goal[idx]
