"""One builder per catalog asset and room-shell piece, in the canonical frame of ``parts.Kit``.

Every builder keeps all parts inside the asset's bounding box and lets the body touch all six
sides, so the generated GLB's bounds equal the catalog dimensions (Table 2). The operational face
(canonical -Y) carries the door, handle, display or keypad, so front and back can be told apart.

The looks (issue 18 item 2): powder-coated and brushed-steel surfaces with normal maps, doors and
panels with their own non-tiling face textures (stickers, glazing with what is behind it, gaskets,
wear around the handles), readable labels, model plates, warning signs and glowing displays.
The meshes are those of the first generator: only textures, UVs and materials changed, so the coacd
collision caches and every layout computed from the assets still hold.

:data:`LIVE_DECALS` are the decals drawn per instance (asset tag, setpoints, dates): the builders draw
them for :data:`~biovln_ms.assetgen.variation.SHIPPED`, the simulator again for each instance's variant.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.parts import Kit, Material
from biovln_ms.assetgen.variation import SHIPPED, Variant

WHITE = (0.90, 0.91, 0.90)
STEEL = (0.72, 0.74, 0.76)
DARK = (0.16, 0.17, 0.19)
BLACK = (0.06, 0.06, 0.07)
OPAQUE = (1.0, 1.0, 1.0, 1.0)  # base colour factor of textured materials (the texture is the colour)


# --- materials ------------------------------------------------------------------------------------
def coat(
    k: Kit, key: str, color: tuple[float, float, float], amount: float = 10.0, tile: float = 0.25
) -> Material:
    """The first generator's powder coat (room-shell pieces keep their look)."""
    return k.material(key, texture=tx.powder_coat(color, k.seed(key), amount=amount), tile=tile)


def paint(
    k: Kit, key: str, color: tuple[float, float, float], tile: float = 0.5, roughness: float = 0.55, **kw
) -> Material:
    """Tiling powder coat with orange peel (one normal map shared by the asset's painted parts)."""
    return k.material(
        key,
        color=OPAQUE,
        texture=tx.paint(color, k.seed(key), **kw),
        normal=tx.peel_normal(k.seed("peel")),
        tile=tile,
        roughness=roughness,
    )


def metal(k: Kit, key: str = "steel", color: tuple[float, float, float] = STEEL) -> Material:
    s = tx.brushed(color, k.seed(key))
    return k.material(
        key, color=OPAQUE, texture=s.albedo, normal=s.normal, tile=0.3, metallic=0.85, roughness=0.35
    )


def plastic(
    k: Kit, key: str, color: tuple[float, float, float], tile: float = 0.3, roughness: float = 0.4
) -> Material:
    return k.material(
        key,
        color=OPAQUE,
        texture=tx.plastic(color, k.seed(key)),
        normal=tx.peel_normal(k.seed("peel")),
        tile=tile,
        roughness=roughness,
    )


def plain(k: Kit, key: str, color: tuple[float, float, float], roughness: float = 0.5) -> Material:
    return k.material(key, color=(*color, 1.0), texture=None, roughness=roughness)


def face(k: Kit, key: str, panel: tx.Panel, roughness: float = 0.5, metallic: float = 0.0) -> Material:
    """A door or panel with its own picture of its -Y face (not tiled; the other faces continue its edges)."""
    return k.material(
        f"art_{key}",
        color=OPAQUE,
        texture=panel.image(),
        tile=None,
        face=True,
        roughness=roughness,
        metallic=metallic,
    )


def glazing(k: Kit, key: str, behind: Image.Image, opacity: float = 0.8) -> Material:
    """A see-through glass pane (RGBA texture, glTF alphaMode BLEND) with reflections, showing ``behind``."""
    return k.material(
        key,
        color=OPAQUE,
        texture=tx.behind_glass(behind, k.seed(key), (0.70, 0.82, 0.86), 0.3, opacity),
        tile=None,
        roughness=0.05,
        metallic=0.1,
    )


def live(
    k: Kit,
    name: str,
    center: tuple[float, float, float],
    width: float,
    height: float,
    facing: str = "-Y",
) -> None:
    """A decal of :data:`LIVE_DECALS` as the shipped asset shows it."""
    k.decal(name, LIVE_DECALS[k.name][name](SHIPPED), center, width, height, facing)


def feet(k: Kit, height: float, inset: float, radius: float = 0.022) -> None:
    mat = plastic(k, "rubber", (0.08, 0.08, 0.09), tile=0.1, roughness=0.9)
    for sx in (-1, 1):
        for sy in (-1, 1):
            k.cylinder(
                f"foot_{sx}{sy}",
                radius,
                height,
                (sx * (k.W / 2 - inset), sy * (k.D / 2 - inset), k.bottom + height / 2),
                mat,
                sections=16,
            )


def window(seed: int, w_px: int, h_px: int, rows: int, back=(0.85, 0.87, 0.88)) -> Image.Image:
    """A glazed door's view: shelves with bottles behind tinted, reflecting glass."""
    return tx.behind_glass(tx.shelves(seed, w_px, h_px, rows, back), seed + 1)


# --- live decals (drawn per instance) -------------------------------------------------------------
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


def incubator_display(v: Variant, chamber: str) -> tx.Surface:
    t = v.pick((37.0, 37.0, 36.5, 37.5), "temp", chamber)
    co2 = v.pick((5.0, 5.0, 5.0, 7.5, 2.0), "co2", chamber)
    rh = v.pick((93, 95, 95, 96), "rh", chamber)
    return tx.display(
        [f"{t:.1f} °C", f"CO2 {co2:.1f}%   RH {rh}%", f"DOOR CLOSED  {chamber.upper()}"],
        v.rng("display", chamber).integers(1 << 30),
        glow=(1.0, 0.55, 0.2),
        height=112,
        bars=5,
    )


def incubator_label(v: Variant) -> Image.Image:
    return tx.label(
        ["CO2 INCUBATOR CI-170", "37 °C  5% CO2  95% RH", f"{v.tag}  DECON {v.date('decon')}"],
        WHITE,
        (0.5, 0.1, 0.1),
        v.rng("label").integers(1 << 30),
        width=320,
        height=128,
        stripe=(0.85, 0.2, 0.15),
        code=v.tag,
        age=v.wear,
    )


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


def cabinet_label(v: Variant) -> Image.Image:
    shelf = v.pick(("SOLVENTS", "BUFFERS", "REAGENTS", "STAINS"), "contents")
    return tx.label(
        ["CHEMICAL STORAGE", f"{shelf} - {v.pick(('GROUP A', 'GROUP B', 'CORE'), 'group')}", v.tag],
        (0.95, 0.95, 0.9),
        (0.6, 0.1, 0.05),
        v.rng("label").integers(1 << 30),
        width=256,
        height=128,
        stripe=(0.9, 0.5, 0.1),
        code=v.tag,
        age=v.wear,
    )


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


def bsc_display(v: Variant) -> tx.Surface:
    inflow = v.pick((0.45, 0.48, 0.50, 0.52), "inflow")
    down = v.pick((0.30, 0.33, 0.35), "down")
    return tx.display(
        ["AIRFLOW OK", f"INFLOW {inflow:.2f} m/s  DOWN {down:.2f} m/s", "UV OFF   LIGHT ON   FAN 1"],
        v.rng("display").integers(1 << 30),
        glow=(0.3, 1.0, 0.5),
        width=384,
        height=112,
        bars=8,
    )


def bsc_label(v: Variant) -> Image.Image:
    return tx.label(
        ["BIOSAFETY CABINET", "CLASS II  TYPE A2", f"CERTIFIED {v.date('cert')}  {v.tag}"],
        WHITE,
        (0.1, 0.3, 0.2),
        v.rng("label").integers(1 << 30),
        width=384,
        height=112,
        stripe=(0.1, 0.6, 0.3),
        code=v.tag,
        age=v.wear,
    )


def bench_label(v: Variant) -> Image.Image:
    return tx.label(
        [f"BENCH {v.pick('ABCDEF', 'bench')}  NO FOOD OR DRINK", v.tag],
        WHITE,
        (0.1, 0.1, 0.4),
        v.rng("label").integers(1 << 30),
        width=320,
        height=64,
        age=v.wear,
    )


def table_label(v: Variant) -> Image.Image:
    return tx.label(
        [f"REAGENT SHELF {v.pick('123456', 'shelf')}  LABEL ALL BOTTLES"],
        WHITE,
        (0.1, 0.3, 0.1),
        v.rng("label").integers(1 << 30),
        width=384,
        height=48,
        age=v.wear,
    )


# --- instruments ----------------------------------------------------------------------------------
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


def incubator(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.88, 0.89, 0.87))
    frame = metal(k, "frame", (0.45, 0.47, 0.50))
    stand_h = 0.35
    for sx in (-1, 1):
        for sy in (-1, 1):
            k.box_span(
                f"leg_{sx}{sy}",
                (
                    sx * W / 2 - (0.05 if sx > 0 else 0),
                    sy * k.D / 2 - (0.05 if sy > 0 else 0),
                    k.bottom + 0.05,
                ),
                (
                    sx * W / 2 + (0.05 if sx < 0 else 0),
                    sy * k.D / 2 + (0.05 if sy < 0 else 0),
                    k.bottom + stand_h,
                ),
                frame,
            )
            k.cylinder(
                f"castor_{sx}{sy}",
                0.025,
                0.05,
                (sx * (W / 2 - 0.025), sy * (k.D / 2 - 0.025), k.bottom + 0.025),
                plastic(k, "castor", (0.08, 0.08, 0.09), tile=0.1, roughness=0.9),
                axis="x",
                sections=12,
            )
    k.box_span(
        "shelf",
        (-W / 2 + 0.05, k.front + 0.05, k.bottom + 0.10),
        (W / 2 - 0.05, k.back - 0.05, k.bottom + 0.13),
        frame,
    )
    chamber_h = (k.H - stand_h) / 2
    steel = metal(k)
    dw, dh = W - 0.03, chamber_h - 0.17
    for i, nm in enumerate(("lower", "upper")):
        z_lo = k.bottom + stand_h + i * chamber_h
        z_hi = z_lo + chamber_h
        k.box_span(
            f"chamber_{nm}",
            (-W / 2, k.front + 0.05, z_lo),
            (W / 2, k.back - 0.001, z_hi - (0.005 if i == 0 else 0.0)),
            body,
        )
        door = tx.Panel.metal(dw, dh, (0.80, 0.82, 0.84), k.seed("door", nm))
        door.shade(dw / 2, dh / 2, dw - 0.03, dh - 0.03, 1.04, 4.0)  # raised centre panel
        if i == 0:
            door.paste(tx.warning("biohazard", k.seed("bio")), 0.08, dh - 0.08, 0.08, 0.08)
        else:
            door.paste(tx.warning("hot", k.seed("hot")), 0.08, dh - 0.08, 0.07, 0.07)
            door.paste(
                tx.model_plate(
                    ["CI-170  CO2 INCUBATOR", "230 V~ 50 Hz 6.5 A", "SN 22-0417-B", "IP20  MAX 55 °C"],
                    k.seed("plate"),
                ),
                0.2,
                0.12,
                0.16,
                0.08,
            )
        door.weather(k.seed("door_wear", nm), 0.4, handle=(dw / 2 + W / 2 - 0.09, 0.32))
        k.box_span(
            f"door_{nm}",
            (-W / 2 + 0.015, k.front + 0.02, z_lo + 0.02),
            (W / 2 - 0.015, k.front + 0.05, z_hi - 0.15),
            face(k, f"door_{nm}", door, roughness=0.4, metallic=0.3),
        )
        k.box_span(
            f"panel_{nm}",
            (-W / 2 + 0.015, k.front + 0.03, z_hi - 0.14),
            (W / 2 - 0.015, k.front + 0.05, z_hi - 0.02),
            plastic(k, "panel", (0.25, 0.27, 0.30), tile=0.2),
        )
        live(k, f"display_{nm}", (-0.15, k.front + 0.0295, z_hi - 0.08), 0.3, 0.09)
        k.decal(
            f"keypad_{nm}",
            tx.keypad(k.seed("keypad", nm), rows=2, cols=3, keys=("+", "-", "CO2", "MENU", "SET", "OK")),
            (0.2, k.front + 0.0295, z_hi - 0.08),
            0.16,
            0.1,
        )
        k.box_span(
            f"handle_{nm}",
            (W / 2 - 0.09, k.front, z_lo + 0.15),
            (W / 2 - 0.06, k.front + 0.02, z_hi - 0.25),
            steel,
        )
        for z in (z_lo + 0.06, z_hi - 0.2):
            k.cylinder(
                f"hinge_{nm}_{z:.2f}",
                0.013,
                0.05,
                (-W / 2 + 0.025, k.front + 0.035, z),
                metal(k, "hinge", (0.5, 0.5, 0.52)),
                sections=12,
            )
        # The inner glass door's window: culture flasks on the chamber's shelves.
        k.decal(
            f"window_{nm}",
            window(k.seed("window", nm), 256, 128, 2, back=(0.78, 0.80, 0.80)),
            (0, k.front + 0.0195, z_lo + 0.30),
            0.45,
            0.22,
        )
    live(k, "label", (0, k.front + 0.0195, k.bottom + stand_h + chamber_h - 0.30), 0.36, 0.14)
    k.decal(
        "rear_vent",
        tx.grille((0.6, 0.6, 0.62), k.seed("rear_vent"), width=256, height=128, slots=12),
        (0, k.back, k.top - 0.4),
        W - 0.2,
        0.4,
        facing="+Y",
    )


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


def cabinet(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.80, 0.81, 0.78))
    k.box_span(
        "plinth",
        (-W / 2 + 0.02, k.front + 0.06, k.bottom),
        (W / 2 - 0.02, k.back - 0.02, k.bottom + 0.08),
        plastic(k, "plinth", (0.08, 0.08, 0.09), roughness=0.9),
    )
    k.box_span("body", (-W / 2, k.front + 0.03, k.bottom + 0.08), (W / 2, k.back, k.top), body)
    steel = metal(k)
    dw, dh = W / 2 - 0.013, k.H - 0.12
    for side in (-1, 1):
        x_lo, x_hi = (-W / 2 + 0.01, -0.003) if side < 0 else (0.003, W / 2 - 0.01)
        door = tx.Panel.painted(dw, dh, (0.84, 0.85, 0.82), k.seed("door", str(side)))
        gx = dw / 2 + (-0.015 if side < 0 else 0.015)  # glazing clear of the handles at the centre seam
        w_px, h_px = tx.Panel.size_px(0.19, 0.62)
        door.shade(gx, 0.83, 0.21, 0.64, 0.6, 2.0)
        door.paste(
            window(k.seed("shelves", str(side)), w_px, h_px, 3, back=(0.9, 0.9, 0.86)), gx, 0.83, 0.19, 0.62
        )
        door.paste(
            tx.ghs("flame" if side < 0 else "exclamation", k.seed("ghs", str(side))), gx, 0.3, 0.12, 0.12
        )
        handle_x = dw - 0.015 if side < 0 else 0.015
        door.weather(k.seed("door_wear", str(side)), 0.4, handle=(handle_x, 0.885))
        k.box_span(
            f"door_{side}",
            (x_lo, k.front + 0.01, k.bottom + 0.10),
            (x_hi, k.front + 0.03, k.top - 0.02),
            face(k, f"door_{side}", door, roughness=0.45),
        )
        k.box_span(
            f"handle_{side}",
            (side * 0.02 - 0.008, k.front, 0.0 - 0.15),
            (side * 0.02 + 0.008, k.front + 0.01, 0.15),
            steel,
        )
        for z in (k.bottom + 0.2, 0.0, k.top - 0.12):
            k.cylinder(
                f"hinge_{side}_{z:.2f}",
                0.01,
                0.05,
                (side * (W / 2 - 0.012), k.front + 0.02, z),
                metal(k, "hinge", (0.4, 0.4, 0.42)),
                sections=12,
            )
        k.decal(
            f"louvre_{side}",
            tx.grille((0.78, 0.79, 0.76), k.seed("louvre", str(side)), width=128, height=144, slots=8),
            ((x_lo + x_hi) / 2, k.front + 0.0095, k.top - 0.25),
            0.18,
            0.2,
        )
    k.box_span("lock", (-0.015, k.front + 0.005, 0.2), (0.015, k.front + 0.01, 0.24), steel)
    live(k, "label", (-0.14, k.front + 0.0095, 0.45), 0.2, 0.1)
    k.decal(
        "hazard",
        tx.label(
            ["FLAMMABLE", "KEEP CLOSED", "NO IGNITION SOURCES"],
            (0.95, 0.8, 0.1),
            BLACK,
            k.seed("hazard"),
            stripe=(0.8, 0.1, 0.05),
        ),
        (0.14, k.front + 0.0095, 0.45),
        0.2,
        0.1,
    )


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


def biosafety_cabinet(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.93, 0.92, 0.86))
    frame = metal(k, "frame", (0.55, 0.57, 0.60))
    stand = 0.70
    for sx in (-1, 1):
        for sy in (-1, 1):
            x = sx * (W / 2 - 0.03)
            y = sy * (k.D / 2 - 0.03)
            k.box_span(
                f"leg_{sx}{sy}", (x - 0.03, y - 0.03, k.bottom), (x + 0.03, y + 0.03, k.bottom + stand), frame
            )
    k.box_span(
        "stand_rail",
        (-W / 2, k.front + 0.1, k.bottom + 0.15),
        (W / 2, k.front + 0.13, k.bottom + 0.19),
        frame,
    )
    z1 = k.bottom + stand
    bw, bh = W - 0.16, k.top - 0.45 - z1
    back = tx.Panel.metal(bw, bh, (0.82, 0.83, 0.84), k.seed("back"))
    back.paste(
        tx.perforated((0.80, 0.81, 0.82), k.seed("perforation"), 384, 96, pitch=7),
        bw / 2,
        0.2,
        bw - 0.04,
        0.25,
    )
    back.shade(bw / 2, bh - 0.05, bw, 0.1, 1.15, 6.0)  # the interior light's glow under the filter
    back.weather(k.seed("back_wear"), 0.3)
    # What the sash shows: the back wall above the sash's lower edge.
    seen = back.arr[: int(round(back.arr.shape[0] * (1 - 0.32 / bh)))]
    k.box_span(
        "body_back",
        (-W / 2 + 0.08, k.front + 0.22, z1),
        (W / 2 - 0.08, k.back, k.top - 0.45),
        face(k, "interior", back, roughness=0.35, metallic=0.5),
    )
    for side in (-1, 1):
        k.box_span(
            f"side_{side}",
            (side * W / 2 - (0.08 if side > 0 else 0), k.front, z1),
            (side * W / 2 + (0.08 if side < 0 else 0), k.back, k.top - 0.45),
            body,
        )
    k.box_span(
        "worktop", (-W / 2 + 0.08, k.front + 0.05, z1), (W / 2 - 0.08, k.front + 0.22, z1 + 0.12), metal(k)
    )
    k.decal(
        "front_grille",
        tx.grille((0.6, 0.62, 0.65), k.seed("front_grille"), width=512, height=32, slots=5),
        (0, k.front + 0.0495, z1 + 0.08),
        W - 0.2,
        0.06,
    )
    k.box_span(
        "armrest",
        (-W / 2 + 0.08, k.front, z1 + 0.09),
        (W / 2 - 0.08, k.front + 0.05, z1 + 0.12),
        plastic(k, "armrest", (0.2, 0.2, 0.22), tile=0.2),
    )
    k.box_span(
        "sash",
        (-W / 2 + 0.08, k.front + 0.06, z1 + 0.32),
        (W / 2 - 0.08, k.front + 0.08, k.top - 0.45),
        glazing(k, "glass", tx.to_image(seen)),
    )
    k.box_span("sash_handle", (-0.3, k.front + 0.04, z1 + 0.31), (0.3, k.front + 0.06, z1 + 0.34), metal(k))
    k.box_span("filter_housing", (-W / 2, k.front + 0.02, k.top - 0.45), (W / 2, k.back, k.top), body)
    live(k, "control_panel", (-0.25, k.front + 0.0195, k.top - 0.2), 0.5, 0.12)
    k.decal(
        "keypad",
        tx.keypad(
            k.seed("keypad"),
            rows=2,
            cols=6,
            width=192,
            keys=("LIGHT", "UV", "FAN", "+", "-", "MENU", "ALARM", "SOCKET", "SASH", "OK", "START", "STOP"),
        ),
        (0.3, k.front + 0.0195, k.top - 0.2),
        0.3,
        0.1,
    )
    live(k, "label", (-0.25, k.front + 0.0195, k.top - 0.36), 0.5, 0.14)
    k.decal(
        "biohazard",
        tx.biohazard(128, 128),
        (0.45, k.front + 0.0195, k.top - 0.36),
        0.12,
        0.12,
    )
    k.decal(
        "top_vent",
        tx.grille((0.8, 0.8, 0.78), k.seed("top_vent"), width=256, height=160, slots=14),
        (0, 0.0, k.top),
        W - 0.2,
        k.D - 0.2,
        facing="+Z",
    )


def lab_bench(k: Kit) -> None:
    top = k.material(
        "worktop",
        color=OPAQUE,
        texture=tx.epoxy((0.09, 0.10, 0.11), k.seed("worktop")),
        tile=0.5,
        roughness=0.3,
    )
    carcass = paint(k, "carcass", (0.80, 0.80, 0.77))
    drawer = k.material(
        "drawer", color=OPAQUE, texture=tx.wood((0.72, 0.60, 0.44), k.seed("drawer")), tile=0.6, roughness=0.5
    )
    k.box_span("worktop", (-k.W / 2, k.front, k.top - 0.04), (k.W / 2, k.back, k.top), top)
    k.box_span(
        "kick",
        (-k.W / 2 + 0.05, k.front + 0.08, k.bottom),
        (k.W / 2 - 0.05, k.back - 0.08, k.bottom + 0.1),
        plastic(k, "kick", (0.08, 0.08, 0.09), roughness=0.9),
    )
    k.box_span(
        "carcass",
        (-k.W / 2 + 0.02, k.front + 0.04, k.bottom + 0.1),
        (k.W / 2 - 0.02, k.back - 0.04, k.top - 0.04),
        carcass,
    )
    steel = metal(k)
    units = 8
    uw = (k.W - 0.04) / units
    for side, y_face, sgn in (("front", k.front + 0.04, -1), ("back", k.back - 0.04, 1)):
        for u in range(units):
            x0 = -k.W / 2 + 0.02 + u * uw
            rows = (0.28, 0.27) if side == "front" else (0.55,)
            z = k.bottom + 0.11
            for r, h in enumerate(rows):
                lo_y, hi_y = (y_face - 0.02, y_face) if sgn < 0 else (y_face, y_face + 0.02)
                k.box_span(
                    f"{side}_drawer_{u}_{r}",
                    (x0 + 0.01, lo_y, z),
                    (x0 + uw - 0.01, hi_y, z + h - 0.01),
                    drawer if side == "front" else carcass,
                )
                if side == "front":
                    k.cylinder(
                        f"{side}_handle_{u}_{r}",
                        0.007,
                        0.22,
                        (x0 + uw / 2, k.front + 0.012, z + h - 0.06),
                        steel,
                        axis="x",
                        sections=10,
                    )
                z += h
    live(k, "label", (0, k.front + 0.0195, k.top - 0.12), 0.4, 0.08)
    k.decal(
        "services",
        tx.label(
            ["GAS  VAC  230V", "AIR  N2   DATA"],
            (0.85, 0.85, 0.82),
            (0.3, 0.1, 0.1),
            k.seed("services"),
            width=384,
        ),
        (0, k.back - 0.0195, k.top - 0.2),
        1.2,
        0.2,
        facing="+Y",
    )


def lab_table(k: Kit) -> None:
    top = k.material(
        "worktop",
        color=OPAQUE,
        texture=tx.epoxy((0.55, 0.57, 0.58), k.seed("worktop")),
        tile=0.5,
        roughness=0.35,
    )
    frame = metal(k, "frame", (0.60, 0.62, 0.65))
    surface = k.bottom + 0.78
    k.box_span("worktop", (-k.W / 2, k.front, surface - 0.04), (k.W / 2, k.back, surface), top)
    for sx in (-1, 1):
        for sy in (-1, 1):
            x = sx * (k.W / 2 - 0.05)
            y = sy * (k.D / 2 - 0.05)
            k.box_span(
                f"leg_{sx}{sy}",
                (x - 0.025, y - 0.025, k.bottom),
                (x + 0.025, y + 0.025, surface - 0.04),
                frame,
            )
    k.box_span(
        "rail",
        (-k.W / 2 + 0.05, k.back - 0.08, k.bottom + 0.15),
        (k.W / 2 - 0.05, k.back - 0.03, k.bottom + 0.19),
        frame,
    )
    drawer = paint(k, "drawer", (0.78, 0.80, 0.82))
    for i, x in enumerate((-0.5, 0.5)):
        k.box_span(
            f"drawer_{i}",
            (x - 0.3, k.front + 0.03, surface - 0.16),
            (x + 0.3, k.front + 0.45, surface - 0.04),
            drawer,
        )
        k.box_span(
            f"drawer_handle_{i}",
            (x - 0.08, k.front + 0.015, surface - 0.11),
            (x + 0.08, k.front + 0.03, surface - 0.09),
            metal(k),
        )
    shelf = paint(k, "shelf", (0.85, 0.86, 0.84))
    for sx in (-1, 1):
        k.box_span(
            f"upright_{sx}",
            (sx * k.W / 2 - (0.04 if sx > 0 else 0), k.back - 0.25, surface),
            (sx * k.W / 2 + (0.04 if sx < 0 else 0), k.back, k.top),
            frame,
        )
    k.box_span(
        "shelf", (-k.W / 2 + 0.04, k.back - 0.25, k.top - 0.03), (k.W / 2 - 0.04, k.back, k.top), shelf
    )
    k.box_span(
        "back_panel", (-k.W / 2 + 0.04, k.back - 0.02, surface), (k.W / 2 - 0.04, k.back, k.top - 0.03), shelf
    )
    colors = [
        (0.2, 0.4, 0.85),
        (0.85, 0.3, 0.2),
        (0.3, 0.7, 0.35),
        (0.9, 0.8, 0.2),
        (0.6, 0.3, 0.7),
        (0.9, 0.9, 0.92),
    ]
    for i in range(12):
        c = colors[i % len(colors)]
        h = 0.12 + 0.03 * (i % 3)
        x = -k.W / 2 + 0.2 + i * 0.17
        k.cylinder(
            f"bottle_{i}",
            0.035,
            h,
            (x, k.back - 0.13, surface + h / 2),
            paint(k, f"bottle_{i % len(colors)}", c, tile=0.3, roughness=0.2, grain=2.0),
            sections=16,
        )
    live(k, "label", (0, k.back - 0.2505, k.top - 0.06), 0.4, 0.05)


# --- instruments added with the molecular-biology lab (issue 18 item 4) ---------------------------
def hood_display(v: Variant) -> tx.Surface:
    vel = v.pick((0.45, 0.48, 0.50, 0.52, 0.55), "velocity")
    return tx.display(
        [f"{vel:.2f} m/s", f"FACE VELOCITY OK   SASH {v.pick((40, 45, 45, 50), 'sash')} cm"],
        v.rng("display").integers(1 << 30),
        glow=(0.3, 1.0, 0.5),
        height=112,
        bars=6,
    )


def hood_label(v: Variant) -> Image.Image:
    return tx.label(
        ["CHEMICAL FUME HOOD", "WORK 15 cm INSIDE THE SASH", f"TESTED {v.date('test')}  {v.tag}"],
        WHITE,
        (0.35, 0.2, 0.05),
        v.rng("label").integers(1 << 30),
        width=352,
        height=112,
        stripe=(0.95, 0.6, 0.1),
        code=v.tag,
        age=v.wear,
    )


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


def microscope_label(v: Variant) -> Image.Image:
    return tx.label(
        [f"MICROSCOPE {v.pick(('M1', 'M2', 'M3'), 'scope')}", f"{v.tag}  SERVICED {v.date('svc')}"],
        WHITE,
        DARK,
        v.rng("label").integers(1 << 30),
        width=256,
        height=80,
        stripe=(0.2, 0.5, 0.8),
        age=v.wear,
    )


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


def fume_hood(k: Kit) -> None:
    W = k.W
    post = 0.10  # the hood's side posts
    z_base = k.bottom + 0.87  # top of the base cabinet
    z_work = z_base + 0.03  # the work surface
    z_fascia = k.top - 0.45  # the fascia with the airflow monitor
    z_duct = k.top - 0.12  # top of the hood; the exhaust collar rises above
    body = paint(k, "body", (0.90, 0.90, 0.87))
    steel = metal(k)
    k.box_span(
        "plinth",
        (-W / 2 + 0.03, k.front + 0.07, k.bottom),
        (W / 2 - 0.03, k.back - 0.02, k.bottom + 0.09),
        plastic(k, "plinth", (0.08, 0.08, 0.09), roughness=0.9),
    )
    k.box_span(
        "base_unit",
        (-W / 2, k.front + 0.04, k.bottom + 0.09),
        (W / 2, k.back, z_base),
        paint(k, "cabinet", (0.74, 0.77, 0.78)),
    )
    dw, dh = W / 2 - 0.02, z_base - k.bottom - 0.13
    for side in (-1, 1):
        door = tx.Panel.painted(dw, dh, (0.76, 0.79, 0.80), k.seed("door", str(side)))
        door.paste(
            tx.ghs("flame" if side < 0 else "exclamation", k.seed("ghs", str(side))), dw / 2, 0.5, 0.13, 0.13
        )
        door.paste(
            tx.label(
                ["FLAMMABLE LIQUIDS" if side < 0 else "ACIDS - CORROSIVE", "KEEP DOOR CLOSED"],
                (0.96, 0.82, 0.15) if side < 0 else (0.95, 0.95, 0.92),
                BLACK,
                k.seed("store", str(side)),
                width=224,
                height=80,
                stripe=(0.8, 0.1, 0.05),
            ),
            dw / 2,
            0.3,
            0.28,
            0.1,
        )
        handle_x = dw - 0.04 if side < 0 else 0.04
        door.weather(k.seed("door_wear", str(side)), 0.45, handle=(handle_x, dh - 0.08))
        x_lo, x_hi = (-W / 2 + 0.01, -0.005) if side < 0 else (0.005, W / 2 - 0.01)
        k.box_span(
            f"door_{side}",
            (x_lo, k.front + 0.02, k.bottom + 0.10),
            (x_hi, k.front + 0.04, z_base - 0.03),
            face(k, f"door_{side}", door, roughness=0.45),
        )
        hx = -0.04 if side < 0 else 0.04
        k.box_span(
            f"handle_{side}",
            (hx - 0.008, k.front + 0.005, z_base - 0.25),
            (hx + 0.008, k.front + 0.02, z_base - 0.09),
            steel,
        )
    k.box_span(
        "work_surface",
        (-W / 2, k.front + 0.02, z_base),
        (W / 2, k.back, z_work),
        k.material(
            "worktop",
            color=OPAQUE,
            texture=tx.epoxy((0.12, 0.12, 0.13), k.seed("worktop")),
            tile=0.5,
            roughness=0.3,
        ),
    )
    k.box_span(
        "airfoil",
        (-W / 2 + post, k.front + 0.01, z_work),
        (W / 2 - post, k.front + 0.08, z_work + 0.03),
        steel,
    )
    for side in (-1, 1):
        k.box_span(
            f"post_{side}",
            (side * W / 2 - (post if side > 0 else 0), k.front, z_work),
            (side * W / 2 + (post if side < 0 else 0), k.back, z_duct),
            body,
        )
    bw, bh = W - 2 * post, z_fascia - z_work
    baffle = tx.Panel.metal(bw, bh, (0.80, 0.81, 0.80), k.seed("baffle"))
    for z in (0.08, bh - 0.12):  # the baffle's exhaust slots, low and high
        baffle.paste(
            tx.grille((0.70, 0.71, 0.70), k.seed("slot", f"{z:.2f}"), 384, 32, slots=1),
            bw / 2,
            z,
            bw - 0.08,
            0.05,
        )
    baffle.shade(bw / 2, bh - 0.03, bw, 0.06, 1.15, 6.0)  # the hood light
    baffle.weather(k.seed("baffle_wear"), 0.5)
    k.box_span(
        "baffle",
        (-W / 2 + post, k.back - 0.08, z_work),
        (W / 2 - post, k.back, z_fascia),
        face(k, "baffle", baffle, roughness=0.35, metallic=0.5),
    )
    w_px, h_px = tx.Panel.size_px(bw, bh - 0.45)
    seen = tx.shelves(k.seed("inside"), w_px, h_px, 1, back=(0.80, 0.81, 0.80))
    k.box_span(
        "sash",
        (-W / 2 + post, k.front + 0.04, z_work + 0.45),
        (W / 2 - post, k.front + 0.06, z_fascia),
        glazing(k, "glass", seen, opacity=0.75),
    )
    k.box_span(
        "sash_handle",
        (-W / 2 + post, k.front + 0.02, z_work + 0.43),
        (W / 2 - post, k.front + 0.04, z_work + 0.47),
        steel,
    )
    for i, (x, h) in enumerate(((-0.3, 0.24), (-0.18, 0.18), (0.2, 0.3))):
        k.cylinder(
            f"bottle_{i}",
            0.045,
            h,
            (x, k.back - 0.25, z_work + h / 2),
            plastic(
                k, f"bottle_{i}", ((0.55, 0.35, 0.15), (0.85, 0.85, 0.88), (0.2, 0.35, 0.7))[i], tile=0.2
            ),
            sections=16,
        )
    fw, fh = W - 2 * post, z_duct - z_fascia
    fascia = tx.Panel.painted(fw, fh, (0.88, 0.88, 0.85), k.seed("fascia"))
    fascia.paste(tx.warning("general", k.seed("warn")), fw - 0.12, fh / 2, 0.12, 0.12)
    fascia.shade(0.25, fh / 2, 0.34, 0.14, 0.6, 2.0)
    fascia.weather(k.seed("fascia_wear"), 0.3)
    k.box_span(
        "fascia",
        (-W / 2 + post, k.front + 0.02, z_fascia),
        (W / 2 - post, k.back, z_duct),
        face(k, "fascia", fascia, roughness=0.5),
    )
    y_f = k.front + 0.0195
    live(k, "display", (-fw / 2 + 0.25, y_f, z_fascia + fh / 2), 0.3, 0.1)
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=1, cols=4, height=48, keys=("LIGHT", "FAN", "MUTE", "EMERG")),
        (0.0, y_f, z_fascia + fh / 2),
        0.2,
        0.06,
    )
    live(k, "label", (0.0, y_f, z_fascia + fh - 0.06), 0.36, 0.1)
    k.cylinder(
        "exhaust_collar",
        0.16,
        k.top - z_duct,
        (0.0, 0.1, (z_duct + k.top) / 2),
        metal(k, "duct", (0.6, 0.61, 0.63)),
        sections=32,
    )
    k.box_span("roof", (-W / 2 + post, k.front + 0.02, z_duct - 0.01), (W / 2 - post, k.back, z_duct), body)


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


#: the nosepiece's objectives: angle on the turret, colour-code ring (ISO 8578) and engraving
OBJECTIVES = (
    (-2.0, (0.85, 0.12, 0.10), ("4x", "0.10")),
    (0.0, (0.95, 0.80, 0.10), ("10x", "0.25")),
    (2.0, (0.45, 0.75, 0.95), ("40x", "0.65")),
)


def microscope(k: Kit) -> None:
    # Texels about as dense as the head camera's pixels from the goal (a finer tiling is averaged away).
    body = paint(k, "body", (0.88, 0.87, 0.83), tile=0.4, mottle=0.05, grain=6.0, chroma=4.0)
    # the stage, eyepiece tubes and knobs: wrinkle-finish black paint and stippled rubber
    black = paint(k, "black", (0.26, 0.26, 0.28), tile=0.4, roughness=0.6, mottle=0.12, grain=9.0, chroma=4.0)
    steel = metal(k)
    z0 = k.bottom
    k.box_span("base", (-0.10, k.front + 0.04, z0), (0.10, k.back, z0 + 0.06), body)
    bw, bh = 0.2, 0.055
    front = tx.Panel.painted(
        bw, bh, (0.50, 0.52, 0.55), k.seed("base_front"), density=900, mottle=0.06, grain=4.0, chroma=4.0
    )
    front.shade(0.16, bh / 2, 0.05, 0.04, 0.6, 1.5)
    front.paste(tx.warning("hot", k.seed("lamp_hot")), 0.105, bh / 2, 0.02, 0.02)
    front.weather(k.seed("base_wear"), 0.4, handle=(0.16, bh / 2))
    front.cut(0.05, bh / 2, 0.08, 0.035)
    k.box_span(
        "base_front",
        (-0.10, k.front + 0.02, z0),
        (0.10, k.front + 0.04, z0 + bh),
        face(k, "base_front", front),
    )
    live(k, "label", (-0.05, k.front + 0.02, z0 + bh / 2), 0.08, 0.035)
    k.decal(
        "control_dial",
        tx.intensity_scale(k.seed("lamp_scale"), 4),
        (0.06, k.front + 0.0195, z0 + bh / 2),
        0.04,
        0.02,
    )
    k.box_span("arm", (-0.05, k.back - 0.08, z0 + 0.06), (0.05, k.back, z0 + 0.36), body)
    k.box_span("head", (-0.06, k.front + 0.18, k.top - 0.10), (0.06, k.back, k.top), body)
    for sx in (-1, 1):
        k.cylinder(
            f"eyepiece_{sx}",
            0.016,
            0.16,
            (sx * 0.032, k.front + 0.02 + 0.08, k.top - 0.03),
            black,
            axis="y",
            sections=20,
        )
        k.cylinder(
            f"eyecup_{sx}",
            0.019,
            0.02,
            (sx * 0.032, k.front + 0.01, k.top - 0.03),
            paint(k, "rubber", (0.18, 0.18, 0.18), tile=0.3, roughness=0.9, mottle=0.1, grain=8.0),
            axis="y",
            sections=20,
        )
    k.cylinder("nosepiece", 0.045, 0.03, (0.0, 0.02, k.top - 0.115), steel, sections=24)
    for i, (a, ring, lines) in enumerate(OBJECTIVES):
        barrel = tx.objective_barrel(ring, lines, k.seed("objective", str(i)))
        k.cylinder(
            f"objective_{i}",
            0.011,
            0.045,
            (0.025 * math.sin(a), 0.02 - 0.025 * math.cos(a), k.top - 0.152),
            k.material(
                f"objective_{i}", color=OPAQUE, texture=barrel, tile=None, metallic=0.8, roughness=0.3
            ),
            sections=16,
        )
    k.box_span("stage", (-0.09, k.front + 0.12, z0 + 0.19), (0.09, k.back - 0.08, z0 + 0.21), black)
    k.box_span(
        "slide",
        (-0.038, k.front + 0.2, z0 + 0.21),
        (0.038, k.front + 0.226, z0 + 0.212),
        k.material("slide", color=(0.85, 0.9, 0.95, 1.0), texture=None, roughness=0.05),
    )
    k.cylinder("condenser", 0.025, 0.06, (0.0, 0.02, z0 + 0.155), black, sections=20)
    k.cylinder("field_lens", 0.028, 0.012, (0.0, 0.02, z0 + 0.066), steel, sections=20)
    k.cylinder("focus_shaft", 0.012, k.W, (0.0, k.back - 0.05, z0 + 0.14), black, axis="x", sections=16)
    for sx in (-1, 1):
        k.cylinder(
            f"focus_knob_{sx}",
            0.035,
            0.03,
            (sx * (k.W / 2 - 0.015), k.back - 0.05, z0 + 0.14),
            paint(k, "knob", (0.30, 0.30, 0.32), tile=0.3, roughness=0.7, mottle=0.1, grain=8.0),
            axis="x",
            sections=24,
        )
    k.cylinder("stage_knob", 0.012, 0.07, (0.075, 0.0, z0 + 0.15), black, sections=12)


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


# --- lab dressing: non-goal objects the generator adds on request (issue 18 item 3) -----------------
#: the safety posters a placed poster shows, one per instance (title, lines, band colour, icon)
POSTERS = (
    (
        "PPE REQUIRED",
        ["LAB COAT, GLOVES AND", "SAFETY GLASSES", "BEYOND THIS POINT"],
        (0.08, 0.32, 0.68),
        "mandatory",
    ),
    (
        "BIOHAZARD",
        ["BIOSAFETY LEVEL 2", "AUTHORISED STAFF ONLY", "NO FOOD OR DRINK"],
        (0.75, 0.1, 0.08),
        "biohazard",
    ),
    (
        "CHEMICAL SPILL?",
        ["1 ALERT OTHERS", "2 CONTAIN WITH SPILL KIT", "3 CALL SAFETY OFFICE"],
        (0.9, 0.6, 0.05),
        "warning",
    ),
    (
        "EMERGENCY",
        ["FIRE / AMBULANCE 112", "SAFETY OFFICE 5555", "FIRST AID: ROOM 1.04"],
        (0.0, 0.5, 0.3),
        "phone",
    ),
)


def poster_image(v: Variant) -> Image.Image:
    title, lines, ground, icon = v.pick(POSTERS, "poster")
    return tx.poster(
        title, [*lines, f"{v.tag}  REV {v.date('rev')}"], ground, v.rng("poster").integers(1 << 30), icon
    )


def shelving_unit(k: Kit) -> None:
    W, D = k.W, k.D
    chrome = metal(k, "chrome", (0.80, 0.81, 0.83))
    r = 0.0125
    for sx in (-1, 1):
        for sy in (-1, 1):
            k.cylinder(
                f"post_{sx}{sy}", r, k.H, (sx * (W / 2 - r), sy * (D / 2 - r), 0.0), chrome, sections=12
            )
    wire = k.material(
        "wire",
        color=OPAQUE,
        texture=tx.perforated((0.78, 0.79, 0.81), k.seed("wire"), 256, 128, pitch=10),
        tile=0.3,
        metallic=0.8,
        roughness=0.35,
    )
    rng = np.random.default_rng(k.seed("stock"))
    colours = [
        (0.2, 0.4, 0.85),
        (0.85, 0.3, 0.2),
        (0.3, 0.7, 0.35),
        (0.9, 0.8, 0.2),
        (0.92, 0.92, 0.9),
        (0.6, 0.45, 0.3),
    ]
    levels = [k.bottom + 0.15 + i * 0.44 for i in range(4)]
    for i, z in enumerate(levels):
        k.box_span(
            f"shelf_{i}", (-W / 2 + 0.02, -D / 2 + 0.02, z), (W / 2 - 0.02, D / 2 - 0.02, z + 0.02), wire
        )
        if i == len(levels) - 1:
            break
        x = -W / 2 + 0.06
        j = 0
        while x < W / 2 - 0.2:
            c = colours[int(rng.integers(len(colours)))]
            if rng.random() < 0.5:  # a bottle
                rad, h = float(rng.uniform(0.035, 0.06)), float(rng.uniform(0.15, 0.3))
                k.cylinder(
                    f"bottle_{i}_{j}",
                    rad,
                    h,
                    (x + rad, float(rng.uniform(-0.08, 0.08)), z + 0.02 + h / 2),
                    plastic(k, f"bottle_{colours.index(c)}", c, tile=0.2, roughness=0.25),
                    sections=16,
                )
                x += 2 * rad + float(rng.uniform(0.02, 0.06))
            else:  # a labelled box of consumables
                bw, bd, bh = (
                    float(rng.uniform(0.15, 0.3)),
                    float(rng.uniform(0.2, 0.35)),
                    float(rng.uniform(0.1, 0.25)),
                )
                box = tx.Panel.painted(bw, bh, (0.85, 0.78, 0.62), k.seed("box", str(i), str(j)), mottle=0.05)
                box.paste(
                    tx.label(
                        [
                            ("TIPS 200 uL", "GLOVES M", "TUBES 1.5 mL", "PLATES 96", "FILTERS")[j % 5],
                            "LOT 2231",
                        ],
                        WHITE,
                        DARK,
                        k.seed("box_label", str(i), str(j)),
                        160,
                        80,
                        stripe=c,
                    ),
                    bw / 2,
                    bh / 2,
                    bw * 0.8,
                    bh * 0.5,
                )
                k.box_span(
                    f"box_{i}_{j}",
                    (x, -bd / 2, z + 0.02),
                    (x + bw, bd / 2, z + 0.02 + bh),
                    face(k, f"box_{i}_{j}", box),
                )
                x += bw + float(rng.uniform(0.02, 0.06))
            j += 1


def lab_sink(k: Kit) -> None:
    W = k.W
    z_top = k.bottom + 0.90
    k.box_span(
        "plinth",
        (-W / 2 + 0.03, k.front + 0.06, k.bottom),
        (W / 2 - 0.03, k.back - 0.02, k.bottom + 0.10),
        plastic(k, "plinth", (0.08, 0.08, 0.09), roughness=0.9),
    )
    k.box_span(
        "base_unit",
        (-W / 2, k.front + 0.03, k.bottom + 0.10),
        (W / 2, k.back, z_top - 0.03),
        paint(k, "body", (0.82, 0.84, 0.84)),
    )
    dw, dh = W / 2 - 0.015, z_top - 0.06 - (k.bottom + 0.11)
    for side in (-1, 1):
        door = tx.Panel.painted(dw, dh, (0.84, 0.86, 0.86), k.seed("door", str(side)))
        if side < 0:
            door.paste(
                tx.label(
                    ["NO CHEMICALS", "DOWN THE DRAIN"],
                    (0.95, 0.95, 0.92),
                    (0.6, 0.05, 0.05),
                    k.seed("drain"),
                    192,
                    80,
                ),
                dw / 2,
                dh * 0.7,
                0.3,
                0.12,
            )
        door.weather(k.seed("door_wear", str(side)), 0.5, handle=(dw - 0.05 if side < 0 else 0.05, dh - 0.08))
        x_lo, x_hi = (-W / 2 + 0.01, -0.005) if side < 0 else (0.005, W / 2 - 0.01)
        k.box_span(
            f"door_{side}",
            (x_lo, k.front + 0.01, k.bottom + 0.11),
            (x_hi, k.front + 0.03, z_top - 0.05),
            face(k, f"door_{side}", door),
        )
    chrome = metal(k, "chrome", (0.85, 0.86, 0.88))
    for side in (-1, 1):
        hx = side * 0.05
        k.box_span(
            f"handle_{side}",
            (hx - 0.008, k.front + 0.0, z_top - 0.25),
            (hx + 0.008, k.front + 0.01, z_top - 0.1),
            chrome,
        )
    top = k.material(
        "worktop",
        color=OPAQUE,
        texture=tx.epoxy((0.12, 0.12, 0.13), k.seed("worktop")),
        tile=0.5,
        roughness=0.3,
    )
    k.box_span("worktop", (-W / 2, k.front, z_top - 0.03), (W / 2, k.back, z_top), top)
    k.box_span("splashback", (-W / 2, k.back - 0.02, z_top), (W / 2, k.back, k.top), top)
    basin = tx.Panel.metal(0.5, 0.36, (0.70, 0.71, 0.73), k.seed("basin"))
    basin.shade(0.25, 0.18, 0.46, 0.32, 0.55, 6.0).shade(0.25, 0.16, 0.05, 0.05, 0.2, 1.5)  # bowl and drain
    k.decal("basin", basin.image(), (0.0, -0.02, z_top + 0.0005), 0.5, 0.36, facing="+Z")
    k.cylinder("faucet", 0.014, 0.16, (0.0, k.back - 0.06, z_top + 0.08), chrome, sections=16)
    k.cylinder("spout", 0.011, 0.16, (0.0, k.back - 0.14, z_top + 0.16), chrome, axis="y", sections=16)
    for sx in (-1, 1):
        k.cylinder(f"tap_{sx}", 0.018, 0.04, (sx * 0.09, k.back - 0.06, z_top + 0.05), chrome, sections=12)
    k.decal(
        "sign",
        tx.label(["HAND WASH SINK", "WASH 20 s"], (0.9, 0.95, 1.0), (0.1, 0.3, 0.6), k.seed("sign"), 256, 80),
        (0.0, k.back - 0.0205, z_top + 0.14),
        0.3,
        0.09,
    )


def eyewash_station(k: Kit) -> None:
    W = k.W
    steel = metal(k)
    k.box_span("bracket", (-0.06, k.back - 0.02, k.bottom), (0.06, k.back, k.bottom + 0.16), steel)
    k.box_span("pipe", (-0.02, k.back - 0.14, k.bottom + 0.02), (0.02, k.back - 0.02, k.bottom + 0.05), steel)
    k.cylinder(
        "bowl",
        0.14,
        0.06,
        (0.0, k.front + 0.14, k.bottom + 0.03),
        plastic(k, "bowl", (0.95, 0.80, 0.10), tile=0.2, roughness=0.3),
        sections=40,
    )
    for sx in (-1, 1):
        k.cylinder(
            f"nozzle_{sx}",
            0.018,
            0.03,
            (sx * 0.045, k.front + 0.14, k.bottom + 0.075),
            plastic(k, "nozzle", (0.1, 0.6, 0.25), tile=0.05),
            sections=12,
        )
    k.box_span(
        "push_flag",
        (-0.06, k.front, k.bottom + 0.04),
        (0.06, k.front + 0.015, k.bottom + 0.12),
        plastic(k, "flag", (0.1, 0.6, 0.25), tile=0.1),
    )
    board = tx.Panel.painted(W, 0.3, (0.0, 0.55, 0.33), k.seed("board"), mottle=0.03)
    board.paste(tx.safety_sign("eyewash", k.seed("sign")), W / 2, 0.15, 0.26, 0.26)
    k.box_span("sign", (-W / 2, k.back - 0.01, k.top - 0.30), (W / 2, k.back, k.top), face(k, "sign", board))


def fire_extinguisher(k: Kit) -> None:
    W = k.W
    k.box_span(
        "bracket",
        (-0.05, k.back - 0.02, k.bottom + 0.05),
        (0.05, k.back, k.bottom + 0.45),
        plastic(k, "bracket", (0.15, 0.15, 0.16), tile=0.1, roughness=0.6),
    )
    half = math.pi * 0.08
    shell = tx.Panel.painted(half, 0.48, (0.80, 0.06, 0.05), k.seed("shell"), density=400, mottle=0.04)
    shell.paste(
        tx.label(
            ["FOAM  9 L", "CLASS A B", "SERVICED"],
            (0.97, 0.95, 0.88),
            BLACK,
            k.seed("instructions"),
            128,
            160,
        ),
        half * 0.5,
        0.24,
        half * 0.8,
        0.22,
    )
    shell.weather(k.seed("shell_wear"), 0.4)
    k.cylinder(
        "body",
        0.08,
        0.48,
        (0.0, k.front + 0.08, k.bottom + 0.24),
        face(k, "shell", shell, roughness=0.3),
        sections=32,
    )
    chrome = metal(k, "chrome", (0.85, 0.86, 0.88))
    k.cylinder("valve", 0.03, 0.06, (0.0, k.front + 0.08, k.bottom + 0.51), chrome, sections=16)
    k.box_span(
        "lever", (-0.015, k.front + 0.02, k.bottom + 0.54), (0.015, k.front + 0.12, k.bottom + 0.56), chrome
    )
    k.cylinder(
        "hose",
        0.01,
        0.4,
        (0.09, k.front + 0.08, k.bottom + 0.3),
        plastic(k, "hose", (0.08, 0.08, 0.09), tile=0.05, roughness=0.8),
        sections=10,
    )
    board = tx.Panel.painted(W, 0.3, (0.80, 0.08, 0.08), k.seed("board"), mottle=0.03)
    board.paste(tx.safety_sign("extinguisher", k.seed("sign")), W / 2, 0.15, 0.26, 0.26)
    k.box_span("sign", (-W / 2, k.back - 0.01, k.top - 0.30), (W / 2, k.back, k.top), face(k, "sign", board))


def safety_poster(k: Kit) -> None:
    k.box_span(
        "board",
        (-k.W / 2, k.front + 0.004, k.bottom),
        (k.W / 2, k.back, k.top),
        paint(k, "board", (0.93, 0.93, 0.91)),
    )
    live(k, "poster", (0.0, k.front, 0.0), k.W - 0.02, k.H - 0.02)
    for sx in (-1, 1):
        for sz in (-1, 1):
            k.cylinder(
                f"pin_{sx}{sz}",
                0.006,
                0.004,
                (sx * (k.W / 2 - 0.02), k.front + 0.002, sz * (k.H / 2 - 0.02)),
                metal(k, "pin", (0.7, 0.7, 0.72)),
                axis="y",
                sections=8,
            )


def lab_stool(k: Kit) -> None:
    W = k.W
    chrome = metal(k, "chrome", (0.80, 0.81, 0.83))
    base = plastic(k, "base", (0.12, 0.12, 0.13), tile=0.2, roughness=0.5)
    r = 0.025
    k.box_span("leg_x", (-W / 2 + r, -0.02, k.bottom + 0.045), (W / 2 - r, 0.02, k.bottom + 0.075), base)
    k.box_span("leg_y", (-0.02, -W / 2 + r, k.bottom + 0.045), (0.02, W / 2 - r, k.bottom + 0.075), base)
    castor = plastic(k, "castor", (0.06, 0.06, 0.07), tile=0.05, roughness=0.8)
    for i, (x, y, axis) in enumerate(
        ((W / 2 - r, 0.0, "y"), (-W / 2 + r, 0.0, "y"), (0.0, W / 2 - r, "x"), (0.0, -W / 2 + r, "x"))
    ):
        k.cylinder(f"castor_{i}", r, 0.02, (x, y, k.bottom + r), castor, axis=axis, sections=12)
    k.cylinder(
        "column", 0.03, k.H - 0.16, (0.0, 0.0, k.bottom + 0.075 + (k.H - 0.16) / 2), chrome, sections=16
    )
    for i, (lo, hi) in enumerate(
        (
            ((-0.17, -0.17), (0.17, -0.15)),
            ((-0.17, 0.15), (0.17, 0.17)),
            ((-0.17, -0.15), (-0.15, 0.15)),
            ((0.15, -0.15), (0.17, 0.15)),
        )
    ):
        k.box_span(
            f"foot_ring_{i}", (lo[0], lo[1], k.bottom + 0.32), (hi[0], hi[1], k.bottom + 0.335), chrome
        )
    seat = k.material(
        "seat",
        color=OPAQUE,
        texture=tx.plastic((0.10, 0.22, 0.42), k.seed("seat")),
        tile=0.15,
        roughness=0.7,
        normal=tx.peel_normal(k.seed("peel")),
    )
    k.cylinder("seat", 0.2, 0.07, (0.0, 0.0, k.top - 0.035), seat, sections=40, top_uv=True)
    k.cylinder("lever", 0.008, 0.1, (0.14, 0.0, k.top - 0.09), chrome, axis="x", sections=8)


def lab_trolley(k: Kit) -> None:
    W, D = k.W, k.D
    steel = metal(k)
    for i, z in enumerate((k.bottom + 0.16, k.bottom + 0.49, k.top - 0.16)):
        k.box_span(f"shelf_{i}", (-W / 2 + 0.05, -D / 2, z), (W / 2, D / 2, z + 0.025), steel)
        k.box_span(f"lip_{i}", (-W / 2 + 0.05, -D / 2, z + 0.025), (W / 2, -D / 2 + 0.01, z + 0.045), steel)
    for sx in (-1, 1):
        for sy in (-1, 1):
            x = W / 2 - 0.02 if sx > 0 else -W / 2 + 0.07
            k.box_span(
                f"post_{sx}{sy}",
                (x - 0.02, sy * (D / 2 - 0.02) - 0.02, k.bottom + 0.08),
                (x + 0.02, sy * (D / 2 - 0.02) + 0.02, k.top - 0.13),
                steel,
            )
            k.cylinder(
                f"castor_{sx}{sy}",
                0.04,
                0.03,
                (x - sx * 0.025, sy * (D / 2 - 0.04), k.bottom + 0.04),
                plastic(k, "castor", (0.08, 0.08, 0.09), tile=0.05, roughness=0.9),
                axis="y",
                sections=16,
            )
    grip = plastic(k, "grip", (0.1, 0.1, 0.11), tile=0.1, roughness=0.7)
    for sy in (-1, 1):
        k.box_span(
            f"handle_post_{sy}",
            (-W / 2, sy * (D / 2 - 0.06) - 0.012, k.top - 0.2),
            (-W / 2 + 0.025, sy * (D / 2 - 0.06) + 0.012, k.top - 0.02),
            steel,
        )
    k.box_span("handle", (-W / 2, -D / 2 + 0.04, k.top - 0.03), (-W / 2 + 0.03, D / 2 - 0.04, k.top), grip)
    gloves = tx.Panel.painted(0.25, 0.12, (0.3, 0.45, 0.85), k.seed("gloves"), mottle=0.04)
    gloves.paste(
        tx.label(["NITRILE GLOVES", "SIZE M  100"], WHITE, DARK, k.seed("gloves_label"), 160, 64),
        0.125,
        0.06,
        0.2,
        0.08,
    )
    z_mid = k.bottom + 0.515
    k.box_span("gloves", (-0.3, -0.12, z_mid), (-0.05, 0.0, z_mid + 0.12), face(k, "gloves", gloves))
    k.box_span(
        "sharps_container",
        (0.1, -0.1, z_mid),
        (0.3, 0.1, z_mid + 0.22),
        plastic(k, "sharps", (0.95, 0.8, 0.1), tile=0.1, roughness=0.4),
    )
    z_top = k.top - 0.135
    k.box_span(
        "tube_rack",
        (-0.2, -0.08, z_top),
        (0.1, 0.06, z_top + 0.06),
        plastic(k, "rack", (0.3, 0.7, 0.4), tile=0.1, roughness=0.4),
    )


def glassware_rack(k: Kit) -> None:
    W, D = k.W, k.D
    k.box_span(
        "tray",
        (-W / 2, -D / 2 + 0.001, k.bottom),
        (W / 2, D / 2, k.bottom + 0.02),
        plastic(k, "tray", (0.9, 0.9, 0.88), tile=0.2, roughness=0.4),
    )
    glass = k.material("glass", color=(0.80, 0.88, 0.92, 1.0), texture=None, roughness=0.05, metallic=0.1)
    z0 = k.bottom + 0.02
    for i, (x, y, r, h) in enumerate(
        ((-0.16, -0.07, 0.045, 0.12), (-0.06, -0.08, 0.035, 0.09), (-0.15, 0.07, 0.05, 0.14))
    ):
        k.cylinder(f"beaker_{i}", r, h, (x, y, z0 + h / 2), glass, sections=20)
    k.cylinder("flask", 0.06, 0.08, (0.03, 0.06, z0 + 0.04), glass, sections=20)
    k.cylinder("flask_neck", 0.017, 0.1, (0.03, 0.06, z0 + 0.13), glass, sections=12)
    media = plastic(k, "media", (0.93, 0.88, 0.55), tile=0.1, roughness=0.2)
    k.cylinder("media_bottle", 0.045, 0.24, (0.16, 0.06, z0 + 0.12), media, sections=20)
    k.cylinder(
        "cap",
        0.03,
        k.top - (z0 + 0.24),
        (0.16, 0.06, (z0 + 0.24 + k.top) / 2),
        plastic(k, "cap", (0.1, 0.3, 0.8), tile=0.05),
        sections=16,
    )
    k.box_span(
        "tube_rack",
        (0.06, -0.13, z0),
        (0.21, -0.03, z0 + 0.05),
        plastic(k, "rack", (0.95, 0.5, 0.1), tile=0.1),
    )
    for j in range(5):
        k.cylinder(f"tube_{j}", 0.007, 0.1, (0.075 + j * 0.03, -0.08, z0 + 0.07), glass, sections=10)
    k.decal(
        "label",
        tx.label(["DRYING RACK", "RINSE x3 DI WATER"], WHITE, DARK, k.seed("label"), 192, 64),
        (0.0, -D / 2, k.bottom + 0.01),
        0.16,
        0.018,
    )


# --- room shell -----------------------------------------------------------------------------------
def wall_panel(k: Kit) -> None:
    wall = coat(k, "wall", (0.86, 0.87, 0.84), amount=5, tile=0.5)
    k.box_span("wall", (-k.W / 2, k.front, k.bottom), (k.W / 2, k.back, k.top), wall)


def floor_tile(k: Kit) -> None:
    vinyl = k.material(
        "vinyl", texture=tx.floor_vinyl((0.55, 0.60, 0.58), k.seed("vinyl")), tile=0.5, roughness=0.7
    )
    k.box_span("floor", (-k.W / 2, k.front, k.bottom), (k.W / 2, k.back, k.top), vinyl)


def ceiling_tile(k: Kit) -> None:
    tile = k.material(
        "ceiling", texture=tx.floor_vinyl((0.93, 0.93, 0.92), k.seed("ceiling")), tile=0.6, roughness=0.9
    )
    k.box_span("ceiling", (-k.W / 2, k.front, k.bottom), (k.W / 2, k.back, k.top), tile)


def door_frame(k: Kit) -> None:
    frame = coat(k, "frame", (0.45, 0.50, 0.58), amount=8)
    k.box_span("jamb_l", (-k.W / 2, k.front, k.bottom), (-k.W / 2 + 0.08, k.back, k.top), frame)
    k.box_span("jamb_r", (k.W / 2 - 0.08, k.front, k.bottom), (k.W / 2, k.back, k.top), frame)
    k.box_span("header", (-k.W / 2, k.front, k.top - 0.1), (k.W / 2, k.back, k.top), frame)
    k.box_span(
        "threshold",
        (-k.W / 2 + 0.08, k.front, k.bottom),
        (k.W / 2 - 0.08, k.back, k.bottom + 0.005),
        plain(k, "threshold", (0.5, 0.5, 0.5), 0.4),
    )


BUILDERS: dict[str, Callable[[Kit], None]] = {
    f.__name__: f
    for f in (
        refrigerator,
        incubator,
        centrifuge,
        mini_centrifuge,
        pipette,
        cabinet,
        waste_bin,
        biosafety_cabinet,
        lab_bench,
        lab_table,
        fume_hood,
        ultra_low_freezer,
        autoclave,
        thermal_cycler,
        microscope,
        water_bath,
        shaker,
        shelving_unit,
        lab_sink,
        eyewash_station,
        fire_extinguisher,
        safety_poster,
        lab_stool,
        lab_trolley,
        glassware_rack,
        wall_panel,
        floor_tile,
        ceiling_tile,
        door_frame,
    )
}

#: per category, the decals drawn per instance (by decal name): variant -> picture
LIVE_DECALS: dict[str, dict[str, Callable[[Variant], Image.Image | tx.Surface]]] = {
    "refrigerator": {"display": fridge_display, "label": fridge_label},
    "incubator": {
        "display_lower": lambda v: incubator_display(v, "lower"),
        "display_upper": lambda v: incubator_display(v, "upper"),
        "label": incubator_label,
    },
    "centrifuge": {"display": centrifuge_display, "label": centrifuge_label},
    "mini_centrifuge": {"display": mini_display, "label": mini_label},
    "pipette": {"label": pipette_label},
    "cabinet": {"label": cabinet_label},
    "waste_bin": {"label": bin_label},
    "biosafety_cabinet": {"control_panel": bsc_display, "label": bsc_label},
    "lab_bench": {"label": bench_label},
    "lab_table": {"label": table_label},
    "fume_hood": {"display": hood_display, "label": hood_label},
    "ultra_low_freezer": {"display": ult_display, "label": ult_label},
    "autoclave": {"display": autoclave_display, "label": autoclave_label},
    "thermal_cycler": {"display": cycler_display, "label": cycler_label},
    "microscope": {"label": microscope_label},
    "water_bath": {"display": bath_display, "label": bath_label},
    "shaker": {"display": shaker_display, "label": shaker_label},
    "safety_poster": {"poster": poster_image},
}
