"""Episode videos: the egocentric camera beside a top-down map with the trajectory, zones and goal, and with
people, where they are and the way they came."""

from __future__ import annotations

from pathlib import Path

import imageio.v2 as imageio
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image, ImageDraw  # noqa: E402

from biovln_ms.scene.spec import SceneSpec  # noqa: E402
from biovln_ms.people.body import PERSON_RADIUS  # noqa: E402
from biovln_ms.scene.topdown import PERSON_COLOR, draw_map  # noqa: E402

#: poses of a person's way drawn behind them (one per action step)
PERSON_TRAIL = 20


class MapCanvas:
    """A rendered top-down map and the world -> pixel transform to draw on it."""

    def __init__(self, spec: SceneSpec, height: int, goal=None, radius: float | None = None) -> None:
        fig, ax = plt.subplots(figsize=(6, 6 * 0.75), dpi=100)
        draw_map(spec, ax)
        if goal is not None:
            ax.plot(*goal, marker="X", ms=12, color="#d62728", markeredgecolor="white", zorder=12)
        fig.tight_layout()
        fig.canvas.draw()
        img = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
        # data -> display pixels (origin bottom-left) -> image rows (origin top-left)
        self._tf = ax.transData
        self._h = img.shape[0]
        plt.close(fig)
        scale = height / img.shape[0]
        self.scale = scale
        self.base = Image.fromarray(img).resize((int(img.shape[1] * scale), height), Image.BILINEAR)

    def to_px(self, xy) -> tuple[float, float]:
        x, y = self._tf.transform(np.asarray(xy, float)[:2])
        return x * self.scale, (self._h - y) * self.scale

    def frame(self, trail: list, pose, people: list | None = None) -> np.ndarray:
        """The map with the robot's ``trail`` and ``pose``; ``people``: each step's people's positions so far
        ((P, 2) arrays, the last now): each person's body now and their last :data:`PERSON_TRAIL` poses."""
        img = self.base.copy()
        draw = ImageDraw.Draw(img)
        if len(trail) > 1:
            draw.line([self.to_px(p) for p in trail], fill=(31, 119, 180), width=3)
        if people:
            self._people(draw, np.stack(people[-PERSON_TRAIL:]))
        cx, cy = self.to_px(pose[:2])
        hx, hy = self.to_px(np.asarray(pose[:2]) + 0.4 * np.array([np.cos(pose[2]), np.sin(pose[2])]))
        draw.line([(cx, cy), (hx, hy)], fill=(0, 0, 0), width=3)
        draw.ellipse([cx - 6, cy - 6, cx + 6, cy + 6], fill=(31, 119, 180), outline=(255, 255, 255))
        return np.asarray(img)

    def _people(self, draw, recent: np.ndarray) -> None:
        """People's bodies (discs) and their recent ways, ``recent`` (poses, people, 2)."""
        r = abs(self.to_px((PERSON_RADIUS, 0.0))[0] - self.to_px((0.0, 0.0))[0])
        for k in range(recent.shape[1]):
            way = [self.to_px(p) for p in recent[:, k]]
            if len(way) > 1:
                draw.line(way, fill=PERSON_COLOR, width=2)
            x, y = way[-1]
            draw.ellipse([x - r, y - r, x + r, y + r], fill=PERSON_COLOR, outline=(0, 0, 0))


def side_by_side(ego: np.ndarray, map_img: np.ndarray) -> np.ndarray:
    h = max(ego.shape[0], map_img.shape[0])
    out = np.full((h, ego.shape[1] + map_img.shape[1], 3), 255, np.uint8)
    out[: ego.shape[0], : ego.shape[1]] = ego
    out[: map_img.shape[0], ego.shape[1] :] = map_img
    # even sizes for H.264
    return out[: out.shape[0] // 2 * 2, : out.shape[1] // 2 * 2]


def write_mp4(frames: list[np.ndarray], out: str | Path, fps: int = 5) -> Path:
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.stem}.partial.mp4")
    with imageio.get_writer(tmp, fps=fps, codec="libx264", quality=7, macro_block_size=2) as w:
        for f in frames:
            w.append_data(f)
    tmp.replace(out)
    return out
