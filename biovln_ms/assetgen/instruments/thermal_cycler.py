"""The 96-well thermal cycler (beyond the paper): a touchscreen drawing the run's temperature profile and
a label drawn per instance."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import WHITE, face, feet, instrument, live, metal, paint
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def cycler_display(v: Variant) -> tx.Surface:
    anneal = v.pick((55.0, 58.0, 60.0, 62.0), "anneal")
    current = v.pick((1, 2, 3, 3), "step")
    cycle = int(v.rng("cycle").integers(1, 36))
    profile = (
        (95.0, "3:00", (0.90, 0.25, 0.20)),
        (95.0, "0:30", (0.95, 0.45, 0.20)),
        (anneal, "0:30", (0.25, 0.55, 0.95)),
        (72.0, "1:00", (0.30, 0.80, 0.40)),
        (72.0, "5:00", (0.55, 0.85, 0.35)),
        (4.0, "HOLD", (0.45, 0.45, 0.85)),
    )
    run = v.pick(("PCR-STD", "COLONY", "QC-16S", "GIBSON"), "run")
    return tx.touchscreen(
        f"RUN {run}",
        profile,
        current,
        [f"CYCLE {cycle}/35   LID 105 °C   BLOCK {profile[current][0]:.1f} °C"],
        v.rng("display").integers(1 << 30),
        width=320,
        height=120,
    )


def cycler_label(v: Variant) -> Image.Image:
    return tx.label(
        ["THERMAL CYCLER TC-96", f"{v.tag}  96 x 0.2 mL"],
        WHITE,
        (0.1, 0.25, 0.4),
        v.rng("label").integers(1 << 30),
        width=256,
        height=64,
        age=v.wear,
    )


@instrument("thermal_cycler", live_decals={"display": cycler_display, "label": cycler_label})
def thermal_cycler(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.84, 0.85, 0.86), tile=0.4, mottle=0.05, grain=5.0, chroma=4.0)
    feet(k, 0.012, 0.04, radius=0.015)
    z0 = k.bottom + 0.012
    z_lid = k.bottom + 0.14
    k.box_span("body", (-W / 2, k.front + 0.05, z0), (W / 2, k.back - 0.001, z_lid), body)
    cw, ch = W, z_lid - z0
    console = tx.Panel.painted(
        cw, ch, (0.62, 0.65, 0.69), k.seed("console"), density=900, mottle=0.06, grain=5.0, chroma=4.0
    )
    console.shade(cw / 2, ch * 0.58, 0.22, 0.085, 0.55, 2.0)
    console.paste(tx.warning("hot", k.seed("hot")), cw - 0.03, 0.025, 0.03, 0.03)
    console.weather(k.seed("console_wear"), 0.3, handle=(cw / 2, ch * 0.58))
    console.cut(cw / 2, ch * 0.58, 0.2, 0.075).cut(cw / 2, 0.022, 0.16, 0.025)
    k.box_span(
        "console",
        (-W / 2, k.front, z0),
        (W / 2, k.front + 0.05, z_lid),
        face(k, "console", console, roughness=0.4),
    )
    live(k, "display", (0.0, k.front, z0 + ch * 0.58), 0.2, 0.075)
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=1, cols=3, height=32, keys=("POWER", "LID", "STOP")),
        (0.0, k.front, z0 + 0.022),
        0.16,
        0.025,
    )
    lid = paint(k, "lid", (0.34, 0.42, 0.56), tile=0.4, roughness=0.3, mottle=0.06, grain=5.0, chroma=4.0)
    k.box_span(
        "lid", (-W / 2 + 0.01, k.front + 0.04, z_lid), (W / 2 - 0.01, k.back - 0.01, k.top - 0.001), lid
    )
    live(k, "label", (0.0, k.front + 0.0395, z_lid + 0.05), 0.2, 0.05)
    k.box_span(
        "lid_latch", (-0.07, k.front + 0.02, z_lid + 0.015), (0.07, k.front + 0.04, z_lid + 0.035), metal(k)
    )
    k.decal(
        "top_vent",
        tx.grille((0.28, 0.33, 0.42), k.seed("top_vent"), width=192, height=128, slots=9),
        (0.0, 0.06, k.top),
        W - 0.08,
        0.2,
        facing="+Z",
    )
    k.decal(
        "rear_vent",
        tx.grille((0.6, 0.6, 0.62), k.seed("rear_vent"), width=192, height=96, slots=6),
        (0.0, k.back, z0 + 0.07),
        W - 0.06,
        0.1,
        facing="+Y",
    )
