"""The lab bench (paper Tables 2 and 6): a long work surface on drawer units, with a bench label drawn
per instance; table-top instruments stand on it."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import OPAQUE, WHITE, instrument, live, metal, paint, plastic
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def bench_label(v: Variant) -> Image.Image:
    return tx.label(
        [f"BENCH {v.pick('ABCDEF', 'bench')}  NO FOOD OR DRINK", v.tag],
        WHITE,
        (0.1, 0.1, 0.4),
        v.rng("label").integers(1 << 30),
        width=320,
        height=64,
        age=v.wear,
    )


@instrument("lab_bench", live_decals={"label": bench_label})
def lab_bench(k: Kit) -> None:
    top = k.material(
        "worktop",
        color=OPAQUE,
        texture=tx.epoxy((0.09, 0.10, 0.11), k.seed("worktop")),
        tile=0.5,
        roughness=0.3,
    )
    carcass = paint(k, "carcass", (0.80, 0.80, 0.77))
    drawer = k.material(
        "drawer", color=OPAQUE, texture=tx.wood((0.72, 0.60, 0.44), k.seed("drawer")), tile=0.6, roughness=0.5
    )
    k.box_span("worktop", (-k.W / 2, k.front, k.top - 0.04), (k.W / 2, k.back, k.top), top)
    k.box_span(
        "kick",
        (-k.W / 2 + 0.05, k.front + 0.08, k.bottom),
        (k.W / 2 - 0.05, k.back - 0.08, k.bottom + 0.1),
        plastic(k, "kick", (0.08, 0.08, 0.09), roughness=0.9),
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
    live(k, "label", (0, k.front + 0.0195, k.top - 0.12), 0.4, 0.08)
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
