"""Where the package's data lives (works from a wheel, an editable install or a checkout)."""

from __future__ import annotations

import os
from pathlib import Path

import biovln_ms.assets as _assets_pkg

ASSET_DIR: Path = Path(_assets_pkg.__file__).resolve().parent
CATALOG_PATH: Path = ASSET_DIR / "catalog.json"
COLLISION_DIR: Path = ASSET_DIR / "collision"


def default_cache_root() -> Path:
    """``~/.cache/biovln_ms``: where the caches and the default datasets live unless told otherwise."""
    return Path.home() / ".cache" / "biovln_ms"


def cache_dir() -> Path:
    """What the package caches on this machine (room shells, LLM replies, scorer embeddings):
    ``$BIOVLN_CACHE_DIR`` (unset or empty: :func:`default_cache_root`)."""
    return Path(os.environ.get("BIOVLN_CACHE_DIR") or default_cache_root())


def asset_glb(name: str) -> Path:
    """Path of the generated GLB for a catalog asset or room-shell piece."""
    return ASSET_DIR / f"{name}.glb"
