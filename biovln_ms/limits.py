"""The limits on what comes from outside the package (ids, names, nesting, data files): one definition
each, shared by the schemas, the loaders and the command line, and listed in docs/trust.md.

An id (an episode, scene, split, room, wall or object id, a catalog category, a template) ends up in file
names (hand-offs, dataset files, recordings), YAML and Markdown, so its character set is closed:
letters, digits, ``_``, ``-`` and ``.``, starting with a letter or a digit (never ``.``, ``..``, a path
separator, a space or a control character), at most ``MAX_ID_LENGTH`` characters. A run name (``eval
--name``) may also hold ``+`` and ``@``, as the default names do (``ppo@rl-fetch+realistic``).
"""

from __future__ import annotations

import re
from typing import Annotated

from pydantic import Field

#: the characters of an id (a regular expression without anchors, for ``re.fullmatch``)
ID_CHARS = r"[A-Za-z0-9][A-Za-z0-9_.\-]*"
MAX_ID_LENGTH = 128
#: the characters of a run name (``eval --name``, the default ``METHOD[@variant][-robot][+preset]``)
RUN_NAME_CHARS = r"[A-Za-z0-9][A-Za-z0-9_.+@\-]*"
ID_RULE = (
    f"letters, digits, '_', '-' and '.', starting with a letter or a digit, at most {MAX_ID_LENGTH} "
    "characters"
)
RUN_NAME_RULE = (
    f"letters, digits, '_', '-', '.', '+' and '@', starting with a letter or a digit, at most "
    f"{MAX_ID_LENGTH} characters"
)

#: the pattern of an id in a pydantic schema (the anchors are the Rust engine's: ``$`` is the end of the text)
ID_PATTERN = f"^{ID_CHARS}$"
#: an id in a pydantic schema
Identifier = Annotated[str, Field(min_length=1, max_length=MAX_ID_LENGTH, pattern=ID_PATTERN)]

#: nesting of any JSON or YAML file read (``[`` / ``{`` levels, YAML block levels)
MAX_DATA_DEPTH = 64
#: nodes (scalars, lists and mappings) of a YAML file, aliases counted once
MAX_YAML_NODES = 100_000
#: a small hand-written data file: a name map, a layout request, a protocol
MAX_SMALL_FILE_BYTES = 2**20
#: entries of a name map (a designer's scene has up to 20,000 nodes)
MAX_NAME_MAP_ENTRIES = 20_000
#: a free-text name (a designer's node name or name-map key)
MAX_NAME_LENGTH = 256
#: protocol files over all protocol folders (the package ships a dozen)
MAX_PROTOCOL_FILES = 1_000
#: characters of a protocol's description
MAX_DESCRIPTION_LENGTH = 4_096
#: ``eval --workers`` (worker processes, each with its own env)
MAX_WORKERS = 1_024


#: a size given as text (``WIDTHxHEIGHT``: frame sizes, the detector's input): ASCII digits, at most 5 each
SIZE_TEXT = r"([0-9]{1,5})[xX]([0-9]{1,5})"


def parse_size(text: str) -> tuple[int, int] | None:
    """(width, height) of ``WIDTHxHEIGHT`` text, or None when it is not that (the caller names the field)."""
    m = re.fullmatch(SIZE_TEXT, text.strip()) if isinstance(text, str) else None
    return (int(m[1]), int(m[2])) if m else None
