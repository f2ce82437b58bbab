"""Where the package's data lives (works from a wheel, an editable install or a checkout)."""

from __future__ import annotations

import os
from pathlib import Path

import biovln_ms.assets as _assets_pkg

ASSET_DIR: Path = Path(_assets_pkg.__file__).resolve().parent
CATALOG_PATH: Path = ASSET_DIR / "catalog.json"
COLLISION_DIR: Path = ASSET_DIR / "collision"


def cache_dir() -> Path:
    """What the package caches on this machine (room shells, LLM replies, scorer embeddings):
    ``$BIOVLN_CACHE_DIR`` (unset or empty: ``~/.cache/biovln_ms``)."""
    return Path(os.environ.get("BIOVLN_CACHE_DIR") or Path.home() / ".cache" / "biovln_ms")


def asset_glb(name: str) -> Path:
    """Path of the generated GLB for a catalog asset or room-shell piece."""
    return ASSET_DIR / f"{name}.glb"
