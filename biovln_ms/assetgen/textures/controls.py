"""Displays and controls: glowing LCDs (with emission maps), keypads, counters, gauges, touchscreens and the
printed scales of microscope objectives and lamp settings."""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Sequence

import numpy as np
from PIL import Image, ImageDraw, ImageFilter
from biovln_ms.assetgen.textures.surfaces import (
    Color,
    Surface,
    _c8,
    _rgb,
    brushed_field,
    noise,
    seed_for,
    to_image,
)
from biovln_ms.assetgen.textures.signs import _paper, fit_text


@lru_cache(maxsize=32)
def _lcd(w: int, h: int) -> np.ndarray:
    """An LCD's dark glass: grain, scanlines, a backlight falling off downwards (read-only; cached)."""
    rng = np.random.default_rng(seed_for("lcd", str(w), str(h)))
    out = _rgb((0.03, 0.05, 0.06)) + 2.5 * noise(rng, h, w, 1, channels=3)
    out[::3] *= 0.75
    out += 6.0 * np.linspace(1, 0, h)[:, None, None]
    out.flags.writeable = False
    return out


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


def counter(text: str, width: int = 96, height: int = 48) -> Image.Image:
    """A mechanical volume counter: black digits in a white window."""
    img = Image.new("RGB", (width, height), (235, 235, 230))
    draw = ImageDraw.Draw(img)
    draw.rectangle([0, 0, width - 1, height - 1], outline=(90, 90, 95), width=2)
    fit_text(draw, (width / 2, height / 2), text, width * 0.85, height * 0.8, (15, 15, 20), "mm")
    return img


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
