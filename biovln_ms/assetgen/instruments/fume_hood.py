"""The fume hood (beyond the paper: a 4-ft bench hood on its base cabinet): a glazed sash, a face-velocity
display and a label drawn per instance."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import (
    BLACK,
    OPAQUE,
    WHITE,
    face,
    glazing,
    instrument,
    live,
    metal,
    paint,
    plastic,
)
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def hood_display(v: Variant) -> tx.Surface:
    vel = v.pick((0.45, 0.48, 0.50, 0.52, 0.55), "velocity")
    return tx.display(
        [f"{vel:.2f} m/s", f"FACE VELOCITY OK   SASH {v.pick((40, 45, 45, 50), 'sash')} cm"],
        v.rng("display").integers(1 << 30),
        glow=(0.3, 1.0, 0.5),
        height=112,
        bars=6,
    )


def hood_label(v: Variant) -> Image.Image:
    return tx.label(
        ["CHEMICAL FUME HOOD", "WORK 15 cm INSIDE THE SASH", f"TESTED {v.date('test')}  {v.tag}"],
        WHITE,
        (0.35, 0.2, 0.05),
        v.rng("label").integers(1 << 30),
        width=352,
        height=112,
        stripe=(0.95, 0.6, 0.1),
        code=v.tag,
        age=v.wear,
    )


@instrument("fume_hood", live_decals={"display": hood_display, "label": hood_label})
def fume_hood(k: Kit) -> None:
    W = k.W
    post = 0.10  # the hood's side posts
    z_base = k.bottom + 0.87  # top of the base cabinet
    z_work = z_base + 0.03  # the work surface
    z_fascia = k.top - 0.45  # the fascia with the airflow monitor
    z_duct = k.top - 0.12  # top of the hood; the exhaust collar rises above
    body = paint(k, "body", (0.90, 0.90, 0.87))
    steel = metal(k)
    k.box_span(
        "plinth",
        (-W / 2 + 0.03, k.front + 0.07, k.bottom),
        (W / 2 - 0.03, k.back - 0.02, k.bottom + 0.09),
        plastic(k, "plinth", (0.08, 0.08, 0.09), roughness=0.9),
    )
    k.box_span(
        "base_unit",
        (-W / 2, k.front + 0.04, k.bottom + 0.09),
        (W / 2, k.back, z_base),
        paint(k, "cabinet", (0.74, 0.77, 0.78)),
    )
    dw, dh = W / 2 - 0.02, z_base - k.bottom - 0.13
    for side in (-1, 1):
        door = tx.Panel.painted(dw, dh, (0.76, 0.79, 0.80), k.seed("door", str(side)))
        door.paste(
            tx.ghs("flame" if side < 0 else "exclamation", k.seed("ghs", str(side))), dw / 2, 0.5, 0.13, 0.13
        )
        door.paste(
            tx.label(
                ["FLAMMABLE LIQUIDS" if side < 0 else "ACIDS - CORROSIVE", "KEEP DOOR CLOSED"],
                (0.96, 0.82, 0.15) if side < 0 else (0.95, 0.95, 0.92),
                BLACK,
                k.seed("store", str(side)),
                width=224,
                height=80,
                stripe=(0.8, 0.1, 0.05),
            ),
            dw / 2,
            0.3,
            0.28,
            0.1,
        )
        handle_x = dw - 0.04 if side < 0 else 0.04
        door.weather(k.seed("door_wear", str(side)), 0.45, handle=(handle_x, dh - 0.08))
        x_lo, x_hi = (-W / 2 + 0.01, -0.005) if side < 0 else (0.005, W / 2 - 0.01)
        k.box_span(
            f"door_{side}",
            (x_lo, k.front + 0.02, k.bottom + 0.10),
            (x_hi, k.front + 0.04, z_base - 0.03),
            face(k, f"door_{side}", door, roughness=0.45),
        )
        hx = -0.04 if side < 0 else 0.04
        k.box_span(
            f"handle_{side}",
            (hx - 0.008, k.front + 0.005, z_base - 0.25),
            (hx + 0.008, k.front + 0.02, z_base - 0.09),
            steel,
        )
    k.box_span(
        "work_surface",
        (-W / 2, k.front + 0.02, z_base),
        (W / 2, k.back, z_work),
        k.material(
            "worktop",
            color=OPAQUE,
            texture=tx.epoxy((0.12, 0.12, 0.13), k.seed("worktop")),
            tile=0.5,
            roughness=0.3,
        ),
    )
    k.box_span(
        "airfoil",
        (-W / 2 + post, k.front + 0.01, z_work),
        (W / 2 - post, k.front + 0.08, z_work + 0.03),
        steel,
    )
    for side in (-1, 1):
        k.box_span(
            f"post_{side}",
            (side * W / 2 - (post if side > 0 else 0), k.front, z_work),
            (side * W / 2 + (post if side < 0 else 0), k.back, z_duct),
            body,
        )
    bw, bh = W - 2 * post, z_fascia - z_work
    baffle = tx.Panel.metal(bw, bh, (0.80, 0.81, 0.80), k.seed("baffle"))
    for z in (0.08, bh - 0.12):  # the baffle's exhaust slots, low and high
        baffle.paste(
            tx.grille((0.70, 0.71, 0.70), k.seed("slot", f"{z:.2f}"), 384, 32, slots=1),
            bw / 2,
            z,
            bw - 0.08,
            0.05,
        )
    baffle.shade(bw / 2, bh - 0.03, bw, 0.06, 1.15, 6.0)  # the hood light
    baffle.weather(k.seed("baffle_wear"), 0.5)
    k.box_span(
        "baffle",
        (-W / 2 + post, k.back - 0.08, z_work),
        (W / 2 - post, k.back, z_fascia),
        face(k, "baffle", baffle, roughness=0.35, metallic=0.5),
    )
    w_px, h_px = tx.Panel.size_px(bw, bh - 0.45)
    seen = tx.shelves(k.seed("inside"), w_px, h_px, 1, back=(0.80, 0.81, 0.80))
    k.box_span(
        "sash",
        (-W / 2 + post, k.front + 0.04, z_work + 0.45),
        (W / 2 - post, k.front + 0.06, z_fascia),
        glazing(k, "glass", seen, opacity=0.75),
    )
    k.box_span(
        "sash_handle",
        (-W / 2 + post, k.front + 0.02, z_work + 0.43),
        (W / 2 - post, k.front + 0.04, z_work + 0.47),
        steel,
    )
    for i, (x, h) in enumerate(((-0.3, 0.24), (-0.18, 0.18), (0.2, 0.3))):
        k.cylinder(
            f"bottle_{i}",
            0.045,
            h,
            (x, k.back - 0.25, z_work + h / 2),
            plastic(
                k, f"bottle_{i}", ((0.55, 0.35, 0.15), (0.85, 0.85, 0.88), (0.2, 0.35, 0.7))[i], tile=0.2
            ),
            sections=16,
        )
    fw, fh = W - 2 * post, z_duct - z_fascia
    fascia = tx.Panel.painted(fw, fh, (0.88, 0.88, 0.85), k.seed("fascia"))
    fascia.paste(tx.warning("general", k.seed("warn")), fw - 0.12, fh / 2, 0.12, 0.12)
    fascia.shade(0.25, fh / 2, 0.34, 0.14, 0.6, 2.0)
    fascia.weather(k.seed("fascia_wear"), 0.3)
    k.box_span(
        "fascia",
        (-W / 2 + post, k.front + 0.02, z_fascia),
        (W / 2 - post, k.back, z_duct),
        face(k, "fascia", fascia, roughness=0.5),
    )
    y_f = k.front + 0.0195
    live(k, "display", (-fw / 2 + 0.25, y_f, z_fascia + fh / 2), 0.3, 0.1)
    k.decal(
        "keypad",
        tx.keypad(k.seed("keypad"), rows=1, cols=4, height=48, keys=("LIGHT", "FAN", "MUTE", "EMERG")),
        (0.0, y_f, z_fascia + fh / 2),
        0.2,
        0.06,
    )
    live(k, "label", (0.0, y_f, z_fascia + fh - 0.06), 0.36, 0.1)
    k.cylinder(
        "exhaust_collar",
        0.16,
        k.top - z_duct,
        (0.0, 0.1, (z_duct + k.top) / 2),
        metal(k, "duct", (0.6, 0.61, 0.63)),
        sections=32,
    )
    k.box_span("roof", (-W / 2 + post, k.front + 0.02, z_duct - 0.01), (W / 2 - post, k.back, z_duct), body)
