"""Lab dressing: a wire shelving unit (never a goal)."""

from __future__ import annotations

import numpy as np

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import DARK, OPAQUE, WHITE, face, instrument, metal, plastic
from biovln_ms.assetgen.parts import Kit


@instrument("shelving_unit")
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
