"""The biohazard waste bin (paper Table 2): a pedal bin with a biohazard label drawn per instance."""

from __future__ import annotations

import math

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import DARK, face, instrument, live, metal, plastic
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def bin_label(v: Variant) -> Image.Image:
    return tx.label(
        ["BIOHAZARDOUS WASTE", f"AUTOCLAVE  ROOM {v.pick(('101', '102', '114', '2.07'), 'room')}"],
        (0.95, 0.78, 0.10),
        (0.7, 0.05, 0.05),
        v.rng("label").integers(1 << 30),
        width=224,
        height=96,
        age=v.wear,
    )


@instrument("waste_bin", live_decals={"label": bin_label})
def waste_bin(k: Kit) -> None:
    W = k.W
    ry = (k.D - 0.05) / 2
    yc = k.front + 0.05 + ry
    # The body's picture wraps half way round (mirrored on the other half): moulded ribs, trefoils on
    # the sides, scuffs and grime.
    half, bh = math.pi * (W / 2 - 0.005 + ry - 0.005) / 2, k.H - 0.07
    wrap = tx.Panel.painted(
        half, bh, (0.95, 0.78, 0.10), k.seed("body"), density=640, mottle=0.06, chroma=3.5
    )
    for z, f in ((bh - 0.03, 1.12), (bh - 0.05, 0.85), (0.06, 1.1), (0.04, 0.86)):
        wrap.shade(half / 2, z, half, 0.012, f, 1.5)
    wrap.paste(tx.warning("biohazard", k.seed("trefoil")), half * 0.3, bh * 0.55, 0.09, 0.09)
    wrap.weather(k.seed("body_wear"), 0.6, handle=(half * 0.9, bh - 0.05))
    body = face(k, "body", wrap, roughness=0.45)
    k.cylinder(
        "base_ring",
        1.0,
        0.03,
        (0, yc, k.bottom + 0.015),
        plastic(k, "ring", (0.08, 0.08, 0.09), tile=0.1, roughness=0.9),
        sections=40,
        scale_xy=(W / 2 - 0.01, ry - 0.01),
    )
    k.cylinder(
        "body",
        1.0,
        k.H - 0.07,
        (0, yc, k.bottom + 0.03 + (k.H - 0.07) / 2),
        body,
        sections=40,
        scale_xy=(W / 2 - 0.005, ry - 0.005),
    )
    k.cylinder(
        "lid",
        1.0,
        0.04,
        (0, yc, k.top - 0.02),
        plastic(k, "lid", (0.17, 0.17, 0.18), tile=0.15, roughness=0.3),
        sections=40,
        scale_xy=(W / 2, ry),
        top_uv=True,
    )
    k.box_span("pedal", (-0.07, k.front, k.bottom), (0.07, k.front + 0.06, k.bottom + 0.03), metal(k))
    k.box_span(
        "hinge",
        (-0.06, k.back - 0.015, k.top - 0.06),
        (0.06, k.back, k.top - 0.03),
        plastic(k, "hinge", DARK, tile=0.1),
    )
    k.decal(
        "biohazard",
        tx.biohazard(160, 160),
        (0, yc - ry + 0.004, 0.02),
        0.15,
        0.15,
    )
    live(k, "label", (0, yc - ry + 0.012, k.bottom + 0.12), 0.14, 0.06)
