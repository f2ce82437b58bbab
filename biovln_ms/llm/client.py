"""A JSON-answering LLM client for OpenAI-compatible chat endpoints (``POST {base_url}/chat/completions``).

Configuration comes from the environment: ``BIOVLN_LLM_BASE_URL`` (default DeepSeek's API),
``BIOVLN_LLM_MODEL`` (default ``deepseek-chat``) and ``BIOVLN_LLM_API_KEY`` (or ``DEEPSEEK_API_KEY``),
``BIOVLN_LLM_TIMEOUT`` (seconds per connect/read, default 20) and ``BIOVLN_LLM_DEADLINE`` (wall-clock
seconds per call across retries and slow streams, default 60). The key is never printed or logged.

Calls use temperature 0, ask for a JSON object and validate it. The body is read by our own bounded
reader (stdlib ``urllib``, which honours the usual proxy variables): at most ``max_response_bytes``
(1 MiB) is ever buffered, an error status's body is never read, and the caller gets its answer or a
counted failure by the deadline whatever the server does. Answers are cached by endpoint, model and
prompt (in memory, and in a JSON-lines file when a cache path is given). Every failure is counted in
``stats`` so callers can fall back; ``ask`` never raises.
"""

from __future__ import annotations

import hashlib
import http.client
import json
import logging
import os
import socket
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from biovln_ms.errors import BioVLNError
from biovln_ms.paths import cache_dir

log = logging.getLogger(__name__)

DEFAULT_BASE_URL = "https://api.deepseek.com"
DEFAULT_MODEL = "deepseek-chat"
DEFAULT_TIMEOUT_S = 20.0
DEFAULT_DEADLINE_S = 60.0
DEFAULT_MAX_RESPONSE_BYTES = 1 << 20  # 1 MiB: a chat answer is a few hundred bytes
RETRY_STATUSES = frozenset({408, 409, 429, 500, 502, 503, 504})
BACKOFF_S = 0.5  # before retry n (n = 1, 2, ...): BACKOFF_S * 2 ** (n - 1), within the deadline
_CHUNK = 64 * 1024


class LLMConfigError(BioVLNError):
    """No usable LLM endpoint is configured."""


def _check_url(url: str) -> None:
    parts = urllib.parse.urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.netloc:
        raise LLMConfigError(
            f"the LLM base URL {url!r} is not an http(s) URL",
            field="BIOVLN_LLM_BASE_URL",
            fix="e.g. BIOVLN_LLM_BASE_URL=https://api.deepseek.com",
        )


class _Sockets:
    """The sockets of one call (duplicates, so that TLS wrapping leaves them valid): at the deadline the
    caller shuts them down, which ends a worker blocked in a read however slowly the server drips."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._socks: list[socket.socket] = []
        self._cut = False

    def track(self, sock: socket.socket) -> socket.socket:
        with self._lock:
            if self._cut:
                sock.close()
                raise _Failure("deadline")
            self._socks.append(sock.dup())
        return sock

    def cut(self) -> None:
        with self._lock:
            self._cut = True
            for s in self._socks:
                try:
                    s.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass

    def close(self) -> None:
        with self._lock:
            for s in self._socks:
                s.close()
            self._socks.clear()

    def connection_class(self, base: type[http.client.HTTPConnection]) -> type[http.client.HTTPConnection]:
        tracker = self

        class Tracked(base):
            def __init__(self, *args: object, **kwargs: object) -> None:
                super().__init__(*args, **kwargs)
                create = self._create_connection
                self._create_connection = lambda *a, **k: tracker.track(create(*a, **k))

        return Tracked


class _Tracked:
    """Mixed into urllib's HTTP and HTTPS handlers: their connections' sockets go to ``sockets``."""

    def __init__(self, sockets: _Sockets) -> None:
        super().__init__()
        self._sockets = sockets

    def do_open(
        self, http_class: type[http.client.HTTPConnection], req: urllib.request.Request, **kwargs: object
    ) -> http.client.HTTPResponse:
        return super().do_open(self._sockets.connection_class(http_class), req, **kwargs)


class _TrackedHTTP(_Tracked, urllib.request.HTTPHandler):
    pass


class _TrackedHTTPS(_Tracked, urllib.request.HTTPSHandler):
    pass


class _NoRedirect(urllib.request.HTTPRedirectHandler):
    """A redirect is a failure (``http_3xx``): the request and its key go nowhere else."""

    def redirect_request(
        self, req: object, fp: object, code: int, msg: str, headers: object, newurl: str
    ) -> None:
        return None


def _env_seconds(name: str, default: float) -> float:
    raw = os.environ.get(name, "")
    try:
        value = float(raw) if raw.strip() else default
    except ValueError:
        value = -1.0
    if not value > 0 or value == float("inf"):
        raise LLMConfigError(
            f"{name}={raw!r} is not a positive number of seconds",
            field=name,
            fix=f"unset it or e.g. {name}=30",
        )
    return value


@dataclass
class LLMConfig:
    base_url: str
    model: str
    api_key: str = field(repr=False)
    timeout: float = DEFAULT_TIMEOUT_S  # seconds per connect and per read
    max_retries: int = 2  # on connection errors, timeouts and 408/409/429/5xx
    deadline: float = DEFAULT_DEADLINE_S  # wall-clock seconds per call, retries included
    max_response_bytes: int = DEFAULT_MAX_RESPONSE_BYTES

    @classmethod
    def from_env(cls) -> LLMConfig:
        key = os.environ.get("BIOVLN_LLM_API_KEY") or os.environ.get("DEEPSEEK_API_KEY")
        if not key:
            raise LLMConfigError(
                "no LLM endpoint configured (BIOVLN_LLM_API_KEY is unset)",
                field="BIOVLN_LLM_API_KEY",
                fix="export BIOVLN_LLM_API_KEY=... (and BIOVLN_LLM_BASE_URL / BIOVLN_LLM_MODEL for a "
                "non-DeepSeek endpoint); LLM-Frontier numbers are not reported without one",
            )
        base_url = os.environ.get("BIOVLN_LLM_BASE_URL", DEFAULT_BASE_URL)
        _check_url(base_url)
        return cls(
            base_url,
            os.environ.get("BIOVLN_LLM_MODEL", DEFAULT_MODEL),
            key,
            _env_seconds("BIOVLN_LLM_TIMEOUT", DEFAULT_TIMEOUT_S),
            deadline=_env_seconds("BIOVLN_LLM_DEADLINE", DEFAULT_DEADLINE_S),
        )

    def __repr__(self) -> str:
        return (
            f"LLMConfig(base_url={self.base_url!r}, model={self.model!r}, api_key='***', "
            f"timeout={self.timeout}, max_retries={self.max_retries}, deadline={self.deadline}, "
            f"max_response_bytes={self.max_response_bytes})"
        )


def default_cache_path() -> Path | None:
    """The persistent response cache of ``eval``: ``$BIOVLN_LLM_CACHE`` (empty or ``off``: none), else
    ``$BIOVLN_CACHE_DIR/llm/responses.jsonl`` (default ``~/.cache/biovln_ms/llm/responses.jsonl``)."""
    env = os.environ.get("BIOVLN_LLM_CACHE")
    if env is not None:
        return None if env.strip().lower() in ("", "off", "none", "0") else Path(env).expanduser()
    return cache_dir() / "llm" / "responses.jsonl"


@dataclass
class LLMStats:
    calls: int = 0
    cache_hits: int = 0
    failures: int = 0
    failure_kinds: dict = field(default_factory=dict)

    def fail(self, kind: str) -> None:
        self.failures += 1
        self.failure_kinds[kind] = self.failure_kinds.get(kind, 0) + 1


class _Failure(Exception):
    """One exchange failed; ``kind`` is what is counted."""

    def __init__(self, kind: str, retry: bool = False) -> None:
        super().__init__(kind)
        self.kind, self.retry = kind, retry


class JSONChatClient:
    """``ask(system, user, validate)`` -> a validated JSON object, or None after a counted failure.

    Failure kinds: ``deadline``, ``timeout``, ``connection``, ``http_<status>``, ``too_large`` (body over
    the cap), ``bad_response`` (body not a chat completion), ``bad_content`` (``content`` missing or not
    a string), ``not_json`` (content not JSON), ``invalid_answer`` (not an object, or refused by
    ``validate``).
    """

    def __init__(self, config: LLMConfig | None = None, cache_path: str | Path | None = None) -> None:
        self.config = config or LLMConfig.from_env()
        _check_url(self.config.base_url)
        self._url = self.config.base_url.rstrip("/") + "/chat/completions"
        self.stats = LLMStats()
        self._cache: dict[str, dict] = {}
        self._lock = threading.Lock()
        self.cache_path = Path(cache_path) if cache_path else None
        if self.cache_path and self.cache_path.exists():
            try:
                lines = self.cache_path.read_text(errors="replace").splitlines()
            except OSError as e:
                log.warning("LLM cache %s unreadable (%s): starting empty", self.cache_path, e)
                lines = []
            for line in lines:
                try:
                    row = json.loads(line)
                    if isinstance(row, dict) and isinstance(row.get("answer"), dict):
                        self._cache[str(row["key"])] = row["answer"]
                except (ValueError, RecursionError, KeyError):
                    continue

    def _key(self, system: str, user: str) -> str:
        ident = [self.config.base_url, self.config.model, system, user]
        return hashlib.sha256(json.dumps(ident).encode()).hexdigest()

    def ask(self, system: str, user: str, validate: Callable[[dict], bool] = lambda obj: True) -> dict | None:
        key = self._key(system, user)
        with self._lock:
            cached = self._cache.get(key)
        if cached is not None and _valid(cached, validate):
            self.stats.cache_hits += 1
            return cached
        self.stats.calls += 1
        body = json.dumps(
            {
                "model": self.config.model,
                "temperature": 0,
                "response_format": {"type": "json_object"},
                "messages": [{"role": "system", "content": system}, {"role": "user", "content": user}],
            }
        ).encode()
        try:
            text = self._call(body)
            obj = _answer(text, validate)
        except _Failure as f:
            self.stats.fail(f.kind)
            return None
        except Exception as e:  # a bug of ours must not end the episode either: counted
            self.stats.fail(type(e).__name__)
            return None
        self._remember(key, obj)
        return obj

    def _call(self, body: bytes) -> bytes:
        """The response body of a 2xx answer, retried within the deadline. The exchange runs in a worker
        thread so that the deadline holds whatever the server does; at the deadline its sockets are shut
        down, which ends the worker too."""
        deadline = time.monotonic() + self.config.deadline
        sockets = _Sockets()
        opener = urllib.request.build_opener(_NoRedirect, _TrackedHTTP(sockets), _TrackedHTTPS(sockets))
        box: list = []
        done = threading.Event()

        def work() -> None:
            try:
                box.append(self._exchange_with_retries(opener, body, deadline))
            except BaseException as e:  # handed to the caller
                box.append(e if isinstance(e, _Failure) else _Failure(type(e).__name__))
            finally:
                sockets.close()
                done.set()

        threading.Thread(target=work, name="biovln-llm-call", daemon=True).start()
        if not done.wait(max(0.0, deadline - time.monotonic())) or not box:
            sockets.cut()
            raise _Failure("deadline")
        if isinstance(box[0], _Failure):
            raise box[0]
        return box[0]

    def _exchange_with_retries(
        self, opener: urllib.request.OpenerDirector, body: bytes, deadline: float
    ) -> bytes:
        attempt = 0
        while True:
            try:
                return self._exchange(opener, body, deadline)
            except _Failure as f:
                attempt += 1
                pause = BACKOFF_S * 2 ** (attempt - 1)
                if not f.retry or attempt > self.config.max_retries or time.monotonic() + pause >= deadline:
                    raise
                time.sleep(pause)

    def _exchange(self, opener: urllib.request.OpenerDirector, body: bytes, deadline: float) -> bytes:
        """One POST; the body read in chunks, stopped at the cap or the deadline."""
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise _Failure("deadline")
        request = urllib.request.Request(
            self._url,
            data=body,
            method="POST",
            headers={
                "Authorization": f"Bearer {self.config.api_key}",
                "Content-Type": "application/json",
                "Accept": "application/json",
                "Accept-Encoding": "identity",
                "User-Agent": "biovln-ms",
            },
        )
        cap = self.config.max_response_bytes
        try:
            with opener.open(request, timeout=min(self.config.timeout, remaining)) as resp:
                if resp.length is not None and resp.length > cap:
                    raise _Failure("too_large")
                chunks, size = [], 0
                while chunk := resp.read1(_CHUNK):
                    size += len(chunk)
                    if size > cap:
                        raise _Failure("too_large")
                    if time.monotonic() > deadline:
                        raise _Failure("deadline")
                    chunks.append(chunk)
                return b"".join(chunks)
        except urllib.error.HTTPError as e:  # its body is never read
            e.close()
            raise _Failure(f"http_{e.code}", retry=e.code in RETRY_STATUSES) from None
        except urllib.error.URLError as e:
            timed_out = isinstance(e.reason, TimeoutError)
            raise _Failure("timeout" if timed_out else "connection", retry=True) from None
        except TimeoutError:
            raise _Failure("timeout", retry=True) from None
        except (OSError, ValueError, http.client.HTTPException) as e:  # reset, truncated or garbled reply
            raise _Failure("connection", retry=True) from e

    def _remember(self, key: str, obj: dict) -> None:
        with self._lock:
            self._cache[key] = obj
            if not self.cache_path:
                return
            line = (json.dumps({"key": key, "answer": obj}) + "\n").encode()
            try:
                self.cache_path.parent.mkdir(parents=True, exist_ok=True)
                fd = os.open(self.cache_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
                try:
                    os.write(fd, line)  # one append: workers sharing the file do not interleave
                finally:
                    os.close(fd)
            except OSError as e:
                log.warning("LLM cache %s not writable (%s): caching in memory only", self.cache_path, e)
                self.cache_path = None


def _valid(obj: object, validate: Callable[[dict], bool]) -> bool:
    try:
        return isinstance(obj, dict) and bool(validate(obj))
    except Exception:  # a validator that trips on an odd answer refuses it
        return False


def _answer(body: bytes, validate: Callable[[dict], bool]) -> dict:
    """The validated JSON object in a chat-completion body (raises ``_Failure``)."""
    try:
        payload = json.loads(body)
    except (ValueError, RecursionError):
        raise _Failure("bad_response") from None
    choices = payload.get("choices") if isinstance(payload, dict) else None
    if not isinstance(choices, list) or not choices or not isinstance(choices[0], dict):
        raise _Failure("bad_response")
    message = choices[0].get("message")
    if not isinstance(message, dict):
        raise _Failure("bad_response")
    content = message.get("content")
    if not isinstance(content, str):
        raise _Failure("bad_content")
    try:
        obj = json.loads(content)
    except (ValueError, RecursionError):
        raise _Failure("not_json") from None
    if not _valid(obj, validate):
        raise _Failure("invalid_answer")
    return obj
