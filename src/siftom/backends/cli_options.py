"""The ``--llm-backend``, ``--llm-base-url`` and ``--llm-model`` flags shared by ``infer``, ``eval``
and ``serve`` (they override ``SIFTOM_LLM_*``; docs/llm.md)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

from siftom.backends.config import LLM_BACKENDS, LLMConfig

F = Callable[..., Any]


def llm_options(f: F) -> F:
    """Add the three flags to a click command (parameters llm_backend, llm_base_url, llm_model)."""
    f = click.option("--llm-model", default=None,
                     help="model name at the endpoint, or a .gguf path / packaged model for llama "
                          "(smollm2-135m, gemma3-270m) [env SIFTOM_LLM_MODEL]")(f)
    f = click.option("--llm-base-url", default=None,
                     help="OpenAI-compatible API root, e.g. http://127.0.0.1:8000/v1 (implies "
                          "--llm-backend openai) [env SIFTOM_LLM_BASE_URL]")(f)
    f = click.option("--llm-backend", type=click.Choice(LLM_BACKENDS.names()), default=None,
                     help="language model: llama (in process) or openai (HTTP endpoint) "
                          "[env SIFTOM_LLM_BACKEND]")(f)
    return f


def flags_given(backend: str | None, base_url: str | None, model: str | None) -> bool:
    """True when any of the flags was given."""
    return any(v is not None for v in (backend, base_url, model))


def llm_config(backend: str | None, base_url: str | None, model: str | None) -> LLMConfig:
    """The configuration from the environment with the flags on top."""
    if base_url is not None and backend is None:
        backend = "openai"
    return LLMConfig.from_env(backend=backend, base_url=base_url, model=model)
