"""SAPIEN views of whole scenes (through the ``BioVLN-LabScene-v0`` ManiSkill env)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from biovln_ms.scene.spec import SceneSpec


def render_overview(
    spec: SceneSpec, out: str | Path, size: tuple[int, int] = (960, 720), lighting: str = "fast"
) -> Path:
    """Render the scene from above at an angle (ceiling left out) to a PNG, under the lighting preset
    ``lighting`` (:data:`biovln_ms.render.lighting.LIGHTING`)."""
    import gymnasium as gym

    import biovln_ms.tasks.lab_scene_env  # noqa: F401  (registers the env)

    env = gym.make(
        "BioVLN-LabScene-v0",
        specs=[spec],
        ceiling=False,
        render_size=size,
        lighting=lighting,
        render_mode="rgb_array",
        obs_mode="none",
        sim_backend="physx_cpu",
        render_backend=_render_backend(),
    )
    try:
        env.reset(seed=0)
        frame = env.render()
        img = np.asarray(frame.cpu().numpy() if hasattr(frame, "cpu") else frame)[0].astype(np.uint8)
    finally:
        env.close()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(img).save(out)
    return out


def _render_backend() -> str:
    import torch

    return "gpu" if torch.cuda.is_available() else "cpu"
