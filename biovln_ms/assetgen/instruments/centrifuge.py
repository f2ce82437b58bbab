"""The benchtop centrifuge (paper Table 2): a lidded rotor housing on feet, with a speed display and a
model label drawn per instance."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import DARK, WHITE, face, feet, instrument, live, paint, plastic
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def centrifuge_display(v: Variant) -> tx.Surface:
    rpm = v.pick((3000, 4000, 4500, 4700), "rpm")
    minutes = v.pick((5, 10, 15, 20), "time")
    temp = v.pick((4, 4, 20), "temp")
    return tx.display(
        [f"{rpm} rpm", f"{int(rpm * rpm * 1.118e-5 * 18.0)} x g  {minutes:02d}:00  {temp} °C"],
        v.rng("display").integers(1 << 30),
        glow=(0.3, 1.0, 0.4),
        height=112,
    )


def centrifuge_label(v: Variant) -> Image.Image:
    return tx.label(
        ["CENTRIFUGE 5400R", "MAX 4700 rpm  4 x 750 mL", f"{v.tag}  ROTOR CHECK {v.date('rotor')}"],
        WHITE,
        (0.15, 0.2, 0.45),
        v.rng("label").integers(1 << 30),
        width=320,
        height=112,
        code=v.tag,
        age=v.wear,
    )


@instrument("centrifuge", live_decals={"display": centrifuge_display, "label": centrifuge_label})
def centrifuge(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.86, 0.87, 0.89))
    feet(k, 0.02, 0.04, radius=0.018)
    z0 = k.bottom + 0.02
    z_lid = k.bottom + 0.45
    k.box_span("body", (-W / 2, k.front + 0.06, z0), (W / 2, k.back, z_lid), body)
    cw, ch = W - 0.02, 0.26
    console = tx.Panel.painted(cw, ch, (0.20, 0.30, 0.55), k.seed("console"), mottle=0.05)
    console.shade(cw / 2, 0.20, 0.32, 0.09, 0.6, 2.0).shade(cw / 2, 0.09, 0.34, 0.14, 0.7, 2.0)
    console.paste(tx.warning("rotor", k.seed("rotor")), 0.025, 0.235, 0.035, 0.035)
    console.paste(tx.warning("general", k.seed("general")), cw - 0.025, 0.235, 0.035, 0.035)
    console.weather(k.seed("console_wear"), 0.35, handle=(cw / 2, 0.1))
    console.cut(cw / 2, 0.20, 0.3, 0.07).cut(cw / 2, 0.09, 0.32, 0.12)  # the display and keypad decals
    k.box_span(
        "console",
        (-W / 2 + 0.01, k.front, z0 + 0.02),
        (W / 2 - 0.01, k.front + 0.06, z0 + 0.28),
        face(k, "console", console, roughness=0.45),
    )
    live(k, "display", (0, k.front, z0 + 0.22), 0.3, 0.07)
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=2, cols=5, width=192, keys=(*"12345678", "START", "STOP")),
        (0, k.front, z0 + 0.11),
        0.32,
        0.12,
    )
    live(k, "label", (0, k.front + 0.0595, z0 + 0.36), 0.3, 0.1)
    lid = paint(k, "lid", (0.30, 0.45, 0.80), tile=0.25, roughness=0.3)
    ry = (k.D - 0.06) / 2
    k.cylinder(
        "lid",
        1.0,
        k.top - z_lid - 0.002,
        (0, k.front + 0.06 + ry, (k.top + z_lid) / 2 - 0.001),
        lid,
        sections=48,
        scale_xy=(W / 2, ry),
    )
    rotor = tx.Panel.metal(0.16, 0.16, (0.55, 0.57, 0.6), k.seed("rotor_face"))
    for a in range(4):  # four swing buckets seen through the lid window
        x = 0.08 + 0.05 * [1, 0, -1, 0][a]
        y = 0.08 + 0.05 * [0, 1, 0, -1][a]
        rotor.shade(x, y, 0.035, 0.035, 0.35, 1.5)
    k.decal(
        "rotor_window",
        tx.behind_glass(rotor.image(), k.seed("window")),
        (0, k.front + 0.06 + ry, k.top),
        0.16,
        0.16,
        facing="+Z",
    )
    k.box_span(
        "lid_handle",
        (-0.08, k.front + 0.035, z_lid),
        (0.08, k.front + 0.06, z_lid + 0.03),
        plastic(k, "handle", DARK, tile=0.1),
    )
    k.decal(
        "rear_vent",
        tx.grille((0.6, 0.6, 0.62), k.seed("rear_vent"), width=192, height=128, slots=8),
        (0, k.back, z0 + 0.2),
        W - 0.1,
        0.25,
        facing="+Y",
    )
