"""Lab dressing: a fire extinguisher on its bracket (never a goal)."""

from __future__ import annotations

import math

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import BLACK, face, instrument, metal, plastic
from biovln_ms.assetgen.parts import Kit


@instrument("fire_extinguisher")
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
