"""The incubated orbital shaker (beyond the paper): a speed and temperature display and a label drawn per
instance."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import WHITE, face, feet, instrument, live, metal, paint
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def shaker_display(v: Variant) -> tx.Surface:
    rpm = v.pick((150, 200, 220, 250), "rpm")
    t = v.pick((30.0, 37.0, 37.0, 18.0), "temp")
    return tx.display(
        [f"{rpm} rpm", f"{t:.1f} °C   {v.pick((4, 16, 18, 24), 'hours'):02d}:00 h"],
        v.rng("display").integers(1 << 30),
        glow=(0.3, 0.9, 1.0),
        height=112,
        bars=6,
    )


def shaker_label(v: Variant) -> Image.Image:
    return tx.label(
        ["INCUBATED ORBITAL SHAKER", "25 mm ORBIT  MAX 400 rpm", f"{v.tag}  {v.date('svc')}"],
        WHITE,
        (0.1, 0.3, 0.3),
        v.rng("label").integers(1 << 30),
        width=320,
        height=112,
        stripe=(0.1, 0.6, 0.6),
        code=v.tag,
        age=v.wear,
    )


@instrument("shaker", live_decals={"display": shaker_display, "label": shaker_label})
def shaker(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.92, 0.92, 0.90))
    steel = metal(k)
    feet(k, 0.03, 0.06)
    z0 = k.bottom + 0.03
    z_lid = k.bottom + 0.30
    k.box_span("body", (-W / 2, k.front + 0.08, z0), (W / 2, k.back - 0.001, z_lid), body)
    cw, ch = W, z_lid - z0
    console = tx.Panel.painted(cw, ch, (0.26, 0.30, 0.34), k.seed("console"), mottle=0.05)
    console.shade(0.2, ch * 0.62, 0.3, 0.1, 0.6, 2.0)
    console.paste(tx.warning("general", k.seed("general")), cw - 0.06, ch * 0.62, 0.07, 0.07)
    console.weather(k.seed("console_wear"), 0.4, handle=(0.45, ch * 0.62))
    console.cut(0.2, ch * 0.62, 0.28, 0.09).cut(0.45, ch * 0.62, 0.16, 0.08).cut(cw / 2, ch * 0.25, 0.32, 0.1)
    k.box_span(
        "console",
        (-W / 2, k.front + 0.02, z0),
        (W / 2, k.front + 0.08, z_lid),
        face(k, "console", console, roughness=0.4),
    )
    y_c = k.front + 0.02
    live(k, "display", (-W / 2 + 0.2, y_c, z0 + ch * 0.62), 0.28, 0.09)
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=2, cols=3, keys=("RPM", "TEMP", "TIME", "+", "START", "STOP")),
        (-W / 2 + 0.45, y_c, z0 + ch * 0.62),
        0.16,
        0.08,
    )
    live(k, "label", (0.0, y_c, z0 + ch * 0.25), 0.32, 0.1)
    k.box_span(
        "lid",
        (-W / 2, k.front + 0.03, z_lid),
        (W / 2, k.back, k.top - 0.002),
        paint(k, "lid", (0.88, 0.89, 0.88)),
    )
    w_px, h_px = tx.Panel.size_px(W - 0.16, k.D - 0.2)
    k.decal(
        "window",
        tx.behind_glass(tx.flask_platform(k.seed("platform"), w_px, h_px), k.seed("window")),
        (0.0, 0.02, k.top),
        W - 0.16,
        k.D - 0.2,
        facing="+Z",
    )
    k.box_span("lid_handle", (-0.2, k.front, z_lid + 0.03), (0.2, k.front + 0.03, z_lid + 0.06), steel)
    hinge = metal(k, "hinge", (0.5, 0.5, 0.52))
    for sx in (-1, 1):
        k.cylinder(
            f"hinge_{sx}",
            0.015,
            0.1,
            (sx * (W / 2 - 0.12), k.back - 0.015, z_lid),
            hinge,
            axis="x",
            sections=12,
        )
    k.decal(
        "rear_vent",
        tx.grille((0.6, 0.6, 0.62), k.seed("rear_vent"), width=256, height=96, slots=8),
        (0.0, k.back, z0 + 0.13),
        W - 0.2,
        0.16,
        facing="+Y",
    )
