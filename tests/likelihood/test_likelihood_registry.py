from pathlib import Path

import pytest

from siftom.errors import BackendUnavailableError, ObservationError, UnknownNameError
from siftom.likelihood.base import Instruction, InstructionLikelihood
from siftom.likelihood.registry import REGISTRY, get_likelihood, likelihood_names, likelihood_spec


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
    assert REGISTRY["acoustic"].needs_audio and not REGISTRY["acoustic"].needs_text
    assert REGISTRY["phonetic"].needs_text and not REGISTRY["phonetic"].needs_audio
    with pytest.raises(ObservationError, match="needs audio"):
        likelihood_spec("acoustic").check(Instruction.from_text("milk"))
    with pytest.raises(ObservationError, match="transcript"):
        likelihood_spec("llm").check(Instruction(audio=Path("a.wav")))


def test_llm_without_backend_says_how_to_install(monkeypatch):
    pytest.importorskip("siftom.backends.llama_cpp")
    try:
        import llama_cpp  # noqa: F401
    except ImportError:
        with pytest.raises(BackendUnavailableError, match=r"siftom\[llm\]"):
            get_likelihood("llm")
