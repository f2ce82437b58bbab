"""Lab dressing: a lab sink on its base unit (never a goal)."""

from __future__ import annotations

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import OPAQUE, face, instrument, metal, paint, plastic
from biovln_ms.assetgen.parts import Kit


@instrument("lab_sink")
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
