"""The -80 C ultra-low freezer (beyond the paper): an upright freezer with a temperature display and a
label drawn per instance."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import DARK, WHITE, face, instrument, live, metal, paint, plastic
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def ult_display(v: Variant) -> tx.Surface:
    t = v.pick((-80, -80, -79, -81, -82), "temp")
    return tx.display(
        [f"{t} °C", f"SET -80   ALARM {v.pick((-70, -65, -70), 'alarm')}   DOOR OK"],
        v.rng("display").integers(1 << 30),
        glow=(1.0, 0.3, 0.25),
        height=112,
        bars=5,
    )


def ult_label(v: Variant) -> Image.Image:
    return tx.label(
        ["-80 °C ULTRA-LOW FREEZER", f"RACKS {v.pick(('A-E', 'F-J', 'K-O'), 'racks')}  ALARM ON", f"{v.tag}"],
        WHITE,
        (0.05, 0.15, 0.45),
        v.rng("label").integers(1 << 30),
        width=320,
        height=128,
        stripe=(0.15, 0.35, 0.85),
        code=v.tag,
        age=v.wear,
    )


@instrument("ultra_low_freezer", live_decals={"display": ult_display, "label": ult_label})
def ultra_low_freezer(k: Kit) -> None:
    W = k.W
    plinth = 0.10
    body = paint(k, "body", (0.93, 0.93, 0.91))
    steel = metal(k)
    k.box_span(
        "plinth",
        (-W / 2 + 0.02, k.front + 0.05, k.bottom + 0.03),
        (W / 2 - 0.02, k.back - 0.02, k.bottom + plinth),
        plastic(k, "plinth", (0.22, 0.23, 0.25)),
    )
    for sx in (-1, 1):
        for sy in (-1, 1):
            k.cylinder(
                f"castor_{sx}{sy}",
                0.03,
                0.03,
                (sx * (W / 2 - 0.06), sy * (k.D / 2 - 0.08), k.bottom + 0.03),
                plastic(k, "castor", (0.08, 0.08, 0.09), tile=0.1, roughness=0.9),
                axis="x",
                sections=12,
            )
    k.decal(
        "kick_grille",
        tx.grille((0.3, 0.31, 0.33), k.seed("kick"), width=384, height=48, slots=5),
        (0, k.front + 0.0495, k.bottom + plinth / 2),
        W - 0.1,
        0.07,
    )
    k.box_span(
        "body", (-W / 2, k.front + 0.08, k.bottom + plinth), (W / 2, k.back - 0.001, k.top - 0.001), body
    )
    dw, dh = W - 0.02, k.H - plinth - 0.04
    door = tx.Panel.painted(dw, dh, (0.95, 0.95, 0.93), k.seed("door"))
    door.shade(dw / 2, dh - 0.2, 0.5, 0.22, 0.55, 2.5)  # the control panel's recess
    door.paste(tx.warning("cold", k.seed("cold")), 0.12, dh - 0.45, 0.1, 0.1)
    door.paste(tx.warning("biohazard", k.seed("bio")), 0.12, dh - 0.58, 0.1, 0.1)
    door.paste(
        tx.label(
            ["RACK MAP", "A  PLASMIDS   B  GLYCEROLS", "C  cDNA      D  PROTEIN", "E  CELL PELLETS"],
            (0.98, 0.98, 0.96),
            DARK,
            k.seed("rack_map"),
            width=256,
            height=224,
        ),
        dw / 2 + 0.05,
        0.85,
        0.34,
        0.3,
    )
    door.paste(
        tx.label(
            ["DO NOT LEAVE", "DOOR OPEN"], (0.98, 0.92, 0.45), (0.6, 0.05, 0.05), k.seed("note"), 160, 96
        ),
        dw / 2 - 0.05,
        0.42,
        0.2,
        0.12,
    )
    door.paste(
        tx.label(["CALL 5555 IF ALARM"], (0.95, 0.3, 0.25), WHITE, k.seed("call"), 224, 48),
        dw / 2,
        0.25,
        0.3,
        0.06,
    )
    door.weather(k.seed("door_wear"), 0.45, handle=(dw - 0.09, dh * 0.55))
    door.cut(dw / 2 - 0.04, dh - 0.16, 0.3, 0.09).cut(dw / 2 - 0.04, dh - 0.27, 0.24, 0.06)
    k.box_span(
        "door",
        (-W / 2 + 0.01, k.front + 0.01, k.bottom + plinth + 0.02),
        (W / 2 - 0.01, k.front + 0.08, k.top - 0.02),
        face(k, "door", door, roughness=0.35),
    )
    y_d = k.front + 0.01
    z_top = k.top - 0.02
    live(k, "display", (-0.04, y_d, z_top - 0.16), 0.3, 0.09)
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=1, cols=4, height=40, keys=("SET", "+", "-", "MUTE")),
        (-0.04, y_d, z_top - 0.27),
        0.24,
        0.06,
    )
    live(k, "label", (-0.12, y_d - 0.0005, k.bottom + plinth + 0.55), 0.3, 0.12)
    k.box_span(
        "handle",
        (W / 2 - 0.11, k.front, k.bottom + 0.95),
        (W / 2 - 0.06, k.front + 0.01, k.bottom + 1.35),
        steel,
    )
    k.box_span(
        "lock",
        (W / 2 - 0.1, k.front + 0.003, k.bottom + 1.40),
        (W / 2 - 0.07, k.front + 0.01, k.bottom + 1.44),
        metal(k, "lock", (0.8, 0.7, 0.4)),
    )
    hinge = metal(k, "hinge", (0.5, 0.5, 0.52))
    for z in (k.bottom + plinth + 0.15, k.top - 0.2):
        k.cylinder(f"hinge_{z:.2f}", 0.015, 0.08, (-W / 2 + 0.02, k.front + 0.02, z), hinge, sections=12)
    k.decal(
        "rear_vent",
        tx.grille((0.55, 0.56, 0.58), k.seed("rear_vent"), width=256, height=160, slots=14),
        (0, k.back, k.bottom + 0.5),
        W - 0.2,
        0.6,
        facing="+Y",
    )
    k.decal(
        "port",
        tx.grille((0.85, 0.85, 0.83), k.seed("port"), width=128, height=64, slots=4),
        (0, 0.1, k.top),
        0.3,
        0.15,
        facing="+Z",
    )
