"""Deterministic procedural textures (numpy RNG + Pillow): surfaces with tens of thousands of colours.

The paper (Table 8) found that flat-shaded assets defeat vision-language recognition; instruments were
recognised only with rich surfaces (the biosafety cabinet's 12.6k-14.9k colours). These textures give
every surface what a real one has: powder-coat mottle and orange peel (a normal map), brushed-steel
streaks, moulded plastic, glass with reflections and transparency, printed labels, model plates,
warning signs, glowing displays (emission maps) and wear. Text uses Pillow's bundled font.

Every function draws from ``numpy.random.default_rng(seed)`` and Pillow only, so the same seed gives
the same pixels on every machine (with the same numpy and Pillow). ``powder_coat`` and ``floor_vinyl``
also texture the room shell (:mod:`biovln_ms.scene.shell`, whose cache is keyed by geometry only): they
must not change.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass
from functools import lru_cache
from typing import Sequence

import numpy as np
from PIL import Image, ImageDraw, ImageFilter, ImageFont

Color = tuple[float, float, float]

#: texel density of the non-tiling face textures (:class:`Panel`), px per metre
PANEL_DENSITY = 256
PANEL_MAX_PX = 640


def seed_for(*keys: str) -> int:
    """A stable seed from strings (crc32: identical on every machine, unlike hash())."""
    return zlib.crc32("/".join(keys).encode())


def _rgb(color: Color) -> np.ndarray:
    return np.asarray(color, float).reshape(1, 1, 3) * 255.0


def to_image(arr: np.ndarray) -> Image.Image:
    """An RGB image of an array in 0-255 (rounded, clipped)."""
    return Image.fromarray(np.clip(np.rint(arr), 0, 255).astype(np.uint8), "RGB")


def _c8(color: Color) -> tuple[int, int, int]:
    return tuple(int(round(255 * c)) for c in color)


@lru_cache(maxsize=64)
def font(size: int) -> ImageFont.FreeTypeFont:
    """Pillow's bundled font at ``size`` px."""
    return ImageFont.load_default(size=max(6, int(size)))


@dataclass(frozen=True)
class Surface:
    """Textures of one material: base colour (RGBA when it is see-through), optional normal and emission."""

    albedo: Image.Image
    normal: Image.Image | None = None
    emission: Image.Image | None = None


# --- the room shell's textures (unchanged: the shell cache does not key on them) -----------------
def powder_coat(
    color: tuple[float, float, float], seed: int, size: int = 128, amount: float = 10.0
) -> Image.Image:
    """Painted-metal look: fine speckle over a soft mottle (walls and door jambs of the room shell)."""
    rng = np.random.default_rng(seed)
    speckle = rng.normal(0.0, amount, (size, size, 1))
    coarse = rng.normal(0.0, amount * 0.5, (size // 16, size // 16))
    mottle = np.asarray(Image.fromarray(coarse.astype(np.float32), "F").resize((size, size), Image.BICUBIC))[
        ..., None
    ]
    tint = rng.normal(0.0, amount * 0.25, (size, size, 3))
    return to_image(_rgb(color) + speckle + mottle + tint)


def floor_vinyl(color: tuple[float, float, float], seed: int, size: int = 128) -> Image.Image:
    """Speckled sheet vinyl with tile seams."""
    rng = np.random.default_rng(seed)
    img = _rgb(color) + rng.normal(0.0, 7.0, (size, size, 3))
    chips = rng.random((size, size)) > 0.97
    img[chips] -= 45.0
    img[:2, :, :] -= 35.0
    img[:, :2, :] -= 35.0
    return to_image(img)


# --- noise ----------------------------------------------------------------------------------------
def noise(
    rng: np.random.Generator, h: int, w: int, cell: int, channels: int = 1, tile: bool = False
) -> np.ndarray:
    """Smooth value noise (h, w, channels) with features ``cell`` px apart, unit standard deviation.
    With ``tile`` it wraps around (h and w must be multiples of ``cell``)."""
    gh, gw = -(-h // cell), -(-w // cell)
    grid = rng.standard_normal((gh, gw, channels)).astype(np.float32)
    if cell == 1:
        return grid
    pad = 2
    g = np.pad(grid, ((pad, pad), (pad, pad), (0, 0)), mode="wrap" if tile else "reflect")
    size = ((gw + 2 * pad) * cell, (gh + 2 * pad) * cell)
    o = pad * cell
    out = np.stack(
        [
            np.asarray(Image.fromarray(g[..., c], "F").resize(size, Image.BICUBIC))[o : o + h, o : o + w]
            for c in range(channels)
        ],
        axis=-1,
    )
    return out / (out.std(axis=(0, 1), keepdims=True) + 1e-6)


def fbm(
    rng: np.random.Generator,
    h: int,
    w: int,
    octaves: Sequence[tuple[int, float]],
    channels: int = 1,
    tile: bool = False,
) -> np.ndarray:
    """Sum of ``noise`` octaves given as (cell px, amplitude)."""
    return sum(a * noise(rng, h, w, c, channels, tile) for c, a in octaves)


def streaks(rng: np.random.Generator, h: int, w: int, length: int, tile: bool = False) -> np.ndarray:
    """Noise stretched along x (brushing, wood fibres): rows vary, each row varies slowly (h, w, 1)."""
    cols = max(1, w // length)
    grid = rng.standard_normal((h, cols)).astype(np.float32)
    g = np.pad(grid, ((0, 0), (2, 2)), mode="wrap" if tile else "reflect")
    step = w / cols
    out = np.asarray(Image.fromarray(g, "F").resize((int(round((cols + 4) * step)), h), Image.BICUBIC))
    o = int(round(2 * step))
    out = out[:, o : o + w]
    return (out / (out.std() + 1e-6))[..., None]


def normal_map(height: np.ndarray, strength: float, tile: bool = True) -> Image.Image:
    """Tangent-space normal map (glTF: +X along u, +Y along v) of a height field (h, w) in texels."""
    if tile:
        du = (np.roll(height, -1, 1) - np.roll(height, 1, 1)) / 2
        dv = (np.roll(height, 1, 0) - np.roll(height, -1, 0)) / 2  # rows run down, v runs up
    else:
        dv_rows, du = np.gradient(height)
        dv = -dv_rows
    n = np.stack([-du * strength, -dv * strength, np.ones_like(height)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return to_image((n * 0.5 + 0.5) * 255.0)


@lru_cache(maxsize=32)
def peel_normal(seed: int, size: int = 256, strength: float = 0.45) -> Image.Image:
    """Orange peel of powder coat and moulded plastic: a fine, tiling bump map."""
    rng = np.random.default_rng(seed)
    return normal_map(fbm(rng, size, size, ((16, 1.0), (8, 0.5), (4, 0.25)), tile=True)[..., 0], strength)


# --- surfaces (tiling) ----------------------------------------------------------------------------
def paint_field(
    rng: np.random.Generator,
    h: int,
    w: int,
    color: Color,
    mottle: float = 0.025,
    grain: float = 3.0,
    chroma: float = 2.5,
    tile: bool = False,
) -> np.ndarray:
    """Powder-coated paint (h, w, 3) in 0-255: soft mottle, a colour drift (mostly warm/cool, some of it
    per channel), fine grain."""
    lum = fbm(rng, h, w, ((64, 1.0), (16, 0.5), (4, 0.3)), tile=tile)
    drift = fbm(rng, h, w, ((32, 1.0), (8, 0.5)), channels=3, tile=tile)
    warm = fbm(rng, h, w, ((64, 1.0), (16, 0.5)), tile=tile) * np.array([1.0, 0.3, -0.8])
    fine = noise(rng, h, w, 1, channels=3)
    return _rgb(color) * (1.0 + mottle * lum) + chroma * (0.6 * drift + 0.9 * warm) + grain * fine


def paint(color: Color, seed: int, size: int = 256, **kw) -> Image.Image:
    """A tiling powder-coat texture (see :func:`paint_field`)."""
    return to_image(paint_field(np.random.default_rng(seed), size, size, color, tile=True, **kw))


def brushed_field(rng: np.random.Generator, h: int, w: int, color: Color, tile: bool = False) -> np.ndarray:
    """Brushed stainless (h, w, 3) in 0-255: horizontal streaks, a faint warm/cool drift, fine grain."""
    s = streaks(rng, h, w, 32, tile) + 0.5 * streaks(rng, h, w, 8, tile)
    drift = fbm(rng, h, w, ((32, 1.0),), channels=3, tile=tile)
    return _rgb(color) * (1.0 + 0.045 * s) + 2.0 * drift + 2.0 * noise(rng, h, w, 1, channels=3)


def brushed(color: Color, seed: int, size: int = 256) -> Surface:
    """A tiling brushed-metal surface with a streak normal map."""
    rng = np.random.default_rng(seed)
    albedo = to_image(brushed_field(rng, size, size, color, tile=True))
    return Surface(albedo, normal_map(streaks(rng, size, size, 16, tile=True)[..., 0], 0.35))


def plastic(color: Color, seed: int, size: int = 256) -> Image.Image:
    """Moulded plastic: broad shading drift and a fine stipple, little grain."""
    rng = np.random.default_rng(seed)
    field = paint_field(rng, size, size, color, mottle=0.05, grain=2.0, chroma=3.0, tile=True)
    stipple = (rng.random((size, size, 1)) > 0.93) * -6.0
    return to_image(field + stipple)


def epoxy(color: Color, seed: int, size: int = 256) -> Image.Image:
    """Epoxy-resin worktop: dark ground with white, grey and bluish flecks."""
    rng = np.random.default_rng(seed)
    img = paint_field(rng, size, size, color, mottle=0.08, grain=3.0, chroma=2.0, tile=True)
    for frac, tint in ((0.006, (70, 70, 70)), (0.006, (40, 42, 48)), (0.003, (30, 45, 70))):
        flecks = rng.random((size, size)) < frac
        img[flecks] += np.asarray(tint, float) * rng.uniform(0.5, 1.0, (int(flecks.sum()), 1))
    return to_image(img)


def wood(color: Color, seed: int, size: int = 256) -> Image.Image:
    """Wood-veneer drawer fronts: fibres along x, growth rings warped by noise, knots of darker tone."""
    rng = np.random.default_rng(seed)
    y = np.arange(size, dtype=float)[:, None]
    warp = fbm(rng, size, size, ((64, 1.0), (16, 0.3)), tile=True)[..., 0]
    rings = np.sin(2 * np.pi * (y / size * 6 + 0.35 * warp))
    fibres = streaks(rng, size, size, 64, tile=True)[..., 0]
    tone = 1.0 + 0.07 * rings + 0.035 * fibres
    base = _rgb(color) * tone[..., None]
    base += 3.0 * noise(rng, size, size, 1, channels=3) + 3.0 * fbm(rng, size, size, ((32, 1),), 3, tile=True)
    return to_image(base)


def glass(tint: Color, seed: int, width: int = 256, height: int = 256, alpha: float = 0.55) -> Image.Image:
    """Tinted glass (RGBA): diagonal reflection bands, smudges; more opaque where it reflects."""
    rng = np.random.default_rng(seed)
    x = np.arange(width, dtype=float)[None, :]
    y = np.arange(height, dtype=float)[:, None]
    t = (x + 0.6 * y) / max(width, height)
    bands = np.clip(np.sin(2 * np.pi * (t * 2.3 + 0.15)) - 0.55, 0, None) * 2.2
    bands += 0.4 * np.clip(np.sin(2 * np.pi * (t * 7.1 + 0.4)) - 0.8, 0, None) * 5
    smudge = np.clip(fbm(rng, height, width, ((12, 1.0), (4, 0.4))) - 0.8, 0, None)[..., 0]
    shine = np.clip(bands + 0.15 * smudge, 0, 1.5)
    rgb = _rgb(tint) * (0.9 + 0.05 * smudge[..., None]) + 70.0 * shine[..., None]
    rgb += 2.5 * noise(rng, height, width, 1, channels=3)
    a = np.clip(alpha + 0.25 * shine + 0.05 * smudge, 0, 1) * 255
    return Image.fromarray(np.dstack([np.clip(np.rint(rgb), 0, 255), np.rint(a)]).astype(np.uint8), "RGBA")


# --- wear -----------------------------------------------------------------------------------------
def weather(
    arr: np.ndarray, rng: np.random.Generator, amount: float, handle: tuple[float, float] | None = None
) -> np.ndarray:
    """Wear on a face texture (h, w, 3) in 0-255: grime rising from the bottom, darker seams, scuffs,
    light scratches, and smudges around ``handle`` (fractions of width and height from the top-left)."""
    h, w, _ = arr.shape
    yy = np.linspace(0.0, 1.0, h)[:, None, None]
    grime = np.clip((yy - 0.6) / 0.4, 0, 1) ** 2 * (0.6 + 0.4 * np.clip(noise(rng, h, w, 16) + 0.5, 0, 1.5))
    arr = arr * (1 - 0.12 * amount * grime) + np.array([12.0, 8.0, 0.0]) * amount * grime
    d = np.minimum.outer(
        np.minimum(np.arange(h), np.arange(h)[::-1]), np.minimum(np.arange(w), np.arange(w)[::-1])
    )
    arr = arr * (1 - 0.10 * np.exp(-d / 3.0))[..., None]
    marks = Image.new("L", (w, h), 0)
    draw = ImageDraw.Draw(marks)
    for _ in range(int(4 + 16 * amount)):  # scuffs, low on the face
        x0, y0 = rng.uniform(0, w), rng.uniform(0.55, 1.0) * h
        ang, ln = rng.uniform(-0.5, 0.5), rng.uniform(0.02, 0.08) * w
        draw.line(
            [x0, y0, x0 + ln * math.cos(ang), y0 + ln * math.sin(ang)],
            fill=int(rng.integers(60, 140)),
            width=2,
        )
    dark = np.asarray(marks.filter(ImageFilter.GaussianBlur(0.8)), float)[..., None] / 255
    arr = arr * (1 - 0.35 * amount * dark)
    marks = Image.new("L", (w, h), 0)
    draw = ImageDraw.Draw(marks)
    for _ in range(int(3 + 10 * amount)):  # scratches, anywhere
        x0, y0 = rng.uniform(0, w), rng.uniform(0, h)
        ang, ln = rng.uniform(0, np.pi), rng.uniform(0.03, 0.15) * w
        draw.line(
            [x0, y0, x0 + ln * math.cos(ang), y0 + ln * math.sin(ang)],
            fill=int(rng.integers(80, 200)),
            width=1,
        )
    arr = arr + 30.0 * amount * np.asarray(marks, float)[..., None] / 255
    if handle is not None:
        hx, hy = handle[0] * w, handle[1] * h
        blob = Image.new("L", (w, h), 0)
        draw = ImageDraw.Draw(blob)
        for _ in range(int(3 + 8 * amount)):
            cx, cy = hx + rng.normal(0, 0.06 * w), hy + rng.normal(0, 0.05 * h)
            r = rng.uniform(0.008, 0.02) * (w + h)
            draw.ellipse([cx - r, cy - r * 1.3, cx + r, cy + r * 1.3], fill=int(rng.integers(40, 110)))
        smudge = np.asarray(blob.filter(ImageFilter.GaussianBlur(3)), float)[..., None] / 255
        arr = arr * (1 - 0.12 * amount * smudge) + np.array([6.0, 5.0, 2.0]) * amount * smudge
    return arr


class Panel:
    """A non-tiling texture for the front of one part (``tile=None`` materials): a ground, things placed in
    metres from the face's bottom-left corner, then wear."""

    def __init__(self, width_m: float, height_m: float, ground: np.ndarray) -> None:
        self.width_m, self.height_m = width_m, height_m
        self.arr = ground
        self.holes: list[tuple[int, int, int, int]] = []

    @staticmethod
    def size_px(width_m: float, height_m: float, density: float = PANEL_DENSITY) -> tuple[int, int]:
        """(w, h) in px at ``density`` px/m, capped at PANEL_MAX_PX on the longer side."""
        scale = min(density, PANEL_MAX_PX / max(width_m, height_m))
        return max(8, int(round(width_m * scale))), max(8, int(round(height_m * scale)))

    @classmethod
    def painted(
        cls, width_m: float, height_m: float, color: Color, seed: int, density: float = PANEL_DENSITY, **kw
    ) -> "Panel":
        w, h = cls.size_px(width_m, height_m, density)
        return cls(width_m, height_m, paint_field(np.random.default_rng(seed), h, w, color, **kw))

    @classmethod
    def metal(cls, width_m: float, height_m: float, color: Color, seed: int) -> "Panel":
        w, h = cls.size_px(width_m, height_m)
        return cls(width_m, height_m, brushed_field(np.random.default_rng(seed), h, w, color))

    def _box(self, x_m: float, y_m: float, w_m: float, h_m: float) -> tuple[int, int, int, int]:
        h, w, _ = self.arr.shape
        sx, sy = w / self.width_m, h / self.height_m
        x0 = int(round((x_m - w_m / 2) * sx))
        y0 = int(round(h - (y_m + h_m / 2) * sy))
        return x0, y0, max(1, int(round(w_m * sx))), max(1, int(round(h_m * sy)))

    def paste(self, img: Image.Image, x_m: float, y_m: float, w_m: float, h_m: float) -> "Panel":
        """Paste ``img`` (RGBA keeps its transparency) centred at (x_m, y_m), ``w_m`` x ``h_m`` metres."""
        x0, y0, pw, ph = self._box(x_m, y_m, w_m, h_m)
        im = img.convert("RGBA").resize((pw, ph), Image.LANCZOS)
        canvas = to_image(self.arr)
        canvas.paste(im, (x0, y0), im)
        self.arr = np.asarray(canvas, float)
        return self

    def shade(
        self, x_m: float, y_m: float, w_m: float, h_m: float, factor: float, blur: float = 2.0
    ) -> "Panel":
        """Darken (factor < 1) or lighten a soft-edged rectangle: recesses, gaskets, shadows of fittings."""
        h, w, _ = self.arr.shape
        x0, y0, pw, ph = self._box(x_m, y_m, w_m, h_m)
        m = Image.new("L", (w, h), 0)
        ImageDraw.Draw(m).rectangle([x0, y0, x0 + pw, y0 + ph], fill=255)
        mask = np.asarray(m.filter(ImageFilter.GaussianBlur(blur)), float)[..., None] / 255
        self.arr = self.arr * (1 + (factor - 1) * mask)
        return self

    def weather(self, seed: int, amount: float, handle: tuple[float, float] | None = None) -> "Panel":
        """Wear (:func:`weather`); ``handle`` in metres from the bottom-left."""
        frac = None
        if handle is not None:
            frac = (handle[0] / self.width_m, 1 - handle[1] / self.height_m)
        self.arr = weather(self.arr, np.random.default_rng(seed), amount, frac)
        return self

    def cut(self, x_m: float, y_m: float, w_m: float, h_m: float) -> "Panel":
        """A hole (alpha 0) one texel inside a rectangle, where a decal lies in the face's own plane:
        the renderer drops the face's fragments there, so the decal shows without z-fighting."""
        self.holes.append(self._box(x_m, y_m, w_m, h_m))
        return self

    def image(self) -> Image.Image:
        """The picture: RGB, or RGBA with alpha 0 in the holes."""
        img = to_image(self.arr)
        if not self.holes:
            return img
        alpha = Image.new("L", img.size, 255)
        for x0, y0, pw, ph in self.holes:
            ImageDraw.Draw(alpha).rectangle([x0 + 1, y0 + 1, x0 + pw - 2, y0 + ph - 2], fill=0)
        img.putalpha(alpha)
        return img


# --- printed things -------------------------------------------------------------------------------
@lru_cache(maxsize=128)
def _paper(w: int, h: int, bg: Color) -> np.ndarray:
    """Printed stock of colour ``bg``: grain and a faint cloudiness (read-only; cached, as labels drawn
    per instance reuse it)."""
    rng = np.random.default_rng(seed_for("paper", str(w), str(h)))
    out = _rgb(bg) + 3.0 * noise(rng, h, w, 1, channels=3) + 2.0 * noise(rng, h, w, 16, 3)
    out.flags.writeable = False
    return out


@lru_cache(maxsize=32)
def _lcd(w: int, h: int) -> np.ndarray:
    """An LCD's dark glass: grain, scanlines, a backlight falling off downwards (read-only; cached)."""
    rng = np.random.default_rng(seed_for("lcd", str(w), str(h)))
    out = _rgb((0.03, 0.05, 0.06)) + 2.5 * noise(rng, h, w, 1, channels=3)
    out[::3] *= 0.75
    out += 6.0 * np.linspace(1, 0, h)[:, None, None]
    out.flags.writeable = False
    return out


def fit_text(
    draw: ImageDraw.ImageDraw,
    xy: tuple[float, float],
    text: str,
    max_w: float,
    max_h: float,
    fill: tuple[int, ...],
    anchor: str = "la",
) -> float:
    """Draw ``text`` as large as fits ``max_w`` x ``max_h`` px; returns the font size used."""
    size = max(6, int(max_h))
    length = draw.textlength(text, font=font(size))
    if length > max_w:  # text length grows about linearly with the size: start from that estimate
        size = max(6, int(size * max_w / length))
    while size > 6 and draw.textlength(text, font=font(size)) > max_w:
        size -= 1
    draw.text(xy, text, fill=fill, font=font(size), anchor=anchor)
    return size


def barcode(draw: ImageDraw.ImageDraw, box: tuple[int, int, int, int], code: str) -> None:
    """A barcode-like bar pattern of ``code`` (a picture of one, not a decodable symbology)."""
    x0, y0, x1, y1 = box
    bits = "".join(f"{b:08b}" for b in zlib.crc32(code.encode()).to_bytes(4, "big") + code.encode())
    unit = max(1.0, (x1 - x0) / (len(bits) * 1.5 + 4))
    x = x0 + 2 * unit
    for i, b in enumerate(bits):
        wbar = unit * (2 if b == "1" else 1)
        if i % 2 == 0 and x + wbar <= x1:
            draw.rectangle([x, y0, x + wbar - 1, y1], fill=(15, 15, 18))
        x += wbar * 0.75


def label(
    lines: Sequence[str],
    bg: Color,
    fg: Color,
    seed: int,
    width: int = 256,
    height: int = 128,
    stripe: Color | None = None,
    code: str | None = None,
    age: float = 0.0,
) -> Image.Image:
    """A printed label: a coloured header band, text fitted to the width, an optional barcode, paper grain;
    ``age`` in [0, 1] yellows and stains it."""
    rng = np.random.default_rng(seed)
    paper = _paper(width, height, bg)
    if age > 0:
        stain = np.clip(noise(rng, height, width, 24), 0, None)
        paper = paper * (1 - 0.05 * age) + np.array([10.0, 6.0, -8.0]) * age * (0.6 + stain)
    img = to_image(paper)
    draw = ImageDraw.Draw(img)
    fg8 = _c8(fg)
    top = 6
    if stripe is not None:
        band = height // 5
        s = np.asarray(stripe, float)
        for y in range(band):  # a printed gradient, lighter at the bottom of the band
            draw.line([0, y, width, y], fill=_c8(tuple(np.clip(s * (1.0 + 0.25 * y / band), 0, 1))))
        top = band + 4
    draw.rectangle([1, 1, width - 2, height - 2], outline=fg8, width=2)
    bottom = height - (height // 4 if code else 4)
    n = max(1, len(lines))
    lh = (bottom - top) / n
    for i, line in enumerate(lines):
        fit_text(draw, (8, top + i * lh), line, width - 16, lh * (0.95 if i == 0 else 0.8), fg8)
    if code:
        barcode(draw, (8, bottom + 2, int(width * 0.65), height - 6), code)
        fit_text(draw, (int(width * 0.68), bottom + 2), code, width * 0.3, height // 6, fg8)
    return img


def model_plate(lines: Sequence[str], seed: int, width: int = 256, height: int = 128) -> Image.Image:
    """A riveted, brushed-aluminium rating plate with engraved text and two symbol boxes."""
    rng = np.random.default_rng(seed)
    img = to_image(brushed_field(rng, height, width, (0.78, 0.79, 0.80)))
    draw = ImageDraw.Draw(img)
    draw.rounded_rectangle([1, 1, width - 2, height - 2], radius=6, outline=(70, 72, 75), width=2)
    for cx, cy in ((7, 7), (width - 8, 7), (7, height - 8), (width - 8, height - 8)):
        draw.ellipse([cx - 3, cy - 3, cx + 3, cy + 3], fill=(150, 152, 156), outline=(60, 60, 62))
    lh = (height - 16) / (len(lines) + 1)
    for i, line in enumerate(lines):
        fit_text(draw, (14, 8 + i * lh), line, width * 0.72, lh * 0.85, (25, 25, 30))
    s = int(lh * 1.1)
    x, y = width - 14 - s, height - 10 - s
    draw.rectangle([x, y, x + s, y + s], outline=(25, 25, 30), width=2)  # double insulation
    draw.rectangle([x + s // 4, y + s // 4, x + 3 * s // 4, y + 3 * s // 4], outline=(25, 25, 30), width=2)
    x -= s + 6  # crossed-out bin (separate collection)
    draw.polygon(
        [
            (x + s * 0.2, y + s * 0.25),
            (x + s * 0.8, y + s * 0.25),
            (x + s * 0.7, y + s),
            (x + s * 0.3, y + s),
        ],
        outline=(25, 25, 30),
    )
    draw.line([x, y, x + s, y + s], fill=(25, 25, 30), width=2)
    draw.line([x + s, y, x, y + s], fill=(25, 25, 30), width=2)
    return img


def _triangle(draw: ImageDraw.ImageDraw, s: int, border: int) -> list[tuple[float, float]]:
    pts = [(s / 2, s * 0.06), (s * 0.96, s * 0.9), (s * 0.04, s * 0.9)]
    draw.polygon(pts, fill=(15, 15, 15))
    inner = [
        (s / 2, s * 0.06 + border * 2.2),
        (s * 0.96 - border * 1.9, s * 0.9 - border),
        (s * 0.04 + border * 1.9, s * 0.9 - border),
    ]
    draw.polygon(inner, fill=(250, 205, 20))
    return inner


def trefoil(
    draw: ImageDraw.ImageDraw, cx: float, cy: float, r: float, color=(15, 15, 15), bg=(250, 205, 20)
) -> None:
    """The biohazard trefoil: three crescents around a ring."""
    for k in range(3):
        a = math.pi / 2 + k * 2 * math.pi / 3
        ox, oy = cx + math.cos(a) * r * 0.55, cy - math.sin(a) * r * 0.55
        draw.ellipse([ox - r * 0.5, oy - r * 0.5, ox + r * 0.5, oy + r * 0.5], fill=color)
        ix, iy = cx + math.cos(a) * r * 0.72, cy - math.sin(a) * r * 0.72
        draw.ellipse([ix - r * 0.36, iy - r * 0.36, ix + r * 0.36, iy + r * 0.36], fill=bg)
    draw.ellipse(
        [cx - r * 0.36, cy - r * 0.36, cx + r * 0.36, cy + r * 0.36],
        outline=color,
        width=max(2, int(r * 0.1)),
    )
    draw.ellipse([cx - r * 0.14, cy - r * 0.14, cx + r * 0.14, cy + r * 0.14], fill=bg)


def warning(kind: str, seed: int, size: int = 128) -> Image.Image:
    """An ISO-7010-style yellow warning triangle (RGBA): 'general', 'electric', 'biohazard', 'hot', 'cold'
    or 'rotor'."""
    rng = np.random.default_rng(seed)
    img = Image.new("RGBA", (size, size), (0, 0, 0, 0))
    draw = ImageDraw.Draw(img)
    _triangle(draw, size, max(2, size // 16))
    cx, cy, r = size / 2, size * 0.6, size * 0.2
    k = (15, 15, 15)
    if kind == "general":
        draw.rectangle([cx - r * 0.16, cy - r * 1.1, cx + r * 0.16, cy + r * 0.35], fill=k)
        draw.ellipse([cx - r * 0.2, cy + r * 0.55, cx + r * 0.2, cy + r * 0.95], fill=k)
    elif kind == "electric":
        draw.polygon(
            [
                (cx + r * 0.2, cy - r * 1.2),
                (cx - r * 0.5, cy + r * 0.1),
                (cx, cy + r * 0.1),
                (cx - r * 0.25, cy + r * 1.1),
                (cx + r * 0.55, cy - r * 0.2),
                (cx + r * 0.05, cy - r * 0.2),
            ],
            fill=k,
        )
    elif kind == "biohazard":
        trefoil(draw, cx, cy, r * 1.15)
    elif kind == "hot":
        for dx in (-0.6, 0.0, 0.6):
            pts = [(cx + r * dx + r * 0.18 * math.sin(t / 3), cy - r * 1.0 + t * r / 8) for t in range(13)]
            draw.line(pts, fill=k, width=max(2, size // 28))
        draw.line([cx - r, cy + r * 0.9, cx + r, cy + r * 0.9], fill=k, width=max(2, size // 24))
    elif kind == "cold":
        for a in range(3):
            ang = a * math.pi / 3
            dx, dy = math.cos(ang) * r, math.sin(ang) * r
            draw.line([cx - dx, cy - dy, cx + dx, cy + dy], fill=k, width=max(2, size // 26))
    elif kind == "rotor":
        draw.arc([cx - r, cy - r, cx + r, cy + r], 200, 520, fill=k, width=max(2, size // 22))
        draw.polygon(
            [(cx + r * 0.95, cy - r * 0.5), (cx + r * 1.35, cy + r * 0.1), (cx + r * 0.5, cy + r * 0.1)],
            fill=k,
        )
        draw.ellipse([cx - r * 0.25, cy - r * 0.25, cx + r * 0.25, cy + r * 0.25], fill=k)
    else:
        raise ValueError(f"unknown warning kind {kind!r}")
    arr = np.asarray(img, float)
    arr[..., :3] += 3.0 * rng.standard_normal((size, size, 1))  # printed vinyl grain
    return Image.fromarray(np.clip(np.rint(arr), 0, 255).astype(np.uint8), "RGBA")


def biohazard(width: int = 128, height: int = 160, text: str = "BIOHAZARD") -> Image.Image:
    """A biohazard label: trefoil on yellow above a black text band."""
    img = to_image(_paper(width, height, (0.98, 0.80, 0.08)))
    draw = ImageDraw.Draw(img)
    side = min(width, int(height * 0.75))
    trefoil(draw, width / 2, side / 2 + 2, side * 0.36, bg=tuple(int(v) for v in np.asarray(img)[2, 2]))
    draw.rectangle([0, int(height * 0.78), width, height], fill=(15, 15, 15))
    fit_text(draw, (width / 2, int(height * 0.8)), text, width - 8, height * 0.17, (250, 205, 20), "ma")
    draw.rectangle([1, 1, width - 2, height - 2], outline=(15, 15, 15), width=max(2, width // 40))
    return img


def prohibition(size: int = 128, text: str = "NO FOOD OR DRINK") -> Image.Image:
    """A red prohibition sign (crossed-out cup) with a caption."""
    h = int(size * 1.3)
    img = to_image(_paper(size, h, (0.97, 0.97, 0.95)))
    draw = ImageDraw.Draw(img)
    c, r = size / 2, size * 0.42
    draw.rectangle([c - r * 0.35, c - r * 0.25, c + r * 0.25, c + r * 0.45], fill=(20, 20, 20))
    draw.arc(
        [c + r * 0.1, c - r * 0.12, c + r * 0.5, c + r * 0.3],
        270,
        90,
        fill=(20, 20, 20),
        width=max(2, size // 25),
    )
    draw.ellipse([c - r, c - r, c + r, c + r], outline=(200, 20, 25), width=max(3, size // 11))
    dx = r * 0.7
    draw.line([c - dx, c - dx, c + dx, c + dx], fill=(200, 20, 25), width=max(3, size // 11))
    fit_text(draw, (c, size * 0.98), text, size - 6, h - size - 4, (20, 20, 20), "ma")
    return img


def display(
    lines: Sequence[str],
    seed: int,
    glow: Color = (0.3, 1.0, 0.5),
    width: int = 256,
    height: int = 96,
    bars: int = 0,
) -> Surface:
    """A backlit LCD (emission map): glowing main reading, smaller status lines, an optional bar graph,
    a dark glass ground with scanlines. The albedo is the same picture dimmed."""
    rng = np.random.default_rng(seed)
    ground = _lcd(width, height)
    layer = Image.new("RGB", (width, height), (0, 0, 0))
    draw = ImageDraw.Draw(layer)
    g8 = _c8(glow)
    dim = _c8(tuple(0.55 * c for c in glow))
    main_h = height * (0.6 if len(lines) > 1 else 0.8)
    fit_text(draw, (10, height * 0.06), lines[0], width * (0.7 if bars else 0.94), main_h, g8)
    for i, line in enumerate(lines[1:]):
        lh = (height * 0.94 - main_h) / max(1, len(lines) - 1)
        fit_text(draw, (10, main_h + height * 0.04 + i * lh), line, width * 0.9, lh * 0.9, dim)
    if bars:
        x0, y1 = int(width * 0.74), int(height * 0.9)
        bw = (width - x0 - 8) / bars
        for b in range(bars):
            bh = (0.3 + 0.7 * rng.random()) * height * 0.75
            draw.rectangle([x0 + b * bw, y1 - bh, x0 + (b + 0.7) * bw, y1], fill=dim if b % 3 else g8)
    halo = np.asarray(layer.filter(ImageFilter.GaussianBlur(max(2, height // 20))), float)
    sharp = np.asarray(layer, float)
    lit = ground + sharp + 0.8 * halo
    emission = to_image(lit)
    return Surface(to_image(lit * 0.35), emission=emission)


def keypad(
    seed: int,
    rows: int = 3,
    cols: int = 4,
    width: int = 128,
    height: int = 96,
    keys: Sequence[str] = "0123456789SRT+-",
    accents: bool = True,
) -> Image.Image:
    """A membrane keypad: shaded keys with their legends; with ``accents`` the last two are green start and
    red stop."""
    rng = np.random.default_rng(seed)
    img = to_image(_paper(width, height, (0.20, 0.22, 0.25)))
    draw = ImageDraw.Draw(img)
    kw, kh = width / cols, height / rows
    n = rows * cols
    for k in range(n):
        i, j = divmod(k, cols)
        x0, y0 = j * kw + 3, i * kh + 3
        base = np.array([150, 152, 160], float) + rng.integers(-8, 9)
        if accents and k == n - 2:
            base = np.array([40, 150, 70], float)
        elif accents and k == n - 1:
            base = np.array([190, 40, 35], float)
        steps = max(2, int(kh - 6))
        for s in range(steps):  # domed key: lighter at the top
            c = tuple(int(v) for v in np.clip(base * (1.12 - 0.3 * s / steps), 0, 255))
            draw.line([x0 + 2, y0 + s, x0 + kw - 8, y0 + s], fill=c)
        draw.rounded_rectangle([x0, y0, x0 + kw - 6, y0 + kh - 6], radius=4, outline=(40, 42, 48), width=1)
        legend = keys[k % len(keys)]
        fit_text(draw, (x0 + (kw - 6) / 2, y0 + (kh - 6) / 2), legend, kw * 0.7, kh * 0.5, (20, 20, 28), "mm")
    return img


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


def ghs(kind: str, seed: int, size: int = 128) -> Image.Image:
    """A GHS hazard pictogram (RGBA): red-bordered diamond with a 'flame' or an 'exclamation' mark."""
    img = Image.new("RGBA", (size, size), (0, 0, 0, 0))
    draw = ImageDraw.Draw(img)
    c = size / 2
    draw.polygon([(c, 1), (size - 2, c), (c, size - 2), (1, c)], fill=(200, 20, 25))
    b = size * 0.09
    draw.polygon([(c, 1 + b), (size - 2 - b, c), (c, size - 2 - b), (1 + b, c)], fill=(250, 250, 248))
    k = (15, 15, 15)
    if kind == "flame":
        pts = [
            (c - size * 0.14, c + size * 0.16),
            (c - size * 0.16, c - size * 0.02),
            (c - size * 0.06, c - size * 0.08),
            (c - size * 0.04, c - size * 0.24),
            (c + size * 0.06, c - size * 0.1),
            (c + size * 0.1, c - size * 0.16),
            (c + size * 0.15, c + 0.0),
            (c + size * 0.14, c + size * 0.16),
        ]
        draw.polygon(pts, fill=k)
        draw.rectangle([c - size * 0.2, c + size * 0.18, c + size * 0.2, c + size * 0.22], fill=k)
    elif kind == "exclamation":
        draw.rectangle([c - size * 0.035, c - size * 0.25, c + size * 0.035, c + size * 0.08], fill=k)
        draw.ellipse([c - size * 0.045, c + size * 0.13, c + size * 0.045, c + size * 0.22], fill=k)
    else:
        raise ValueError(f"unknown GHS pictogram {kind!r}")
    arr = np.asarray(img, float)
    arr[..., :3] += 3.0 * np.random.default_rng(seed).standard_normal((size, size, 1))
    return Image.fromarray(np.clip(np.rint(arr), 0, 255).astype(np.uint8), "RGBA")


def counter(text: str, width: int = 96, height: int = 48) -> Image.Image:
    """A mechanical volume counter: black digits in a white window."""
    img = Image.new("RGB", (width, height), (235, 235, 230))
    draw = ImageDraw.Draw(img)
    draw.rectangle([0, 0, width - 1, height - 1], outline=(90, 90, 95), width=2)
    fit_text(draw, (width / 2, height / 2), text, width * 0.85, height * 0.8, (15, 15, 20), "mm")
    return img


# --- added with the molecular-biology instruments (issue 18 item 4) --------------------------------
def dial(seed: int, reading: float, label_text: str = "kPa", size: int = 128) -> Image.Image:
    """A round pressure gauge (RGBA): a chrome bezel, a white face with a scale, a red band and a needle at
    ``reading`` (0 to 1 of the scale)."""
    rng = np.random.default_rng(seed)
    img = Image.new("RGBA", (size, size), (0, 0, 0, 0))
    draw = ImageDraw.Draw(img)
    c, r = size / 2, size / 2 - 1
    draw.ellipse([c - r, c - r, c + r, c + r], fill=(150, 152, 158, 255), outline=(60, 62, 66, 255), width=2)
    ri = r * 0.84
    draw.ellipse([c - ri, c - ri, c + ri, c + ri], fill=(246, 246, 240, 255))
    start, span = 225.0, 270.0  # degrees, clockwise from the top-left, as dial gauges run
    draw.arc(
        [c - ri * 0.9, c - ri * 0.9, c + ri * 0.9, c + ri * 0.9], -45 - 54, -45, fill=(200, 30, 30), width=4
    )
    for t in range(11):
        a = math.radians(start - span * t / 10)
        inner = ri * (0.72 if t % 5 == 0 else 0.8)
        draw.line(
            [
                c + math.cos(a) * inner,
                c - math.sin(a) * inner,
                c + math.cos(a) * ri * 0.92,
                c - math.sin(a) * ri * 0.92,
            ],
            fill=(25, 25, 30, 255),
            width=2,
        )
    fit_text(draw, (c, c + ri * 0.35), label_text, ri * 0.8, ri * 0.25, (25, 25, 30, 255), "mm")
    a = math.radians(start - span * min(max(reading, 0.0), 1.0))
    draw.line(
        [c, c, c + math.cos(a) * ri * 0.78, c - math.sin(a) * ri * 0.78], fill=(190, 25, 25, 255), width=3
    )
    draw.ellipse([c - 5, c - 5, c + 5, c + 5], fill=(30, 30, 32, 255))
    arr = np.asarray(img, float)
    arr[..., :3] += 2.0 * rng.standard_normal((size, size, 1))
    return Image.fromarray(np.clip(np.rint(arr), 0, 255).astype(np.uint8), "RGBA")


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


def safety_sign(kind: str, seed: int, width: int = 192, height: int = 192) -> Image.Image:
    """An ISO 7010-style sign on a coloured board with its caption: 'eyewash' (green, E011) or
    'extinguisher' (red, F001)."""
    ground, text = {"eyewash": ((0.0, 0.55, 0.33), "EYE WASH"), "extinguisher": ((0.80, 0.08, 0.08), "FIRE")}[
        kind
    ]
    img = to_image(_paper(width, height, ground))
    draw = ImageDraw.Draw(img)
    white = (250, 250, 248)
    s = min(width, height * 0.72)
    cx, cy = width / 2, s / 2 + 4
    if kind == "eyewash":  # a face and the two jets rising into the eyes
        draw.ellipse([cx - s * 0.22, cy - s * 0.3, cx + s * 0.22, cy + s * 0.2], outline=white, width=4)
        for dx in (-0.09, 0.09):
            draw.ellipse([cx + s * dx - 6, cy - s * 0.1 - 5, cx + s * dx + 6, cy - s * 0.1 + 5], fill=white)
            draw.arc(
                [cx + s * dx - s * 0.12, cy - s * 0.1, cx + s * dx + s * 0.12, cy + s * 0.42],
                200,
                340,
                white,
                3,
            )
    else:  # an extinguisher with its flame
        draw.rounded_rectangle([cx - s * 0.1, cy - s * 0.2, cx + s * 0.1, cy + s * 0.35], 8, fill=white)
        draw.rectangle([cx - s * 0.04, cy - s * 0.3, cx + s * 0.04, cy - s * 0.2], fill=white)
        draw.line([cx + s * 0.04, cy - s * 0.27, cx + s * 0.25, cy - s * 0.33], fill=white, width=5)
        draw.polygon(
            [(cx - s * 0.38, cy + s * 0.35), (cx - s * 0.3, cy), (cx - s * 0.2, cy + s * 0.35)], fill=white
        )
    fit_text(draw, (width / 2, s + 8), text, width - 12, height - s - 14, white, "ma")
    arr = np.asarray(img, float) + 2.0 * np.random.default_rng(seed).standard_normal((height, width, 1))
    return to_image(arr)


def poster(
    title: str, lines: Sequence[str], ground: Color, seed: int, icon: str, width: int = 256, height: int = 362
) -> Image.Image:
    """A printed safety poster (A-series proportions): a coloured title band, an ISO-style icon ('mandatory'
    blue disc with a figure, 'warning' triangle, 'biohazard', 'phone') and text lines."""
    rng = np.random.default_rng(seed)
    img = to_image(_paper(width, height, (0.97, 0.97, 0.95)))
    draw = ImageDraw.Draw(img)
    band = height // 6
    draw.rectangle([0, 0, width, band], fill=_c8(ground))
    fit_text(draw, (width / 2, band * 0.2), title, width - 16, band * 0.65, (250, 250, 248), "ma")
    s = int(width * 0.45)
    x0, y0 = (width - s) // 2, band + 12
    if icon == "mandatory":
        draw.ellipse([x0, y0, x0 + s, y0 + s], fill=(20, 80, 170))
        c = x0 + s / 2
        draw.ellipse([c - s * 0.09, y0 + s * 0.15, c + s * 0.09, y0 + s * 0.33], fill=(250, 250, 248))
        draw.rectangle([c - s * 0.16, y0 + s * 0.36, c + s * 0.16, y0 + s * 0.7], fill=(250, 250, 248))
        draw.rectangle([c - s * 0.13, y0 + s * 0.7, c + s * 0.13, y0 + s * 0.85], fill=(250, 250, 248))
    elif icon in ("warning", "biohazard"):
        sub = warning("biohazard" if icon == "biohazard" else "general", seed, s)
        img.paste(sub, (x0, y0), sub)
    else:  # a telephone handset in a green square
        draw.rectangle([x0, y0, x0 + s, y0 + s], fill=(0, 140, 80))
        draw.arc([x0 + s * 0.2, y0 + s * 0.2, x0 + s * 0.8, y0 + s * 0.9], 200, 340, (250, 250, 248), 10)
        for dx in (0.2, 0.68):
            draw.rectangle(
                [x0 + s * dx, y0 + s * 0.45, x0 + s * (dx + 0.12), y0 + s * 0.62], fill=(250, 250, 248)
            )
    top = y0 + s + 10
    lh = (height - top - 8) / max(1, len(lines))
    for i, line in enumerate(lines):
        fit_text(draw, (10, top + i * lh), line, width - 20, lh * 0.8, (25, 25, 30))
    arr = np.asarray(img, float) + 2.5 * rng.standard_normal((height, width, 1))
    return to_image(arr)


# --- added with the looks of the small bench instruments (issue 18 item 2) --------------------------
def touchscreen(
    title: str,
    profile: Sequence[tuple[float, str, Color]],
    current: int,
    lines: Sequence[str],
    seed: int,
    width: int = 320,
    height: int = 160,
) -> Surface:
    """A colour touchscreen (emission map) of a programmable instrument: a title bar, a run profile drawn as
    coloured steps (``profile``: temperature, caption, colour; step ``current`` highlighted), status lines.
    The albedo is the same picture dimmed."""
    rng = np.random.default_rng(seed)
    yy = np.linspace(0.0, 1.0, height)[:, None, None]
    ground = _rgb((0.05, 0.09, 0.16)) * (1.25 - 0.5 * yy) + 3.0 * noise(rng, height, width, 1, channels=3)
    img = to_image(ground)
    draw = ImageDraw.Draw(img)
    bar = height // 6
    for y in range(bar):  # the title bar, a vertical gradient
        draw.line([0, y, width, y], fill=_c8((0.10 + 0.12 * y / bar, 0.35 + 0.1 * y / bar, 0.65)))
    fit_text(draw, (6, bar * 0.12), title, width * 0.7, bar * 0.8, (240, 245, 250))
    fit_text(
        draw, (width - 6, bar * 0.12), "12:4" + str(seed % 10), width * 0.2, bar * 0.8, (200, 220, 240), "ra"
    )
    g0, g1 = bar + 6, int(height * 0.68)  # graph band (px rows)
    lo, hi = min(t for t, _, _ in profile) - 10.0, max(t for t, _, _ in profile) + 8.0
    step = (width - 12) / len(profile)
    prev = None
    for i, (t, caption, col) in enumerate(profile):
        x0, x1 = 6 + i * step, 6 + (i + 1) * step
        y = g1 - (t - lo) / (hi - lo) * (g1 - g0)
        c = np.asarray(col, float)
        for r in range(int(y), g1):  # the area under the step, fading downwards
            f = 0.35 + 0.5 * (g1 - r) / max(1.0, g1 - y)
            draw.line([x0 + 1, r, x1 - 1, r], fill=_c8(tuple(np.clip(c * f, 0, 1))))
        if prev is not None:
            draw.line([x0, prev, x0 + 4, y], fill=(250, 250, 250), width=2)
        draw.line([x0 + 4, y, x1, y], fill=(250, 250, 250), width=2)
        fit_text(draw, ((x0 + x1) / 2, y - 2), f"{t:.0f}", step * 0.8, height * 0.08, (235, 240, 245), "md")
        fit_text(draw, ((x0 + x1) / 2, g1 + 2), caption, step * 0.9, height * 0.07, (170, 190, 210), "ma")
        if i == current:
            draw.rectangle([x0, g0, x1 - 1, g1], outline=(255, 210, 60), width=2)
        prev = y
    lh = (height - g1 - height * 0.1) / max(1, len(lines))
    for i, line in enumerate(lines):
        fit_text(draw, (6, g1 + height * 0.09 + i * lh), line, width - 12, lh * 0.85, (210, 225, 240))
    lit = np.asarray(img, float)
    lit += 0.5 * np.asarray(img.filter(ImageFilter.GaussianBlur(max(2, height // 40))), float)
    return Surface(to_image(lit * 0.4), emission=to_image(lit * 0.9))


def objective_barrel(
    ring: Color, engraving: Sequence[str], seed: int, width: int = 128, height: int = 128
) -> Image.Image:
    """A microscope objective's barrel unrolled (a cylinder's texture: rows run down the barrel): chrome
    with its magnification's colour-code ring and its engraved lettering, knurled at the top."""
    rng = np.random.default_rng(seed)
    arr = brushed_field(rng, height, width, (0.80, 0.81, 0.83))  # turning marks run round the barrel
    arr = arr * (1.0 + 0.12 * np.sin(np.linspace(0, np.pi, width))[None, :, None] - 0.06)
    arr[: height // 8] *= 0.55 + 0.25 * (np.arange(width)[None, :, None] % 4 < 2)  # knurling
    r0, r1 = int(height * 0.62), int(height * 0.72)
    arr[r0:r1] = _rgb(ring) * (0.9 + 0.1 * noise(rng, r1 - r0, width, 4, 3)) + 3.0 * noise(
        rng, r1 - r0, width, 1, 3
    )
    img = to_image(arr)
    draw = ImageDraw.Draw(img)
    lh = (r0 - height // 8 - 6) / max(1, len(engraving))
    for i, line in enumerate(engraving):
        fit_text(
            draw, (width / 4, height // 8 + 4 + i * lh), line, width * 0.45, lh * 0.9, (35, 35, 40), "ma"
        )
    return img


def intensity_scale(seed: int, setting: int, width: int = 128, height: int = 48) -> Image.Image:
    """The graduated scale beside a lamp's intensity knob: a dark-to-bright wedge, ticks 1-6, a pointer at
    ``setting``."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 1.0, width)[None, :, None]
    arr = _rgb((0.16, 0.16, 0.18)) + 3.0 * noise(rng, height, width, 1, 3)
    band = slice(height // 2, height - 6)
    arr[band] = (
        _rgb((0.25, 0.22, 0.12))
        + x * _rgb((0.7, 0.65, 0.35))
        + 3.0 * noise(rng, height - 6 - height // 2, width, 1, 3)
    )
    img = to_image(arr)
    draw = ImageDraw.Draw(img)
    for i in range(6):
        xi = 8 + i * (width - 16) / 5
        draw.line([xi, height // 2 - 6, xi, height // 2 - 1], fill=(230, 230, 225), width=1)
        fit_text(draw, (xi, 2), str(i + 1), width / 8, height * 0.3, (230, 230, 225), "ma")
    xs = 8 + (setting - 1) * (width - 16) / 5
    draw.polygon([(xs - 4, height - 2), (xs + 4, height - 2), (xs, height // 2 + 2)], fill=(240, 60, 40))
    return img
