"""Lab dressing: a lab stool (never a goal)."""

from __future__ import annotations

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import OPAQUE, instrument, metal, plastic
from biovln_ms.assetgen.parts import Kit


@instrument("lab_stool")
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
