"""Lab protocols as data: ordered (and any-order) visits to the catalog's goal instruments.

The shipped protocols are JSON files in ``biovln_ms/protocols/data/``; users add their own by passing
folders to :func:`load_protocols` or naming them in the ``BIOVLN_PROTOCOL_PATH`` environment variable.
"""

from biovln_ms.protocols.library import (
    MAX_VISITS,
    MIN_VISITS,
    PROTOCOL_DIR,
    Protocol,
    ProtocolError,
    ProtocolLibrary,
    Step,
    Visit,
    load_protocol_file,
    load_protocols,
    parse_protocol,
)

__all__ = [
    "MAX_VISITS",
    "MIN_VISITS",
    "PROTOCOL_DIR",
    "Protocol",
    "ProtocolError",
    "ProtocolLibrary",
    "Step",
    "Visit",
    "load_protocol_file",
    "load_protocols",
    "parse_protocol",
]
