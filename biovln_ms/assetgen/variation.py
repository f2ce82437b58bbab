"""Per-instance looks: two incubators in one lab differ in labels, wear and colour.

A :class:`Variant` is drawn from a scene's name and seed and an object's id, so a scene always looks
the same and two instances of a category in it differ. It changes textures only (geometry and bounds
stay exactly the catalog's): the live decals of :data:`biovln_ms.assetgen.instruments.LIVE_DECALS`
(asset tag, setpoints, dates) are drawn again for it, and the large painted surfaces get one of
:data:`PAINTS` paint looks (tint and wear, :func:`restyle`): a bounded set, so that their textures are
made once per process however many scenes are built. The shipped GLBs show :data:`SHIPPED`. The
simulator applies variants when it builds a scene (:mod:`biovln_ms.sim.instance_looks`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence, TypeVar

import numpy as np
from PIL import Image

from biovln_ms.assetgen.textures import noise, seed_for

T = TypeVar("T")

#: per-channel tint of painted surfaces: overall value, and each channel's drift (hue) around it
VALUE_RANGE = (0.93, 1.03)
HUE_JITTER = 0.025
#: wear from nearly new to well used
WEAR_RANGE = (0.05, 0.95)
#: paint looks (tint and wear) per category
PAINTS = 6


@dataclass(frozen=True)
class Variant:
    """One instance's look: a key for its random choices, a tint, a wear level and an asset tag."""

    key: int
    tint: tuple[float, float, float] = (1.0, 1.0, 1.0)
    wear: float = 0.35

    @property
    def tag(self) -> str:
        """The asset-tag number printed on its labels."""
        return f"BV-{self.key % 90000 + 10000:05d}"

    def rng(self, *keys: str) -> np.random.Generator:
        return np.random.default_rng([self.key, seed_for(*keys)])

    def pick(self, options: Sequence[T], *keys: str) -> T:
        """One of ``options``, chosen by the variant (and ``keys``, so choices are independent)."""
        return options[int(self.rng("pick", *keys).integers(len(options)))]

    def date(self, *keys: str) -> str:
        """A plausible service or certification date (YYYY-MM)."""
        r = self.rng("date", *keys)
        return f"{int(r.integers(2023, 2027))}-{int(r.integers(1, 13)):02d}"


#: the look of the shipped GLBs
SHIPPED = Variant(key=0)


def paint_look(index: int) -> tuple[tuple[float, float, float], float]:
    """(tint, wear) of paint look ``index``: evenly spread wear, a value and hue drift within range."""
    rng = np.random.default_rng(seed_for("paint", str(index)))
    value = rng.uniform(*VALUE_RANGE)
    hue = np.clip(rng.normal(0.0, HUE_JITTER / 2, 3), -HUE_JITTER, HUE_JITTER)
    tint = tuple(float(round(value * (1.0 + h), 4)) for h in hue)
    lo, hi = WEAR_RANGE
    wear = lo + (hi - lo) * (index + rng.uniform(0.2, 0.8)) / PAINTS
    return tint, float(round(wear, 3))


def variant_for(scene_name: str, scene_seed: int, object_id: str) -> Variant:
    """The variant of object ``object_id`` in scene ``scene_name`` generated from ``scene_seed``."""
    key = seed_for("instance", scene_name, str(scene_seed), object_id)
    tint, wear = paint_look(key % PAINTS)
    return Variant(key=key, tint=tint, wear=wear)


def restyle(
    image: Image.Image, tint: tuple[float, float, float], wear: float, salt: str, face: bool
) -> np.ndarray:
    """``image`` (a painted surface) in a paint look's ``tint`` and ``wear``, as RGBA uint8 (H, W, 4).

    Wear darkens and yellows the paint in soft blotches; on a ``face`` texture (stretched once over a
    door or panel, not tiled) the grime also rises from the bottom edge."""
    arr = np.asarray(image.convert("RGB"), np.float32)
    h, w, _ = arr.shape
    rng = np.random.default_rng([seed_for("restyle", salt), int(wear * 1000)])
    cell = max(8, min(h, w) // 4)
    blot = np.clip(noise(rng, h, w, cell, tile=not face)[..., 0] * 0.5 + 0.5, 0, 1)
    grime = wear * (0.5 * blot + (np.linspace(0, 1, h)[:, None] ** 3 if face else 0.0))
    arr *= np.asarray(tint, np.float32) * (1 - 0.07 * grime)[..., None]
    arr += np.asarray([6.0, 4.0, 0.0], np.float32) * grime[..., None]
    rgba = np.empty((h, w, 4), np.uint8)
    rgba[..., :3] = np.clip(np.rint(arr), 0, 255)
    rgba[..., 3] = 255
    return rgba
