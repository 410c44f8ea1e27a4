"""Bad output paths and out-of-range numbers on the command line end in a one-line error naming
the fix, never a traceback."""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from siftom.cli import main

needs_flite = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
needs_dev_full = pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux)")


def _run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str]:
    try:
        code = main(list(args))
    except SystemExit as exc:  # click's usage errors
        code = exc.code if isinstance(exc.code, int) else 1
    cap = capsys.readouterr()
    return code, cap.out + cap.err


def _one_line_error(out: str) -> str:
    assert "Traceback" not in out, out
    errors = [line for line in out.splitlines() if line.lower().startswith("error:")]
    assert len(errors) == 1, out
    return errors[0]


@needs_flite
@needs_dev_full
def test_say_to_a_full_device_is_a_one_line_error(capsys):
    code, out = _run(capsys, "say", "hello", "-o", "/dev/full")
    assert code != 0
    line = _one_line_error(out)
    assert line.startswith("Error: cannot write") and "/dev/full" in line and "give -o" in line


@needs_flite
def test_say_when_the_disk_is_full_is_a_one_line_error(capsys, monkeypatch, tmp_path):
    import siftom.speech.audio as audio

    def full(path: object, x: object, rate: int = 16000) -> Path:
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(audio, "write_wav", full)
    code, out = _run(capsys, "say", "hello", "-o", str(tmp_path / "x.wav"))
    assert code != 0
    line = _one_line_error(out)
    assert "No space left on device" in line and str(tmp_path / "x.wav") in line


@needs_flite
@pytest.mark.parametrize("args", [["--noise", "babble"], ["--seed", "-1"], ["--snr", "1e5"],
                                  ["--noise", "babble", "--snr", "1e5"], ["--noise", "babble", "--seed", "-1"],
                                  ["--noise", "babble", "--snr", "nan"], ["--noise", "babble", "--snr", "-1e5"]])
def test_say_options_give_a_wav_or_a_one_line_error(capsys, tmp_path, args):
    wav = tmp_path / "x.wav"
    code, out = _run(capsys, "say", "hello", *args, "-o", str(wav))
    if code == 0:
        assert wav.is_file() and "Traceback" not in out
    else:
        _one_line_error(out)
        assert not wav.exists()


@pytest.fixture
def recorded(tmp_path: Path) -> Path:
    from siftom.people.collect import Collection, CollectOptions
    from siftom.speech.audio import wav_bytes

    t = np.arange(16000) / 16000
    c = Collection(tmp_path / "ds", CollectOptions(domain="kitchen-v0", scenarios=1))
    c.agree("p1")
    c.save("p1", 0, wav_bytes((0.3 * np.sin(2 * np.pi * 220 * t)).astype(np.float32)), "bring me the milk")
    return tmp_path / "ds"


@pytest.mark.parametrize("args", [["--seed", "-1"], ["--snr", "1e5"], ["--snr=-1e5"], ["--snr", "nan"],
                                  ["--snr", "10,1e5"]])
def test_dataset_mix_numbers_out_of_range_are_one_line_errors(capsys, recorded, args):
    code, out = _run(capsys, "dataset", "mix", str(recorded), *args)
    assert code != 0
    line = _one_line_error(out)
    assert "--seed" in line or "--snr" in line


def test_dataset_mix_still_mixes(capsys, recorded):
    code, out = _run(capsys, "dataset", "mix", str(recorded), "--snr", "20,5", "--seed", "3")
    assert code == 0, out
    assert "2 noisy copies" in out


def test_dataset_mix_that_cannot_write_is_a_one_line_error(capsys, monkeypatch, recorded):
    import siftom.speech.audio as audio

    def full(path: object, x: object, rate: int = 16000) -> Path:
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(audio, "write_wav", full)
    code, out = _run(capsys, "dataset", "mix", str(recorded))
    assert code != 0
    line = _one_line_error(out)
    assert str(recorded) in line and "No space left on device" in line and "free disk space" in line


def test_dataset_build_that_cannot_write_is_a_one_line_error(capsys, monkeypatch, tmp_path):
    import siftom.speech.audio as audio

    def full(path: object, x: object, rate: int = 16000) -> Path:
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(audio, "write_wav", full)
    out_dir = tmp_path / "built"
    code, out = _run(capsys, "dataset", "build", "--domain", "kitchen-v0", "--out", str(out_dir), "--scenarios", "1",
                     "--speakers", "1", "--voices", "flite-slt", "--snr", "none", "--workers", "1")
    assert code != 0
    line = _one_line_error(out)
    assert str(out_dir) in line and "No space left on device" in line


@pytest.mark.parametrize("args", [("demo", "--seed", "-1"), ("demo", "--snr", "1e5"),
                                  ("bench", "latency", "--snr", "1e5", "--quick", "--repeats", "1"),
                                  ("bench", "stream", "--seed", "-1", "--quick", "--noise-seconds", "0"),
                                  ("bench", "acoustic", "--snr", "1e5", "--quick")])
def test_every_command_that_mixes_noise_refuses_a_bad_seed_or_snr_in_one_line(capsys, args):
    code, out = _run(capsys, *args)
    assert code != 0
    line = _one_line_error(out)
    assert ("seed" in line and ">= 0" in line) or ("SNR" in line and "-50 to 100 dB" in line), line


def test_a_mix_refuses_what_no_command_should_pass_it():
    from siftom.errors import AudioError
    from siftom.speech.noise import make_rng, mix_at_snr

    speech = np.sin(np.arange(16000) / 5.0)
    for snr in (1e5, -1e5, float("nan")):
        with pytest.raises(AudioError, match="outside -50 to 100 dB"):
            mix_at_snr(speech, np.ones(100), snr, 0)
    with pytest.raises(AudioError, match=">= 0"):
        make_rng(-1)
    assert mix_at_snr(speech, np.ones(100), 10, 0).shape == speech.shape
