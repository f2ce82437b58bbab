"""Fused CPU kernels of the sensor noise models (:mod:`biovln_ms.sensor_noise`), compiled by Numba.

Each kernel takes a whole batch in one call and makes one pass over each image, computing value for value
what the models' torch path computes in several passes (the torch path runs on other devices;
``tests/test_sensor_noise.py`` checks the two agree bit for bit). Single-threaded, as an env worker is;
compiled on first use and cached on disk (Numba's ``cache=True``: the package's ``__pycache__``, or the
user's cache directory where that is not writable). ``error_model="numpy"``: a division by zero gives an
infinity, as in torch, instead of raising. The loops are written for LLVM to vectorise: slices instead of
offset arithmetic and selects instead of branches; an in-place loop reads and writes only the one array.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["depth_frames", "rgb_frames"]


@njit(cache=True, error_model="numpy")
def rgb_frames(images, bank, wide, wide_steps, offsets):
    """In place, :class:`~biovln_ms.sensor_noise.RGBNoise` on each image of ``images`` (uint8
    ``(N, bytes)``, rows contiguous): ``x = clip(x + n, 0, 255)`` at byte ``i``, ``n`` the step at
    ``offsets[row] + i``. ``bank``: the steps as int8 in two's complement (uint8), saturated at +-127;
    ``wide`` (sorted) and ``wide_steps``: the positions and values of the steps beyond, set after the pass.

    The pass adds in uint8 and detects the wrap: with ``s = (x + b) mod 256``, a non-negative step
    (``b < 128``) overflowed iff ``s < x`` (then 255), a negative one (``b >= 128``, ``n = b - 256``)
    went below 0 iff ``s > x`` (then 0)."""
    size = images.shape[1]
    for row in range(images.shape[0]):
        o = offsets[row]
        img, b = images[row], bank[o : o + size]
        first, last = np.searchsorted(wide, o), np.searchsorted(wide, o + size)
        kept = img[wide[first:last] - o].astype(np.int32)  # the inputs under wide steps
        for i in range(size):
            x, d = img[i], b[i]
            s = np.uint8(x + d)
            img[i] = (np.uint8(0) if s > x else s) if d >= 128 else (np.uint8(255) if s < x else s)
        for e in range(first, last):
            img[wide[e] - o] = np.uint8(min(max(kept[e - first] + wide_steps[e], 0), 255))


@njit(cache=True, error_model="numpy")
def depth_frames(depth, codes, dys, dxs, moves, rows, pad, disp, offsets, q, k_max, lut, near, far, mm, out):
    """:class:`~biovln_ms.sensor_noise.DepthNoise` on each image of ``depth`` (``(N, H * W)``, int16 mm or
    float32) into ``out`` (``(N, H, W)``, the dtype of ``lut``; it may be ``depth`` itself): the jittered
    read ``z``, ``v = disp[offsets[n] + i] + q / z`` in float32, clamped to ``[0, k_max]`` (NaN and -inf
    to 0, +inf to ``k_max``), truncated, and ``out = lut[v]``. With ``mm > 0`` the lookup is arithmetic and
    vectorised instead: ``out = rint(mm / k)`` for ``near <= k <= far``, else 0 (the caller checked that
    this reproduces ``lut`` at every ``k``; it does for int16 millimetres).

    ``codes`` (uint8 or uint16, one per bank pixel): the bank's (row, column) shift of each pixel as a code
    ``c`` into ``dys[c]``, ``dxs[c]`` (at most ``pad`` rows) and ``moves[c] = dys[c] * W + dxs[c]``; image
    ``n``'s window starts at bank row ``rows[n]``. Pixel ``(y, x)`` reads ``(y + dy, x + dx)``, the row
    clamped to the image near its top and bottom edges. ``pad == 0``: no jitter.

    Row by row: a read loop, then the arithmetic and the lookup (two loops, the arithmetic one vectorised;
    one vectorised loop when the lookup is arithmetic). Output
    row ``y`` goes to memory once no later row reads input row ``y`` (after row ``y + pad``), through a ring
    of ``pad + 1`` rows, so ``out`` may be ``depth``."""
    height, width = out.shape[1], out.shape[2]
    zero, top = np.float32(0.0), np.float32(k_max)
    z = np.empty(width, np.float32)
    k = np.empty(width, np.int32)
    ring = np.empty((pad + 1, width), out.dtype)
    for n in range(depth.shape[0]):
        img, dst, start = depth[n], out[n], rows[n] * width
        for y in range(height):
            first = y * width
            if pad == 0:
                for x in range(width):
                    z[x] = img[first + x]
            else:
                c = codes[start + first : start + first + width]
                if pad <= y < height - pad:
                    for x in range(width):
                        z[x] = img[np.uintp(first + x + moves[c[x]])]
                else:
                    for x in range(width):
                        y_read = min(max(y + dys[c[x]], 0), height - 1)
                        z[x] = img[np.uintp(y_read * width + x + dxs[c[x]])]
            d = disp[offsets[n] + first : offsets[n] + first + width]
            slot = ring[y % (pad + 1)]
            if y > pad:
                dst[y - pad - 1] = slot  # no row from y on reads input row y - pad - 1
            if mm > 0:
                for x in range(width):
                    v = d[x] + q / z[x]
                    v = v if v > zero else zero  # NaN too
                    kf = np.floor(v if v < top else top)  # the truncation of a value >= 0
                    slot[x] = np.rint(mm / kf) if near <= kf <= far else zero
            else:
                for x in range(width):
                    v = d[x] + q / z[x]
                    v = v if v > zero else zero
                    k[x] = np.int32(v if v < top else top)
                for x in range(width):
                    slot[x] = lut[k[x]]
        for y in range(max(height - pad - 1, 0), height):
            dst[y] = ring[y % (pad + 1)]
