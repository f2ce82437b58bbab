"""The pipette stand (paper Table 2): a narrow carousel of pipettes with a calibration label drawn per
instance."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import DARK, WHITE, instrument, live, paint, plastic
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def pipette_label(v: Variant) -> Image.Image:
    return tx.label(
        ["P200", f"CAL {v.date('cal')[2:]}"],
        WHITE,
        DARK,
        v.rng("label").integers(1 << 30),
        width=96,
        height=96,
        stripe=(0.95, 0.8, 0.2),
        age=v.wear,
    )


@instrument("pipette", live_decals={"label": pipette_label})
def pipette(k: Kit) -> None:
    base = paint(k, "base", (0.30, 0.32, 0.36), tile=0.1, mottle=0.06)
    k.box_span("base", (-k.W / 2, k.front, k.bottom), (k.W / 2, k.back, k.bottom + 0.015), base)
    k.box_span(
        "column", (-k.W / 2 + 0.005, k.back - 0.03, k.bottom + 0.015), (k.W / 2 - 0.005, k.back, k.top), base
    )
    k.box_span(
        "arm",
        (-k.W / 2 + 0.008, k.front + 0.04, k.top - 0.025),
        (k.W / 2 - 0.008, k.back - 0.03, k.top - 0.005),
        paint(k, "arm", (0.85, 0.3, 0.2), tile=0.1, mottle=0.06),
    )
    y_p = k.front + 0.06
    body = plastic(k, "pipette", (0.88, 0.88, 0.86), tile=0.05)
    k.cylinder("pipette_body", 0.016, 0.13, (0, y_p, k.top - 0.11), body, sections=20)
    k.cylinder(
        "plunger",
        0.008,
        0.04,
        (0, y_p, k.top - 0.025),
        plastic(k, "plunger", (0.95, 0.80, 0.15), tile=0.03),
        sections=16,
    )
    k.cylinder("shaft", 0.007, 0.06, (0, y_p, k.top - 0.205), body, sections=16)
    k.cylinder(
        "tip",
        0.004,
        0.035,
        (0, y_p, k.top - 0.2525),
        k.material("tip", color=(0.95, 0.85, 0.2, 1.0), texture=None, roughness=0.3),
        sections=12,
    )
    k.decal("volume", tx.counter("200"), (0, y_p - 0.0165, k.top - 0.09), 0.03, 0.015)
    live(k, "label", (0, k.back - 0.0305, k.bottom + 0.12), 0.028, 0.028)
