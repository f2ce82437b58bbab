"""A JSON-answering LLM client for OpenAI-compatible chat endpoints (``openai`` package).

Configuration comes from the environment: ``BIOVLN_LLM_BASE_URL`` (default DeepSeek's API),
``BIOVLN_LLM_MODEL`` (default ``deepseek-chat``) and ``BIOVLN_LLM_API_KEY`` (or ``DEEPSEEK_API_KEY``).
The key is never printed or logged. Calls use temperature 0, a timeout and retries, ask for a JSON
object, validate it, and are cached by prompt; every failure is counted so callers can fall back.
"""

from __future__ import annotations

import hashlib
import json
import os
import threading
from dataclasses import dataclass, field
from pathlib import Path

from biovln_ms.errors import BioVLNError

DEFAULT_BASE_URL = "https://api.deepseek.com"
DEFAULT_MODEL = "deepseek-chat"


class LLMConfigError(BioVLNError):
    """No usable LLM endpoint is configured."""


@dataclass
class LLMConfig:
    base_url: str
    model: str
    api_key: str = field(repr=False)
    timeout: float = 20.0
    max_retries: int = 2

    @classmethod
    def from_env(cls) -> "LLMConfig":
        key = os.environ.get("BIOVLN_LLM_API_KEY") or os.environ.get("DEEPSEEK_API_KEY")
        if not key:
            raise LLMConfigError(
                "no LLM endpoint configured (BIOVLN_LLM_API_KEY is unset)",
                field="BIOVLN_LLM_API_KEY",
                fix="export BIOVLN_LLM_API_KEY=... (and BIOVLN_LLM_BASE_URL / BIOVLN_LLM_MODEL for a "
                "non-DeepSeek endpoint); LLM-Frontier numbers are not reported without one",
            )
        return cls(
            os.environ.get("BIOVLN_LLM_BASE_URL", DEFAULT_BASE_URL),
            os.environ.get("BIOVLN_LLM_MODEL", DEFAULT_MODEL),
            key,
            float(os.environ.get("BIOVLN_LLM_TIMEOUT", "20")),
        )

    def __repr__(self) -> str:
        return f"LLMConfig(base_url={self.base_url!r}, model={self.model!r}, api_key='***')"


@dataclass
class LLMStats:
    calls: int = 0
    cache_hits: int = 0
    failures: int = 0
    failure_kinds: dict = field(default_factory=dict)

    def fail(self, kind: str) -> None:
        self.failures += 1
        self.failure_kinds[kind] = self.failure_kinds.get(kind, 0) + 1


class JSONChatClient:
    """``ask(system, user, validate)`` -> a validated JSON object, or None after a counted failure."""

    def __init__(self, config: LLMConfig | None = None, cache_path: str | Path | None = None) -> None:
        from openai import OpenAI

        self.config = config or LLMConfig.from_env()
        self._client = OpenAI(
            base_url=self.config.base_url,
            api_key=self.config.api_key,
            timeout=self.config.timeout,
            max_retries=self.config.max_retries,
        )
        self.stats = LLMStats()
        self._cache: dict[str, dict] = {}
        self._lock = threading.Lock()
        self.cache_path = Path(cache_path) if cache_path else None
        if self.cache_path and self.cache_path.exists():
            for line in self.cache_path.read_text().splitlines():
                try:
                    row = json.loads(line)
                    self._cache[row["key"]] = row["answer"]
                except (json.JSONDecodeError, KeyError):
                    continue

    def _key(self, system: str, user: str) -> str:
        return hashlib.sha256(json.dumps([self.config.model, system, user]).encode()).hexdigest()

    def ask(self, system: str, user: str, validate=lambda obj: True) -> dict | None:
        key = self._key(system, user)
        with self._lock:
            if key in self._cache:
                self.stats.cache_hits += 1
                return self._cache[key]
        self.stats.calls += 1
        try:
            resp = self._client.chat.completions.create(
                model=self.config.model,
                temperature=0,
                response_format={"type": "json_object"},
                messages=[{"role": "system", "content": system}, {"role": "user", "content": user}],
            )
            text = resp.choices[0].message.content or ""
        except Exception as e:  # network, timeout, HTTP errors: counted, the caller falls back
            self.stats.fail(type(e).__name__)
            return None
        try:
            obj = json.loads(text)
        except json.JSONDecodeError:
            self.stats.fail("not_json")
            return None
        if not isinstance(obj, dict) or not validate(obj):
            self.stats.fail("invalid_answer")
            return None
        with self._lock:
            self._cache[key] = obj
            if self.cache_path:
                self.cache_path.parent.mkdir(parents=True, exist_ok=True)
                with open(self.cache_path, "a") as f:
                    f.write(json.dumps({"key": key, "answer": obj}) + "\n")
        return obj
