"""The lab table (paper Tables 2 and 6): a work table with a reagent shelf at the back and a shelf label
drawn per instance; table-top instruments stand on it."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import OPAQUE, WHITE, instrument, live, metal, paint
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


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


@instrument("lab_table", live_decals={"label": table_label})
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
