"""One builder per catalog asset and room-shell piece, one module each, in the canonical frame of
``parts.Kit``.

Every builder keeps all parts inside the asset's bounding box and lets the body touch all six sides, so
the generated GLB's bounds equal the catalog dimensions (paper Table 2). The operational face (canonical
-Y) carries the door, handle, display or keypad, so front and back can be told apart. The looks are
physically based (powder coat and brushed steel with normal maps, panel pictures, labels, glowing
displays) because the paper's Table 8 found a vision-language model recognises instruments with rich
surfaces.

A builder registers itself with ``@instrument(name, live_decals=...)`` (:mod:`._kit`); importing this
package imports every module in it, so a new instrument is its catalog entry plus one module here.
:data:`BUILDERS` and :data:`LIVE_DECALS` are read-only views of the registry.
"""

from __future__ import annotations

import importlib
import pkgutil

from biovln_ms.assetgen.instruments._kit import BUILDERS, LIVE_DECALS, REGISTRY, instrument, unregister

for _module in sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")):
    importlib.import_module(f"{__name__}.{_module}")

__all__ = ["BUILDERS", "LIVE_DECALS", "REGISTRY", "instrument", "unregister"]
