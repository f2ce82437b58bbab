"""Cost of the sensor noise models (``biovln_ms.sensor_noise``) per frame, single-threaded.

    python benchmarks/sensor_noise.py [--frames 500]

For 640x480 and 128x128 (N = 1, ``torch.set_num_threads(1)``, CPU) prints the median ms/frame of
``RGBNoise`` on a uint8 ``(1, H, W, 3)`` image, both as a 3-channel view of an RGBA tensor (what ManiSkill's
minimal shader returns, the env's default) and contiguous (the default shader), and of ``DepthNoise`` on an
int16-millimetre ``(1, H, W, 1)`` depth image (what the rgbd obs mode returns), a new key per frame as in
an episode, next to a plain ``img.clone()`` of the same tensors as the reference (cloning the RGBA view is
slow: torch copies 3 of 4 bytes element by element). Two regimes: ``hot`` (frames back to back, the banks
and images stay in cache) and ``evicted`` (64 MB written between frames, as a render step would, not timed).
The budget: all of ``realistic``'s work over ``ideal`` (both models, the actuation noise, the base-frame
extrinsics) costs at most 5 % of an env step. ``benchmarks/env_speed.py`` measures that inside the env.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import torch

from biovln_ms.sensor_noise import DepthNoise, RGBNoise, frame_keys

HFOV_DEG = 79.0  # the env's default camera (task_config.camera_hfov_deg)


def scene_like_depth(h: int, w: int) -> torch.Tensor:
    """Floor-and-wall-like depth in int16 mm: 0.4-12 m over the rows, a band of no-hit (0) pixels on top."""
    rng = np.random.default_rng(0)
    rows = np.linspace(12000, 400, h)[:, None]
    cols = 1.0 + 0.3 * np.sin(np.linspace(0, 6, w))[None, :]
    z = rows * cols + rng.normal(0, 5, (h, w))
    z[: h // 20] = 0
    return torch.as_tensor(np.clip(z, 0, 32767).astype(np.int16)).reshape(1, h, w, 1)


def median_ms(fn, frames: int, evict: torch.Tensor | None) -> float:
    ts = []
    for i in range(frames + 10):
        if evict is not None:
            evict.add_(1)
        t = time.perf_counter()
        fn(i)
        if i >= 10:
            ts.append(time.perf_counter() - t)
    return float(np.median(ts)) * 1e3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=500)
    args = ap.parse_args()
    torch.set_num_threads(1)
    evict = torch.zeros(16 * 1024 * 1024, dtype=torch.int32)  # 64 MB, twice a 32 MB L3
    print(f"torch {torch.__version__}, 1 thread, CPU; median ms/frame of {args.frames} frames, N = 1")
    head = (
        "size",
        "caches",
        "rgb layout",
        "rgb clone",
        "RGBNoise",
        "depth clone",
        "DepthNoise",
        "both models",
    )
    print(f"{head[0]:<8} {head[1]:<8} {head[2]:<10}" + "".join(f" {h:>11}" for h in head[3:]))
    for w, h in ((640, 480), (128, 128)):
        f = (w / 2) / math.tan(math.radians(HFOV_DEG) / 2)
        rgb_noise = RGBNoise(h, w, sigma=0.1, seed=0)
        depth_noise = DepthNoise(h, w, focal_px=f, seed=0)
        rgba = torch.randint(0, 256, (1, h, w, 4), dtype=torch.uint8)
        depth = scene_like_depth(h, w)
        keys = [frame_keys(7, i) for i in range(args.frames + 10)]
        for regime, ev in (("hot", None), ("evicted", evict)):
            for layout, rgb in (("RGBA view", rgba[..., :3]), ("contiguous", rgba[..., :3].contiguous())):
                row = (
                    median_ms(lambda i: rgb.clone(), args.frames, ev),
                    median_ms(lambda i: rgb_noise(rgb, keys[i]), args.frames, ev),
                    median_ms(lambda i: depth.clone(), args.frames, ev),
                    median_ms(lambda i: depth_noise(depth, keys[i]), args.frames, ev),
                    median_ms(
                        lambda i: (rgb_noise(rgb, keys[i]), depth_noise(depth, keys[i])), args.frames, ev
                    ),
                )
                print(f"{f'{w}x{h}':<8} {regime:<8} {layout:<10}" + "".join(f" {x:>11.3f}" for x in row))


if __name__ == "__main__":
    main()
