"""Fittings and what is seen through glass: vent grilles, perforated sheet, shelves behind a glazed door, a
shaker's flask platform."""

from __future__ import annotations

import math

import numpy as np
from PIL import Image, ImageDraw
from biovln_ms.assetgen.textures.surfaces import Color, _c8, brushed_field, glass, paint_field, to_image


def grille(color: Color, seed: int, width: int = 256, height: int = 64, slots: int = 10) -> Image.Image:
    """Ventilation louvres across a painted strip: dark slots with a lit lower lip."""
    rng = np.random.default_rng(seed)
    img = paint_field(rng, height, width, color, mottle=0.03, grain=2.5)
    period = height / slots
    for k in range(slots):
        y0 = int(k * period + period * 0.2)
        y1 = int(k * period + period * 0.7)
        x0, x1 = width // 20, width - width // 20
        depth = np.linspace(0.15, 0.45, max(1, y1 - y0))[:, None, None]
        img[y0:y1, x0:x1] *= depth
        img[y1 : y1 + max(1, int(period * 0.12)), x0:x1] *= 1.15
    return to_image(img)


def perforated(color: Color, seed: int, width: int = 256, height: int = 256, pitch: int = 8) -> Image.Image:
    """A perforated steel sheet (a biosafety cabinet's back wall): staggered dark holes."""
    rng = np.random.default_rng(seed)
    img = brushed_field(rng, height, width, color)
    yy, xx = np.mgrid[0:height, 0:width].astype(float)
    row = np.floor(yy / pitch)
    dx = (xx + (row % 2) * pitch / 2) % pitch - pitch / 2
    dy = yy % pitch - pitch / 2
    hole = np.clip(1.0 - (np.hypot(dx, dy) - pitch * 0.22), 0, 1)[..., None]
    return to_image(img * (1 - 0.75 * hole))


def shelves(
    seed: int, width: int = 256, height: int = 320, rows: int = 4, back: Color = (0.85, 0.87, 0.88)
) -> Image.Image:
    """The view through a glass door: a lit back wall, wire shelves, bottles, flasks and boxes."""
    rng = np.random.default_rng(seed)
    img = paint_field(rng, height, width, back, mottle=0.05, grain=2.0)
    img *= (0.75 + 0.3 * np.linspace(1, 0, height))[:, None, None]  # lit from the top
    canvas = to_image(img)
    draw = ImageDraw.Draw(canvas)
    palette = [
        (0.85, 0.2, 0.15),
        (0.2, 0.45, 0.85),
        (0.95, 0.8, 0.2),
        (0.3, 0.7, 0.35),
        (0.95, 0.95, 0.95),
        (0.55, 0.3, 0.15),
        (0.6, 0.35, 0.75),
        (0.9, 0.5, 0.1),
    ]
    pitch = height / rows
    for r in range(rows):
        y_shelf = int((r + 1) * pitch - 6)
        x = 4 + rng.uniform(0, 8)
        while x < width - 12:
            kind = rng.integers(0, 3)
            col = np.asarray(palette[rng.integers(0, len(palette))])
            wdt = rng.uniform(0.07, 0.14) * width
            hgt = rng.uniform(0.45, 0.85) * pitch
            top = y_shelf - hgt
            for s in range(int(wdt)):  # cylindrical shading across the item
                f = 0.65 + 0.45 * math.sin(math.pi * (s + 0.5) / wdt)
                c = _c8(tuple(np.clip(col * f, 0, 1)))
                if kind == 0:  # bottle: body + neck + cap
                    draw.line([x + s, top + hgt * 0.25, x + s, y_shelf], fill=c)
                elif kind == 1:  # box
                    draw.line([x + s, top + hgt * 0.3, x + s, y_shelf], fill=c)
                else:  # flask: shoulders slope down from the neck
                    draw.line([x + s, top + hgt * (0.2 + abs(s - wdt / 2) / wdt), x + s, y_shelf], fill=c)
            if kind == 0:
                draw.rectangle(
                    [x + wdt * 0.3, top + hgt * 0.05, x + wdt * 0.7, top + hgt * 0.25],
                    fill=_c8(tuple(col * 0.5)),
                )
            if kind != 1:
                draw.rectangle(
                    [x + wdt * 0.15, top + hgt * 0.5, x + wdt * 0.85, top + hgt * 0.7], fill=(240, 240, 235)
                )
            x += wdt + rng.uniform(2, 10)
        draw.rectangle([0, y_shelf, width, y_shelf + 4], fill=(150, 155, 160))
        draw.line([0, y_shelf + 5, width, y_shelf + 5], fill=(90, 92, 96))
    return canvas


def behind_glass(
    scene: Image.Image,
    seed: int,
    tint: Color = (0.80, 0.88, 0.92),
    alpha: float = 0.25,
    opacity: float | None = None,
) -> Image.Image:
    """``scene`` seen through a glazed door: tinted, with the glass's reflections over it. With ``opacity``
    the result is RGBA of that opacity: a see-through pane that also shows what is behind it to renderers
    that draw transparent surfaces over black (SAPIEN's fast "minimal" shader)."""
    pane = glass(tint, seed, scene.width, scene.height, alpha)
    out = Image.alpha_composite(scene.convert("RGBA"), pane)
    if opacity is None:
        return out.convert("RGB")
    out.putalpha(int(round(255 * opacity)))
    return out


def flask_platform(
    seed: int, width: int = 256, height: int = 192, cols: int = 4, rows: int = 3
) -> Image.Image:
    """A shaker platform seen from above: a brushed tray, spring clamps and Erlenmeyer flasks of broth."""
    rng = np.random.default_rng(seed)
    canvas = to_image(brushed_field(rng, height, width, (0.70, 0.72, 0.74)))
    draw = ImageDraw.Draw(canvas)
    pw, ph = width / cols, height / rows
    broth = [(0.86, 0.74, 0.42), (0.80, 0.66, 0.35), (0.92, 0.86, 0.62), (0.75, 0.80, 0.55)]
    for i in range(rows):
        for j in range(cols):
            cx, cy = (j + 0.5) * pw, (i + 0.5) * ph
            r = min(pw, ph) * 0.4
            draw.ellipse([cx - r, cy - r, cx + r, cy + r], outline=(60, 62, 66), width=3)  # clamp ring
            if rng.random() < 0.8:
                col = _c8(broth[int(rng.integers(len(broth)))])
                draw.ellipse([cx - r * 0.85, cy - r * 0.85, cx + r * 0.85, cy + r * 0.85], fill=col)
                draw.ellipse(
                    [cx - r * 0.3, cy - r * 0.3, cx + r * 0.3, cy + r * 0.3],
                    fill=(235, 235, 228),
                    outline=(150, 150, 150),
                )  # foam plug in the neck
    return canvas
