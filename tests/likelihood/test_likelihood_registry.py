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
    pytest.importorskip("siftom.backends.llama_cpp")
    try:
        import llama_cpp  # noqa: F401
    except ImportError:
        with pytest.raises(BackendUnavailableError, match=r"siftom\[llm\]"):
            get_likelihood("llm")


def test_an_endpoint_in_the_environment_makes_llm_available(monkeypatch):
    monkeypatch.setenv("SIFTOM_LLM_BASE_URL", "http://127.0.0.1:9/v1")
    monkeypatch.delenv("SIFTOM_LLM_MODEL", raising=False)
    assert "SIFTOM_LLM_MODEL" in likelihood_spec("llm").missing()  # the fix is named
    monkeypatch.setenv("SIFTOM_LLM_MODEL", "some-model")
    assert likelihood_spec("llm").missing() is None
