"""The CO2 incubator (paper Table 2): two stacked chambers, each door with its own display of
temperature, CO2 and humidity drawn per instance."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import WHITE, face, instrument, live, metal, paint, plastic, window
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


def incubator_display(v: Variant, chamber: str) -> tx.Surface:
    t = v.pick((37.0, 37.0, 36.5, 37.5), "temp", chamber)
    co2 = v.pick((5.0, 5.0, 5.0, 7.5, 2.0), "co2", chamber)
    rh = v.pick((93, 95, 95, 96), "rh", chamber)
    return tx.display(
        [f"{t:.1f} °C", f"CO2 {co2:.1f}%   RH {rh}%", f"DOOR CLOSED  {chamber.upper()}"],
        v.rng("display", chamber).integers(1 << 30),
        glow=(1.0, 0.55, 0.2),
        height=112,
        bars=5,
    )


def incubator_label(v: Variant) -> Image.Image:
    return tx.label(
        ["CO2 INCUBATOR CI-170", "37 °C  5% CO2  95% RH", f"{v.tag}  DECON {v.date('decon')}"],
        WHITE,
        (0.5, 0.1, 0.1),
        v.rng("label").integers(1 << 30),
        width=320,
        height=128,
        stripe=(0.85, 0.2, 0.15),
        code=v.tag,
        age=v.wear,
    )


@instrument(
    "incubator",
    live_decals={
        "display_lower": lambda v: incubator_display(v, "lower"),
        "display_upper": lambda v: incubator_display(v, "upper"),
        "label": incubator_label,
    },
)
def incubator(k: Kit) -> None:
    W = k.W
    body = paint(k, "body", (0.88, 0.89, 0.87))
    frame = metal(k, "frame", (0.45, 0.47, 0.50))
    stand_h = 0.35
    for sx in (-1, 1):
        for sy in (-1, 1):
            k.box_span(
                f"leg_{sx}{sy}",
                (
                    sx * W / 2 - (0.05 if sx > 0 else 0),
                    sy * k.D / 2 - (0.05 if sy > 0 else 0),
                    k.bottom + 0.05,
                ),
                (
                    sx * W / 2 + (0.05 if sx < 0 else 0),
                    sy * k.D / 2 + (0.05 if sy < 0 else 0),
                    k.bottom + stand_h,
                ),
                frame,
            )
            k.cylinder(
                f"castor_{sx}{sy}",
                0.025,
                0.05,
                (sx * (W / 2 - 0.025), sy * (k.D / 2 - 0.025), k.bottom + 0.025),
                plastic(k, "castor", (0.08, 0.08, 0.09), tile=0.1, roughness=0.9),
                axis="x",
                sections=12,
            )
    k.box_span(
        "shelf",
        (-W / 2 + 0.05, k.front + 0.05, k.bottom + 0.10),
        (W / 2 - 0.05, k.back - 0.05, k.bottom + 0.13),
        frame,
    )
    chamber_h = (k.H - stand_h) / 2
    steel = metal(k)
    dw, dh = W - 0.03, chamber_h - 0.17
    for i, nm in enumerate(("lower", "upper")):
        z_lo = k.bottom + stand_h + i * chamber_h
        z_hi = z_lo + chamber_h
        k.box_span(
            f"chamber_{nm}",
            (-W / 2, k.front + 0.05, z_lo),
            (W / 2, k.back - 0.001, z_hi - (0.005 if i == 0 else 0.0)),
            body,
        )
        door = tx.Panel.metal(dw, dh, (0.80, 0.82, 0.84), k.seed("door", nm))
        door.shade(dw / 2, dh / 2, dw - 0.03, dh - 0.03, 1.04, 4.0)  # raised centre panel
        if i == 0:
            door.paste(tx.warning("biohazard", k.seed("bio")), 0.08, dh - 0.08, 0.08, 0.08)
        else:
            door.paste(tx.warning("hot", k.seed("hot")), 0.08, dh - 0.08, 0.07, 0.07)
            door.paste(
                tx.model_plate(
                    ["CI-170  CO2 INCUBATOR", "230 V~ 50 Hz 6.5 A", "SN 22-0417-B", "IP20  MAX 55 °C"],
                    k.seed("plate"),
                ),
                0.2,
                0.12,
                0.16,
                0.08,
            )
        door.weather(k.seed("door_wear", nm), 0.4, handle=(dw / 2 + W / 2 - 0.09, 0.32))
        k.box_span(
            f"door_{nm}",
            (-W / 2 + 0.015, k.front + 0.02, z_lo + 0.02),
            (W / 2 - 0.015, k.front + 0.05, z_hi - 0.15),
            face(k, f"door_{nm}", door, roughness=0.4, metallic=0.3),
        )
        k.box_span(
            f"panel_{nm}",
            (-W / 2 + 0.015, k.front + 0.03, z_hi - 0.14),
            (W / 2 - 0.015, k.front + 0.05, z_hi - 0.02),
            plastic(k, "panel", (0.25, 0.27, 0.30), tile=0.2),
        )
        live(k, f"display_{nm}", (-0.15, k.front + 0.0295, z_hi - 0.08), 0.3, 0.09)
        k.decal(
            f"keypad_{nm}",
            tx.keypad(k.seed("keypad", nm), rows=2, cols=3, keys=("+", "-", "CO2", "MENU", "SET", "OK")),
            (0.2, k.front + 0.0295, z_hi - 0.08),
            0.16,
            0.1,
        )
        k.box_span(
            f"handle_{nm}",
            (W / 2 - 0.09, k.front, z_lo + 0.15),
            (W / 2 - 0.06, k.front + 0.02, z_hi - 0.25),
            steel,
        )
        for z in (z_lo + 0.06, z_hi - 0.2):
            k.cylinder(
                f"hinge_{nm}_{z:.2f}",
                0.013,
                0.05,
                (-W / 2 + 0.025, k.front + 0.035, z),
                metal(k, "hinge", (0.5, 0.5, 0.52)),
                sections=12,
            )
        # The inner glass door's window: culture flasks on the chamber's shelves.
        k.decal(
            f"window_{nm}",
            window(k.seed("window", nm), 256, 128, 2, back=(0.78, 0.80, 0.80)),
            (0, k.front + 0.0195, z_lo + 0.30),
            0.45,
            0.22,
        )
    live(k, "label", (0, k.front + 0.0195, k.bottom + stand_h + chamber_h - 0.30), 0.36, 0.14)
    k.decal(
        "rear_vent",
        tx.grille((0.6, 0.6, 0.62), k.seed("rear_vent"), width=256, height=128, slots=12),
        (0, k.back, k.top - 0.4),
        W - 0.2,
        0.4,
        facing="+Y",
    )
