"""Contact sheet of every asset rendered with SAPIEN: front and back, operational face marked, and on the
front view a ring at the catalog's interaction point (projected through the camera, so it shows where the
point is even when the part is behind a lip or inside an opening).

Each tile also reports the number of distinct colours on the asset's pixels (the paper's Table 8
measure of surface diversity).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from biovln_ms.assetgen.generate import AssetPlan, plans
from biovln_ms.catalog import Catalog, InteractionPoint, load_catalog
from biovln_ms.paths import ASSET_DIR
from biovln_ms.render.lighting import apply_lighting
from biovln_ms.render.sapien_utils import look_at_pose, new_scene, take_rgb

MARKER_COLOR = [0.95, 0.1, 0.1, 1.0]
RING_COLOR = (255, 215, 0)  # the interaction point's ring on the front view
RING_RADIUS = 7  # px


@dataclass
class AssetRender:
    name: str
    face: str | None
    front: np.ndarray
    back: np.ndarray
    front_colors: int
    back_colors: int
    interaction_px: tuple[float, float] | None = None  # the interaction point in the front view (u, v)
    interaction_label: str = ""


def _add_face_marker(scene, plan: AssetPlan):
    """A red arrow on the floor, from the operational face outwards."""
    import sapien

    f = np.array([*plan.model_face, 0.0])
    depth = plan.dimensions[0] / 2 if abs(f[0]) > 0.5 else plan.dimensions[1] / 2
    length = 0.35 + 0.1 * max(plan.dimensions[:2])
    yaw = float(np.arctan2(f[1], f[0]))
    q = [np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]
    b = scene.create_actor_builder()
    mat = sapien.render.RenderMaterial(base_color=MARKER_COLOR)
    b.add_box_visual(
        sapien.Pose([length / 2, 0, 0.005], [1, 0, 0, 0]), half_size=[length / 2, 0.025, 0.005], material=mat
    )
    b.add_box_visual(
        sapien.Pose([length, 0, 0.005], [np.cos(np.pi / 8), 0, 0, np.sin(np.pi / 8)]),
        half_size=[0.07, 0.07, 0.005],
        material=mat,
    )
    marker = b.build_kinematic(name="face_marker")
    marker.set_pose(sapien.Pose((f * (depth + 0.02)).tolist(), q))
    return marker


#: the room a lighting preset lights on the contact sheet: 4 m x 4 m, 3 m high (one ceiling fixture), the
#: asset in the middle
STUDIO = SimpleNamespace(
    rooms=[
        SimpleNamespace(kind="room", polygon=[(-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)], height=3.0)
    ]
)


class AssetRenderer:
    """One SAPIEN scene reused for every asset (a new scene per asset costs seconds on lavapipe). Lit by
    fixed studio lights, or with ``lighting`` by that preset's lights (:mod:`biovln_ms.render.lighting`)
    over a 4 m x 4 m room around the asset (no walls drawn: the floor and the asset), seen through the
    head camera's shader (ManiSkill's "minimal", 8-bit colour: SAPIEN's default shader pack casts no
    point-light shadows)."""

    def __init__(self, size: int = 320, asset_dir: Path = ASSET_DIR, lighting: str | None = None) -> None:
        import sapien

        self.asset_dir = Path(asset_dir)
        self.scene = new_scene()
        if lighting is not None:
            for e in self.scene.get_entities():  # new_scene's studio lights
                if any(isinstance(c, sapien.render.RenderLightComponent) for c in e.components):
                    self.scene.remove_entity(e)
            apply_lighting(self.scene, STUDIO, lighting)
            sapien.render.set_camera_shader_dir("minimal")
            sapien.render.set_picture_format("Color", "r8g8b8a8unorm")
            sapien.render.set_picture_format("PositionSegmentation", "r16g16b16a16sint")
        self.head_shader = lighting is not None
        floor = self.scene.create_actor_builder()
        floor.add_box_visual(
            sapien.Pose([0, 0, -0.01]),
            half_size=[8, 8, 0.01],
            material=sapien.render.RenderMaterial(base_color=[0.78, 0.80, 0.82, 1]),
        )
        floor.build_static(name="floor")
        self.camera = self.scene.add_camera("preview", size, size, np.deg2rad(50), 0.05, 50)

    def render(self, plan: AssetPlan, interaction: InteractionPoint | None = None) -> AssetRender:
        """The asset on the floor, seen from its operational face and from behind; ``interaction`` (model
        space) is projected into the front view."""
        import sapien

        b = self.scene.create_actor_builder()
        b.add_visual_from_file(str(self.asset_dir / f"{plan.name}.glb"))
        actor = b.build_kinematic(name=plan.name)
        actor.set_pose(sapien.Pose([0, 0, plan.dimensions[2] / 2]))
        marker = _add_face_marker(self.scene, plan) if plan.face is not None else None
        target = np.array([0.0, 0.0, plan.dimensions[2] * 0.45])
        radius = float(np.linalg.norm(plan.dimensions)) * 1.05 + 0.4
        f = np.array([*plan.model_face, 0.0])
        side = np.array([-f[1], f[0], 0.0])
        out = []
        pixel = None
        for sign in (1.0, -1.0):
            eye = target + sign * f * radius + 0.35 * side * radius + np.array([0, 0, 0.45 * radius])
            self.camera.entity.set_pose(look_at_pose(eye, target))
            rgb = take_rgb(self.scene, self.camera)
            if sign > 0 and interaction is not None:
                pixel = self._project(np.asarray(interaction.point) + [0.0, 0.0, plan.dimensions[2] / 2])
            if self.head_shader:
                mask = self.camera.get_picture("PositionSegmentation")[..., 3] == actor.per_scene_id
            else:
                mask = self.camera.get_picture("Segmentation")[..., 1] == actor.per_scene_id
            colors = len(np.unique(rgb[mask].reshape(-1, 3), axis=0)) if mask.any() else 0
            out.append((rgb, colors))
        self.scene.remove_entity(actor)
        if marker is not None:
            self.scene.remove_entity(marker)
        label = interaction.label if interaction is not None else ""
        return AssetRender(plan.name, plan.face, out[0][0], out[1][0], out[0][1], out[1][1], pixel, label)

    def _project(self, point: np.ndarray) -> tuple[float, float]:
        """Pixel (u, v) of a world point in the camera's current view."""
        cam = self.camera.get_extrinsic_matrix() @ np.append(point, 1.0)  # OpenCV: x right, y down, z ahead
        u, v, w = self.camera.get_intrinsic_matrix() @ cam
        return float(u / w), float(v / w)


def contact_sheet(
    out_path: Path,
    catalog: Catalog | None = None,
    tile: int = 320,
    progress: bool = True,
    asset_dir: Path = ASSET_DIR,
    lighting: str | None = None,
) -> list[AssetRender]:
    """Render every asset (front and back) into one PNG, in studio light or under the preset ``lighting``
    (see :class:`AssetRenderer`); returns the renders with colour counts."""
    from tqdm import tqdm

    catalog = catalog or load_catalog()
    renderer = AssetRenderer(tile, asset_dir, lighting)
    points = {a.name: a.interaction for a in catalog.assets()}
    renders = [
        renderer.render(p, points.get(p.name))
        for p in tqdm(plans(catalog), desc="rendering assets", disable=not progress)
    ]
    cols = 4
    caption = 62
    rows = (2 * len(renders) + cols - 1) // cols
    sheet = Image.new("RGB", (cols * tile, rows * (tile + caption)), (250, 250, 250))
    draw = ImageDraw.Draw(sheet)
    font = ImageFont.load_default(size=15)
    for i, r in enumerate(renders):
        for j, (img, view, n) in enumerate(
            ((r.front, "FRONT", r.front_colors), (r.back, "BACK", r.back_colors))
        ):
            k = 2 * i + j
            x, y = (k % cols) * tile, (k // cols) * (tile + caption)
            sheet.paste(Image.fromarray(img), (x, y))
            draw.text((x + 6, y + tile + 3), f"{r.name}  [{view}]", fill=(0, 0, 0), font=font)
            if r.face is None:
                face_note = "room shell" if j == 0 else "room shell, reverse"
            else:
                face_note = f"op. face {r.face} (red arrow)" if j == 0 else "rear side"
            draw.text((x + 6, y + tile + 22), f"{face_note}; {n} colours", fill=(90, 90, 90), font=font)
            if j == 0 and r.interaction_px is not None:
                u, v = x + r.interaction_px[0], y + r.interaction_px[1]
                for radius, color in ((RING_RADIUS + 2, (0, 0, 0)), (RING_RADIUS, RING_COLOR)):
                    draw.ellipse((u - radius, v - radius, u + radius, v + radius), outline=color, width=3)
                note = f"interaction: {r.interaction_label} (yellow ring)"
                draw.text((x + 6, y + tile + 41), note, fill=(90, 90, 90), font=font)
    out_path = Path(out_path)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    sheet.save(out_path)
    return renders
