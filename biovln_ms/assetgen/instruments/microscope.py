"""The upright compound microscope (beyond the paper): objectives with ISO 8578 colour rings, a lamp
scale, and a label drawn per instance."""

from __future__ import annotations

import math

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import DARK, OPAQUE, WHITE, face, instrument, live, metal, paint
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def microscope_label(v: Variant) -> Image.Image:
    return tx.label(
        [f"MICROSCOPE {v.pick(('M1', 'M2', 'M3'), 'scope')}", f"{v.tag}  SERVICED {v.date('svc')}"],
        WHITE,
        DARK,
        v.rng("label").integers(1 << 30),
        width=256,
        height=80,
        stripe=(0.2, 0.5, 0.8),
        age=v.wear,
    )


#: the nosepiece's objectives: angle on the turret, colour-code ring (ISO 8578) and engraving
OBJECTIVES = (
    (-2.0, (0.85, 0.12, 0.10), ("4x", "0.10")),
    (0.0, (0.95, 0.80, 0.10), ("10x", "0.25")),
    (2.0, (0.45, 0.75, 0.95), ("40x", "0.65")),
)


@instrument("microscope", live_decals={"label": microscope_label})
def microscope(k: Kit) -> None:
    # Texels about as dense as the head camera's pixels from the goal (a finer tiling is averaged away).
    body = paint(k, "body", (0.88, 0.87, 0.83), tile=0.4, mottle=0.05, grain=6.0, chroma=4.0)
    # the stage, eyepiece tubes and knobs: wrinkle-finish black paint and stippled rubber
    black = paint(k, "black", (0.26, 0.26, 0.28), tile=0.4, roughness=0.6, mottle=0.12, grain=9.0, chroma=4.0)
    steel = metal(k)
    z0 = k.bottom
    k.box_span("base", (-0.10, k.front + 0.04, z0), (0.10, k.back, z0 + 0.06), body)
    bw, bh = 0.2, 0.055
    front = tx.Panel.painted(
        bw, bh, (0.50, 0.52, 0.55), k.seed("base_front"), density=900, mottle=0.06, grain=4.0, chroma=4.0
    )
    front.shade(0.16, bh / 2, 0.05, 0.04, 0.6, 1.5)
    front.paste(tx.warning("hot", k.seed("lamp_hot")), 0.105, bh / 2, 0.02, 0.02)
    front.weather(k.seed("base_wear"), 0.4, handle=(0.16, bh / 2))
    front.cut(0.05, bh / 2, 0.08, 0.035)
    k.box_span(
        "base_front",
        (-0.10, k.front + 0.02, z0),
        (0.10, k.front + 0.04, z0 + bh),
        face(k, "base_front", front),
    )
    live(k, "label", (-0.05, k.front + 0.02, z0 + bh / 2), 0.08, 0.035)
    k.decal(
        "control_dial",
        tx.intensity_scale(k.seed("lamp_scale"), 4),
        (0.06, k.front + 0.0195, z0 + bh / 2),
        0.04,
        0.02,
    )
    k.box_span("arm", (-0.05, k.back - 0.08, z0 + 0.06), (0.05, k.back, z0 + 0.36), body)
    k.box_span("head", (-0.06, k.front + 0.18, k.top - 0.10), (0.06, k.back, k.top), body)
    for sx in (-1, 1):
        k.cylinder(
            f"eyepiece_{sx}",
            0.016,
            0.16,
            (sx * 0.032, k.front + 0.02 + 0.08, k.top - 0.03),
            black,
            axis="y",
            sections=20,
        )
        k.cylinder(
            f"eyecup_{sx}",
            0.019,
            0.02,
            (sx * 0.032, k.front + 0.01, k.top - 0.03),
            paint(k, "rubber", (0.18, 0.18, 0.18), tile=0.3, roughness=0.9, mottle=0.1, grain=8.0),
            axis="y",
            sections=20,
        )
    k.cylinder("nosepiece", 0.045, 0.03, (0.0, 0.02, k.top - 0.115), steel, sections=24)
    for i, (a, ring, lines) in enumerate(OBJECTIVES):
        barrel = tx.objective_barrel(ring, lines, k.seed("objective", str(i)))
        k.cylinder(
            f"objective_{i}",
            0.011,
            0.045,
            (0.025 * math.sin(a), 0.02 - 0.025 * math.cos(a), k.top - 0.152),
            k.material(
                f"objective_{i}", color=OPAQUE, texture=barrel, tile=None, metallic=0.8, roughness=0.3
            ),
            sections=16,
        )
    k.box_span("stage", (-0.09, k.front + 0.12, z0 + 0.19), (0.09, k.back - 0.08, z0 + 0.21), black)
    k.box_span(
        "slide",
        (-0.038, k.front + 0.2, z0 + 0.21),
        (0.038, k.front + 0.226, z0 + 0.212),
        k.material("slide", color=(0.85, 0.9, 0.95, 1.0), texture=None, roughness=0.05),
    )
    k.cylinder("condenser", 0.025, 0.06, (0.0, 0.02, z0 + 0.155), black, sections=20)
    k.cylinder("field_lens", 0.028, 0.012, (0.0, 0.02, z0 + 0.066), steel, sections=20)
    k.cylinder("focus_shaft", 0.012, k.W, (0.0, k.back - 0.05, z0 + 0.14), black, axis="x", sections=16)
    for sx in (-1, 1):
        k.cylinder(
            f"focus_knob_{sx}",
            0.035,
            0.03,
            (sx * (k.W / 2 - 0.015), k.back - 0.05, z0 + 0.14),
            paint(k, "knob", (0.30, 0.30, 0.32), tile=0.3, roughness=0.7, mottle=0.1, grain=8.0),
            axis="x",
            sections=24,
        )
    k.cylinder("stage_knob", 0.012, 0.07, (0.075, 0.0, z0 + 0.15), black, sections=12)
