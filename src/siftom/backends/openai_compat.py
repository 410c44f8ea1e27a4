"""One client for OpenAI-compatible HTTP endpoints: prompt scoring and chat.

* :meth:`OpenAIClient.score` (the :class:`~siftom.backends.scoring.TextScorer` contract): prompt
  log-probs from ``/completions`` with ``echo=True, logprobs=1, max_tokens=0`` (vLLM, the
  llama.cpp server; many hosted APIs do not offer it). The llama.cpp server's prompt log-probs
  are shifted by one token for models without a BOS token (a known llama.cpp server bug); prefer the
  in-process backend for those.
* :meth:`OpenAIClient.chat`: ``/chat/completions`` with optional ``logprobs``/``top_logprobs``,
  ``n`` samples, JSON-schema structured output (``response_format``) and image content parts,
  passed through unchanged. :meth:`OpenAIClient.chat_json` parses a structured answer.

Every request has a timeout; 429s, 5xx answers, timeouts, dropped connections and malformed
bodies are retried with exponential backoff (honouring ``Retry-After``). Answers are cached on
disk keyed by model + request, so repeated evaluations cost nothing. An endpoint that lacks
what a path needs raises :class:`EndpointCapabilityError`, which says what is missing and which
path works instead.
"""

from __future__ import annotations

import hashlib
import json
import time
import urllib.error
import urllib.request
from collections.abc import Callable, Sequence
from typing import Any

from siftom.backends.config import ENV_API_KEY, ENV_BASE_URL, ENV_MODEL, LLMConfig
from siftom.backends.scoring import ResponseCache, ScoreCache
from siftom.errors import BackendUnavailableError

__all__ = ["EndpointCapabilityError", "OpenAIClient", "OpenAICompletionsScorer"]

# Words in a 400/422 answer that mean "this endpoint does not offer that parameter".
_CAPABILITY_WORDS = {
    "completions": ("echo", "logprobs", "not supported", "unsupported"),
    "chat/completions": ("logprobs", "top_logprobs", "response_format", "json_schema", "image",
                         "not supported", "unsupported"),
}
_HINTS = {
    "completions": "prompt scoring needs an endpoint whose /completions accepts echo=True with "
                   "logprobs (vLLM, llama.cpp server); for chat-only services the LLM baselines "
                   "use the chat path instead, and the LLM likelihood can run in process "
                   "(--llm-backend llama)",
    "chat/completions": "use an endpoint with /chat/completions (vLLM, llama.cpp server, most "
                        "hosted APIs)",
}
_MAX_BACKOFF_S = 20.0


class EndpointCapabilityError(BackendUnavailableError):
    """The endpoint answers but lacks what this path needs (an API, a parameter, log-probs)."""


class OpenAIClient:
    """A client for one model behind an OpenAI-compatible endpoint.

    Args:
        config: the settings (default :meth:`LLMConfig.from_env` with backend "openai").
        batch_size: prompts per ``/completions`` request when scoring.
        use_cache: keep answers on disk under ``config.cache_dir``.
        backoff_s: first retry delay; doubles on each further retry (capped at 20 s).
        **overrides: settings applied on top of ``config`` (``base_url``, ``model``,
            ``api_key``, ``timeout_s``, ``max_retries``, ``cache_dir``). ``cache_dir=False``
            turns the cache off; ``timeout`` is accepted for ``timeout_s``.
    """

    def __init__(
        self,
        config: LLMConfig | str | None = None,
        *,
        batch_size: int = 8,
        use_cache: bool = True,
        backoff_s: float = 0.5,
        **overrides: Any,
    ) -> None:
        if isinstance(config, str):  # the old positional base_url
            overrides["base_url"], config = config, None
        if overrides.get("cache_dir") is False:
            use_cache = False
            overrides.pop("cache_dir")
        if "timeout" in overrides:
            overrides["timeout_s"] = overrides.pop("timeout")
        overrides.pop("backend", None)
        if config is None:
            config = LLMConfig.from_env(backend="openai", **overrides)
        else:
            config = config.with_overrides(**overrides)
        if config.backend != "openai":
            config = LLMConfig.from_env(backend="openai", base_url=config.base_url, model=config.model,
                                        api_key=config.api_key, timeout_s=config.timeout_s,
                                        max_retries=config.max_retries, cache_dir=config.cache_dir)
        if batch_size < 1:
            raise BackendUnavailableError(f"batch_size must be >= 1, got {batch_size}")
        self.config = config
        self.base_url: str = config.base_url  # type: ignore[assignment]  # validated by LLMConfig
        self.model: str = config.model  # type: ignore[assignment]
        self.batch_size = batch_size
        self.backoff_s = max(0.0, float(backoff_s))
        self.model_id = f"openai:{self.base_url}:{self.model}"
        self.requests = 0  # counter: HTTP requests sent (retries included)
        self.cache_hits = 0  # counter: answers served from the disk cache
        self._sleep: Callable[[float], None] = time.sleep
        folder = config.resolved_cache_dir
        self.score_cache = ScoreCache(folder / "llm-scores.sqlite") if use_cache else None
        self.response_cache = ResponseCache(folder / "llm-responses.sqlite") if use_cache else None

    @classmethod
    def from_env(cls, **overrides: Any) -> OpenAIClient:
        """A client configured by ``SIFTOM_LLM_*`` with ``overrides`` on top."""
        return cls(**overrides)

    # ----------------------------------------------------------------- prompt scoring

    def score(self, prefix: str, items: Sequence[tuple[str, str]]) -> list[float]:
        """log P(target | prefix + context) for each (context, target), from echoed log-probs."""
        prompts = [prefix + ctx for ctx, _ in items]
        keys = [ScoreCache.key(self.model_id, p, t) for p, (_, t) in zip(prompts, items, strict=True)]
        found = self.score_cache.get_many(keys) if self.score_cache is not None else {}
        todo = [k for k, key in enumerate(keys) if key not in found]
        new: dict[str, float] = {}
        for start in range(0, len(todo), self.batch_size):
            chunk = todo[start : start + self.batch_size]
            values = self._score_batch([(prompts[k], items[k][1]) for k in chunk])
            for k, v in zip(chunk, values, strict=True):
                new[keys[k]] = v
        if new and self.score_cache is not None:
            self.score_cache.put_many(new)
        found.update(new)
        return [found[k] for k in keys]

    def _score_batch(self, pairs: Sequence[tuple[str, str]]) -> list[float]:
        body = {"model": self.model, "prompt": [p + t for p, t in pairs], "max_tokens": 0,
                "echo": True, "logprobs": 1, "temperature": 0.0}
        data = self.post("completions", body, use_cache=False)
        choices = sorted(data.get("choices") or [], key=lambda c: c.get("index", 0))
        if len(choices) != len(pairs):
            raise EndpointCapabilityError(
                f"{self.base_url}/completions returned {len(choices)} choices for {len(pairs)} "
                "prompts; if the server takes one prompt per request, use batch_size=1"
            )
        return [self._target_logprob(c, p, t) for c, (p, t) in zip(choices, pairs, strict=True)]

    def _target_logprob(self, choice: dict[str, Any], prompt: str, target: str) -> float:
        """Sum the log-probs of the echoed tokens that overlap the target's characters."""
        lp = choice.get("logprobs") or {}
        tokens = lp.get("tokens")
        values = lp.get("token_logprobs")
        if not tokens or values is None:
            raise EndpointCapabilityError(
                f"{self.base_url}/completions returned no prompt log-probs for echo=True, logprobs=1; "
                + _HINTS["completions"]
            )
        offsets = lp.get("text_offset")
        if offsets is None:  # reconstruct from token lengths
            offsets, pos = [], 0
            for tok in tokens:
                offsets.append(pos)
                pos += len(tok)
        offsets = [o - offsets[0] for o in offsets]  # some servers count from a non-zero origin
        start = len(prompt)
        total = 0.0
        for tok, off, v in zip(tokens, offsets, values, strict=False):
            if off + len(tok) > start and v is not None and off < start + len(target):
                total += float(v)
        return total

    # ----------------------------------------------------------------- chat

    def chat(
        self,
        messages: Sequence[dict[str, Any]],
        *,
        response_format: dict[str, Any] | None = None,
        logprobs: bool = False,
        top_logprobs: int | None = None,
        n: int = 1,
        temperature: float = 0.0,
        max_tokens: int | None = None,
        seed: int | None = None,
        use_cache: bool = True,
        **extra: Any,
    ) -> dict[str, Any]:
        """POST ``/chat/completions`` and return the endpoint's JSON answer.

        ``messages`` pass through unchanged, so content may be a string or a list of parts
        (``{"type": "text", ...}``, ``{"type": "image_url", "image_url": {"url": "data:..."}}``).
        ``response_format`` is sent as given, e.g. ``{"type": "json_schema", "json_schema":
        {"name": ..., "schema": ..., "strict": True}}``. ``top_logprobs`` implies ``logprobs``.
        Sampled answers (``temperature > 0``) are cached too, so a rerun replays them; pass a
        different ``seed`` (or ``use_cache=False``) for fresh samples.
        """
        if not messages or not all(isinstance(m, dict) and "role" in m and "content" in m
                                    for m in messages):
            raise BackendUnavailableError(
                "chat messages must be a non-empty list of {'role': ..., 'content': ...} dicts"
            )
        if n < 1:
            raise BackendUnavailableError(f"n must be >= 1, got {n}")
        body: dict[str, Any] = {"model": self.model, "messages": list(messages),
                                "temperature": float(temperature)}
        if n != 1:
            body["n"] = n
        if max_tokens is not None:
            body["max_tokens"] = int(max_tokens)
        if seed is not None:
            body["seed"] = int(seed)
        if top_logprobs is not None:
            logprobs = True
            body["top_logprobs"] = int(top_logprobs)
        if logprobs:
            body["logprobs"] = True
        if response_format is not None:
            body["response_format"] = response_format
        body.update(extra)
        data = self.post("chat/completions", body, use_cache=use_cache)
        if not isinstance(data.get("choices"), list) or not data["choices"]:
            raise BackendUnavailableError(
                f"{self.base_url}/chat/completions answered without choices: {json.dumps(data)[:200]}"
            )
        return data

    def chat_json(self, messages: Sequence[dict[str, Any]], schema: dict[str, Any], *,
                  name: str = "answer", **kwargs: Any) -> Any:
        """Ask for JSON that follows ``schema`` (structured output) and return it parsed."""
        fmt = {"type": "json_schema", "json_schema": {"name": name, "schema": schema, "strict": True}}
        data = self.chat(messages, response_format=fmt, **kwargs)
        text = self.message_text(data)
        try:
            return json.loads(text)
        except (ValueError, RecursionError):
            raise EndpointCapabilityError(
                f"{self.model} at {self.base_url} answered text that is not JSON ({text[:120]!r}) "
                "although a JSON schema was requested; the endpoint may ignore response_format: "
                "use a server with structured output (vLLM, llama.cpp server with a grammar)"
            ) from None

    @staticmethod
    def message_text(data: dict[str, Any], index: int = 0) -> str:
        """The text of choice ``index`` of a chat answer (content parts joined)."""
        try:
            content = data["choices"][index]["message"]["content"]
        except (KeyError, IndexError, TypeError):
            raise BackendUnavailableError(
                f"chat answer has no choices[{index}].message.content: {json.dumps(data)[:200]}"
            ) from None
        if isinstance(content, list):
            content = "".join(str(p.get("text", "")) for p in content if isinstance(p, dict))
        return "" if content is None else str(content)

    # ----------------------------------------------------------------- transport

    def _request_key(self, path: str, body: dict[str, Any]) -> str:
        """Cache key of a request: model + path + canonical JSON body."""
        canon = json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
        return hashlib.sha256("\0".join((self.model_id, path, canon)).encode()).hexdigest()

    def post(self, path: str, body: dict[str, Any], *, use_cache: bool = True) -> dict[str, Any]:
        """POST JSON to ``base_url/path`` with retries; the answer as a dict (cached on disk)."""
        path = path.strip("/")
        return self._send(path, self._request_key(path, body), json.dumps(body).encode(), "application/json",
                          use_cache)

    def post_form(self, path: str, fields: Sequence[tuple[str, str]], files: Sequence[tuple[str, str, bytes, str]],
                  *, use_cache: bool = True) -> dict[str, Any]:
        """POST ``multipart/form-data`` (``fields``: (name, value); ``files``: (name, filename, bytes,
        content type)) with the same retries and cache as :meth:`post`; the JSON answer as a dict."""
        import uuid

        path = path.strip("/")
        canon = {"fields": [list(f) for f in fields],
                 "files": [[n, fn, hashlib.sha256(b).hexdigest(), ct] for n, fn, b, ct in files]}
        boundary = f"siftom-{uuid.uuid4().hex}"
        parts: list[bytes] = []
        for name, value in fields:
            parts.append(f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"\r\n\r\n{value}\r\n'
                         .encode())
        for name, filename, data, ctype in files:
            parts.append(f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"; filename="{filename}"'
                         f"\r\nContent-Type: {ctype}\r\n\r\n".encode() + data + b"\r\n")
        parts.append(f"--{boundary}--\r\n".encode())
        return self._send(path, self._request_key(path, canon), b"".join(parts),
                          f"multipart/form-data; boundary={boundary}", use_cache)

    def _send(self, path: str, key: str, payload: bytes, content_type: str, use_cache: bool) -> dict[str, Any]:
        """POST ``payload`` with retries and backoff; the JSON answer (cached under ``key``)."""
        if use_cache and self.response_cache is not None:
            hit = self.response_cache.get(key)
            if hit is not None:
                self.cache_hits += 1
                cached: dict[str, Any] = json.loads(hit)
                return cached
        url = f"{self.base_url}/{path}"
        headers = {"Content-Type": content_type}
        if self.config.api_key:
            headers["Authorization"] = f"Bearer {self.config.api_key}"
        attempts = self.config.max_retries + 1
        problem, wait = "", self.backoff_s
        for attempt in range(attempts):
            if attempt:
                self._sleep(min(wait, _MAX_BACKOFF_S))
                wait = self.backoff_s * 2**attempt
            req = urllib.request.Request(url, data=payload, headers=headers, method="POST")
            self.requests += 1
            try:
                with urllib.request.urlopen(req, timeout=self.config.timeout_s) as resp:
                    raw = resp.read()
            except urllib.error.HTTPError as e:
                detail = _read_detail(e)
                if e.code == 429 or e.code >= 500:
                    problem = f"HTTP {e.code}: {detail}"
                    wait = max(wait, _retry_after(e.headers.get("Retry-After") if e.headers else None))
                    continue
                raise self._http_error(path, e.code, detail) from None
            except urllib.error.URLError as e:
                if isinstance(e.reason, ConnectionRefusedError):
                    raise BackendUnavailableError(
                        f"cannot reach {url} (connection refused); is the server running? "
                        f"check {ENV_BASE_URL} / --llm-base-url"
                    ) from None
                problem = f"network error: {e.reason}"
                continue
            except (TimeoutError, ConnectionError, OSError) as e:
                problem = f"timed out after {self.config.timeout_s:g} s" if isinstance(e, TimeoutError) \
                    else f"network error: {e}"
                continue
            try:
                data = json.loads(raw.decode("utf-8"))
            except (UnicodeDecodeError, ValueError, RecursionError):  # ValueError: bad JSON, a 5000-digit int
                problem = f"malformed answer (not JSON): {raw[:120]!r}"
                continue
            if not isinstance(data, dict):
                problem = f"malformed answer (a JSON {type(data).__name__}, not an object)"
                continue
            if "error" in data and "choices" not in data and "text" not in data:
                raise self._http_error(path, 200, json.dumps(data["error"])[:300])
            if use_cache and self.response_cache is not None:
                self.response_cache.put(key, json.dumps(data))
            return data
        raise BackendUnavailableError(
            f"{url} failed {attempts} time(s), last: {problem}; raise SIFTOM_LLM_TIMEOUT / "
            "SIFTOM_LLM_MAX_RETRIES or check the server"
        )

    def _http_error(self, path: str, code: int, detail: str) -> BackendUnavailableError:
        url = f"{self.base_url}/{path}"
        if code in (401, 403):
            return BackendUnavailableError(
                f"{url} refused the credentials (HTTP {code}: {detail}); set {ENV_API_KEY}"
            )
        if code in (404, 405, 501):
            if "model" in detail.lower() and code == 404:
                return BackendUnavailableError(
                    f"{url}: model {self.model!r} not found (HTTP 404: {detail}); set {ENV_MODEL} "
                    "to a model the endpoint serves"
                )
            return EndpointCapabilityError(
                f"{url} does not exist (HTTP {code}); {_HINTS.get(path, 'check the API root')}"
            )
        low = detail.lower()
        if code in (400, 422) and any(w in low for w in _CAPABILITY_WORDS.get(path, ())):
            return EndpointCapabilityError(
                f"{url} rejected a parameter this path needs (HTTP {code}: {detail}); "
                + _HINTS.get(path, "")
            )
        return BackendUnavailableError(f"{url} answered HTTP {code}: {detail}")


def _read_detail(e: urllib.error.HTTPError) -> str:
    try:
        return e.read().decode(errors="replace")[:300]
    except Exception:  # noqa: BLE001 - the body is only used in the message
        return ""


def _retry_after(value: str | None) -> float:
    try:
        return max(0.0, float(value)) if value else 0.0
    except ValueError:
        return 0.0


# The old name: the completions scorer is this client's ``score`` method.
OpenAICompletionsScorer = OpenAIClient
