"""The Blender add-on packaged as an installable zip (Edit > Preferences > Add-ons > Install from Disk)."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

ADDON_NAME = "biovln_lsat"
ADDON_DIR = Path(__file__).parent / "blender_addon" / ADDON_NAME


def addon_zip_bytes() -> bytes:
    """The add-on's modules under ``biovln_lsat/``, with fixed timestamps: the same source, the same bytes."""
    files = sorted(ADDON_DIR.glob("*.py"))
    if not any(f.name == "__init__.py" for f in files):
        raise FileNotFoundError(
            f"{ADDON_DIR}: the add-on's __init__.py is missing; reinstall biovln-ms (package data)"
        )
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for f in files:
            z.writestr(zipfile.ZipInfo(f"{ADDON_NAME}/{f.name}", (1980, 1, 1, 0, 0, 0)), f.read_bytes())
    return buf.getvalue()
