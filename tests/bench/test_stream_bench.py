"""siftom bench stream's scoring: which detected utterances count as cut, merged or missed, and the
delay measured from the true end of speech."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from siftom.bench.stream import SpokenInstruction, StreamBenchOptions, _score, noise_files

TRUTHS = [SpokenInstruction("a", "", 1.0, 2.0), SpokenInstruction("b", "", 3.0, 4.0),
          SpokenInstruction("c", "", 5.0, 6.0), SpokenInstruction("d", "", 7.0, 8.0)]


def answer(start, end, at, event="decision"):
    return (SimpleNamespace(start_s=start, end_s=end), {"event": event, "heard": "x", "command": "fetch(x)",
                                                         "decision": "act", "timings": {}}, at)


def test_outcomes_and_delays():
    t0 = 100.0
    answers = [answer(0.95, 2.05, t0 + 2.5),  # a: ok, decided 0.5 s after its end
               answer(2.9, 3.5, t0 + 4.0), answer(3.6, 4.05, t0 + 4.6),  # b: cut in two
               answer(4.9, 8.1, t0 + 8.6)]  # c and d merged into one
    r = _score(answers, TRUTHS, t0)
    assert [u["outcome"] for u in r["utterances"]] == ["ok", "cut", "merged", "merged"]
    assert r["utterances"][0]["delay_s"] == pytest.approx(0.5)
    assert (r["p50_s"], r["answered"], r["cut_share"], r["merged_share"], r["missed"]) == (pytest.approx(0.5), 1, 0.25, 0.5, 0)


def test_an_early_end_is_a_cut_and_nothing_is_a_miss():
    r = _score([answer(0.95, 1.7, 102.0)], TRUTHS[:2], 100.0)  # ends 0.3 s before the speech does
    assert [u["outcome"] for u in r["utterances"]] == ["cut", "missed"]
    assert r["p50_s"] is None and r["missed"] == 1


def test_noise_clip_selection():
    every = noise_files(StreamBenchOptions())
    assert len(every) == 44
    quick = noise_files(StreamBenchOptions(quick=True))
    assert len(quick) == len({f.stem.rsplit("_", 1)[0] for f in every}) == 11  # one per category
    assert [f.stem for f in noise_files(StreamBenchOptions(noise_clips=("fan_01",)))] == ["fan_01"]


@pytest.mark.skipif(__import__("shutil").which("flite") is None, reason="flite is not installed")
def test_the_bench_streams_a_spoken_request_and_scores_the_answer(tmp_path):
    """The real listener behind the bench (not stand-in dicts): a request streamed in chunks is
    cut, answered and scored as the person's request."""
    import subprocess

    import numpy as np

    from siftom.bench.stream import RATE, _home, _noise_triggers
    from siftom.speech.audio import load_audio

    wav = tmp_path / "say.wav"
    subprocess.run(["flite", "-voice", "slt", "-t", "can you pass me the cereal", "-o", str(wav)], check=True)
    x = load_audio(wav)
    padded = tmp_path / "padded.wav"
    import soundfile as sf

    sf.write(padded, np.concatenate([np.zeros(RATE // 2), x, np.zeros(RATE)]).astype(np.float32), RATE)
    home = _home("phonetic")
    try:
        got = _noise_triggers(padded, len(x) / RATE + 1.5, home)
    finally:
        home.close()
    assert got["segments"] >= 1 and got["decisions"] >= 1
    assert any("cereal" in h for h in got["heard"])
