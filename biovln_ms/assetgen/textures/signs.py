"""Printed things: text fitted to a box, barcodes, labels and model plates, warning triangles, the
biohazard and prohibition signs, GHS pictograms, safety signs and posters."""

from __future__ import annotations

import math
import zlib
from functools import lru_cache
from typing import Sequence

import numpy as np
from PIL import Image, ImageDraw
from biovln_ms.assetgen.textures.surfaces import (
    Color,
    _c8,
    _rgb,
    brushed_field,
    font,
    noise,
    seed_for,
    to_image,
)


@lru_cache(maxsize=128)
def _paper(w: int, h: int, bg: Color) -> np.ndarray:
    """Printed stock of colour ``bg``: grain and a faint cloudiness (read-only; cached, as labels drawn
    per instance reuse it)."""
    rng = np.random.default_rng(seed_for("paper", str(w), str(h)))
    out = _rgb(bg) + 3.0 * noise(rng, h, w, 1, channels=3) + 2.0 * noise(rng, h, w, 16, 3)
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
