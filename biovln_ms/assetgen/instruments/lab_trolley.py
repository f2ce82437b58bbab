"""Lab dressing: a lab trolley (never a goal)."""

from __future__ import annotations

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import DARK, WHITE, face, instrument, metal, plastic
from biovln_ms.assetgen.parts import Kit


@instrument("lab_trolley")
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
