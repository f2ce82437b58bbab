"""Time building scene specs into ManiSkill (``reset(options={"reconfigure": True})``).

    python benchmarks/scene_build.py [--n 10]

The first build in a process pays for shader compilation and asset loading; the budget (<= 2 s)
is for later builds. Reference in the same run: the raw SAPIEN cost of rendering one 640x480 frame
of the built scene, printed as a ratio.

The table goes to ``docs/data/benchmarks/scene_build.json`` (``--data-out``), which the docs' benchmarks
page renders.
"""

from __future__ import annotations

import argparse
import gc
import time
from pathlib import Path

import gymnasium as gym

import biovln_ms.tasks.lab_scene_env  # noqa: F401
from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.render.sapien_utils import vulkan_device_label
from biovln_ms.scene.generator import generate_scene


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=10)
    ap.add_argument("--template", default="single_room")
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "scene_build.json")
    args = ap.parse_args()
    specs = [generate_scene(args.template, seed) for seed in range(args.n)]
    t0 = time.perf_counter()
    env = gym.make(
        "BioVLN-LabScene-v0",
        specs=[specs[0]],
        obs_mode="none",
        sim_backend="physx_cpu",
        render_backend="cpu",
        render_mode="rgb_array",
        render_size=(640, 480),
    )
    env.reset(seed=0)
    env.render()
    first = time.perf_counter() - t0
    gc.freeze()
    times = []
    for spec in specs[1:]:
        env.unwrapped._specs = [spec]
        t = time.perf_counter()
        env.reset(seed=0, options={"reconfigure": True})
        env.render()  # count lazy GPU/lavapipe uploads of the new scene as part of the build
        times.append(time.perf_counter() - t)
        built = set(env.unwrapped.scene_builder.built[0].objects)
        assert built == {o.id for o in spec.objects()}, "reconfigure did not rebuild the new spec"
    env.render()  # warm-up
    t = time.perf_counter()
    for _ in range(10):
        env.render()
    frame = (time.perf_counter() - t) / 10
    env.close()
    later = sorted(times)
    print(f"first build + frame (env creation, shader JIT): {first:.2f} s")
    print(
        f"later builds incl. first frame: median {later[len(later) // 2]:.3f} s, max {later[-1]:.3f} s "
        f"(budget 2 s) over {len(times)} scenes"
    )
    print(
        f"one 640x480 frame of the built scene: {frame * 1e3:.1f} ms -> "
        f"a build = {later[len(later) // 2] / frame:.1f} frames"
    )
    med = later[len(later) // 2]
    write_table(
        args.data_out,
        f"Building {args.template} specs into ManiSkill, including the first frame",
        ["first build (env creation, shader JIT)", "later builds: median / max", "× one frame", "budget"],
        [[f"{first:.1f} s", f"{med * 1e3:.0f} / {later[-1] * 1e3:.0f} ms", f"{med / frame:.1f}×", "2 s"]],
        render_device=vulkan_device_label(),
    )


if __name__ == "__main__":
    main()
