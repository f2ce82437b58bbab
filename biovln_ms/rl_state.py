"""The paper's RL state vector (the ``rl_state`` sensor of ``BioVLN-OpFace-RL-v0``), as one function of a
pose, a goal and a clearance: the env computes it from the simulator's pose and clearance, and a policy
without GPS+compass from its own estimates (``biovln_ms.baselines.sb3_policy``), so both read the same
formula."""

from __future__ import annotations

import numpy as np

__all__ = ["rl_state_vector"]


def rl_state_vector(pose: np.ndarray, goal: np.ndarray, clearance: np.ndarray, scale: float) -> np.ndarray:
    """``(N, 9)`` float32: position / s, heading as (cos, sin), goal / s, the goal in the robot frame / s
    and min(clearance, 2) / 2, with s = ``scale`` (the task's ``position_scale``, 4 m); ``pose`` (N, 3) is
    (x, y, yaw), ``goal`` (N, 2), ``clearance`` (N,) in metres."""
    yaw = pose[:, 2]
    c, s = np.cos(yaw), np.sin(yaw)
    d = goal - pose[:, :2]
    local = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], 1)
    return np.concatenate(
        [
            pose[:, :2] / scale,
            np.stack([c, s], 1),
            goal / scale,
            local / scale,
            (np.minimum(clearance, 2.0) / 2.0)[:, None],
        ],
        axis=1,
    ).astype(np.float32)
