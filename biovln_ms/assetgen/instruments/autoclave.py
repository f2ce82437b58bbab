"""The vertical top-loading autoclave (beyond the paper): a cycle display and a label drawn per instance."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import (
    DARK,
    WHITE,
    face,
    feet,
    instrument,
    live,
    metal,
    paint,
    plastic,
)
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def autoclave_display(v: Variant) -> tx.Surface:
    prog = v.pick(("LIQUIDS", "SOLIDS", "WASTE", "AGAR"), "program")
    temp = v.pick((121, 121, 134), "temp", prog)
    return tx.display(
        [f"{temp} °C  {v.pick((15, 20, 30), 'time')} min", f"PROG {prog}   READY"],
        v.rng("display").integers(1 << 30),
        glow=(1.0, 0.6, 0.2),
        height=112,
        bars=4,
    )


def autoclave_label(v: Variant) -> Image.Image:
    return tx.label(
        ["STEAM STERILIZER", "PRESSURE VESSEL  MAX 2.5 bar", f"INSPECTED {v.date('inspect')}  {v.tag}"],
        WHITE,
        (0.4, 0.1, 0.05),
        v.rng("label").integers(1 << 30),
        width=320,
        height=112,
        stripe=(0.85, 0.25, 0.1),
        code=v.tag,
        age=v.wear,
    )


@instrument("autoclave", live_decals={"display": autoclave_display, "label": autoclave_label})
def autoclave(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.88, 0.89, 0.90))
    steel = metal(k)
    feet(k, 0.04, 0.06)
    z0 = k.bottom + 0.04
    z_deck = k.top - 0.15
    k.box_span("body", (-W / 2, k.front + 0.03, z0), (W / 2, k.back - 0.001, z_deck), body)
    cw, ch = W - 0.04, 0.26
    console = tx.Panel.painted(cw, ch, (0.30, 0.33, 0.38), k.seed("console"), mottle=0.05)
    console.shade(0.18, 0.17, 0.3, 0.1, 0.6, 2.0)
    console.paste(tx.warning("hot", k.seed("hot")), cw - 0.05, 0.2, 0.06, 0.06)
    console.weather(k.seed("console_wear"), 0.35, handle=(0.18, 0.07))
    for x, z, w, h in ((0.18, 0.17, 0.26, 0.08), (0.18, 0.07, 0.24, 0.07), (cw - 0.1, 0.09, 0.12, 0.12)):
        console.cut(x, z, w, h)  # display, keypad and gauge decals
    k.box_span(
        "console",
        (-W / 2 + 0.02, k.front, z_deck - ch - 0.02),
        (W / 2 - 0.02, k.front + 0.03, z_deck - 0.02),
        face(k, "console", console, roughness=0.45),
    )
    x_c, z_c = -W / 2 + 0.02, z_deck - ch - 0.02
    live(k, "display", (x_c + 0.18, k.front, z_c + 0.17), 0.26, 0.08)
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=1, cols=4, height=40, keys=("PROG", "+", "START", "STOP")),
        (x_c + 0.18, k.front, z_c + 0.07),
        0.24,
        0.07,
    )
    k.decal("gauge", tx.dial(k.seed("gauge"), 0.1, "bar"), (x_c + cw - 0.1, k.front, z_c + 0.09), 0.12, 0.12)
    pw, ph = W - 0.08, z_deck - ch - 0.06 - (z0 + 0.05)
    panel = tx.Panel.painted(pw, ph, (0.90, 0.91, 0.92), k.seed("panel"))
    panel.paste(tx.warning("general", k.seed("general")), 0.1, ph - 0.1, 0.09, 0.09)
    panel.paste(
        tx.label(
            ["DRAIN BEFORE SERVICE", "WATER RESERVOIR"], (0.95, 0.95, 0.92), DARK, k.seed("drain"), 224, 80
        ),
        pw / 2 + 0.08,
        ph - 0.1,
        0.26,
        0.09,
    )
    panel.weather(k.seed("panel_wear"), 0.5)
    k.box_span(
        "door_service",
        (-W / 2 + 0.04, k.front + 0.015, z0 + 0.05),
        (W / 2 - 0.04, k.front + 0.03, z_deck - ch - 0.06),
        face(k, "service", panel, roughness=0.45),
    )
    live(k, "label", (0.0, k.front + 0.0145, z0 + 0.05 + ph * 0.45), 0.3, 0.1)
    k.box_span("deck", (-W / 2, k.front + 0.03, z_deck), (W / 2, k.back, z_deck + 0.02), steel)
    k.cylinder(
        "lid",
        0.25,
        k.top - 0.03 - (z_deck + 0.02),
        (0.0, 0.03, (z_deck + 0.02 + k.top - 0.03) / 2),
        paint(k, "lid", (0.35, 0.37, 0.40), tile=0.25, roughness=0.35),
        sections=48,
    )
    k.box_span(
        "lid_handle", (-0.17, 0.01, k.top - 0.03), (0.17, 0.05, k.top), metal(k, "handle", (0.2, 0.2, 0.22))
    )
    k.cylinder(
        "exhaust_bottle",
        0.05,
        0.12,
        (W / 2 - 0.07, k.back - 0.07, z_deck + 0.02 + 0.06),
        plastic(k, "bottle", (0.85, 0.86, 0.84), tile=0.1, roughness=0.2),
        sections=20,
    )
    k.decal(
        "rear_vent",
        tx.grille((0.6, 0.6, 0.62), k.seed("rear_vent"), width=192, height=128, slots=8),
        (0, k.back, z0 + 0.3),
        W - 0.2,
        0.3,
        facing="+Y",
    )
