"""Lab dressing: a wall safety poster, its picture drawn per instance from :data:`POSTERS` (never a
goal)."""

from __future__ import annotations

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import instrument, live, metal, paint
from biovln_ms.assetgen.parts import Kit
from biovln_ms.assetgen.variation import Variant


#: the safety posters a placed poster shows, one per instance (title, lines, band colour, icon)
POSTERS = (
    (
        "PPE REQUIRED",
        ["LAB COAT, GLOVES AND", "SAFETY GLASSES", "BEYOND THIS POINT"],
        (0.08, 0.32, 0.68),
        "mandatory",
    ),
    (
        "BIOHAZARD",
        ["BIOSAFETY LEVEL 2", "AUTHORISED STAFF ONLY", "NO FOOD OR DRINK"],
        (0.75, 0.1, 0.08),
        "biohazard",
    ),
    (
        "CHEMICAL SPILL?",
        ["1 ALERT OTHERS", "2 CONTAIN WITH SPILL KIT", "3 CALL SAFETY OFFICE"],
        (0.9, 0.6, 0.05),
        "warning",
    ),
    (
        "EMERGENCY",
        ["FIRE / AMBULANCE 112", "SAFETY OFFICE 5555", "FIRST AID: ROOM 1.04"],
        (0.0, 0.5, 0.3),
        "phone",
    ),
)


def poster_image(v: Variant) -> Image.Image:
    title, lines, ground, icon = v.pick(POSTERS, "poster")
    return tx.poster(
        title, [*lines, f"{v.tag}  REV {v.date('rev')}"], ground, v.rng("poster").integers(1 << 30), icon
    )


@instrument("safety_poster", live_decals={"poster": poster_image})
def safety_poster(k: Kit) -> None:
    k.box_span(
        "board",
        (-k.W / 2, k.front + 0.004, k.bottom),
        (k.W / 2, k.back, k.top),
        paint(k, "board", (0.93, 0.93, 0.91)),
    )
    live(k, "poster", (0.0, k.front, 0.0), k.W - 0.02, k.H - 0.02)
    for sx in (-1, 1):
        for sz in (-1, 1):
            k.cylinder(
                f"pin_{sx}{sz}",
                0.006,
                0.004,
                (sx * (k.W / 2 - 0.02), k.front + 0.002, sz * (k.H / 2 - 0.02)),
                metal(k, "pin", (0.7, 0.7, 0.72)),
                axis="y",
                sections=8,
            )
