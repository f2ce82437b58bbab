"""One builder per catalog asset and room-shell piece, in the canonical frame of ``parts.Kit``.

Every builder keeps all parts inside the asset's bounding box and lets the body touch all six
sides, so the generated GLB's bounds equal the catalog dimensions (Table 2). The operational face
(canonical -Y) carries the door, handle, display or keypad, so front and back can be told apart.
"""

from __future__ import annotations

from typing import Callable

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.parts import Kit, Material

WHITE = (0.90, 0.91, 0.90)
STEEL = (0.72, 0.74, 0.76)
DARK = (0.16, 0.17, 0.19)
BLACK = (0.06, 0.06, 0.07)


def paint(
    k: Kit, key: str, color: tuple[float, float, float], amount: float = 10.0, tile: float = 0.25
) -> Material:
    return k.material(key, texture=tx.powder_coat(color, k.seed(key), amount=amount), tile=tile)


def metal(k: Kit, key: str = "steel", color: tuple[float, float, float] = STEEL) -> Material:
    return k.material(
        key, texture=tx.brushed_metal(color, k.seed(key)), tile=0.15, metallic=0.8, roughness=0.35
    )


def plain(k: Kit, key: str, color: tuple[float, float, float], roughness: float = 0.5) -> Material:
    return k.material(key, color=(*color, 1.0), texture=None, roughness=roughness)


def feet(k: Kit, height: float, inset: float, radius: float = 0.022) -> None:
    mat = plain(k, "rubber", BLACK, roughness=0.9)
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


def refrigerator(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", WHITE)
    door = paint(k, "door", (0.93, 0.94, 0.95), amount=6)
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
    # Two doors: freezer above, fridge below.
    split = k.top - 0.55
    k.box_span(
        "door_freezer",
        (-W / 2 + 0.01, k.front + 0.015, split + 0.01),
        (W / 2 - 0.01, k.front + 0.04, k.top - 0.01),
        door,
    )
    k.box_span(
        "door_fridge",
        (-W / 2 + 0.01, k.front + 0.015, z0 + 0.09),
        (W / 2 - 0.01, k.front + 0.04, split - 0.01),
        door,
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
    hinge = plain(k, "hinge", (0.5, 0.5, 0.52), roughness=0.3)
    for z in (k.top - 0.03, split + 0.02, split - 0.03, z0 + 0.1):
        k.cylinder(f"hinge_{z:.2f}", 0.012, 0.04, (-W / 2 + 0.02, k.front + 0.02, z), hinge, sections=12)
    k.decal(
        "display",
        tx.display("+4.0 C", k.seed("display"), glow=(0.4, 0.8, 1.0)),
        (-0.1, k.front + 0.0145, split + 0.38),
        0.22,
        0.08,
    )
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=1, cols=4, height=40),
        (-0.1, k.front + 0.0145, split + 0.30),
        0.22,
        0.06,
    )
    k.decal(
        "label",
        tx.label(
            ["REFRIGERATOR", "2-8 C  LAB USE"],
            WHITE,
            (0.1, 0.2, 0.5),
            k.seed("label"),
            stripe=(0.1, 0.3, 0.8),
        ),
        (-0.15, k.front + 0.0145, split - 0.25),
        0.3,
        0.15,
    )
    k.decal(
        "vent",
        tx.grille((0.5, 0.52, 0.55), k.seed("vent"), slots=6),
        (0, k.front + 0.039, z0 + 0.045),
        W - 0.1,
        0.07,
    )


def incubator(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.88, 0.89, 0.87))
    door = paint(k, "door", (0.80, 0.82, 0.84), amount=7)
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
                plain(k, "castor", BLACK, 0.9),
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
    for i, nm in enumerate(("lower", "upper")):
        z_lo = k.bottom + stand_h + i * chamber_h
        z_hi = z_lo + chamber_h
        k.box_span(
            f"chamber_{nm}",
            (-W / 2, k.front + 0.05, z_lo),
            (W / 2, k.back - 0.001, z_hi - (0.005 if i == 0 else 0.0)),
            body,
        )
        k.box_span(
            f"door_{nm}",
            (-W / 2 + 0.015, k.front + 0.02, z_lo + 0.02),
            (W / 2 - 0.015, k.front + 0.05, z_hi - 0.15),
            door,
        )
        k.box_span(
            f"panel_{nm}",
            (-W / 2 + 0.015, k.front + 0.03, z_hi - 0.14),
            (W / 2 - 0.015, k.front + 0.05, z_hi - 0.02),
            plain(k, "panel", (0.25, 0.27, 0.30)),
        )
        k.decal(
            f"display_{nm}",
            tx.display(f"37.0C {5 + i}.0%", k.seed("display", nm), glow=(1.0, 0.55, 0.2)),
            (-0.15, k.front + 0.0295, z_hi - 0.08),
            0.3,
            0.09,
        )
        k.decal(
            f"keypad_{nm}",
            tx.keypad(k.seed("keypad", nm), rows=2, cols=3),
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
                plain(k, "hinge", (0.5, 0.5, 0.52), 0.3),
                sections=12,
            )
        k.decal(
            f"window_{nm}",
            tx.label(
                ["CHAMBER " + ("B" if i else "A"), "CO2 5%  RH 95%"],
                (0.75, 0.85, 0.9),
                DARK,
                k.seed("window", nm),
            ),
            (0, k.front + 0.0195, z_lo + 0.30),
            0.45,
            0.22,
        )
    k.decal(
        "label",
        tx.label(
            ["CO2 INCUBATOR", "37 C"], WHITE, (0.5, 0.1, 0.1), k.seed("label"), stripe=(0.85, 0.2, 0.15)
        ),
        (0, k.front + 0.0195, k.bottom + stand_h + chamber_h - 0.30),
        0.36,
        0.14,
    )
    k.decal(
        "rear_vent",
        tx.grille((0.6, 0.6, 0.62), k.seed("rear_vent"), slots=12),
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
    console = paint(k, "console", (0.20, 0.30, 0.55), amount=8)
    k.box_span(
        "console", (-W / 2 + 0.01, k.front, z0 + 0.02), (W / 2 - 0.01, k.front + 0.06, z0 + 0.28), console
    )
    k.decal(
        "display",
        tx.display("4500 rpm", k.seed("display"), glow=(0.3, 1.0, 0.4)),
        (0, k.front, z0 + 0.22),
        0.3,
        0.07,
    )
    k.decal("keypad", tx.keypad(k.seed("keypad"), rows=2, cols=5), (0, k.front, z0 + 0.11), 0.32, 0.12)
    k.decal(
        "label",
        tx.label(["CENTRIFUGE", "MAX 4700 x g"], WHITE, (0.15, 0.2, 0.45), k.seed("label")),
        (0, k.front + 0.0595, z0 + 0.36),
        0.3,
        0.1,
    )
    lid = paint(k, "lid", (0.30, 0.45, 0.80), amount=8)
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
    k.decal(
        "rotor_window",
        tx.label(["ROTOR", "LOCKED"], (0.7, 0.8, 0.95), DARK, k.seed("window"), width=128, height=128),
        (0, k.front + 0.06 + ry, k.top),
        0.16,
        0.16,
        facing="+Z",
    )
    k.box_span(
        "lid_handle",
        (-0.08, k.front + 0.035, z_lid),
        (0.08, k.front + 0.06, z_lid + 0.03),
        plain(k, "handle", DARK),
    )
    k.decal(
        "rear_vent",
        tx.grille((0.6, 0.6, 0.62), k.seed("rear_vent"), slots=8),
        (0, k.back, z0 + 0.2),
        W - 0.1,
        0.25,
        facing="+Y",
    )


def mini_centrifuge(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.94, 0.94, 0.92), amount=7)
    feet(k, 0.015, 0.05, radius=0.02)
    z0 = k.bottom + 0.015
    z_lid = k.bottom + 0.25
    k.box_span("body", (-W / 2, k.front + 0.08, z0), (W / 2, k.back, z_lid), body)
    console = paint(k, "console", (0.35, 0.36, 0.40), amount=8)
    k.box_span("console", (-W / 2 + 0.02, k.front, z0), (W / 2 - 0.02, k.front + 0.08, z0 + 0.16), console)
    k.decal(
        "display",
        tx.display("13000 rpm", k.seed("display"), glow=(0.4, 0.9, 1.0)),
        (-0.08, k.front, z0 + 0.11),
        0.26,
        0.07,
    )
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=1, cols=4, height=48),
        (0.14, k.front, z0 + 0.11),
        0.16,
        0.05,
    )
    k.decal(
        "label",
        tx.label(["MINI CENTRIFUGE"], WHITE, (0.3, 0.3, 0.35), k.seed("label"), height=64),
        (0, k.front, z0 + 0.04),
        0.34,
        0.06,
    )
    lid = k.material(
        "lid",
        color=(0.45, 0.65, 0.95, 1.0),
        texture=tx.powder_coat((0.45, 0.65, 0.95), k.seed("lid"), amount=5),
        tile=0.2,
        roughness=0.15,
    )
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
        plain(k, "rotor", (0.75, 0.75, 0.78), 0.3),
        sections=32,
    )
    k.box_span(
        "hinge", (-0.12, k.back - 0.03, z_lid - 0.02), (0.12, k.back, z_lid + 0.03), plain(k, "hinge", DARK)
    )


def pipette(k: Kit) -> None:
    base = paint(k, "base", (0.30, 0.32, 0.36), amount=8)
    k.box_span("base", (-k.W / 2, k.front, k.bottom), (k.W / 2, k.back, k.bottom + 0.015), base)
    k.box_span(
        "column", (-k.W / 2 + 0.005, k.back - 0.03, k.bottom + 0.015), (k.W / 2 - 0.005, k.back, k.top), base
    )
    k.box_span(
        "arm",
        (-k.W / 2 + 0.008, k.front + 0.04, k.top - 0.025),
        (k.W / 2 - 0.008, k.back - 0.03, k.top - 0.005),
        paint(k, "arm", (0.85, 0.3, 0.2), amount=8),
    )
    y_p = k.front + 0.06
    body = paint(k, "pipette", (0.88, 0.88, 0.86), amount=6, tile=0.05)
    k.cylinder("pipette_body", 0.016, 0.13, (0, y_p, k.top - 0.11), body, sections=20)
    k.cylinder(
        "plunger", 0.008, 0.04, (0, y_p, k.top - 0.025), plain(k, "plunger", (0.15, 0.35, 0.9)), sections=16
    )
    k.cylinder("shaft", 0.007, 0.06, (0, y_p, k.top - 0.205), body, sections=16)
    k.cylinder(
        "tip", 0.004, 0.035, (0, y_p, k.top - 0.2525), plain(k, "tip", (0.95, 0.85, 0.2), 0.3), sections=12
    )
    k.decal(
        "volume",
        tx.display("200 uL", k.seed("volume"), glow=(0.1, 0.1, 0.1), height=64),
        (0, y_p - 0.0165, k.top - 0.09),
        0.03,
        0.015,
    )
    k.decal(
        "label",
        tx.label(["P200"], WHITE, DARK, k.seed("label"), width=64, height=64),
        (0, k.back - 0.0305, k.bottom + 0.12),
        0.028,
        0.028,
    )


def cabinet(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.62, 0.64, 0.60))
    door = paint(k, "door", (0.70, 0.72, 0.68), amount=7)
    k.box_span(
        "plinth",
        (-W / 2 + 0.02, k.front + 0.06, k.bottom),
        (W / 2 - 0.02, k.back - 0.02, k.bottom + 0.08),
        plain(k, "plinth", BLACK, 0.9),
    )
    k.box_span("body", (-W / 2, k.front + 0.03, k.bottom + 0.08), (W / 2, k.back, k.top), body)
    steel = metal(k)
    for side in (-1, 1):
        x_lo, x_hi = (-W / 2 + 0.01, -0.003) if side < 0 else (0.003, W / 2 - 0.01)
        k.box_span(
            f"door_{side}",
            (x_lo, k.front + 0.01, k.bottom + 0.10),
            (x_hi, k.front + 0.03, k.top - 0.02),
            door,
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
                plain(k, "hinge", (0.4, 0.4, 0.42), 0.3),
                sections=12,
            )
        k.decal(
            f"louvre_{side}",
            tx.grille((0.55, 0.57, 0.53), k.seed("louvre", str(side)), slots=8),
            ((x_lo + x_hi) / 2, k.front + 0.0095, k.top - 0.25),
            0.18,
            0.2,
        )
    k.box_span("lock", (-0.015, k.front + 0.005, 0.2), (0.015, k.front + 0.01, 0.24), steel)
    k.decal(
        "label",
        tx.label(
            ["CHEMICAL", "STORAGE"],
            (0.95, 0.95, 0.9),
            (0.6, 0.1, 0.05),
            k.seed("label"),
            stripe=(0.9, 0.5, 0.1),
        ),
        (-0.14, k.front + 0.0095, 0.45),
        0.2,
        0.1,
    )
    k.decal(
        "hazard",
        tx.label(["FLAMMABLE", "KEEP CLOSED"], (0.95, 0.8, 0.1), BLACK, k.seed("hazard")),
        (0.14, k.front + 0.0095, 0.45),
        0.2,
        0.1,
    )


def waste_bin(k: Kit) -> None:
    W = k.W
    ry = (k.D - 0.05) / 2
    yc = k.front + 0.05 + ry
    body = paint(k, "body", (0.95, 0.78, 0.10), amount=9, tile=0.15)
    k.cylinder(
        "base_ring",
        1.0,
        0.03,
        (0, yc, k.bottom + 0.015),
        plain(k, "ring", BLACK, 0.9),
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
        paint(k, "lid", (0.12, 0.12, 0.13), amount=6),
        sections=40,
        scale_xy=(W / 2, ry),
    )
    k.box_span("pedal", (-0.07, k.front, k.bottom), (0.07, k.front + 0.06, k.bottom + 0.03), metal(k))
    k.box_span(
        "hinge", (-0.06, k.back - 0.015, k.top - 0.06), (0.06, k.back, k.top - 0.03), plain(k, "hinge", DARK)
    )
    k.decal("biohazard", tx.biohazard(k.seed("biohazard")), (0, yc - ry + 0.004, 0.02), 0.15, 0.15)
    k.decal(
        "label",
        tx.label(["BIOHAZARD", "WASTE"], (0.98, 0.98, 0.95), (0.7, 0.05, 0.05), k.seed("label"), height=96),
        (0, yc - ry + 0.012, k.bottom + 0.12),
        0.14,
        0.06,
    )


def biosafety_cabinet(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.93, 0.92, 0.86), amount=8)
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
    k.box_span("body_back", (-W / 2 + 0.08, k.front + 0.22, z1), (W / 2 - 0.08, k.back, k.top - 0.45), body)
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
        tx.grille((0.6, 0.62, 0.65), k.seed("front_grille"), slots=5),
        (0, k.front + 0.0495, z1 + 0.08),
        W - 0.2,
        0.06,
    )
    k.box_span(
        "armrest",
        (-W / 2 + 0.08, k.front, z1 + 0.09),
        (W / 2 - 0.08, k.front + 0.05, z1 + 0.12),
        plain(k, "armrest", (0.2, 0.2, 0.22)),
    )
    glass = k.material(
        "glass",
        color=(0.55, 0.75, 0.85, 1.0),
        texture=tx.powder_coat((0.55, 0.72, 0.82), k.seed("glass"), amount=4),
        tile=0.5,
        roughness=0.05,
        metallic=0.1,
    )
    k.box_span(
        "sash",
        (-W / 2 + 0.08, k.front + 0.06, z1 + 0.32),
        (W / 2 - 0.08, k.front + 0.08, k.top - 0.45),
        glass,
    )
    k.box_span("sash_handle", (-0.3, k.front + 0.04, z1 + 0.31), (0.3, k.front + 0.06, z1 + 0.34), metal(k))
    k.box_span("filter_housing", (-W / 2, k.front + 0.02, k.top - 0.45), (W / 2, k.back, k.top), body)
    k.decal(
        "control_panel",
        tx.display("AIRFLOW OK 0.45m/s", k.seed("display"), glow=(0.3, 1.0, 0.5), width=384),
        (-0.25, k.front + 0.0195, k.top - 0.2),
        0.5,
        0.12,
    )
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=2, cols=6, width=192),
        (0.3, k.front + 0.0195, k.top - 0.2),
        0.3,
        0.1,
    )
    k.decal(
        "label",
        tx.label(
            ["BIOSAFETY CABINET", "CLASS II  A2"],
            WHITE,
            (0.1, 0.3, 0.2),
            k.seed("label"),
            stripe=(0.1, 0.6, 0.3),
            width=384,
        ),
        (-0.25, k.front + 0.0195, k.top - 0.36),
        0.5,
        0.14,
    )
    k.decal(
        "biohazard", tx.biohazard(k.seed("biohazard")), (0.45, k.front + 0.0195, k.top - 0.36), 0.12, 0.12
    )
    k.decal(
        "top_vent",
        tx.grille((0.8, 0.8, 0.78), k.seed("top_vent"), slots=14),
        (0, 0.0, k.top),
        W - 0.2,
        k.D - 0.2,
        facing="+Z",
    )


def lab_bench(k: Kit) -> None:
    top = k.material(
        "worktop", texture=tx.speckled_epoxy((0.09, 0.10, 0.11), k.seed("worktop")), tile=0.3, roughness=0.3
    )
    carcass = paint(k, "carcass", (0.80, 0.80, 0.77), amount=8)
    drawer = k.material("drawer", texture=tx.wood_grain((0.72, 0.60, 0.44), k.seed("drawer")), tile=0.4)
    k.box_span("worktop", (-k.W / 2, k.front, k.top - 0.04), (k.W / 2, k.back, k.top), top)
    k.box_span(
        "kick",
        (-k.W / 2 + 0.05, k.front + 0.08, k.bottom),
        (k.W / 2 - 0.05, k.back - 0.08, k.bottom + 0.1),
        plain(k, "kick", BLACK, 0.9),
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
    k.decal(
        "label",
        tx.label(["BENCH A", "NO FOOD OR DRINK"], WHITE, (0.1, 0.1, 0.4), k.seed("label")),
        (0, k.front + 0.0195, k.top - 0.12),
        0.4,
        0.08,
    )
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
        "worktop", texture=tx.speckled_epoxy((0.55, 0.57, 0.58), k.seed("worktop")), tile=0.3, roughness=0.35
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
    drawer = paint(k, "drawer", (0.78, 0.80, 0.82), amount=7)
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
    shelf = paint(k, "shelf", (0.85, 0.86, 0.84), amount=7)
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
            plain(k, f"bottle_{i % len(colors)}", c, 0.2),
            sections=16,
        )
    k.decal(
        "label",
        tx.label(["REAGENT SHELF", "LABEL ALL BOTTLES"], WHITE, (0.1, 0.3, 0.1), k.seed("label")),
        (0, k.back - 0.2505, k.top - 0.06),
        0.4,
        0.05,
    )


# --- room shell ---------------------------------------------------------------------------------
def wall_panel(k: Kit) -> None:
    wall = paint(k, "wall", (0.86, 0.87, 0.84), amount=5, tile=0.5)
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
    frame = paint(k, "frame", (0.45, 0.50, 0.58), amount=8)
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
        wall_panel,
        floor_tile,
        ceiling_tile,
        door_frame,
    )
}
