"""The storage cabinet (paper Table 2): glazed doors showing shelves of bottles and a chemical-storage
label drawn per instance."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import BLACK, face, instrument, live, metal, paint, plastic, window
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


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


@instrument("cabinet", live_decals={"label": cabinet_label})
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
