"""The speech subcommands end to end through siftom.cli.main."""

from __future__ import annotations

import json
import shutil

import pytest

from siftom.cli import main

needs_flite = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")


@needs_flite
def test_say_then_transcribe_json(tmp_path, capsys):
    out = tmp_path / "say.wav"
    assert main(["say", "pass me the cereal", "--voice", "flite-slt", "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["transcribe", str(out), "--nbest", "5", "--vocab", "cereal,milk,sugar", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["text"] == "pass me the cereal"
    assert all(set(h) == {"text", "score"} for h in data["nbest"])
    assert "words" in data and "rtf" in data
    assert data["no_speech"] is False and data["vad"]["speech"] is True


def test_transcribe_says_no_speech_for_silence_and_noise(tmp_path, capsys):
    import numpy as np

    from siftom.speech.audio import write_wav
    from siftom.speech.noise import get_noise

    silence, noise = tmp_path / "silence.wav", tmp_path / "noise.wav"
    write_wav(silence, np.zeros(16000 * 3, np.float32))
    write_wav(noise, 0.1 * get_noise("pink").sample(16000 * 3, np.random.default_rng(0)))
    for path in (silence, noise):
        assert main(["transcribe", str(path), "--json"]) == 0
        data = json.loads(capsys.readouterr().out)
        assert data["no_speech"] is True and data["text"] == "" and data["nbest"] == []
    assert main(["transcribe", str(silence)]) == 0
    captured = capsys.readouterr()
    assert captured.out == "" and "no speech heard" in captured.err


@needs_flite
def test_say_with_noise_is_deterministic(tmp_path):
    a, b = tmp_path / "a.wav", tmp_path / "b.wav"
    for p in (a, b):
        assert main(["say", "bring me the milk", "--noise", "pink", "--snr", "5", "--seed", "7", "-o", str(p)]) == 0
    assert a.read_bytes() == b.read_bytes()


def test_voices_json(capsys):
    assert main(["voices", "--json"]) == 0
    names = {v["name"] for v in json.loads(capsys.readouterr().out)}
    assert {"flite-slt", "espeak-en-us+klatt", "espeak-es"} <= names


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["say", "hi", "--voice", "nobody", "-o", "x.wav"], "unknown voice"),
        (["transcribe", "missing.wav"], "does not exist"),
        (["transcribe", "notes.txt"], "not a WAV"),
    ],
)
def test_errors_are_one_line(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("hello" * 100)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


@pytest.mark.parametrize("engine", ["pocketsphinx-vocab", "pocketsphinx-dual"])
def test_scene_engine_without_vocab_names_the_flag(tmp_path, capsys, engine):
    import numpy as np

    from siftom.speech.audio import write_wav

    wav = write_wav(tmp_path / "a.wav", np.zeros(16000, np.float32))
    assert main(["transcribe", str(wav), "--engine", engine]) == 2
    err = capsys.readouterr().err
    assert "--vocab" in err and f"--engine {engine}" in err and err.count("\n") == 1
    assert "vocabulary=" not in err  # the command line's flag, not the Python argument


def test_long_file_is_refused_by_transcribe(tmp_path, capsys):
    import numpy as np
    import soundfile as sf

    p = tmp_path / "long.wav"
    sf.write(p, np.zeros(8000 * 60 * 30, np.int16), 8000)
    assert main(["transcribe", str(p)]) == 2
    assert "1800 s" in capsys.readouterr().err


@pytest.mark.slow
def test_bench_asr_quick(tmp_path, capsys):
    assert main(["bench", "asr", "--quick", "--json", "--out", str(tmp_path)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["rows"] and (tmp_path / "wer_vs_snr.png").is_file()
