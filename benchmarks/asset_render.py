"""Render cost of each generated asset vs. a raw SAPIEN reference frame in the same run.

The reference is one grey box seen by the same camera at the same resolution: the ratio tells how
much the assets' detail (parts, textures) costs over SAPIEN's floor cost for a frame.

    python benchmarks/asset_render.py [--size 640x480] [--frames 30]

The table goes to ``docs/data/benchmarks/asset_render.json`` (``--data-out``), which the docs' benchmarks
page renders.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import sapien

from biovln_ms.assetgen.generate import plans
from biovln_ms.catalog import load_catalog
from biovln_ms.measured import docs_data_dir, write_table
from biovln_ms.paths import asset_glb
from biovln_ms.render.sapien_utils import device_kind, look_at_pose, new_scene, take_rgb


def frame_ms(scene, cam, frames: int) -> float:
    take_rgb(scene, cam)  # warm-up (shader JIT, uploads)
    t = time.perf_counter()
    for _ in range(frames):
        take_rgb(scene, cam)
    return (time.perf_counter() - t) / frames * 1e3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "benchmarks" / "asset_render.json")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    scene = new_scene()
    cam = scene.add_camera("bench", w, h, np.deg2rad(60), 0.05, 50)
    ref = scene.create_actor_builder()
    ref.add_box_visual(
        half_size=[0.4, 0.4, 0.4], material=sapien.render.RenderMaterial(base_color=[0.6, 0.6, 0.6, 1])
    )
    ref_actor = ref.build_kinematic(name="reference")
    cam.entity.set_pose(look_at_pose([-3.0, 1.0, 1.5], [0, 0, 0.5]))
    base = frame_ms(scene, cam, args.frames)
    scene.remove_entity(ref_actor)
    print(
        f"device: {scene.render_system.device.name} ({device_kind(scene.render_system.device)}), "
        f"{w}x{h}, {args.frames} frames"
    )
    print(f"{'reference (one box)':<22} {base:8.2f} ms/frame   1.00x")
    rows = [["reference (one grey box)", f"{base:.1f}", "1.00×"]]
    for plan in plans(load_catalog()):
        b = scene.create_actor_builder()
        b.add_visual_from_file(str(asset_glb(plan.name)))
        actor = b.build_kinematic(name=plan.name)
        actor.set_pose(sapien.Pose([0, 0, plan.dimensions[2] / 2]))
        ms = frame_ms(scene, cam, args.frames)
        print(f"{plan.name:<22} {ms:8.2f} ms/frame {ms / base:6.2f}x")
        rows.append([plan.name, f"{ms:.1f}", f"{ms / base:.2f}×"])
        scene.remove_entity(actor)
    dev = scene.render_system.device
    write_table(
        args.data_out,
        f"Render cost of each asset, {w}×{h}, {args.frames} frames",
        ["asset", "ms / frame", "× reference frame"],
        rows,
        render_device=f"{dev.name} ({device_kind(dev)})",
    )


if __name__ == "__main__":
    main()
