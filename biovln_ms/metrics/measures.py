"""Per-step and per-episode measures, batched over ``num_envs`` (habitat-lab's measures, ManiSkill's tensors).

A :class:`MeasureSet` resets (rows ``env_idx``) and updates registered measures in dependency order from a
:class:`StepState` (the robots' planar poses and commands, tensors with a leading ``num_envs`` dimension)
and a :class:`BatchContext` (each sub-env's episode), and exposes their values as an ``info`` dict.
Reward, success and fail are measures too; the task config names which. Conventions (paper §4.2):

* ``clearance`` is the planar distance from the robot's centre (the agent position, as Habitat and
  the paper record trajectories) to the nearest instrument body (Zone 1); the robot radius is NOT
  subtracted, so a robot touching a body reads ``clearance == radius``. MCR and VRT use the same value.
* ``zone2_violation``: the robot's centre is inside some instrument's Zone 2.
* ``facing_instrument``: the target's centre lies within half the camera's horizontal field of view.
* ``collisions``: steps whose commanded forward motion was cut short by contact (moved < 90 %).
* SPL = success * l_opt / max(l, l_opt); soft SPL = (1 - d_T / d_0) * l_opt / max(l, l_opt) with geodesic
  d_T at the end and d_0 at the start; DTG = final Euclidean distance; VRT = fraction of steps
  (the start included) with clearance < 0.5 m; MCR = minimum clearance over the trajectory.
* ``nav_reward`` is Eq. 5: (d_{t-1} - d_t) - step penalty + success bonus * success - safety penalty.

Geometry that differs per scene (geodesics, clearance, Zone 2) is queried per sub-env; everything else
is one tensor operation over the batch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, ClassVar

import numpy as np
import torch

from biovln_ms.geometry.zones import SAFETY_THRESHOLD, InstrumentArray, PlacedInstrument
from biovln_ms.task_config import NavTaskConfig

F64 = torch.float64


@dataclass
class EpisodeContext:
    """What the measures know about one sub-env's episode (fixed at reset)."""

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


class BatchContext:
    """The episodes of ``n`` sub-envs, with the per-env numbers the batched measures need as tensors."""

    def __init__(self, n: int, device: torch.device | str = "cpu") -> None:
        self.n, self.device = n, torch.device(device)
        self.episodes: list[EpisodeContext | None] = [None] * n
        z = lambda *shape: torch.zeros(n, *shape, dtype=F64, device=self.device)  # noqa: E731
        self.goal, self.target_centre = z(2), z(2)
        self.radius, self.start_geodesic, self.hfov = z(), z(), z()
        self.zone3 = z(8)  # centre (2), unit axes u, v (2 + 2), half extents (2)
        self.has_zone3 = torch.zeros(n, dtype=torch.bool, device=self.device)

    def set(self, i: int, ctx: EpisodeContext) -> None:
        """Sub-env ``i`` starts the episode ``ctx``."""
        self.episodes[i] = ctx
        t = lambda v: torch.as_tensor(np.asarray(v, float), dtype=F64, device=self.device)  # noqa: E731
        self.goal[i], self.target_centre[i] = t(ctx.goal), t(ctx.target.center_xy)
        self.radius[i], self.start_geodesic[i], self.hfov[i] = (
            ctx.success_radius,
            ctx.start_geodesic,
            ctx.hfov,
        )
        self.has_zone3[i] = ctx.target.model_face is not None
        if ctx.target.model_face is not None:
            corners = ctx.target.zone3_corners()
            u, v = corners[1] - corners[0], corners[3] - corners[0]
            lu, lv = np.linalg.norm(u), np.linalg.norm(v)
            self.zone3[i] = t(np.concatenate([corners.mean(axis=0), u / lu, v / lv, [lu / 2, lv / 2]]))

    def episode(self, i: int) -> EpisodeContext:
        ctx = self.episodes[i]
        if ctx is None:
            raise RuntimeError(f"sub-env {i} has no episode: reset it first")
        return ctx


@dataclass
class StepState:
    """The robots after an action (or at reset), each field with a leading ``num_envs`` dimension."""

    position: torch.Tensor  # (N, 2) float64
    yaw: torch.Tensor  # (N,) float64
    stopped: torch.Tensor  # (N,) bool
    commanded_forward: torch.Tensor  # (N,) float64
    moved_forward: torch.Tensor  # (N,) float64

    @classmethod
    def at_rest(cls, pose: torch.Tensor) -> "StepState":
        """The state at reset: pose (N, 3), no command."""
        pose = pose.to(F64)
        zeros = torch.zeros(len(pose), dtype=F64, device=pose.device)
        return cls(
            pose[:, :2],
            pose[:, 2],
            torch.zeros(len(pose), dtype=torch.bool, device=pose.device),
            zeros,
            zeros,
        )


class Measure:
    """One named value per sub-env. ``compute`` gives rows ``idx``; accumulating measures override
    ``reset``/``update``. ``state_names`` are the tensors a state dict saves and restores."""

    uuid: ClassVar[str]
    dependencies: ClassVar[tuple[str, ...]] = ()
    dtype: ClassVar[torch.dtype] = F64
    shape: ClassVar[tuple[int, ...]] = ()
    state_names: ClassVar[tuple[str, ...]] = ("value",)
    exact_info: ClassVar[bool] = False  # True: info keeps float64 (poses); else floats as float32

    def __init__(self, n: int, device: torch.device, cfg: NavTaskConfig) -> None:
        self.cfg = cfg
        self.value = torch.zeros(n, *self.shape, dtype=self.dtype, device=device)

    def compute(self, ctx: BatchContext, s: StepState, m: "MeasureSet", idx: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def reset(self, ctx: BatchContext, s: StepState, m: "MeasureSet", idx: torch.Tensor) -> None:
        self.value[idx] = self.compute(ctx, s, m, idx)

    def update(self, ctx: BatchContext, s: StepState, m: "MeasureSet", idx: torch.Tensor) -> None:
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


Rows = torch.Tensor | slice  # the sub-envs a measure call touches: an index tensor, or all of them


def rows(idx: Rows, n: int) -> list[int]:
    """The sub-env indices of ``idx``."""
    return list(range(n))[idx] if isinstance(idx, slice) else idx.tolist()


class SceneQueryMeasure(Measure):
    """A value of the robot's position read from its own sub-env's scene geometry (numpy / shapely), queried
    again only for sub-envs whose position changed since the last query (a turn keeps it)."""

    state_names = ("value", "at")

    def __init__(self, n: int, device: torch.device, cfg: NavTaskConfig) -> None:
        super().__init__(n, device, cfg)
        self.at = torch.full((n, 2), math.nan, dtype=F64, device=device)  # where each value was queried

    def query(self, ctx: EpisodeContext, p: np.ndarray):
        raise NotImplementedError

    def reset(self, ctx, s, m, idx):
        self.at[idx] = math.nan
        self.update(ctx, s, m, idx)

    def update(self, ctx, s, m, idx):
        pos, at = s.position.cpu().numpy(), self.at.cpu().numpy()
        todo = [i for i in rows(idx, ctx.n) if not np.array_equal(pos[i], at[i])]
        if todo:
            values = [self.query(ctx.episode(i), pos[i]) for i in todo]
            self.value[todo] = torch.tensor(values, dtype=self.dtype, device=self.value.device)
            self.at[todo] = s.position[todo]


@register_measure
class DistanceToGoal(Measure):
    uuid = "distance_to_goal"

    def compute(self, ctx, s, m, idx):
        return torch.linalg.norm(s.position[idx] - ctx.goal[idx], dim=1)


@register_measure
class GeodesicDistanceToGoal(SceneQueryMeasure):
    uuid = "geodesic_distance_to_goal"

    def query(self, c, p):
        return float(c.geodesic(p))


@register_measure
class Clearance(SceneQueryMeasure):
    uuid = "clearance"

    def query(self, c, p):
        return c.array.clearance(p)


@register_measure
class Zone2Violation(SceneQueryMeasure):
    uuid = "zone2_violation"
    dtype = torch.bool

    def query(self, c, p):
        return c.array.in_zone2(p)


@register_measure
class InZone3(Measure):
    uuid = "in_zone3"
    dtype = torch.bool

    def compute(self, ctx, s, m, idx):
        z = ctx.zone3[idx]
        d = s.position[idx] - z[:, 0:2]
        du, dv = (d * z[:, 2:4]).sum(1), (d * z[:, 4:6]).sum(1)
        return ctx.has_zone3[idx] & (du.abs() <= z[:, 6] + 1e-9) & (dv.abs() <= z[:, 7] + 1e-9)


def wrap_angle(a: torch.Tensor) -> torch.Tensor:
    """Angles wrapped to [-pi, pi)."""
    return torch.remainder(a + math.pi, 2 * math.pi) - math.pi


@register_measure
class FacingInstrument(Measure):
    uuid = "facing_instrument"
    dtype = torch.bool

    def compute(self, ctx, s, m, idx):
        d = ctx.target_centre[idx] - s.position[idx]
        bearing = wrap_angle(torch.atan2(d[:, 1], d[:, 0]) - s.yaw[idx])
        return bearing.abs() <= ctx.hfov[idx] / 2


@register_measure
class Collisions(Measure):
    uuid = "collisions"
    dtype = torch.int64

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0

    def update(self, ctx, s, m, idx):
        cmd, moved = s.commanded_forward[idx], s.moved_forward[idx]
        self.value[idx] += ((cmd > 0) & (moved < 0.9 * cmd)).to(self.dtype)


@register_measure
class Stopped(Measure):
    uuid = "stopped"
    dtype = torch.bool

    def compute(self, ctx, s, m, idx):
        return s.stopped[idx]


@register_measure
class Success(Measure):
    uuid = "success"
    dtype = torch.bool
    dependencies = ("distance_to_goal", "stopped")

    def compute(self, ctx, s, m, idx):
        return m["stopped"][idx] & (m["distance_to_goal"][idx] <= ctx.radius[idx])


@register_measure
class FailedStop(Measure):
    """STOP outside the success radius: the episode ends as a failure."""

    uuid = "failed_stop"
    dtype = torch.bool
    dependencies = ("stopped", "success")

    def compute(self, ctx, s, m, idx):
        return m["stopped"][idx] & ~m["success"][idx]


@register_measure
class Steps(Measure):
    uuid = "steps"
    dtype = torch.int64

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0

    def update(self, ctx, s, m, idx):
        self.value[idx] += 1


@register_measure
class PathLength(Measure):
    uuid = "path_length"
    state_names = ("value", "last")

    def __init__(self, n, device, cfg):
        super().__init__(n, device, cfg)
        self.last = torch.zeros(n, 2, dtype=F64, device=device)

    def reset(self, ctx, s, m, idx):
        self.last[idx] = s.position[idx]
        self.value[idx] = 0.0

    def update(self, ctx, s, m, idx):
        self.value[idx] += torch.linalg.norm(s.position[idx] - self.last[idx], dim=1)
        self.last[idx] = s.position[idx]


@register_measure
class MinClearance(Measure):
    """MCR: the minimum clearance over the trajectory so far."""

    uuid = "mcr"
    dependencies = ("clearance",)

    def reset(self, ctx, s, m, idx):
        self.value[idx] = m["clearance"][idx]

    def update(self, ctx, s, m, idx):
        self.value[idx] = torch.minimum(self.value[idx], m["clearance"][idx])


@register_measure
class ViolationRate(Measure):
    """VRT: fraction of trajectory poses (start included) within 0.5 m of an instrument body."""

    uuid = "vrt"
    dependencies = ("clearance",)
    state_names = ("value", "poses", "violations")

    def __init__(self, n, device, cfg):
        super().__init__(n, device, cfg)
        self.poses = torch.zeros(n, dtype=torch.int64, device=device)
        self.violations = torch.zeros(n, dtype=torch.int64, device=device)

    def reset(self, ctx, s, m, idx):
        self.poses[idx] = 0
        self.violations[idx] = 0
        self.update(ctx, s, m, idx)

    def update(self, ctx, s, m, idx):
        self.poses[idx] += 1
        self.violations[idx] += (m["clearance"][idx] < SAFETY_THRESHOLD).to(torch.int64)
        self.value[idx] = self.violations[idx].to(F64) / self.poses[idx].to(F64)


def _efficiency(ctx: BatchContext, m: "MeasureSet", idx: torch.Tensor) -> torch.Tensor:
    """l_opt / max(l, l_opt) (the path-length factor of SPL and soft SPL)."""
    l_opt = ctx.start_geodesic[idx]
    return l_opt / torch.clamp(torch.maximum(m["path_length"][idx], l_opt), min=1e-9)


@register_measure
class SPL(Measure):
    uuid = "spl"
    dependencies = ("success", "path_length")

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0.0

    def compute(self, ctx, s, m, idx):
        return m["success"][idx].to(F64) * _efficiency(ctx, m, idx)


@register_measure
class SoftSPL(Measure):
    uuid = "soft_spl"
    dependencies = ("geodesic_distance_to_goal", "path_length")

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0.0

    def compute(self, ctx, s, m, idx):
        d = m["geodesic_distance_to_goal"][idx]
        d0 = torch.clamp(ctx.start_geodesic[idx], min=1e-9)
        progress = torch.where(torch.isfinite(d), torch.clamp(1.0 - d / d0, min=0.0), torch.zeros_like(d))
        return progress * _efficiency(ctx, m, idx)


@register_measure
class NavReward(Measure):
    """Eq. 5. The success bonus is paid once, at a successful STOP ("a sparse success bonus"): paying
    1[d_t < r] every step, as printed, would reward hovering inside the radius. The safety penalty is
    flat below 0.5 m clearance, or proportional (1 - clearance / 0.5) in the RL variant."""

    uuid = "nav_reward"
    dependencies = ("distance_to_goal", "success", "clearance")
    state_names = ("value", "previous_distance")

    def __init__(self, n, device, cfg):
        super().__init__(n, device, cfg)
        self.previous_distance = torch.zeros(n, dtype=F64, device=device)

    def reset(self, ctx, s, m, idx):
        self.value[idx] = 0.0
        self.previous_distance[idx] = m["distance_to_goal"][idx]

    def update(self, ctx, s, m, idx):
        c = self.cfg
        d, clearance = m["distance_to_goal"][idx], m["clearance"][idx]
        unsafe = clearance < SAFETY_THRESHOLD
        scale = (1.0 - clearance / SAFETY_THRESHOLD) if c.proportional_safety else torch.ones_like(clearance)
        safety = torch.where(unsafe, c.safety_penalty * scale, torch.zeros_like(clearance))
        self.value[idx] = (
            (self.previous_distance[idx] - d)
            - c.step_penalty
            + c.success_bonus * m["success"][idx].to(F64)
            - safety
        )
        self.previous_distance[idx] = d


@register_measure
class AgentPose(Measure):
    """The robot's planar pose (x, y, yaw) in the world frame: for evaluation logs, not for policies."""

    uuid = "agent_pose"
    shape = (3,)
    exact_info = True

    def compute(self, ctx, s, m, idx):
        return torch.cat([s.position[idx], s.yaw[idx, None]], dim=1)


@register_measure
class GoalPosition(Measure):
    """The task's goal (x, y) in the world frame: for evaluation logs, not for policies."""

    uuid = "goal_position"
    shape = (2,)
    exact_info = True

    def compute(self, ctx, s, m, idx):
        return ctx.goal[idx]


class MeasureSet:
    """Registered measures for ``n`` sub-envs, updated in dependency order."""

    def __init__(
        self,
        names: tuple[str, ...] = NavTaskConfig().measures,
        n: int = 1,
        device: torch.device | str = "cpu",
        cfg: NavTaskConfig | None = None,
    ) -> None:
        order: list[str] = []

        def visit(name: str, stack: tuple = ()) -> None:
            if name in order:
                return
            if name not in _REGISTRY:
                raise KeyError(f"unknown measure '{name}'; registered: {', '.join(_REGISTRY)}")
            if name in stack:
                raise ValueError(f"measure dependency cycle: {' -> '.join(stack + (name,))}")
            for d in _REGISTRY[name].dependencies:
                visit(d, stack + (name,))
            order.append(name)

        for name in names:
            visit(name)
        self.names, self.n, self.device = tuple(names), n, torch.device(device)
        cfg = cfg or NavTaskConfig()
        self.measures = {name: _REGISTRY[name](n, self.device, cfg) for name in order}

    def __getitem__(self, name: str) -> torch.Tensor:
        return self.measures[name].value

    def _idx(self, env_idx: torch.Tensor | None) -> torch.Tensor | slice:
        """Rows to touch: a slice for all of them (basic indexing is several times cheaper than a tensor)."""
        return slice(None) if env_idx is None else env_idx.to(self.device)

    def reset(self, ctx: BatchContext, state: StepState, env_idx: torch.Tensor | None = None) -> None:
        """Start the episodes of sub-envs ``env_idx`` (all by default)."""
        idx = self._idx(env_idx)
        for meas in self.measures.values():
            meas.reset(ctx, state, self, idx)

    def update(self, ctx: BatchContext, state: StepState, env_idx: torch.Tensor | None = None) -> None:
        """One step of sub-envs ``env_idx`` (all by default)."""
        idx = self._idx(env_idx)
        for meas in self.measures.values():
            meas.update(ctx, state, self, idx)

    def info(self, names: tuple[str, ...] | None = None) -> dict[str, torch.Tensor]:
        """Copies of the values (floats as float32 unless ``exact_info``, counts as int32)."""
        out = {}
        for name in names or self.names:
            meas = self.measures[name]
            v = meas.value
            if v.is_floating_point() and not meas.exact_info:
                v = v.to(torch.float32)
            out[name] = v.to(torch.int32) if v.dtype == torch.int64 else v.clone()
        return out

    def state_dict(self) -> dict[str, dict[str, torch.Tensor]]:
        """Every measure's state tensors (cloned): what a replay needs to continue the episode."""
        return {
            name: {k: getattr(meas, k).clone() for k in meas.state_names}
            for name, meas in self.measures.items()
        }

    def load_state_dict(self, state: dict, env_idx: torch.Tensor | None = None) -> None:
        """Restore rows ``env_idx`` (all by default) from :meth:`state_dict` output."""
        idx = self._idx(env_idx)
        missing = sorted(set(self.measures) - set(state))
        if missing:
            raise KeyError(f"the task state has no measure {', '.join(missing)}")
        for name, meas in self.measures.items():
            for k in meas.state_names:
                t = getattr(meas, k)
                t[idx] = torch.as_tensor(state[name][k], device=t.device).to(t.dtype)[idx]
