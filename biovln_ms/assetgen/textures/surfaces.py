"""The materials: seeds and colours, noise, the tiling surfaces (powder coat, floor vinyl, paint, brushed
steel, plastic, epoxy, wood, glass), wear, and ``Panel``, the non-tiling texture of one part's face that
the printed things are placed on."""

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
