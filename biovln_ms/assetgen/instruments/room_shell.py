"""The room-shell pieces (wall panel, floor tile, ceiling tile, door frame): plain slabs with
powder-coat and vinyl textures."""

from __future__ import annotations

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.instruments._kit import coat, instrument, plain
from biovln_ms.assetgen.parts import Kit


@instrument("wall_panel")
def wall_panel(k: Kit) -> None:
    wall = coat(k, "wall", (0.86, 0.87, 0.84), amount=5, tile=0.5)
    k.box_span("wall", (-k.W / 2, k.front, k.bottom), (k.W / 2, k.back, k.top), wall)


@instrument("floor_tile")
def floor_tile(k: Kit) -> None:
    vinyl = k.material(
        "vinyl", texture=tx.floor_vinyl((0.55, 0.60, 0.58), k.seed("vinyl")), tile=0.5, roughness=0.7
    )
    k.box_span("floor", (-k.W / 2, k.front, k.bottom), (k.W / 2, k.back, k.top), vinyl)


@instrument("ceiling_tile")
def ceiling_tile(k: Kit) -> None:
    tile = k.material(
        "ceiling", texture=tx.floor_vinyl((0.93, 0.93, 0.92), k.seed("ceiling")), tile=0.6, roughness=0.9
    )
    k.box_span("ceiling", (-k.W / 2, k.front, k.bottom), (k.W / 2, k.back, k.top), tile)


@instrument("door_frame")
def door_frame(k: Kit) -> None:
    frame = coat(k, "frame", (0.45, 0.50, 0.58), amount=8)
    k.box_span("jamb_l", (-k.W / 2, k.front, k.bottom), (-k.W / 2 + 0.08, k.back, k.top), frame)
    k.box_span("jamb_r", (k.W / 2 - 0.08, k.front, k.bottom), (k.W / 2, k.back, k.top), frame)
    k.box_span("header", (-k.W / 2, k.front, k.top - 0.1), (k.W / 2, k.back, k.top), frame)
    k.box_span(
        "threshold",
        (-k.W / 2 + 0.08, k.front, k.bottom),
        (k.W / 2 - 0.08, k.back, k.bottom + 0.005),
        plain(k, "threshold", (0.5, 0.5, 0.5), 0.4),
    )
