"""Errors that name what is wrong and how to fix it, instead of a deep traceback."""

from __future__ import annotations


class BioVLNError(Exception):
    """Base class: a message meant for the user, with an optional source, field and fix."""

    def __init__(
        self, message: str, *, source: str | None = None, field: str | None = None, fix: str | None = None
    ) -> None:
        self.message = message
        self.source = source
        self.field = field
        self.fix = fix
        super().__init__(self.__str__())

    def __str__(self) -> str:
        parts = []
        if self.source:
            parts.append(one_line(str(self.source)))
        if self.field:
            parts.append(f"field '{one_line(str(self.field), MAX_FIELD)}'")
        head = ": ".join(parts)
        message = one_line(str(self.message))
        text = f"{head}: {message}" if head else message
        if self.fix:
            text += f" (fix: {one_line(str(self.fix))})"
        return text


#: characters of a field name an error shows (a key of a crafted file can be a megabyte long)
MAX_FIELD = 120


def one_line(text: str, limit: int | None = None) -> str:
    """``text`` with every line break and other unprintable character escaped (an error stays one line,
    whatever the file it quotes holds), cut to ``limit`` characters."""
    if not text.isprintable():
        text = "".join(c if c.isprintable() else ascii(c)[1:-1] for c in text)
    return text if limit is None or len(text) <= limit else text[: limit - 3] + "..."


def shown(value: object, limit: int = 40) -> str:
    """``repr(value)`` as :func:`one_line` cut to ``limit`` characters: a value echoed in an error."""
    return one_line(repr(value), limit)


class CatalogError(BioVLNError):
    """Malformed catalog data, or an unknown instrument name."""


class AssetError(BioVLNError):
    """A missing, corrupt or mismatching asset file."""


class RenderError(BioVLNError):
    """SAPIEN could not render (no Vulkan device, missing driver)."""


def describe_validation_error(err) -> tuple[str, str]:
    """(field, message) of a pydantic ValidationError's first error.

    Field paths read like ``instruments[2].position``. Model-level validators in this package
    raise "FIELD: message"; that FIELD is used when pydantic itself can only say "<root>".
    """
    first = err.errors()[0]
    loc = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in first["loc"]).lstrip(".")
    msg = first["msg"].removeprefix("Value error, ")
    head, sep, rest = msg.partition(": ")
    if sep and " " not in head and head:
        loc = f"{loc}.{head}" if loc else head
        msg = rest
    return loc or "<root>", msg
