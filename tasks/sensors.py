"""The task's sensors (Habitat's GPS, compass, PointGoal-with-GPS+compass and ObjectGoal; the paper's RL
state vector), batched: each maps :class:`SensorInputs` to a float32 tensor with a leading ``num_envs``
dimension. A task config lists the sensors its observation carries (``NavTaskConfig.sensors``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import torch

from biovln_ms.metrics.measures import wrap_angle
from biovln_ms.task_config import NavTaskConfig


@dataclass
class SensorInputs:
    """What the sensors read, for every sub-env (float64 poses in the world frame)."""

    pose: torch.Tensor  # (N, 3) x, y, yaw now
    start: torch.Tensor  # (N, 3) x, y, yaw at the episode's start
    goal: torch.Tensor  # (N, 2) the task's goal
    objectgoal: torch.Tensor  # (N, C) float32 one-hot target category (set at reset)
    clearance: torch.Tensor  # (N,) the clearance measure
    cfg: NavTaskConfig


SENSORS: dict[str, Callable[[SensorInputs], torch.Tensor]] = {}


def register_sensor(uuid: str):
    """Register ``fn(inputs) -> (N, k) tensor`` as observation key ``uuid``."""

    def wrap(fn: Callable[[SensorInputs], torch.Tensor]) -> Callable[[SensorInputs], torch.Tensor]:
        SENSORS[uuid] = fn
        return fn

    return wrap


def _rotate(xy: torch.Tensor, yaw: torch.Tensor) -> torch.Tensor:
    """``xy`` (N, 2) expressed in frames turned by ``yaw`` (N,)."""
    c, s = torch.cos(yaw), torch.sin(yaw)
    return torch.stack([c * xy[:, 0] + s * xy[:, 1], -s * xy[:, 0] + c * xy[:, 1]], dim=1)


@register_sensor("gps")
def gps(x: SensorInputs) -> torch.Tensor:
    """Position in the episode frame: origin at the start, x along the start heading."""
    return _rotate(x.pose[:, :2] - x.start[:, :2], x.start[:, 2]).float()


@register_sensor("compass")
def compass(x: SensorInputs) -> torch.Tensor:
    """Heading relative to the start heading, in [-pi, pi)."""
    return wrap_angle(x.pose[:, 2] - x.start[:, 2])[:, None].float()


@register_sensor("pointgoal_with_gps_compass")
def pointgoal_with_gps_compass(x: SensorInputs) -> torch.Tensor:
    """(rho, phi): distance to the goal and its bearing in the robot frame (counter-clockwise positive)."""
    d = x.goal - x.pose[:, :2]
    rho = torch.linalg.norm(d, dim=1)
    phi = wrap_angle(torch.atan2(d[:, 1], d[:, 0]) - x.pose[:, 2])
    return torch.stack([rho, phi], dim=1).float()


@register_sensor("objectgoal")
def objectgoal(x: SensorInputs) -> torch.Tensor:
    """One-hot target category (the catalog's goal categories, in order)."""
    return x.objectgoal


@register_sensor("rl_state")
def rl_state(x: SensorInputs) -> torch.Tensor:
    """The paper's RL observation: position / s, heading as (cos, sin), goal / s, the goal in the robot
    frame / s and min(clearance, 2) / 2, with s = ``position_scale`` (4 m)."""
    s = x.cfg.position_scale
    local = _rotate(x.goal - x.pose[:, :2], x.pose[:, 2])
    yaw = x.pose[:, 2]
    return torch.cat(
        [
            x.pose[:, :2] / s,
            torch.stack([torch.cos(yaw), torch.sin(yaw)], 1),
            x.goal / s,
            local / s,
            (torch.clamp(x.clearance, max=2.0) / 2.0)[:, None],
        ],
        dim=1,
    ).float()


def semantic_category(segmentation: torch.Tensor, lookup: torch.Tensor) -> torch.Tensor:
    """Per pixel, 1 + the goal-category index of the object seen there (0: none): ``lookup`` maps
    segmentation ids to those values."""
    seg = segmentation.long().clamp(min=0, max=len(lookup) - 1)
    return lookup[seg]
