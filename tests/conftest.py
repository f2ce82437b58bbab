"""Shared fixtures. Every test runs with the network closed except loopback: nothing in the package
may download anything at run time, and a test that tries fails loudly."""

from __future__ import annotations

import atexit
import contextlib
import copy
import ipaddress
import json
import os
import shutil
import socket
import tempfile
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest
from hypothesis import settings

# Hermetic caches: the default dataset and the room-shell meshes go to a fresh folder per run. Subprocesses
# and pytest-xdist's workers inherit it (the controller makes it; the folder goes when the controller ends).
_TMP = os.environ.get("BIOVLN_TEST_TMP")
if not _TMP:
    _TMP = os.environ["BIOVLN_TEST_TMP"] = tempfile.mkdtemp(prefix="biovln-tests-")
    atexit.register(shutil.rmtree, _TMP, ignore_errors=True)
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


def _registries() -> list[tuple[object, str]]:
    """(module, attribute) of every registry a test can extend from outside the package."""
    import biovln_ms.eval.methods as methods
    import biovln_ms.metrics.measures as measures
    import biovln_ms.registration as registration
    import biovln_ms.scene.templates as templates
    import biovln_ms.tasks.sensors as sensors

    return [
        (methods, "METHODS"),
        (measures, "_REGISTRY"),
        (registration, "VARIANTS"),
        (registration, "ENV_IDS"),
        (registration, "VARIANT_HOOKS"),
        (templates, "_REGISTRY"),
        (templates, "_SKIPPED"),
        (templates, "_BUILTIN_LOADED"),
        (sensors, "SENSORS"),
    ]


@pytest.fixture(scope="module", autouse=True)
def _registries_restored():
    """A test file's registrations (plugins, templates, measures, variants) end with the file, so the next
    file on the same pytest-xdist worker sees only what the package ships."""
    import gymnasium as gym
    from mani_skill.utils.registration import REGISTERED_ENVS

    from biovln_ms.registration import ENV_IDS

    held = [(m, a, copy.copy(getattr(m, a))) for m, a in _registries()]
    env_ids = set(ENV_IDS)
    yield
    for uid in set(ENV_IDS) - env_ids:  # a variant the file registered: gone from gymnasium and ManiSkill
        gym.registry.pop(uid, None)
        REGISTERED_ENVS.pop(uid, None)
    for module, attr, saved in held:
        now = getattr(module, attr)
        if isinstance(now, dict):
            now.clear()
            now.update(saved)
        elif isinstance(now, list):
            now[:] = saved
        else:
            setattr(module, attr, saved)


@pytest.fixture(scope="session")
def catalog():
    from biovln_ms.catalog import load_catalog

    return load_catalog()


@pytest.fixture(scope="session")
def held_out_dataset(tmp_path_factory):
    """Factory: a dataset of the held-out scene of seed 154 (the four MS categories) with the given
    episodes per split, e.g. ``held_out_dataset(ms_val=3)``; built once per combination."""
    from biovln_ms.splits import FOUR_CATEGORIES
    from biovln_ms.episodes.writer import SplitPlan, write_dataset
    from biovln_ms.scene.generator import generate_scene

    built: dict = {}

    def make(**episodes_per_split: int) -> str:
        key = tuple(sorted(episodes_per_split.items()))
        if key not in built:
            root = tmp_path_factory.mktemp("data") / "ds"
            scene = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
            write_dataset(root, [SplitPlan(s, [(scene, n, False)]) for s, n in key], progress=False)
            built[key] = str(root)
        return built[key]

    return make


class FakeOpenAIHandler(BaseHTTPRequestHandler):
    """A local OpenAI-compatible chat endpoint: records each request; the test's
    ``server.reply(body) -> str`` gives the assistant's content."""

    def do_POST(self):
        body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
        self.server.requests.append(
            {"path": self.path, "body": body, "auth": self.headers.get("Authorization")}
        )
        content = self.server.reply(body)
        payload = {
            "id": "x",
            "object": "chat.completion",
            "created": 0,
            "model": body["model"],
            "choices": [
                {"index": 0, "finish_reason": "stop", "message": {"role": "assistant", "content": content}}
            ],
            "usage": {"prompt_tokens": 1, "completion_tokens": 1, "total_tokens": 2},
        }
        data = json.dumps(payload).encode()
        self.send_response(200)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def log_message(self, *args):
        pass


@contextlib.contextmanager
def loopback_server(handler: type[BaseHTTPRequestHandler], **attrs):
    """A threaded HTTP server with ``handler`` on 127.0.0.1 (free port), ``attrs`` set; stopped after."""
    srv = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    for k, v in attrs.items():
        setattr(srv, k, v)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    try:
        yield srv
    finally:
        srv.shutdown()
        srv.server_close()


@pytest.fixture
def openai_server():
    """A local OpenAI-compatible server on loopback (set ``.reply``; ``.requests`` records the calls)."""
    with loopback_server(FakeOpenAIHandler, requests=[], reply=lambda body: "{}") as srv:
        yield srv
