"""Lab dressing: an eyewash station with its sign (never a goal)."""

from __future__ import annotations

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import face, instrument, metal, plastic
from biovln_ms.assetgen.parts import Kit


@instrument("eyewash_station")
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
