"""What every instrument builder shares: the registry its ``@instrument`` decorator fills, the palette,
the materials (powder coat, brushed steel, moulded plastic, panel pictures, glass), feet, glazed-door views
and the live decals as the shipped asset shows them.

The registry maps a catalog name to its builder (a function drawing the asset into a ``parts.Kit``) and
its live decals: the decals redrawn per placed instance (asset tag, setpoints, dates) from a
:class:`~biovln_ms.assetgen.variation.Variant`. The builders draw them for
:data:`~biovln_ms.assetgen.variation.SHIPPED`, the simulator again for each instance's variant. This module
imports no builder: each builder module imports it and registers itself.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from PIL import Image

from biovln_ms.assetgen import textures as tx
from biovln_ms.assetgen.parts import Kit, Material
from biovln_ms.assetgen.variation import SHIPPED, Variant
from biovln_ms.errors import AssetError

Builder = Callable[[Kit], None]
#: a live decal: the instance's variant -> its picture (a plain image, or a surface with emission)
Decal = Callable[[Variant], "Image.Image | tx.Surface"]


@dataclass(frozen=True)
class Registered:
    """One registered asset: its catalog name, builder and live decals (decal name -> drawing)."""

    name: str
    build: Builder
    live_decals: Mapping[str, Decal]


#: catalog name -> its registration, filled by :func:`instrument` as the builder modules are imported
REGISTRY: dict[str, Registered] = {}


def instrument(name: str, live_decals: Mapping[str, Decal] | None = None) -> Callable[[Builder], Builder]:
    """Register the decorated function as the builder of the catalog asset ``name`` (its GLB is
    ``assets/<name>.glb``), with the decals drawn per instance. A second builder for a name is refused;
    the same function registered again (its module reloaded) replaces the first."""

    def register(build: Builder) -> Builder:
        old = REGISTRY.get(name)
        if old is not None and _origin(old.build) != _origin(build):
            raise AssetError(
                f"'{name}' already has a builder ({'.'.join(_origin(old.build))})",
                field="name",
                fix="give the new instrument its own catalog name",
            )
        REGISTRY[name] = Registered(name, build, MappingProxyType(dict(live_decals or {})))
        return build

    return register


def unregister(name: str) -> None:
    """Remove ``name`` from the registry (a builder registered for a while, as tests do)."""
    REGISTRY.pop(name, None)


def _origin(f: Callable) -> tuple[str, str]:
    return f.__module__, f.__qualname__


class _View(Mapping):
    """A read-only mapping over :data:`REGISTRY`: name -> one field of its registration (names whose
    field is empty left out)."""

    def __init__(self, pick: Callable[[Registered], Any]) -> None:
        self._pick = pick

    def __getitem__(self, name: str) -> Any:
        value = self._pick(REGISTRY[name])
        if not value:
            raise KeyError(name)
        return value

    def __iter__(self) -> Iterator[str]:
        return (n for n, r in REGISTRY.items() if self._pick(r))

    def __len__(self) -> int:
        return sum(1 for _ in self)


#: catalog name -> builder
BUILDERS: Mapping[str, Builder] = _View(lambda r: r.build)
#: catalog name -> its live decals (decal name -> drawing); assets without any are left out
LIVE_DECALS: Mapping[str, Mapping[str, Decal]] = _View(lambda r: r.live_decals)


WHITE = (0.90, 0.91, 0.90)
STEEL = (0.72, 0.74, 0.76)
DARK = (0.16, 0.17, 0.19)
BLACK = (0.06, 0.06, 0.07)
OPAQUE = (1.0, 1.0, 1.0, 1.0)  # base colour factor of textured materials (the texture is the colour)


# --- materials ------------------------------------------------------------------------------------
def coat(
    k: Kit, key: str, color: tuple[float, float, float], amount: float = 10.0, tile: float = 0.25
) -> Material:
    """Powder coat without a normal map: the room-shell pieces' look."""
    return k.material(key, texture=tx.powder_coat(color, k.seed(key), amount=amount), tile=tile)


def paint(
    k: Kit, key: str, color: tuple[float, float, float], tile: float = 0.5, roughness: float = 0.55, **kw
) -> Material:
    """Tiling powder coat with orange peel (one normal map shared by the asset's painted parts)."""
    return k.material(
        key,
        color=OPAQUE,
        texture=tx.paint(color, k.seed(key), **kw),
        normal=tx.peel_normal(k.seed("peel")),
        tile=tile,
        roughness=roughness,
    )


def metal(k: Kit, key: str = "steel", color: tuple[float, float, float] = STEEL) -> Material:
    s = tx.brushed(color, k.seed(key))
    return k.material(
        key, color=OPAQUE, texture=s.albedo, normal=s.normal, tile=0.3, metallic=0.85, roughness=0.35
    )


def plastic(
    k: Kit, key: str, color: tuple[float, float, float], tile: float = 0.3, roughness: float = 0.4
) -> Material:
    return k.material(
        key,
        color=OPAQUE,
        texture=tx.plastic(color, k.seed(key)),
        normal=tx.peel_normal(k.seed("peel")),
        tile=tile,
        roughness=roughness,
    )


def plain(k: Kit, key: str, color: tuple[float, float, float], roughness: float = 0.5) -> Material:
    return k.material(key, color=(*color, 1.0), texture=None, roughness=roughness)


def face(k: Kit, key: str, panel: tx.Panel, roughness: float = 0.5, metallic: float = 0.0) -> Material:
    """A door or panel with its own picture of its -Y face (not tiled; the other faces continue its edges)."""
    return k.material(
        f"art_{key}",
        color=OPAQUE,
        texture=panel.image(),
        tile=None,
        face=True,
        roughness=roughness,
        metallic=metallic,
    )


def glazing(k: Kit, key: str, behind: Image.Image, opacity: float = 0.8) -> Material:
    """A see-through glass pane (RGBA texture, glTF alphaMode BLEND) with reflections, showing ``behind``."""
    return k.material(
        key,
        color=OPAQUE,
        texture=tx.behind_glass(behind, k.seed(key), (0.70, 0.82, 0.86), 0.3, opacity),
        tile=None,
        roughness=0.05,
        metallic=0.1,
    )


def live(
    k: Kit,
    name: str,
    center: tuple[float, float, float],
    width: float,
    height: float,
    facing: str = "-Y",
) -> None:
    """A decal of :data:`LIVE_DECALS` as the shipped asset shows it."""
    k.decal(name, LIVE_DECALS[k.name][name](SHIPPED), center, width, height, facing)


def feet(k: Kit, height: float, inset: float, radius: float = 0.022) -> None:
    mat = plastic(k, "rubber", (0.08, 0.08, 0.09), tile=0.1, roughness=0.9)
    for sx in (-1, 1):
        for sy in (-1, 1):
            k.cylinder(
                f"foot_{sx}{sy}",
                radius,
                height,
                (sx * (k.W / 2 - inset), sy * (k.D / 2 - inset), k.bottom + height / 2),
                mat,
                sections=16,
            )


def window(seed: int, w_px: int, h_px: int, rows: int, back=(0.85, 0.87, 0.88)) -> Image.Image:
    """A glazed door's view: shelves with bottles behind tinted, reflecting glass."""
    return tx.behind_glass(tx.shelves(seed, w_px, h_px, rows, back), seed + 1)
