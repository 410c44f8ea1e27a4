"""Ask a vision-language model one question, check the answer, retry once with the reason.

The model is any OpenAI-compatible ``/chat/completions`` endpoint that takes image parts
(vLLM, llama.cpp server, Ollama, hosted APIs), reached through
:class:`siftom.backends.openai_compat.OpenAIClient` with the LLM configuration
(``SIFTOM_LLM_BASE_URL``, ``SIFTOM_LLM_API_KEY``, timeouts and retries with backoff); the model
name is ``SIFTOM_VLM_MODEL``, else ``SIFTOM_LLM_MODEL``.

Each question is sent with its JSON schema (structured output). An answer is parsed, checked
against the schema, then by the question's own check (scene graph, action legality, goals);
when that fails, the model sees its answer and the checker's message once more and may
correct it. A second failure is a :class:`~siftom.errors.PerceptionError`: nothing is repaired
silently. Accepted answers are cached on disk under a key made of the images' SHA-256, the
prompt, the schema and the model, so re-running a benchmark costs nothing.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TypeVar

from siftom.errors import BackendUnavailableError, PerceptionError
from siftom.perception.frames import Frame
from siftom.perception.prompts import SYSTEM
from siftom.perception.schemas import SCHEMAS, check_schema
from siftom.safejson import loads
from siftom.settings.environment import VLM_MODEL, read

T = TypeVar("T")
ENV_VLM_MODEL = VLM_MODEL
RETRY = ("Your answer was rejected: {error}\nAnswer the same question again with corrected JSON only, "
         "matching the schema.")
_FENCE = re.compile(r"^\s*```(?:json)?\s*\n(.*)\n\s*```\s*$", re.DOTALL)


def cache_key(model: str, schema: str, prompt: str, frames: Sequence[Frame]) -> str:
    """SHA-256 of the model, the schema name, the system and user prompts and each image's SHA-256."""
    parts = [model, schema, SYSTEM, prompt, *(f.sha256 for f in frames)]
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()


class AnswerCache:
    """Accepted answers as JSON files named by their key (written atomically)."""

    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)

    def get(self, key: str) -> Any | None:
        path = self.folder / f"{key}.json"
        try:
            return json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None

    def put(self, key: str, value: Any) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=self.folder, suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(value, fh)
        os.replace(tmp, self.folder / f"{key}.json")


def parse_answer(content: str | None) -> Any:
    """The JSON object in a message (a ```json fence around it is allowed); PerceptionError otherwise."""
    if not isinstance(content, str) or not content.strip():
        raise PerceptionError("the answer is empty; answer with one JSON object")
    m = _FENCE.match(content)
    text = m.group(1) if m else content
    try:
        value = loads(text, "the answer", PerceptionError)
    except PerceptionError as exc:
        raise PerceptionError(f"{exc}: {content[:80]!r}") from None
    if not isinstance(value, dict):
        raise PerceptionError(f"the answer is a JSON {type(value).__name__}, not an object")
    return value


class VisionModel:
    """One vision-language model behind an OpenAI-compatible endpoint.

    Args:
        client: an :class:`~siftom.backends.openai_compat.OpenAIClient` (default: from the
            environment, model ``$SIFTOM_VLM_MODEL`` or ``$SIFTOM_LLM_MODEL``).
        model: the model name (overrides the environment).
        use_cache: keep accepted answers on disk (``<cache_dir>/perception``).
        max_tokens: the longest answer asked for (a 50-object scene graph is ~6k tokens).

    Counters: ``requests`` (questions sent to the model, retries included) and ``cache_hits``.
    """

    def __init__(self, client: Any = None, *, model: str | None = None, use_cache: bool = True,
                 max_tokens: int = 8192, **overrides: Any) -> None:
        if client is None:
            from siftom.backends.config import LLMConfig
            from siftom.backends.openai_compat import OpenAIClient

            name = model or read(ENV_VLM_MODEL)
            config = LLMConfig.from_env(backend="openai", model=name, **overrides)
            client = OpenAIClient(config, use_cache=False)
        self.client = client
        self.model: str = client.model
        client_config = getattr(client, "config", None)
        if client_config is not None:
            folder = client_config.resolved_cache_dir / "perception"
        else:
            from siftom.backends.config import cache_root

            folder = cache_root() / "perception"
        self.cache = AnswerCache(folder) if use_cache else None
        self.max_tokens = max_tokens
        self.requests = 0
        self.cache_hits = 0

    def ask(self, stage: str, prompt: str, frames: Sequence[Frame], schema: str, check: Callable[[Any], T]) -> T:
        """Ask, check with ``check`` (raising PerceptionError), retry once; the checked value."""
        key = cache_key(self.model, schema, prompt, frames)
        if self.cache is not None:
            hit = self.cache.get(key)
            if hit is not None:
                try:
                    value = check(hit)
                except PerceptionError:  # accepted by an older siftom, not by this one: ask again
                    pass
                else:
                    self.cache_hits += 1
                    return value
        parts: list[dict[str, Any]] = [{"type": "text", "text": prompt}]
        parts += [{"type": "image_url", "image_url": {"url": f.data_url()}} for f in frames]
        messages: list[dict[str, Any]] = [{"role": "system", "content": SYSTEM}, {"role": "user", "content": parts}]
        def validated(text: str | None) -> tuple[Any, Any]:
            answer = parse_answer(text)
            check_schema(answer, schema)
            return answer, check(answer)

        content = self._chat(messages, schema, stage)
        try:
            answer, value = validated(content)
        except PerceptionError as first:
            messages += [{"role": "assistant", "content": content or ""},
                         {"role": "user", "content": RETRY.format(error=first)}]
            content = self._chat(messages, schema, stage)
            try:
                answer, value = validated(content)
            except PerceptionError as second:
                why = f"{second}" if str(second) == str(first) else f"first: {first}; after being told: {second}"
                raise PerceptionError(
                    f"{stage}: the model's answer was rejected twice ({why}). Try a stronger vision model "
                    f"({ENV_VLM_MODEL}) or clearer frames; see docs/perception.md"
                ) from None
        if self.cache is not None:
            self.cache.put(key, answer)
        return value

    def _chat(self, messages: list[dict[str, Any]], schema: str, stage: str) -> str | None:
        fmt = {"type": "json_schema", "json_schema": {"name": schema, "schema": SCHEMAS[schema], "strict": True}}
        self.requests += 1
        try:
            data = self.client.chat(messages, response_format=fmt, temperature=0.0, max_tokens=self.max_tokens,
                                    use_cache=False)
        except BackendUnavailableError as exc:
            raise type(exc)(f"{stage}: {exc}") from None
        try:
            choice = data["choices"][0]
            content = choice["message"]["content"]
        except (KeyError, IndexError, TypeError):
            raise BackendUnavailableError(f"{stage}: the endpoint's answer has no choices[0].message.content; "
                                          "is it an OpenAI-compatible chat endpoint?") from None
        if choice.get("finish_reason") == "length":
            raise PerceptionError(f"{stage}: the answer was cut off at {self.max_tokens} tokens; raise it "
                                  "(siftom perceive --max-tokens N, or VisionModel(max_tokens=N)) or show fewer "
                                  "objects per frame")
        text: str | None = content
        return text
