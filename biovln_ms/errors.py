"""Errors that name what is wrong and how to fix it, instead of a deep traceback."""

from __future__ import annotations


class BioVLNError(Exception):
    """Base class: a message meant for the user, with an optional source, field and fix."""

    def __init__(self, message: str, *, source: str | None = None, field: str | None = None,
                 fix: str | None = None) -> None:
        self.message = message
        self.source = source
        self.field = field
        self.fix = fix
        super().__init__(self.__str__())

    def __str__(self) -> str:
        parts = []
        if self.source:
            parts.append(str(self.source))
        if self.field:
            parts.append(f"field '{self.field}'")
        head = ": ".join(parts)
        text = f"{head}: {self.message}" if head else self.message
        if self.fix:
            text += f" (fix: {self.fix})"
        return text


class CatalogError(BioVLNError):
    """Malformed catalog data, or an unknown instrument name."""


class AssetError(BioVLNError):
    """A missing, corrupt or mismatching asset file."""


class RenderError(BioVLNError):
    """SAPIEN could not render (no Vulkan device, missing driver)."""
