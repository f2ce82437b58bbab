"""The lab refrigerator (paper Table 2): a glazed door showing its shelves, a condenser coil behind,
and a display and asset label drawn per instance."""

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
    plain,
    window,
)
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def fridge_display(v: Variant) -> tx.Surface:
    t = v.pick((3.5, 4.0, 4.0, 4.5, 5.0), "setpoint")
    return tx.display(
        [f"+{t:.1f} °C", f"SET +{v.pick((4.0, 4.0, 5.0), 'set'):.1f}   ALARM OK"],
        v.rng("display").integers(1 << 30),
        glow=(0.4, 0.8, 1.0),
        height=128,
        bars=6,
    )


def fridge_label(v: Variant) -> Image.Image:
    return tx.label(
        ["LAB REFRIGERATOR LR-500", "+2 TO +8 °C  SAMPLES ONLY", f"ASSET {v.tag}  SERVICED {v.date('svc')}"],
        WHITE,
        (0.1, 0.2, 0.5),
        v.rng("label").integers(1 << 30),
        width=320,
        height=160,
        stripe=(0.1, 0.3, 0.8),
        code=v.tag,
        age=v.wear,
    )


@instrument("refrigerator", live_decals={"display": fridge_display, "label": fridge_label})
def refrigerator(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", WHITE)
    feet(k, 0.04, 0.06)
    z0 = k.bottom + 0.04
    k.box_span("body", (-W / 2, k.front + 0.04, z0), (W / 2, k.back - 0.03, k.top), body)
    # Condenser coil on the back: horizontal tubes.
    coil = plain(k, "coil", DARK, roughness=0.8)
    for i in range(9):
        k.cylinder(
            f"coil_{i}", 0.008, W - 0.16, (0, k.back - 0.015, z0 + 0.2 + i * 0.15), coil, axis="x", sections=8
        )
    k.box_span(
        "coil_rail_l", (-W / 2 + 0.06, k.back - 0.03, z0 + 0.15), (-W / 2 + 0.09, k.back, z0 + 1.45), coil
    )
    k.box_span(
        "coil_rail_r", (W / 2 - 0.09, k.back - 0.03, z0 + 0.15), (W / 2 - 0.06, k.back, z0 + 1.45), coil
    )
    # Two doors: freezer above (stickers), fridge below (glazed, shelves of samples behind).
    split = k.top - 0.55
    dw = W - 0.02
    hi_freezer, hi_fridge = k.top - 0.01 - (split + 0.01), split - 0.01 - (z0 + 0.09)
    door_color = (0.93, 0.94, 0.95)
    freezer = tx.Panel.painted(dw, hi_freezer, door_color, k.seed("freezer"))
    freezer.shade(dw / 2, 0.01, dw, 0.02, 0.7, 1.5)  # the gasket's shadow under the door
    freezer.paste(tx.prohibition(), 0.12, 0.30, 0.11, 0.143)
    freezer.paste(tx.warning("cold", k.seed("cold")), 0.62, 0.42, 0.08, 0.08)
    freezer.paste(
        tx.label(["-20 °C BOX 3", "DO NOT DEFROST"], (0.98, 0.92, 0.45), DARK, k.seed("note"), 160, 96),
        0.58,
        0.22,
        0.15,
        0.09,
    )
    freezer.weather(k.seed("freezer_wear"), 0.4, handle=(dw / 2 + W / 2 - 0.085, 0.27))
    fridge = tx.Panel.painted(dw, hi_fridge, door_color, k.seed("fridge"))
    gw, gh = 0.66, 0.58
    w_px, h_px = tx.Panel.size_px(gw, gh)
    fridge.shade(0.38, 0.42, gw + 0.05, gh + 0.05, 0.55, 3.0)  # gasket around the glazing
    fridge.paste(window(k.seed("shelves"), w_px, h_px, 4), 0.38, 0.42, gw, gh)
    fridge.paste(tx.warning("biohazard", k.seed("bio")), 0.08, 0.80, 0.07, 0.07)
    fridge.weather(k.seed("fridge_wear"), 0.45, handle=(dw / 2 + W / 2 - 0.085, 0.785))
    k.box_span(
        "door_freezer",
        (-W / 2 + 0.01, k.front + 0.015, split + 0.01),
        (W / 2 - 0.01, k.front + 0.04, k.top - 0.01),
        face(k, "freezer", freezer, roughness=0.35),
    )
    k.box_span(
        "door_fridge",
        (-W / 2 + 0.01, k.front + 0.015, z0 + 0.09),
        (W / 2 - 0.01, k.front + 0.04, split - 0.01),
        face(k, "fridge", fridge, roughness=0.25),
    )
    steel = metal(k)
    for nm, lo, hi in (("freezer", split + 0.08, k.top - 0.08), ("fridge", split - 0.55, split - 0.08)):
        k.box_span(f"handle_{nm}", (W / 2 - 0.10, k.front, lo), (W / 2 - 0.07, k.front + 0.012, hi), steel)
        for z in (lo + 0.02, hi - 0.02):
            k.box_span(
                f"handle_{nm}_post_{z:.2f}",
                (W / 2 - 0.095, k.front + 0.012, z - 0.01),
                (W / 2 - 0.075, k.front + 0.015, z + 0.01),
                steel,
            )
    hinge = metal(k, "hinge", (0.5, 0.5, 0.52))
    for z in (k.top - 0.03, split + 0.02, split - 0.03, z0 + 0.1):
        k.cylinder(f"hinge_{z:.2f}", 0.012, 0.04, (-W / 2 + 0.02, k.front + 0.02, z), hinge, sections=12)
    live(k, "display", (-0.1, k.front + 0.0145, split + 0.38), 0.22, 0.08)
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=1, cols=4, height=40, keys=("+", "-", "SET", "ALM")),
        (-0.1, k.front + 0.0145, split + 0.30),
        0.22,
        0.06,
    )
    live(k, "label", (-0.15, k.front + 0.0145, split - 0.25), 0.3, 0.15)
    k.decal(
        "vent",
        tx.grille((0.5, 0.52, 0.55), k.seed("vent"), width=384, height=48, slots=6),
        (0, k.front + 0.039, z0 + 0.045),
        W - 0.1,
        0.07,
    )
