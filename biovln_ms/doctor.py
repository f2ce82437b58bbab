"""`biovln-ms doctor`: versions, the Vulkan device SAPIEN uses, one rendered frame, asset integrity."""

from __future__ import annotations

import platform
import sys
from importlib import metadata

import numpy as np

from biovln_ms.assetgen.generate import verify_assets
from biovln_ms.errors import RenderError
from biovln_ms.paths import ASSET_DIR
from biovln_ms.render.sapien_utils import BACKPORTS_FIX, device_kind, look_at_pose, new_scene, take_rgb
from biovln_ms.sim.maniskill_compat import maniskill_distribution

PACKAGES = ("sapien", "mani-skill", "torch", "gymnasium", "stable-baselines3", "trimesh", "coacd", "numpy")


def versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for name in PACKAGES:
        if name == "mani-skill":  # or the nightly, which installs the same package under another name
            dist, version = maniskill_distribution()
            out[name] = version if dist == name or version == "NOT INSTALLED" else f"{version} ({dist})"
            continue
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "NOT INSTALLED"
    return out


def render_probe(size: int = 64) -> dict:
    """Render a red box on a grey floor; returns device info and the frame's mean colour."""
    import sapien

    scene = new_scene()
    dev = scene.render_system.device
    b = scene.create_actor_builder()
    b.add_box_visual(
        half_size=[0.3, 0.3, 0.3], material=sapien.render.RenderMaterial(base_color=[0.9, 0.1, 0.1, 1])
    )
    b.build_kinematic(name="probe")
    cam = scene.add_camera("probe", size, size, 1.0, 0.01, 20)
    cam.entity.set_pose(look_at_pose([-2.0, 0.3, 0.8], [0, 0, 0]))
    rgb = take_rgb(scene, cam)
    centre = rgb[size // 2 - 4 : size // 2 + 4, size // 2 - 4 : size // 2 + 4].reshape(-1, 3).mean(0)
    if not (centre[0] > 80 and centre[0] > 2 * centre[1]):
        raise RenderError(
            f"the probe frame is wrong (centre colour {centre.round().tolist()}, expected red)",
            fix="update the Vulkan driver; " + BACKPORTS_FIX,
        )
    return {
        "device": dev.name,
        "kind": device_kind(dev),
        "frame": f"{size}x{size}",
        "centre_rgb": [int(v) for v in centre.round()],
        "frame_mean": float(np.mean(rgb)),
    }


def run_doctor(echo=print) -> int:
    """Print the report; 0 when everything works, 1 otherwise (with the fix named)."""

    ok = True
    echo("BioVLN-MS doctor")
    for k, v in versions().items():
        echo(f"  {k:<18} {v}")
        if v == "NOT INSTALLED":
            ok = False
            echo(f"    -> fix: pip install {k}  (or run `bash scripts/install_python.sh`)")
    echo(f"  {'platform':<18} {platform.platform()} ({sys.executable})")
    try:
        probe = render_probe()
        echo(f"  {'vulkan device':<18} {probe['device']} ({probe['kind']})")
        echo(f"  {'render probe':<18} OK: {probe['frame']} frame, centre RGB {probe['centre_rgb']}")
    except Exception as e:  # any failure here is reported with the fix, never as a traceback
        ok = False
        echo(f"  {'render probe':<18} FAILED: {e}")
        if not isinstance(e, RenderError):
            echo(f"    -> fix: {BACKPORTS_FIX}")
    problems = verify_assets(ASSET_DIR)
    if problems:
        ok = False
        echo(f"  {'assets':<18} {len(problems)} problem(s):")
        for p in problems:
            echo(f"    {p}")
    else:
        echo(f"  {'assets':<18} OK ({ASSET_DIR})")
    echo("OK" if ok else "PROBLEMS FOUND (see the fixes above)")
    return 0 if ok else 1
