"""The mini centrifuge (paper Table 2): a small lidded housing with a speed display and a model label
drawn per instance."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import DARK, WHITE, face, feet, instrument, live, metal, plastic
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def mini_display(v: Variant) -> tx.Surface:
    rpm = v.pick((6000, 10000, 12000, 13400), "rpm")
    return tx.display(
        [f"{rpm} rpm", f"{int(rpm * rpm * 1.118e-5 * 6.0)} x g  {v.pick((1, 2, 5), 'time')} min"],
        v.rng("display").integers(1 << 30),
        glow=(0.4, 0.9, 1.0),
        height=112,
    )


def mini_label(v: Variant) -> Image.Image:
    return tx.label(
        ["MINI CENTRIFUGE MC-12", f"{v.tag}  12 x 1.5/2.0 mL"],
        WHITE,
        (0.3, 0.3, 0.35),
        v.rng("label").integers(1 << 30),
        width=320,
        height=64,
        age=v.wear,
    )


@instrument("mini_centrifuge", live_decals={"display": mini_display, "label": mini_label})
def mini_centrifuge(k: Kit) -> None:
    W = k.W
    body = plastic(k, "body", (0.94, 0.94, 0.92), tile=0.25)
    feet(k, 0.015, 0.05, radius=0.02)
    z0 = k.bottom + 0.015
    z_lid = k.bottom + 0.25
    k.box_span("body", (-W / 2, k.front + 0.08, z0), (W / 2, k.back, z_lid), body)
    cw, ch = W - 0.04, 0.16
    console = tx.Panel.painted(cw, ch, (0.35, 0.36, 0.40), k.seed("console"), mottle=0.05)
    console.shade(cw / 2 - 0.08, 0.11, 0.28, 0.09, 0.6, 2.0)
    console.paste(tx.warning("rotor", k.seed("rotor")), cw - 0.03, 0.04, 0.035, 0.035)
    console.weather(k.seed("console_wear"), 0.35, handle=(cw / 2 + 0.14, 0.11))
    for x, z, w, h in ((-0.08, 0.11, 0.26, 0.07), (0.14, 0.11, 0.16, 0.05), (0.0, 0.04, 0.34, 0.06)):
        console.cut(cw / 2 + x, z, w, h)  # the display, keypad and label decals
    k.box_span(
        "console",
        (-W / 2 + 0.02, k.front, z0),
        (W / 2 - 0.02, k.front + 0.08, z0 + 0.16),
        face(k, "console", console, roughness=0.45),
    )
    live(k, "display", (-0.08, k.front, z0 + 0.11), 0.26, 0.07)
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=1, cols=4, height=48, keys=("+", "-", "START", "STOP")),
        (0.14, k.front, z0 + 0.11),
        0.16,
        0.05,
    )
    live(k, "label", (0, k.front, z0 + 0.04), 0.34, 0.06)
    lid = plastic(k, "lid", (0.45, 0.65, 0.95), tile=0.2, roughness=0.15)
    ry = (k.D - 0.08) / 2
    k.cylinder(
        "lid",
        1.0,
        k.top - z_lid,
        (0, k.front + 0.08 + ry, (k.top + z_lid) / 2),
        lid,
        sections=48,
        scale_xy=(W / 2 - 0.02, ry),
    )
    k.cylinder(
        "rotor",
        0.12,
        0.01,
        (0, k.front + 0.08 + ry, k.top - 0.005),
        metal(k, "rotor", (0.75, 0.75, 0.78)),
        sections=32,
    )
    k.box_span(
        "hinge",
        (-0.12, k.back - 0.03, z_lid - 0.02),
        (0.12, k.back, z_lid + 0.03),
        plastic(k, "hinge", DARK, tile=0.1),
    )
