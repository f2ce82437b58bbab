"""Shared fixtures. Every test runs with the network closed except loopback: nothing in the package
may download anything at run time, and a test that tries fails loudly."""

from __future__ import annotations

import ipaddress
import os
import socket
import tempfile

import pytest
from hypothesis import settings

# Hermetic caches: the default dataset and the room-shell meshes go to a fresh folder per run
# (subprocesses inherit it).
_TMP = tempfile.mkdtemp(prefix="biovln-tests-")
os.environ["BIOVLN_DATA_DIR"] = os.path.join(_TMP, "data")
os.environ["BIOVLN_CACHE_DIR"] = os.path.join(_TMP, "cache")

settings.register_profile("biovln", deadline=None, print_blob=True)
settings.load_profile("biovln")

_real_connect = socket.socket.connect


def _guarded_connect(self, address):
    host = address[0] if isinstance(address, tuple) else address
    if isinstance(host, str) and self.family in (socket.AF_INET, socket.AF_INET6):
        try:
            ok = host == "localhost" or ipaddress.ip_address(host).is_loopback
        except ValueError:
            ok = False
        if not ok:
            raise RuntimeError(f"test tried to reach {address}: BioVLN-MS must not download at run time")
    return _real_connect(self, address)


@pytest.fixture(autouse=True)
def _no_network(monkeypatch):
    monkeypatch.setattr(socket.socket, "connect", _guarded_connect)
    yield


@pytest.fixture(scope="session")
def catalog():
    from biovln_ms.catalog import load_catalog

    return load_catalog()
