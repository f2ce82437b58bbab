"""Camera parameters re-expressed in the robot's base frame: what a robot without GPS+compass knows of its
cameras (the mount), given the world-frame parameters a simulator reports and the base's planar pose.

For a base at ``(x, y)`` with yaw ``t`` (``c, s = cos t, sin t``), ``base2world = [[c, -s, 0, x],
[s, c, 0, y], [0, 0, 1, 0], [0, 0, 0, 1]]`` and its inverse ``world2base = [[c, s, 0, -(c x + s y)],
[-s, c, 0, s x - c y], [0, 0, 1, 0], [0, 0, 0, 1]]``, built in float64 and rounded to the parameters'
dtype. Then ``extrinsic_cv <- extrinsic_cv @ base2world`` (world -> camera, applied to base points) and
``cam2world_gl <- world2base @ cam2world_gl`` (camera -> base).

Two implementations, equal bit for bit (``tests/test_base_frame.py``): the transforms of
:func:`base_transforms` applied with torch's batched matmul (the env does this on other devices), and the
fused CPU kernel :func:`camera_params_in_base_frame` (Numba), one call instead of some twenty small array
operations, which cost far more than their arithmetic right after a render has evicted the caches. The
kernel reproduces torch's CPU matmul of these small matrices: each entry a float32 sum from 0 over ``k`` in
order of the float32 products, no fused multiply-add.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["base_transforms", "camera_params_in_base_frame"]


def base_transforms(pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(base2world, world2base)``, float64 ``(N, 4, 4)``, of the planar poses ``(N, 3)`` (x, y, yaw)."""
    x, y, c, s = pose[:, 0], pose[:, 1], np.cos(pose[:, 2]), np.sin(pose[:, 2])
    base2world = np.zeros((len(pose), 4, 4))
    base2world[:, 0, 0], base2world[:, 0, 1], base2world[:, 1, 0], base2world[:, 1, 1] = c, -s, s, c
    base2world[:, :2, 3], base2world[:, 2, 2], base2world[:, 3, 3] = pose[:, :2], 1.0, 1.0
    world2base = base2world.transpose(0, 2, 1).copy()  # a planar rigid motion's inverse: R^T, -R^T t
    world2base[:, 3, :2] = 0.0
    world2base[:, 0, 3], world2base[:, 1, 3] = -(c * x + s * y), s * x - c * y
    return base2world, world2base


@njit(cache=True)
def camera_params_in_base_frame(pose, extrinsic_cv, cam2world_gl, extrinsic_out, cam2base_out):
    """For each sub-env ``n`` (``pose`` float64 ``(N, 3)``; the rest float32): ``extrinsic_out[n] =
    extrinsic_cv[n] @ base2world`` (``(3, 4)``) and ``cam2base_out[n] = world2base @ cam2world_gl[n]``
    (``(4, 4)``), as :func:`base_transforms` and torch's float32 matmul compute them."""
    b2w = np.zeros((4, 4), np.float32)
    w2b = np.zeros((4, 4), np.float32)
    b2w[2, 2] = b2w[3, 3] = w2b[2, 2] = w2b[3, 3] = np.float32(1.0)
    for n in range(pose.shape[0]):
        x, y = pose[n, 0], pose[n, 1]
        c, s = np.cos(pose[n, 2]), np.sin(pose[n, 2])
        b2w[0, 0] = b2w[1, 1] = w2b[0, 0] = w2b[1, 1] = np.float32(c)
        b2w[1, 0] = w2b[0, 1] = np.float32(s)
        b2w[0, 1] = w2b[1, 0] = np.float32(-s)
        b2w[0, 3], b2w[1, 3] = np.float32(x), np.float32(y)
        w2b[0, 3], w2b[1, 3] = np.float32(-(c * x + s * y)), np.float32(s * x - c * y)
        _matmul(extrinsic_cv[n], b2w, extrinsic_out[n])
        _matmul(w2b, cam2world_gl[n], cam2base_out[n])


@njit(cache=True)
def _matmul(a, b, out):
    """``out = a @ b`` in float32, each entry summed from 0 over ``k`` in order (torch's CPU kernel for
    matrices this small)."""
    for i in range(a.shape[0]):
        for j in range(b.shape[1]):
            acc = np.float32(0.0)
            for k in range(a.shape[1]):
                acc += a[i, k] * b[k, j]
            out[i, j] = acc
