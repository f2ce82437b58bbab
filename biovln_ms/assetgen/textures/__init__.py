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

The package's modules: ``surfaces`` (materials, wear, ``Panel``), ``signs`` (labels and signs),
``controls`` (displays and controls), ``details`` (grilles, perforation, views through glass). The
instruments use them as one namespace: ``from biovln_ms.assetgen import textures as tx``.
"""

from biovln_ms.assetgen.textures.surfaces import (
    Color,
    PANEL_DENSITY,
    PANEL_MAX_PX,
    Panel,
    Surface,
    brushed,
    brushed_field,
    epoxy,
    fbm,
    floor_vinyl,
    font,
    glass,
    noise,
    normal_map,
    paint,
    paint_field,
    peel_normal,
    plastic,
    powder_coat,
    seed_for,
    streaks,
    to_image,
    weather,
    wood,
)
from biovln_ms.assetgen.textures.signs import (
    barcode,
    biohazard,
    fit_text,
    ghs,
    label,
    model_plate,
    poster,
    prohibition,
    safety_sign,
    trefoil,
    warning,
)
from biovln_ms.assetgen.textures.controls import (
    counter,
    dial,
    display,
    intensity_scale,
    keypad,
    objective_barrel,
    touchscreen,
)
from biovln_ms.assetgen.textures.details import behind_glass, flask_platform, grille, perforated, shelves

__all__ = [
    "Color",
    "PANEL_DENSITY",
    "PANEL_MAX_PX",
    "seed_for",
    "to_image",
    "font",
    "Surface",
    "powder_coat",
    "floor_vinyl",
    "noise",
    "fbm",
    "streaks",
    "normal_map",
    "peel_normal",
    "paint_field",
    "paint",
    "brushed_field",
    "brushed",
    "plastic",
    "epoxy",
    "wood",
    "glass",
    "weather",
    "Panel",
    "fit_text",
    "barcode",
    "label",
    "model_plate",
    "trefoil",
    "warning",
    "biohazard",
    "prohibition",
    "ghs",
    "safety_sign",
    "poster",
    "display",
    "keypad",
    "counter",
    "dial",
    "touchscreen",
    "objective_barrel",
    "intensity_scale",
    "grille",
    "perforated",
    "shelves",
    "behind_glass",
    "flask_platform",
]
