"""The LLM client's limits against hostile or broken servers on loopback: the per-call deadline, the
response size cap, malformed answers as counted failures, and `eval`'s persistent cache."""

from __future__ import annotations

import json
import socket
import threading
import time
import tracemalloc
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler

import numpy as np
import pytest

from biovln_ms.llm.client import JSONChatClient, LLMConfig, LLMConfigError
from conftest import loopback_server

KEY = "sk-limits-test"


class RawServer:
    """A loopback TCP server: ``script(conn, stop)`` answers each connection after the request is read."""

    def __init__(self, script: Callable[[socket.socket, threading.Event], None]) -> None:
        self.script, self.stop, self.requests = script, threading.Event(), 0
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        while not self.stop.is_set():
            try:
                conn, _ = self.sock.accept()
            except OSError:
                continue
            threading.Thread(target=self._handle, args=(conn,), daemon=True).start()

    def _handle(self, conn: socket.socket) -> None:
        with conn:
            data = b""
            while b"\r\n\r\n" not in data:
                chunk = conn.recv(65536)
                if not chunk:
                    return
                data += chunk
            head, _, rest = data.partition(b"\r\n\r\n")
            length = next(
                int(line.split(b":")[1])
                for line in head.split(b"\r\n")
                if line.lower().startswith(b"content-length")
            )
            while len(rest) < length:
                rest += conn.recv(65536)
            self.requests += 1
            try:
                self.script(conn, self.stop)
            except OSError:  # the client hung up: what a bounded client does
                pass

    def close(self) -> None:
        self.stop.set()
        self.sock.close()


@pytest.fixture
def raw_server():
    servers: list[RawServer] = []

    def make(script: Callable[[socket.socket, threading.Event], None]) -> RawServer:
        servers.append(RawServer(script))
        return servers[-1]

    yield make
    for s in servers:
        s.close()


def config(port: int, **kw) -> LLMConfig:
    kw = {"timeout": 1.0, "max_retries": 0, **kw}
    return LLMConfig(f"http://127.0.0.1:{port}/v1", "deepseek-chat", KEY, **kw)


def drip(payload: bytes, head: bytes = b"", every: float = 0.5, for_at_most: float = 8.0):
    """Send ``head``, then ``payload`` one byte every ``every`` seconds (for at most ``for_at_most`` s,
    so that an unbounded client also ends)."""

    def script(conn: socket.socket, stop: threading.Event) -> None:
        conn.sendall(head)
        end = time.monotonic() + for_at_most
        for b in payload:
            if stop.is_set() or time.monotonic() > end:
                return
            conn.sendall(bytes([b]))
            time.sleep(every)

    return script


HEAD = b"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: 100000\r\n\r\n"


@pytest.mark.parametrize("where", ["body", "headers"])
def test_slow_drip_ends_at_the_deadline(raw_server, where):
    """1 byte / 0.5 s never trips a 1 s read timeout; the 1.5 s deadline still holds."""
    srv = raw_server(drip(b'{"choices": [' * 1000, head=HEAD) if where == "body" else drip(HEAD))
    c = JSONChatClient(config(srv.port, deadline=1.5))
    t0 = time.monotonic()
    assert c.ask("s", "u") is None
    assert time.monotonic() - t0 < 1.5 + 1.0
    assert c.stats.failure_kinds == {"deadline": 1}
    time.sleep(0.2)  # the worker's socket was shut down at the deadline: it has ended, not lingering
    assert not [t for t in threading.enumerate() if t.name == "biovln-llm-call" and t.is_alive()]


def endless(status: bytes, limit: int = 64 << 20):
    """An endless body (cut by the server after ``limit`` bytes, so that an unbounded client ends)."""

    def script(conn: socket.socket, stop: threading.Event) -> None:
        conn.sendall(
            b"HTTP/1.1 " + status + b"\r\nContent-Type: application/json\r\nConnection: close\r\n\r\n"
        )
        chunk, sent = b'{"choices": ' + b" " * (64 * 1024 - 12), 0
        while sent < limit and not stop.is_set():
            conn.sendall(chunk)
            sent += len(chunk)

    return script


@pytest.mark.parametrize("status", [b"200 OK", b"500 Internal Server Error"])
def test_endless_stream_is_cut_at_the_cap_with_bounded_memory(raw_server, status):
    srv = raw_server(endless(status))
    c = JSONChatClient(config(srv.port, deadline=10.0))
    tracemalloc.start()
    try:
        t0 = time.monotonic()
        assert c.ask("s", "u") is None
        elapsed = time.monotonic() - t0
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert elapsed < 5.0
    assert peak < 8 << 20  # the 1 MiB cap and a few chunks, never the stream
    assert c.stats.failures == 1
    assert c.stats.failure_kinds == ({"too_large": 1} if status.startswith(b"200") else {"http_500": 1})


def test_declared_huge_body_is_refused_unread(raw_server):
    srv = raw_server(
        lambda conn, stop: conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: 10000000000\r\n\r\n{")
    )
    c = JSONChatClient(config(srv.port, max_response_bytes=4096))
    assert c.ask("s", "u") is None and c.stats.failure_kinds == {"too_large": 1}


def test_retries_stay_within_the_deadline(raw_server):
    srv = raw_server(lambda conn, stop: conn.sendall(b"HTTP/1.1 503 Busy\r\nContent-Length: 0\r\n\r\n"))
    c = JSONChatClient(config(srv.port, max_retries=50, deadline=1.2))
    t0 = time.monotonic()
    assert c.ask("s", "u") is None
    assert time.monotonic() - t0 < 1.2 + 0.5
    assert 2 <= srv.requests <= 3 and c.stats.failure_kinds == {"http_503": 1}  # 0 s, 0.5 s, (1.5 s: past)


class PayloadHandler(BaseHTTPRequestHandler):
    """Answers with ``server.payload`` (bytes) as the whole body."""

    def do_POST(self):
        self.rfile.read(int(self.headers["Content-Length"]))
        self.server.requests += 1
        data = self.server.payload
        self.send_response(200)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def log_message(self, *args):
        pass


@pytest.fixture
def payload_server():
    with loopback_server(PayloadHandler, requests=0, payload=b"{}") as srv:
        yield srv


def completion(message: dict) -> bytes:
    return json.dumps({"id": "x", "choices": [{"index": 0, "message": message}]}).encode()


CASES = [  # (body, failure kind)
    (completion({"role": "assistant", "content": 42}), "bad_content"),
    (completion({"role": "assistant", "content": None}), "bad_content"),
    (completion({"role": "assistant", "content": ["{", "}"]}), "bad_content"),
    (completion({"role": "assistant", "content": {"choice": 1}}), "bad_content"),
    (completion({"role": "assistant"}), "bad_content"),
    (completion({"role": "assistant", "content": "I would go left"}), "not_json"),
    (completion({"role": "assistant", "content": "[" * 100_000}), "not_json"),
    (completion({"role": "assistant", "content": "[1, 2]"}), "invalid_answer"),
    (completion({"role": "assistant", "content": '{"choice": "left"}'}), "invalid_answer"),
    (completion({"role": "assistant", "content": '{"pick": 1}'}), "invalid_answer"),
    (json.dumps({"choices": []}).encode(), "bad_response"),
    (json.dumps({"choices": [{"message": "hi"}]}).encode(), "bad_response"),
    (json.dumps({"choices": "x"}).encode(), "bad_response"),
    (json.dumps([1, 2]).encode(), "bad_response"),
    (b"<html>gateway</html>", "bad_response"),
]


def test_malformed_answers_are_counted_failures_never_exceptions(payload_server):
    c = JSONChatClient(config(payload_server.server_address[1]))

    def choice(o: dict) -> bool:
        return o["choice"] + 1 > 0  # trips (KeyError, TypeError) on a wrong shape: refused, not raised

    expected: dict[str, int] = {}
    for i, (body, kind) in enumerate(CASES):
        payload_server.payload = body
        assert c.ask("s", f"case {i}", choice) is None, kind
        expected[kind] = expected.get(kind, 0) + 1
    assert c.stats.failure_kinds == expected and c.stats.failures == len(CASES) == payload_server.requests
    payload_server.payload = completion({"role": "assistant", "content": '{"choice": 1}'})
    assert c.ask("s", "fine", choice) == {"choice": 1}


def test_policy_falls_back_on_a_raising_client():
    from biovln_ms.baselines.frontier.planner import Candidate
    from biovln_ms.baselines.llm_frontier import LLMFrontierPolicy

    class Broken:
        def ask(self, system, user, validate):
            raise RuntimeError("boom")

    pol = LLMFrontierPolicy(client=Broken())
    pol.category = "incubator"
    cands = [Candidate(2.0, np.array([1.0, 1.0]), 20), Candidate(2.5, np.array([5.0, 1.0]), 30)]
    assert np.allclose(pol.choose(cands, np.zeros(3)), [1.0, 1.0])
    assert pol.episode_stats() == {"llm_consulted": 1, "llm_fallbacks": 1}


def test_limits_from_the_environment(monkeypatch):
    monkeypatch.setenv("BIOVLN_LLM_API_KEY", KEY)
    monkeypatch.setenv("BIOVLN_LLM_DEADLINE", "7.5")
    monkeypatch.delenv("BIOVLN_LLM_TIMEOUT", raising=False)
    cfg = LLMConfig.from_env()
    assert (cfg.deadline, cfg.timeout, cfg.max_response_bytes) == (7.5, 20.0, 1 << 20)
    assert KEY not in repr(cfg)
    monkeypatch.setenv("BIOVLN_LLM_DEADLINE", "soon")
    with pytest.raises(LLMConfigError, match="BIOVLN_LLM_DEADLINE"):
        LLMConfig.from_env()
    monkeypatch.setenv("BIOVLN_LLM_DEADLINE", "7.5")
    monkeypatch.setenv("BIOVLN_LLM_BASE_URL", "file:///etc")
    with pytest.raises(LLMConfigError, match="not an http"):
        LLMConfig.from_env()


def test_eval_factory_uses_the_persistent_cache(payload_server, monkeypatch, tmp_path):
    """`eval` builds the policy through the registry: a second run of the same prompt (a fresh
    policy, as in a new `eval` process) is answered from the cache."""
    from biovln_ms.baselines.frontier.planner import Candidate
    from biovln_ms.eval.methods import METHODS

    payload_server.payload = completion({"role": "assistant", "content": '{"choice": 1}'})
    monkeypatch.setenv("BIOVLN_LLM_API_KEY", KEY)
    monkeypatch.setenv("BIOVLN_LLM_BASE_URL", f"http://127.0.0.1:{payload_server.server_address[1]}/v1")
    monkeypatch.delenv("BIOVLN_LLM_CACHE", raising=False)
    monkeypatch.setenv("BIOVLN_CACHE_DIR", str(tmp_path))
    cands = [Candidate(2.0, np.array([1.0, 1.0]), 20), Candidate(2.5, np.array([5.0, 1.0]), 30)]
    for run in range(2):
        METHODS["llm_frontier"].preflight()
        pol = METHODS["llm_frontier"].factory()
        pol.category = "incubator"
        assert np.allclose(pol.choose(cands, np.zeros(3)), [5.0, 1.0]), run
    assert payload_server.requests == 1 and pol.client.stats.cache_hits == 1
    assert (tmp_path / "llm" / "responses.jsonl").is_file()
    monkeypatch.setenv("BIOVLN_LLM_CACHE", str(tmp_path / "mine.jsonl"))  # the override
    pol = METHODS["llm_frontier"].factory()
    pol.category = "incubator"
    pol.choose(cands, np.zeros(3))
    assert payload_server.requests == 2 and (tmp_path / "mine.jsonl").is_file()
