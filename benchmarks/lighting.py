"""Frame cost of the lighting presets: ``quality`` vs ``fast`` in one run.

For each preset and size, the head camera of ``BioVLN-OpFace-v0`` (obs_mode="rgbd") timed through the env
(ms per ``step``, the observation included) and raw (SAPIEN's update_render + take_picture + read-back).

    python benchmarks/lighting.py [--sizes 640x480 128x128] [--steps 30]
"""

from __future__ import annotations

import argparse
import time


def measure(lighting: str, width: int, height: int, steps: int) -> tuple[float, float]:
    """(env ms/frame, raw ms/frame) of the head camera under ``lighting`` at ``width``x``height``."""
    import gymnasium as gym

    import biovln_ms  # noqa: F401
    from biovln_ms.render.sapien_utils import raw_camera_rate

    env = gym.make(
        "BioVLN-OpFace-v0", obs_mode="rgbd", camera_width=width, camera_height=height, lighting=lighting
    )
    try:
        env.reset(seed=0)
        turn = 2  # TURN_LEFT: the robot stays put, the view changes
        for _ in range(10):
            env.step(turn)
        t = time.perf_counter()
        for _ in range(steps):
            env.step(turn)
        env_ms = 1000 * (time.perf_counter() - t) / steps
        raw_ms = 1000 / raw_camera_rate(env, steps)
    finally:
        env.close()
    return env_ms, raw_ms


def main(argv: list[str] | None = None) -> None:
    from biovln_ms.render.lighting import LIGHTING
    from biovln_ms.render.sapien_utils import vulkan_device_label

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["640x480", "128x128"])
    ap.add_argument("--steps", type=int, default=60)
    args = ap.parse_args(argv)
    print(f"device: {vulkan_device_label()}")
    print("| size | preset | env ms/frame | raw ms/frame | env x fast | raw x fast |")
    print("|---|---|---|---|---|---|")
    for size in args.sizes:
        w, h = (int(v) for v in size.split("x"))
        base = None
        for name in LIGHTING:
            env_ms, raw_ms = measure(name, w, h, args.steps)
            base = base or (env_ms, raw_ms)
            print(
                f"| {w}x{h} | {name} | {env_ms:.1f} | {raw_ms:.1f} | "
                f"{env_ms / base[0]:.2f} | {raw_ms / base[1]:.2f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
