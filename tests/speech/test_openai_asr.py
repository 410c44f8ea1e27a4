"""The OpenAI-compatible transcription engine against a local fake server: the wire format, the
N-best from samples, retries, the cache and the errors that say how to fix the setup."""

from __future__ import annotations

import numpy as np
import pytest

from siftom.errors import BackendUnavailableError
from siftom.speech.asr.base import get_engine
from support.fake_openai import Reply, form, transcription_answer

CLIP = (0.1 * np.sin(np.arange(32_000) * 2 * np.pi * 220 / 16_000)).astype(np.float32)


def engine(server, tmp_path, **kw):
    return get_engine("openai", base_url=server.url, model="whisper-small", cache_dir=tmp_path,
                      backoff_s=0.0, **kw)


def by_temperature(answers):
    """A handler answering each request by its temperature field."""
    def handle(req):
        fields = dict(form(req)[0])
        return Reply.json(answers[fields["temperature"]])
    return handle


def test_request_is_multipart_verbose_json_with_the_wav(fake_openai, tmp_path):
    fake_openai.on("audio/transcriptions", lambda r: Reply.json(transcription_answer(
        " Can you pass me the cereal?", -0.2, words=[("Can", 0.1, 0.3), ("you", 0.3, 0.4), ("pass", 0.4, 0.6),
                                                       ("me", 0.6, 0.7), ("the", 0.7, 0.8), ("cereal?", 0.8, 1.3)])))
    tr = engine(fake_openai, tmp_path).transcribe(CLIP, nbest=1)
    assert tr.text == "can you pass me the cereal" and tr.engine == "openai"
    assert [w.text for w in tr.words][-1] == "cereal" and tr.words[-1].end == pytest.approx(1.3)
    req = fake_openai.requests[-1]
    assert req.path == "audio/transcriptions" and req.headers["Content-Type"].startswith("multipart/form-data")
    fields, files = form(req)
    f = dict(fields)
    assert f["model"] == "whisper-small" and f["response_format"] == "verbose_json" and f["temperature"] == "0"
    assert ("timestamp_granularities[]", "word") in fields and f["language"] == "en"
    assert files["file"][:4] == b"RIFF" and len(files["file"]) > 60_000  # 2 s of 16 kHz 16-bit audio


def test_samples_at_several_temperatures_make_the_nbest_best_first(fake_openai, tmp_path):
    fake_openai.on("audio/transcriptions", by_temperature({
        "0": transcription_answer("pass me the serial", -0.4),
        "0.2": transcription_answer("pass me the cereal", -0.3),
        "0.4": transcription_answer("pass me the serial", -0.6),  # a repeat keeps its best score
        "0.6": transcription_answer("pass me the oatmeal", -0.9),
        "0.8": transcription_answer("", -2.0, no_speech_prob=0.9),  # silence: dropped
    }))
    tr = engine(fake_openai, tmp_path).transcribe(CLIP, nbest=10)
    assert [h.text for h in tr.nbest] == ["pass me the cereal", "pass me the serial", "pass me the oatmeal"]
    assert [h.score for h in tr.nbest] == pytest.approx([-0.3, -0.4, -0.9])
    assert tr.text == "pass me the cereal" and len(fake_openai.requests) == 5
    ins = tr.to_instruction(samples=CLIP)
    assert ins.nbest[0].text == "pass me the cereal" and ins.has_audio


def test_retries_then_caches_so_a_rerun_sends_nothing(fake_openai, tmp_path):
    fake_openai.script("audio/transcriptions", Reply.error(503, "loading model"), Reply.malformed())
    fake_openai.on("audio/transcriptions", lambda r: Reply.json(transcription_answer("bring me the milk")))
    eng = engine(fake_openai, tmp_path, max_retries=3)
    assert eng.transcribe(CLIP, nbest=2).nbest[0].text == "bring me the milk"
    sent = len(fake_openai.requests)
    assert sent == 4  # 503, malformed, then one answer per temperature
    again = engine(fake_openai, tmp_path)
    assert again.transcribe(CLIP, nbest=2).text == "bring me the milk" and len(fake_openai.requests) == sent


def test_silence_is_an_empty_transcript(fake_openai, tmp_path):
    fake_openai.on("audio/transcriptions", lambda r: Reply.json(transcription_answer("Thank you.", -1.5, 0.95)))
    tr = engine(fake_openai, tmp_path).transcribe(np.zeros(16_000, np.float32), nbest=3)
    assert tr.text == "" and tr.nbest == ()


def test_errors_say_how_to_fix_the_setup(fake_openai, tmp_path, monkeypatch):
    monkeypatch.delenv("SIFTOM_ASR_BASE_URL", raising=False)
    with pytest.raises(BackendUnavailableError, match="SIFTOM_ASR_BASE_URL"):
        get_engine("openai", model="m")
    with pytest.raises(BackendUnavailableError, match="SIFTOM_ASR_MODEL"):
        get_engine("openai", base_url=fake_openai.url)
    # the server lacks the endpoint: a capability error naming it
    with pytest.raises(BackendUnavailableError, match="audio/transcriptions"):
        engine(fake_openai, tmp_path).transcribe(CLIP)
    fake_openai.script("audio/transcriptions", Reply.error(401, "bad key"))
    with pytest.raises(BackendUnavailableError, match="credentials"):
        engine(fake_openai, tmp_path).transcribe(CLIP)


def test_settings_come_from_the_environment(fake_openai, tmp_path, monkeypatch):
    monkeypatch.setenv("SIFTOM_ASR_BASE_URL", fake_openai.url)
    monkeypatch.setenv("SIFTOM_ASR_MODEL", "env-model")
    monkeypatch.setenv("SIFTOM_ASR_API_KEY", "sk-asr")
    monkeypatch.setenv("SIFTOM_CACHE_DIR", str(tmp_path))
    fake_openai.on("audio/transcriptions", lambda r: Reply.json(transcription_answer("get the sugar")))
    assert get_engine("openai").transcribe(CLIP).text == "get the sugar"
    req = fake_openai.requests[-1]
    assert dict(form(req)[0])["model"] == "env-model" and req.headers["Authorization"] == "Bearer sk-asr"
