"""Every ``SIFTOM_*`` environment variable siftom reads, what it means, and the one place it is read.

The settings sections' own variables (``SIFTOM_INFER_LIKELIHOOD``, ``SIFTOM_SERVICE_WORKERS`` ...)
are derived from the option classes by :class:`siftom.settings.Settings`; the variables below
configure parts that have no section (a process-wide switch, an endpoint, a model folder). A
stage that needs one asks this module by name; a name missing from :data:`VARIABLES` is an
error, so every variable siftom reads is listed here (``siftom config show`` prints them).

This module sits at the bottom of the house with the rest of :mod:`siftom.settings`: any stage
may import it.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from siftom.errors import BackendUnavailableError, SettingsError

CONFIG = "SIFTOM_CONFIG"
PREFIX = "SIFTOM_"

# LLM (docs/llm.md); the deprecated spellings are still honoured (the new name wins when both are set)
LLM_BACKEND = "SIFTOM_LLM_BACKEND"
LLM_BASE_URL = "SIFTOM_LLM_BASE_URL"
LLM_MODEL = "SIFTOM_LLM_MODEL"
LLM_API_KEY = "SIFTOM_LLM_API_KEY"
LLM_TIMEOUT = "SIFTOM_LLM_TIMEOUT"
LLM_MAX_RETRIES = "SIFTOM_LLM_MAX_RETRIES"
LLM_PROMPT = "SIFTOM_LLM_PROMPT"
LLM_THREADS = "SIFTOM_LLM_THREADS"
CACHE_DIR = "SIFTOM_CACHE_DIR"
LLM_BACKEND_OLD = "SIFTOM_LLM"
CACHE_DIR_OLD = "SIFTOM_CACHE"
LLM_GGUF_OLD = "SIFTOM_LLM_GGUF"

VLM_MODEL = "SIFTOM_VLM_MODEL"
ASR_BASE_URL = "SIFTOM_ASR_BASE_URL"
ASR_MODEL = "SIFTOM_ASR_MODEL"
ASR_API_KEY = "SIFTOM_ASR_API_KEY"
WHISPER_MODEL = "SIFTOM_WHISPER_MODEL"
ASR_WORKERS = "SIFTOM_ASR_WORKERS"
NO_NUMBA = "SIFTOM_NO_NUMBA"
TOKEN = "SIFTOM_TOKEN"

VARIABLES: Mapping[str, str] = {
    CONFIG: "the settings file (TOML) read when no --config is given",
    LLM_BACKEND: "the LLM backend: llama (in process) or openai (an HTTP endpoint)",
    LLM_BASE_URL: "an OpenAI-compatible endpoint's API root, e.g. http://127.0.0.1:8000/v1",
    LLM_MODEL: "the served model name (openai) or a GGUF path / packaged model (llama)",
    LLM_API_KEY: "the endpoint's bearer token (environment only: keep keys out of shell history)",
    LLM_TIMEOUT: "seconds per LLM HTTP request",
    LLM_MAX_RETRIES: "retries after a 429, a 5xx, a timeout or a dropped connection",
    LLM_PROMPT: "the LLM likelihood's prompt: sounds (pronunciations shown) or plain",
    LLM_THREADS: "CPU threads of the in-process LLM (default: llama.cpp's)",
    CACHE_DIR: "the folder of every siftom cache (default $XDG_CACHE_HOME/siftom or ~/.cache/siftom)",
    LLM_BACKEND_OLD: f"deprecated spelling of {LLM_BACKEND}",
    CACHE_DIR_OLD: f"deprecated spelling of {CACHE_DIR}",
    LLM_GGUF_OLD: f"deprecated: {LLM_MODEL} takes a GGUF path too",
    VLM_MODEL: f"the vision model of `siftom perceive` (default: {LLM_MODEL})",
    ASR_BASE_URL: "an OpenAI-compatible transcription endpoint (the openai-server ASR engine)",
    ASR_MODEL: "the transcription endpoint's model name",
    ASR_API_KEY: "the transcription endpoint's bearer token",
    WHISPER_MODEL: "a CTranslate2 Whisper folder used instead of the packaged tiny.en (--whisper-model)",
    ASR_WORKERS: "how many warm ASR worker processes a server keeps (0: decode in the calling process)",
    NO_NUMBA: "set to skip the compiled planner core (the pure-numpy path computes the same numbers)",
    TOKEN: "the service's access token when --token/--token-file are not given",
}


def read(name: str, env: Mapping[str, str] | None = None) -> str | None:
    """The value of ``SIFTOM_*`` variable ``name`` in ``env`` (default: the process environment),
    None when unset or empty. ``name`` must be listed in :data:`VARIABLES`."""
    if name not in VARIABLES:
        raise SettingsError(f"{name} is not a siftom environment variable; list it in "
                            "siftom.settings.environment.VARIABLES with what it means")
    value = (os.environ if env is None else env).get(name)
    return value if value else None


def cache_root(env: Mapping[str, str] | None = None) -> Path:
    """``$SIFTOM_CACHE_DIR`` (or the deprecated ``$SIFTOM_CACHE``), else
    ``$XDG_CACHE_HOME/siftom`` or ``~/.cache/siftom``. Every siftom cache lives under it."""
    env = os.environ if env is None else env
    value = read(CACHE_DIR, env) or read(CACHE_DIR_OLD, env)
    if value:
        return Path(value).expanduser()
    return Path(env.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "siftom"


def llm_configured(env: Mapping[str, str] | None = None) -> bool:
    """True when the environment names an LLM (a backend or an endpoint).

    Optional LLM uses (the evaluator's LLM baselines) run only then; the LLM likelihood itself
    falls back to the in-process SmolLM2 when nothing is configured.
    """
    return bool(read(LLM_BACKEND, env) or read(LLM_BACKEND_OLD, env) or read(LLM_BASE_URL, env))


def numba_disabled() -> bool:
    """Whether ``SIFTOM_NO_NUMBA`` asks for the pure-numpy planner core."""
    return read(NO_NUMBA) is not None


def asr_workers(default: int) -> int:
    """How many ASR worker processes one process keeps (``SIFTOM_ASR_WORKERS``; 0 = none)."""
    raw = (read(ASR_WORKERS) or "").strip().lower()
    if raw in ("0", "false", "no", "off"):
        return 0
    return int(raw) if raw.isdigit() else default


def llm_threads() -> int | None:
    """CPU threads of the in-process LLM (``SIFTOM_LLM_THREADS``), None for llama.cpp's default."""
    value = (read(LLM_THREADS) or "").strip()
    if not value:
        return None
    if not value.isdigit() or int(value) < 1:
        raise BackendUnavailableError(
            f"{LLM_THREADS} must be a whole number >= 1 (CPU threads), got {value!r}; fix or unset it")
    return int(value)
