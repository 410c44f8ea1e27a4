"""Decoding in a worker process: same transcript as in-process, and robust when the worker fails."""

from __future__ import annotations

import os

import numpy as np
import pytest

from siftom.speech.asr.dual import DualEngine
from siftom.speech.asr.worker import EngineWorker, WorkerError

VOCAB = [f"{c} the {f}" for f in ("cereal", "milk", "sugar", "tea") for c in ("pass me", "bring me", "i need")]


@pytest.fixture(scope="module")
def speech(cereal_clip: np.ndarray) -> np.ndarray:
    """A request outside the phrasings: 'um' + 'pass me the cereal' + 'please' (flite)."""
    from siftom.speech.tts import synthesize

    return np.concatenate([synthesize("well i think", "flite-slt"), cereal_clip, synthesize("thanks", "flite-slt")])


def _same(a, b) -> None:  # noqa: ANN001
    assert a.text == b.text
    assert [h.text for h in a.nbest] == [h.text for h in b.nbest]
    assert [h.score for h in a.nbest] == pytest.approx([h.score for h in b.nbest])


def test_dual_decodes_the_same_in_a_worker_process_as_in_process(speech: np.ndarray) -> None:
    par = DualEngine(VOCAB)
    seq = DualEngine(VOCAB, parallel=False)
    try:
        assert par._worker is None  # an engine used once starts no process
        first = par.transcribe(speech, nbest=5)
        assert not first.extra["parallel"]
        assert par._worker is not None  # started after the first call
        par._worker.wait_ready()
        a = par.transcribe(speech, nbest=5)
        assert a.extra["parallel"]  # the worker did the open decode
        assert par._open is not None  # (the first call decoded in-process)
        _same(a, first)
        _same(a, seq.transcribe(speech, nbest=5))
        assert "cereal" in a.text.split()
        assert seq._worker is None
    finally:
        par.close()


def test_dual_falls_back_to_in_process_decoding_when_the_worker_dies(speech: np.ndarray) -> None:
    eng = DualEngine(VOCAB)
    eng.transcribe(speech, nbest=5)
    worker = eng._worker
    assert worker is not None
    worker.wait_ready()
    worker._proc.kill()
    worker._proc.wait()
    tr = eng.transcribe(speech, nbest=5)
    assert not eng.parallel  # sequential from now on, same answer
    _same(tr, DualEngine(VOCAB, parallel=False).transcribe(speech, nbest=5))


def test_workers_can_be_switched_off(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SIFTOM_ASR_WORKERS", "0")
    eng = DualEngine(VOCAB)
    eng.transcribe(np.zeros(8000, dtype=np.float32))
    assert not eng.parallel and eng._worker is None


def test_a_worker_ends_its_process_on_close_and_refuses_other_processes() -> None:
    w = EngineWorker("pocketsphinx-vocab", vocabulary=VOCAB)
    w.wait_ready()
    assert w.usable
    w.owner = os.getpid() + 1  # as seen from a forked copy
    assert not w.usable
    with pytest.raises(WorkerError, match="another process"):
        w.submit(np.zeros(16000, dtype=np.float32))
    w.owner = os.getpid()
    w.close()
    assert w._proc.poll() is not None
    with pytest.raises(WorkerError):
        w.submit(np.zeros(16000, dtype=np.float32))


def test_a_worker_reports_an_engine_that_cannot_be_built() -> None:
    w = EngineWorker("pocketsphinx-vocab", vocabulary=["zzqx vvkq"])
    with pytest.raises(WorkerError, match="CMUdict"):
        w.wait_ready()
    assert w._proc.wait(timeout=10) is not None



def _decode_in_child(eng: DualEngine, speech: np.ndarray, conn) -> None:  # noqa: ANN001
    tr = eng.transcribe(speech, nbest=5)  # in-process: the parent's worker is not this process's
    conn.send((tr.text, eng._worker is not None and eng._worker.owner == os.getpid()))
    eng.close()


@pytest.mark.slow
def test_a_forked_copy_of_the_engine_starts_its_own_worker(speech: np.ndarray) -> None:
    """evaluate builds the engine, then forks pool workers: the copies must not share the pipes."""
    import multiprocessing as mp

    eng = DualEngine(VOCAB)
    try:
        expect = eng.transcribe(speech, nbest=5).text
        eng._worker.wait_ready()
        assert eng.transcribe(speech, nbest=5).extra["parallel"]
        ctx = mp.get_context("fork")
        a, b = ctx.Pipe()
        p = ctx.Process(target=_decode_in_child, args=(eng, speech, b))
        p.start()
        assert a.poll(60)
        text, own_worker = a.recv()
        p.join(10)
        assert (text, own_worker) == (expect, True)
        again = eng.transcribe(speech, nbest=5)
        assert again.text == expect and again.extra["parallel"]  # the parent's worker still answers
        assert eng.parallel
    finally:
        eng.close()


@pytest.mark.slow
def test_a_process_keeps_at_most_the_allowed_number_of_workers(speech: np.ndarray,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """Engines beyond the limit evict the least recently used worker; its engine restarts one."""
    monkeypatch.setenv("SIFTOM_ASR_WORKERS", "1")
    a, b = DualEngine(VOCAB), DualEngine(VOCAB[:6])
    try:
        a.transcribe(speech, nbest=5)
        b.transcribe(speech, nbest=5)
        b._worker.wait_ready()
        assert b.transcribe(speech, nbest=5).extra["parallel"]
        assert a._worker is not None and a._worker.evicted and not a._worker.usable
        assert b._worker is not None and b._worker.usable
        expect = DualEngine(VOCAB, parallel=False).transcribe(speech, nbest=5)
        _same(a.transcribe(speech, nbest=5), expect)  # in-process; a starts a worker again, evicting b's
        assert a.parallel and a._worker is not None and a._worker.usable and b._worker.evicted
    finally:
        a.close()
        b.close()


def _wait_in_worker(eng, seconds: float = 60.0) -> None:  # noqa: ANN001
    import time

    deadline = time.monotonic() + seconds
    while not eng.in_worker:
        assert time.monotonic() < deadline, "the worker did not become ready"
        time.sleep(0.1)


def test_a_server_recogniser_decodes_in_its_worker_exactly_as_here_and_survives_its_death(speech: np.ndarray) -> None:
    from siftom.speech.asr.pocketsphinx import PocketsphinxEngine
    from siftom.speech.asr.worker import WorkerEngine

    here = PocketsphinxEngine(vocabulary=VOCAB)
    eng = WorkerEngine(PocketsphinxEngine(vocabulary=VOCAB), "pocketsphinx-vocab", VOCAB)
    try:
        assert eng._worker is not None  # building from the start
        _wait_in_worker(eng)
        _same(eng.transcribe(speech, nbest=5), here.transcribe(speech, nbest=5))
        assert eng.name == here.name and eng.unknown_words == here.unknown_words  # the local engine's attributes
        eng._worker._proc.kill()
        eng._worker._proc.wait()
        _same(eng.transcribe(speech, nbest=5), here.transcribe(speech, nbest=5))  # decoded here from now on
        assert not eng.in_worker
    finally:
        eng.close()


def test_the_observer_of_a_server_decodes_in_a_worker_and_hears_what_any_other_observer_hears(
        speech: np.ndarray) -> None:
    from siftom.observer import Observer
    from siftom.scenarios.base import get_scenario

    sc = get_scenario("kitchen-cereal-v0")
    server, here = Observer(decode_in_worker=True), Observer()
    rec = server.recogniser(sc.world, sc.verb)
    try:
        _wait_in_worker(rec.engine)
        _same(rec.transcribe(speech, 10), here.recogniser(sc.world, sc.verb).transcribe(speech, 10))
    finally:
        rec.engine.close()
