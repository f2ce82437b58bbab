"""The Class II biosafety cabinet (paper Table 8): a see-through sash over the work area, an airflow
control panel and a certification label drawn per instance."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import WHITE, face, glazing, instrument, live, metal, paint, plastic
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def bsc_display(v: Variant) -> tx.Surface:
    inflow = v.pick((0.45, 0.48, 0.50, 0.52), "inflow")
    down = v.pick((0.30, 0.33, 0.35), "down")
    return tx.display(
        ["AIRFLOW OK", f"INFLOW {inflow:.2f} m/s  DOWN {down:.2f} m/s", "UV OFF   LIGHT ON   FAN 1"],
        v.rng("display").integers(1 << 30),
        glow=(0.3, 1.0, 0.5),
        width=384,
        height=112,
        bars=8,
    )


def bsc_label(v: Variant) -> Image.Image:
    return tx.label(
        ["BIOSAFETY CABINET", "CLASS II  TYPE A2", f"CERTIFIED {v.date('cert')}  {v.tag}"],
        WHITE,
        (0.1, 0.3, 0.2),
        v.rng("label").integers(1 << 30),
        width=384,
        height=112,
        stripe=(0.1, 0.6, 0.3),
        code=v.tag,
        age=v.wear,
    )


@instrument("biosafety_cabinet", live_decals={"control_panel": bsc_display, "label": bsc_label})
def biosafety_cabinet(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.93, 0.92, 0.86))
    frame = metal(k, "frame", (0.55, 0.57, 0.60))
    stand = 0.70
    for sx in (-1, 1):
        for sy in (-1, 1):
            x = sx * (W / 2 - 0.03)
            y = sy * (k.D / 2 - 0.03)
            k.box_span(
                f"leg_{sx}{sy}", (x - 0.03, y - 0.03, k.bottom), (x + 0.03, y + 0.03, k.bottom + stand), frame
            )
    k.box_span(
        "stand_rail",
        (-W / 2, k.front + 0.1, k.bottom + 0.15),
        (W / 2, k.front + 0.13, k.bottom + 0.19),
        frame,
    )
    z1 = k.bottom + stand
    bw, bh = W - 0.16, k.top - 0.45 - z1
    back = tx.Panel.metal(bw, bh, (0.82, 0.83, 0.84), k.seed("back"))
    back.paste(
        tx.perforated((0.80, 0.81, 0.82), k.seed("perforation"), 384, 96, pitch=7),
        bw / 2,
        0.2,
        bw - 0.04,
        0.25,
    )
    back.shade(bw / 2, bh - 0.05, bw, 0.1, 1.15, 6.0)  # the interior light's glow under the filter
    back.weather(k.seed("back_wear"), 0.3)
    # What the sash shows: the back wall above the sash's lower edge.
    seen = back.arr[: int(round(back.arr.shape[0] * (1 - 0.32 / bh)))]
    k.box_span(
        "body_back",
        (-W / 2 + 0.08, k.front + 0.22, z1),
        (W / 2 - 0.08, k.back, k.top - 0.45),
        face(k, "interior", back, roughness=0.35, metallic=0.5),
    )
    for side in (-1, 1):
        k.box_span(
            f"side_{side}",
            (side * W / 2 - (0.08 if side > 0 else 0), k.front, z1),
            (side * W / 2 + (0.08 if side < 0 else 0), k.back, k.top - 0.45),
            body,
        )
    k.box_span(
        "worktop", (-W / 2 + 0.08, k.front + 0.05, z1), (W / 2 - 0.08, k.front + 0.22, z1 + 0.12), metal(k)
    )
    k.decal(
        "front_grille",
        tx.grille((0.6, 0.62, 0.65), k.seed("front_grille"), width=512, height=32, slots=5),
        (0, k.front + 0.0495, z1 + 0.08),
        W - 0.2,
        0.06,
    )
    k.box_span(
        "armrest",
        (-W / 2 + 0.08, k.front, z1 + 0.09),
        (W / 2 - 0.08, k.front + 0.05, z1 + 0.12),
        plastic(k, "armrest", (0.2, 0.2, 0.22), tile=0.2),
    )
    k.box_span(
        "sash",
        (-W / 2 + 0.08, k.front + 0.06, z1 + 0.32),
        (W / 2 - 0.08, k.front + 0.08, k.top - 0.45),
        glazing(k, "glass", tx.to_image(seen)),
    )
    k.box_span("sash_handle", (-0.3, k.front + 0.04, z1 + 0.31), (0.3, k.front + 0.06, z1 + 0.34), metal(k))
    k.box_span("filter_housing", (-W / 2, k.front + 0.02, k.top - 0.45), (W / 2, k.back, k.top), body)
    live(k, "control_panel", (-0.25, k.front + 0.0195, k.top - 0.2), 0.5, 0.12)
    k.decal(
        "keypad",
        tx.keypad(
            k.seed("keypad"),
            rows=2,
            cols=6,
            width=192,
            keys=("LIGHT", "UV", "FAN", "+", "-", "MENU", "ALARM", "SOCKET", "SASH", "OK", "START", "STOP"),
        ),
        (0.3, k.front + 0.0195, k.top - 0.2),
        0.3,
        0.1,
    )
    live(k, "label", (-0.25, k.front + 0.0195, k.top - 0.36), 0.5, 0.14)
    k.decal(
        "biohazard",
        tx.biohazard(128, 128),
        (0.45, k.front + 0.0195, k.top - 0.36),
        0.12,
        0.12,
    )
    k.decal(
        "top_vent",
        tx.grille((0.8, 0.8, 0.78), k.seed("top_vent"), width=256, height=160, slots=14),
        (0, 0.0, k.top),
        W - 0.2,
        k.D - 0.2,
        facing="+Z",
    )
