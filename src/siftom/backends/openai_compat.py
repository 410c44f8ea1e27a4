"""Prompt log-probs from any OpenAI-compatible ``/v1/completions`` endpoint.

Works with vLLM, the llama.cpp server, and hosted APIs that return prompt log-probs for
``echo=True, logprobs=1, max_tokens=0``. (The llama.cpp server's prompt log-probs are shifted by
one token for models without a BOS token, upstream issue #1983; prefer the in-process backend
for those.) Responses are cached on disk, so repeated evaluations cost nothing.
"""

from __future__ import annotations

import json
import os
import urllib.error
import urllib.request
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from siftom.backends.scoring import ScoreCache, default_cache_dir
from siftom.errors import BackendUnavailableError

ENV_BASE_URL = "SIFTOM_LLM_BASE_URL"
ENV_API_KEY = "SIFTOM_LLM_API_KEY"
ENV_MODEL = "SIFTOM_LLM_MODEL"


class OpenAICompletionsScorer:
    """Score texts through an OpenAI-compatible completions endpoint.

    Args:
        base_url: e.g. ``http://127.0.0.1:8000/v1`` (default ``$SIFTOM_LLM_BASE_URL``).
        api_key: bearer token (default ``$SIFTOM_LLM_API_KEY``; none sent when empty).
        model: model name sent in the request (default ``$SIFTOM_LLM_MODEL``).
        cache_dir: folder for the SQLite cache (default :func:`default_cache_dir`); ``None``
            keeps the default, ``False`` disables the cache.
        batch_size: prompts per request (the API accepts a list of prompts).
        timeout: seconds per request.
    """

    def __init__(
        self,
        base_url: str | None = None,
        api_key: str | None = None,
        model: str | None = None,
        *,
        cache_dir: Path | str | None | bool = None,
        batch_size: int = 8,
        timeout: float = 60.0,
    ) -> None:
        base_url = base_url or os.environ.get(ENV_BASE_URL)
        if not base_url:
            raise BackendUnavailableError(
                f"no endpoint for the OpenAI-compatible LLM backend; pass base_url= or set "
                f"{ENV_BASE_URL}, e.g. http://127.0.0.1:8000/v1"
            )
        self.base_url = base_url.rstrip("/")
        self.api_key = api_key if api_key is not None else os.environ.get(ENV_API_KEY, "")
        self.model = model or os.environ.get(ENV_MODEL, "")
        if not self.model:
            raise BackendUnavailableError(
                f"no model name for the OpenAI-compatible LLM backend; pass model= or set {ENV_MODEL}"
            )
        if batch_size < 1:
            raise BackendUnavailableError(f"batch_size must be >= 1, got {batch_size}")
        self.batch_size = batch_size
        self.timeout = timeout
        self.model_id = f"openai:{self.base_url}:{self.model}"
        self.requests = 0  # counter: HTTP requests made
        if cache_dir is False:
            self.cache: ScoreCache | None = None
        else:
            folder = Path(cache_dir) if isinstance(cache_dir, str | Path) else default_cache_dir()
            self.cache = ScoreCache(folder / "llm-scores.sqlite")

    def score(self, prefix: str, items: Sequence[tuple[str, str]]) -> list[float]:
        """log P(target | prefix + context) for each (context, target)."""
        prompts = [prefix + ctx for ctx, _ in items]
        keys = [ScoreCache.key(self.model_id, p, t) for p, (_, t) in zip(prompts, items, strict=True)]
        found = self.cache.get_many(keys) if self.cache is not None else {}
        todo = [k for k, key in enumerate(keys) if key not in found]
        new: dict[str, float] = {}
        for start in range(0, len(todo), self.batch_size):
            chunk = todo[start : start + self.batch_size]
            values = self._request([(prompts[k], items[k][1]) for k in chunk])
            for k, v in zip(chunk, values, strict=True):
                new[keys[k]] = v
        if new and self.cache is not None:
            self.cache.put_many(new)
        found.update(new)
        return [found[k] for k in keys]

    def _request(self, pairs: Sequence[tuple[str, str]]) -> list[float]:
        body = {
            "model": self.model,
            "prompt": [p + t for p, t in pairs],
            "max_tokens": 0,
            "echo": True,
            "logprobs": 1,
            "temperature": 0.0,
        }
        headers = {"Content-Type": "application/json"}
        if self.api_key:
            headers["Authorization"] = f"Bearer {self.api_key}"
        req = urllib.request.Request(f"{self.base_url}/completions", data=json.dumps(body).encode(),
                                     headers=headers, method="POST")
        self.requests += 1
        try:
            with urllib.request.urlopen(req, timeout=self.timeout) as resp:
                data = json.loads(resp.read().decode())
        except urllib.error.HTTPError as e:
            detail = e.read().decode(errors="replace")[:300]
            raise BackendUnavailableError(
                f"{self.base_url}/completions answered HTTP {e.code}: {detail}"
            ) from e
        except (urllib.error.URLError, TimeoutError, OSError) as e:
            raise BackendUnavailableError(
                f"cannot reach {self.base_url}/completions ({e}); check {ENV_BASE_URL}"
            ) from e
        except json.JSONDecodeError as e:
            raise BackendUnavailableError(f"{self.base_url}/completions returned invalid JSON") from e
        choices = sorted(data.get("choices") or [], key=lambda c: c.get("index", 0))
        if len(choices) != len(pairs):
            raise BackendUnavailableError(
                f"{self.base_url}/completions returned {len(choices)} choices for {len(pairs)} prompts; "
                "if the server takes one prompt per request, use batch_size=1"
            )
        return [_target_logprob(c, p, t) for c, (p, t) in zip(choices, pairs, strict=True)]


def _target_logprob(choice: dict[str, Any], prompt: str, target: str) -> float:
    """Sum the log-probs of the echoed tokens that overlap the target's characters."""
    lp = choice.get("logprobs") or {}
    tokens = lp.get("tokens")
    values = lp.get("token_logprobs")
    if not tokens or values is None:
        raise BackendUnavailableError(
            "the endpoint returned no prompt log-probs; it must support echo=True with logprobs "
            "(vLLM, llama.cpp server; not every hosted API does)"
        )
    offsets = lp.get("text_offset")
    if offsets is None:  # reconstruct from token lengths
        offsets, pos = [], 0
        for tok in tokens:
            offsets.append(pos)
            pos += len(tok)
    start = len(prompt)
    total = 0.0
    for tok, off, v in zip(tokens, offsets, values, strict=False):
        if off + len(tok) > start and v is not None and off < start + len(target):
            total += float(v)
    return total
