"""The water bath with its gable lid (beyond the paper): a temperature display and a label drawn per
instance."""

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


def bath_display(v: Variant) -> tx.Surface:
    t = v.pick((37.0, 42.0, 56.0, 65.0), "temp")
    return tx.display(
        [f"{t:.1f} °C", f"SET {t:.1f}   LEVEL OK"],
        v.rng("display").integers(1 << 30),
        glow=(1.0, 0.35, 0.25),
        height=96,
        bars=4,
    )


def bath_label(v: Variant) -> Image.Image:
    return tx.label(
        ["WATER BATH WB-20", f"{v.tag}  DISTILLED WATER ONLY"],
        WHITE,
        (0.05, 0.3, 0.5),
        v.rng("label").integers(1 << 30),
        width=320,
        height=64,
        stripe=(0.1, 0.5, 0.8),
        age=v.wear,
    )


@instrument("water_bath", live_decals={"display": bath_display, "label": bath_label})
def water_bath(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.90, 0.91, 0.92))
    steel = metal(k)
    feet(k, 0.015, 0.04, radius=0.015)
    z0 = k.bottom + 0.015
    z_rim = k.bottom + 0.20
    k.box_span("body", (-W / 2, k.front + 0.06, z0), (W / 2, k.back - 0.001, z_rim - 0.03), body)
    cw, ch = W, z_rim - 0.03 - z0
    console = tx.Panel.painted(cw, ch, (0.18, 0.36, 0.56), k.seed("console"), mottle=0.05)
    console.shade(0.16, ch * 0.6, 0.22, 0.07, 0.6, 2.0)
    console.paste(tx.warning("hot", k.seed("hot")), cw - 0.05, ch * 0.6, 0.06, 0.06)
    console.weather(k.seed("console_wear"), 0.35, handle=(0.4, ch * 0.6))
    console.cut(0.16, ch * 0.6, 0.2, 0.06).cut(0.38, ch * 0.6, 0.14, 0.05).cut(cw / 2, ch * 0.2, 0.3, 0.04)
    k.box_span(
        "console",
        (-W / 2, k.front, z0),
        (W / 2, k.front + 0.06, z_rim - 0.03),
        face(k, "console", console, roughness=0.4),
    )
    live(k, "display", (-W / 2 + 0.16, k.front, z0 + ch * 0.6), 0.2, 0.06)
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=1, cols=3, height=40, keys=("SET", "+", "-"), accents=False),
        (-W / 2 + 0.38, k.front, z0 + ch * 0.6),
        0.14,
        0.05,
    )
    live(k, "label", (0.0, k.front, z0 + ch * 0.2), 0.3, 0.04)
    k.box_span("rim", (-W / 2, k.front + 0.04, z_rim - 0.03), (W / 2, k.back, z_rim), steel)
    lid = metal(k, "lid", (0.78, 0.80, 0.82))
    k.box_span(
        "lid", (-W / 2 + 0.01, k.front + 0.05, z_rim), (W / 2 - 0.01, k.back - 0.01, k.top - 0.05), lid
    )
    k.box_span("lid_ridge", (-W / 2 + 0.03, -0.06, k.top - 0.05), (W / 2 - 0.03, 0.08, k.top), lid)
    k.box_span(
        "lid_handle",
        (-0.1, k.front + 0.03, z_rim + 0.02),
        (0.1, k.front + 0.05, z_rim + 0.04),
        plastic(k, "handle", DARK, tile=0.1),
    )
    k.decal(
        "rear_plate",
        tx.model_plate(["WB-20  20 L", "230 V~ 50 Hz 1.2 kW", "IP21"], k.seed("plate")),
        (0.0, k.back, z0 + 0.1),
        0.16,
        0.08,
        facing="+Y",
    )
