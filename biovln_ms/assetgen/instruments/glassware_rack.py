"""Lab dressing: a drying tray with glassware (never a goal)."""

from __future__ import annotations

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import DARK, WHITE, instrument, plastic
from biovln_ms.assetgen.parts import Kit


@instrument("glassware_rack")
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
