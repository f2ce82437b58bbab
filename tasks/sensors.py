"""The task's sensors (Habitat's GPS, compass, PointGoal-with-GPS+compass and ObjectGoal; the paper's RL
state vector), batched: each maps :class:`SensorInputs` (host arrays, like the measures they read) to a
float32 array with a leading ``num_envs`` dimension; the env hands them to policies as tensors on its
device. A task config lists the sensors its observation carries (``NavTaskConfig.sensors``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import torch

from biovln_ms.metrics.measures import wrap_angle
from biovln_ms.rl_state import rl_state_vector
from biovln_ms.task_config import NavTaskConfig


@dataclass
class SensorInputs:
    """What the sensors read, for every sub-env (float64 poses in the world frame)."""

    pose: np.ndarray  # (N, 3) x, y, yaw now
    start: np.ndarray  # (N, 3) x, y, yaw at the episode's start
    goal: np.ndarray  # (N, 2) the task's goal
    objectgoal: np.ndarray  # (N, C) float32 one-hot target category (set at reset)
    clearance: np.ndarray  # (N,) the clearance measure
    cfg: NavTaskConfig


SENSORS: dict[str, Callable[[SensorInputs], np.ndarray]] = {}


def register_sensor(uuid: str):
    """Register ``fn(inputs) -> (N, k) float32 array`` (a new array each call) as observation key ``uuid``."""

    def wrap(fn: Callable[[SensorInputs], np.ndarray]) -> Callable[[SensorInputs], np.ndarray]:
        SENSORS[uuid] = fn
        return fn

    return wrap


def _rotate(xy: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """``xy`` (N, 2) expressed in frames turned by ``yaw`` (N,)."""
    c, s = np.cos(yaw), np.sin(yaw)
    out = np.empty_like(xy)
    out[:, 0], out[:, 1] = c * xy[:, 0] + s * xy[:, 1], -s * xy[:, 0] + c * xy[:, 1]
    return out


@register_sensor("gps")
def gps(x: SensorInputs) -> np.ndarray:
    """Position in the episode frame: origin at the start, x along the start heading."""
    return _rotate(x.pose[:, :2] - x.start[:, :2], x.start[:, 2]).astype(np.float32)


@register_sensor("compass")
def compass(x: SensorInputs) -> np.ndarray:
    """Heading relative to the start heading, in [-pi, pi)."""
    return wrap_angle(x.pose[:, 2] - x.start[:, 2])[:, None].astype(np.float32)


@register_sensor("pointgoal_with_gps_compass")
def pointgoal_with_gps_compass(x: SensorInputs) -> np.ndarray:
    """(rho, phi): distance to the goal and its bearing in the robot frame (counter-clockwise positive)."""
    d = x.goal - x.pose[:, :2]
    out = np.empty((len(d), 2), np.float32)
    out[:, 0] = np.hypot(d[:, 0], d[:, 1])
    out[:, 1] = wrap_angle(np.arctan2(d[:, 1], d[:, 0]) - x.pose[:, 2])
    return out


@register_sensor("pointgoal")
def pointgoal(x: SensorInputs) -> np.ndarray:
    """(rho, phi) of the goal in the episode's start frame: what the robot is told once, without GPS+compass
    (Habitat's PointGoal sensor); it does not change as the robot moves."""
    d = x.goal - x.start[:, :2]
    out = np.empty((len(d), 2), np.float32)
    out[:, 0] = np.hypot(d[:, 0], d[:, 1])
    out[:, 1] = wrap_angle(np.arctan2(d[:, 1], d[:, 0]) - x.start[:, 2])
    return out


@register_sensor("objectgoal")
def objectgoal(x: SensorInputs) -> np.ndarray:
    """One-hot target category (the catalog's goal categories, in order)."""
    return x.objectgoal.copy()


@register_sensor("rl_state")
def rl_state(x: SensorInputs) -> np.ndarray:
    """The paper's RL observation (:func:`biovln_ms.rl_state.rl_state_vector`) from the robot's pose."""
    return rl_state_vector(x.pose, x.goal, x.clearance, x.cfg.position_scale)


def semantic_category(segmentation: torch.Tensor, lookup: torch.Tensor) -> torch.Tensor:
    """Per pixel, 1 + the goal-category index of the object seen there (0: none): ``lookup`` maps
    segmentation ids to those values. The result is on the image's device (a GPU renderer returns images on
    the GPU while a ``physx_cpu`` env keeps its other tensors on the CPU)."""
    seg = segmentation.long().clamp(min=0, max=len(lookup) - 1)
    return lookup.to(seg.device)[seg]
