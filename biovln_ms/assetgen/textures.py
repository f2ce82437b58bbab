"""Deterministic procedural textures (numpy RNG + Pillow): surfaces with thousands of colours.

The paper (Table 8) found that flat-shaded assets defeat vision-language recognition; these
textures give every surface grain, labels and displays.
"""

from __future__ import annotations

import zlib

import numpy as np
from PIL import Image, ImageDraw, ImageFont


def seed_for(*keys: str) -> int:
    """A stable seed from strings (crc32: identical on every machine, unlike hash())."""
    return zlib.crc32("/".join(keys).encode())


def _rgb(color: tuple[float, float, float]) -> np.ndarray:
    return np.asarray(color, float).reshape(1, 1, 3) * 255.0


def _to_image(arr: np.ndarray) -> Image.Image:
    return Image.fromarray(np.clip(np.rint(arr), 0, 255).astype(np.uint8), "RGB")


def powder_coat(
    color: tuple[float, float, float], seed: int, size: int = 128, amount: float = 10.0
) -> Image.Image:
    """Painted-metal look: fine speckle over a soft mottle."""
    rng = np.random.default_rng(seed)
    speckle = rng.normal(0.0, amount, (size, size, 1))
    coarse = rng.normal(0.0, amount * 0.5, (size // 16, size // 16))
    mottle = np.asarray(Image.fromarray(coarse.astype(np.float32), "F").resize((size, size), Image.BICUBIC))[
        ..., None
    ]
    tint = rng.normal(0.0, amount * 0.25, (size, size, 3))
    return _to_image(_rgb(color) + speckle + mottle + tint)


def brushed_metal(color: tuple[float, float, float], seed: int, size: int = 128) -> Image.Image:
    """Stainless look: horizontal streaks."""
    rng = np.random.default_rng(seed)
    streaks = rng.normal(0.0, 14.0, (size, 1, 1)) + rng.normal(0.0, 5.0, (size, size, 1))
    return _to_image(_rgb(color) + streaks + rng.normal(0.0, 2.0, (size, size, 3)))


def speckled_epoxy(color: tuple[float, float, float], seed: int, size: int = 128) -> Image.Image:
    """Bench-top epoxy resin: dark base with light flecks."""
    rng = np.random.default_rng(seed)
    base = _rgb(color) + rng.normal(0.0, 6.0, (size, size, 3))
    flecks = rng.random((size, size)) > 0.985
    base[flecks] += 90.0
    return _to_image(base)


def wood_grain(color: tuple[float, float, float], seed: int, size: int = 128) -> Image.Image:
    rng = np.random.default_rng(seed)
    y = np.arange(size)[:, None]
    x = np.arange(size)[None, :]
    phase = rng.uniform(0, 2 * np.pi)
    rings = np.sin(y * 0.35 + 3.0 * np.sin(x * 0.05 + phase)) * 14.0
    return _to_image(_rgb(color) + rings[..., None] + rng.normal(0.0, 5.0, (size, size, 3)))


def floor_vinyl(color: tuple[float, float, float], seed: int, size: int = 128) -> Image.Image:
    """Speckled sheet vinyl with tile seams."""
    rng = np.random.default_rng(seed)
    img = _rgb(color) + rng.normal(0.0, 7.0, (size, size, 3))
    chips = rng.random((size, size)) > 0.97
    img[chips] -= 45.0
    img[:2, :, :] -= 35.0
    img[:, :2, :] -= 35.0
    return _to_image(img)


def grille(color: tuple[float, float, float], seed: int, size: int = 128, slots: int = 10) -> Image.Image:
    """Ventilation louvres: dark slots on a painted panel."""
    img = np.asarray(powder_coat(color, seed, size, amount=6.0), float)
    period = size // slots
    for k in range(slots):
        y0 = k * period + period // 4
        img[y0 : y0 + period // 2, size // 10 : size - size // 10] *= 0.25
    return _to_image(img)


def _font(size: int) -> ImageFont.ImageFont:
    return ImageFont.load_default(size=size)


def label(
    lines: list[str],
    bg: tuple[float, float, float],
    fg: tuple[float, float, float],
    seed: int,
    width: int = 256,
    height: int = 128,
    stripe: tuple[float, float, float] | None = None,
) -> Image.Image:
    """A printed label: text lines, an optional colour stripe, paper grain."""
    rng = np.random.default_rng(seed)
    base = _rgb(bg) + rng.normal(0.0, 4.0, (height, width, 3))
    img = _to_image(base)
    draw = ImageDraw.Draw(img)
    if stripe is not None:
        draw.rectangle([0, 0, width, height // 6], fill=tuple(int(255 * c) for c in stripe))
    draw.rectangle([2, 2, width - 3, height - 3], outline=tuple(int(255 * c) for c in fg), width=3)
    fsize = max(10, int(height / (len(lines) + 1.2)))
    y = height // 6 + 4 if stripe is not None else 8
    for line in lines:
        draw.text((10, y), line, fill=tuple(int(255 * c) for c in fg), font=_font(fsize))
        y += int(fsize * 1.05)
    return img


def display(
    text: str,
    seed: int,
    glow: tuple[float, float, float] = (0.3, 1.0, 0.5),
    width: int = 256,
    height: int = 96,
) -> Image.Image:
    """An LCD: dark glass, glowing digits, scanlines."""
    rng = np.random.default_rng(seed)
    base = _rgb((0.04, 0.07, 0.08)) + rng.normal(0.0, 3.0, (height, width, 3))
    base[::3] *= 0.8
    img = _to_image(base)
    draw = ImageDraw.Draw(img)
    draw.text((12, height // 6), text, fill=tuple(int(255 * c) for c in glow), font=_font(int(height * 0.55)))
    return img


def biohazard(seed: int, size: int = 128) -> Image.Image:
    """Yellow warning label with a black biohazard-like trefoil."""
    rng = np.random.default_rng(seed)
    img = _to_image(_rgb((0.98, 0.80, 0.08)) + rng.normal(0.0, 4.0, (size, size, 3)))
    draw = ImageDraw.Draw(img)
    c = size / 2
    r = size * 0.18
    for k in range(3):
        a = np.pi / 2 + k * 2 * np.pi / 3
        cx, cy = c + np.cos(a) * r * 0.9, c - np.sin(a) * r * 0.9
        draw.ellipse([cx - r, cy - r, cx + r, cy + r], outline=(10, 10, 10), width=max(3, size // 20))
    draw.ellipse([c - r * 0.35, c - r * 0.35, c + r * 0.35, c + r * 0.35], fill=(10, 10, 10))
    draw.rectangle([3, 3, size - 4, size - 4], outline=(10, 10, 10), width=max(2, size // 40))
    return img


def keypad(seed: int, rows: int = 3, cols: int = 4, width: int = 128, height: int = 96) -> Image.Image:
    """A membrane keypad: grey keys with symbols."""
    rng = np.random.default_rng(seed)
    img = _to_image(_rgb((0.22, 0.24, 0.27)) + rng.normal(0.0, 4.0, (height, width, 3)))
    draw = ImageDraw.Draw(img)
    kw, kh = width / cols, height / rows
    symbols = "0123456789SRT+-"
    k = 0
    for i in range(rows):
        for j in range(cols):
            shade = int(150 + rng.integers(0, 40))
            x0, y0 = j * kw + 3, i * kh + 3
            draw.rounded_rectangle(
                [x0, y0, x0 + kw - 6, y0 + kh - 6], radius=4, fill=(shade, shade, shade + 10)
            )
            draw.text(
                (x0 + kw / 3, y0 + kh / 5),
                symbols[k % len(symbols)],
                fill=(20, 20, 30),
                font=_font(int(kh * 0.45)),
            )
            k += 1
    return img
