"""Scoring beside the caller (a second CTranslate2 call, texts scored while Whisper transcribes,
a clip's work kept for the parts of a request) gives the values of one plain call."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from siftom.likelihood.whisper_factor import forget_clips, whisper_available
from siftom.observation import Hypothesis, Instruction
from siftom.world.commands import RobotCommand

pytestmark = [pytest.mark.skipif(not whisper_available(), reason="needs the whisper extra"),
              pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")]
FOODS = ("cereal", "oatmeal", "milk", "sugar", "coffee", "honey", "flour", "pasta")


class Plain:
    """A WhisperScorer seen without its fingerprint and scoring every batch in one call: no memo,
    nothing on the side."""

    def __init__(self, inner: object) -> None:
        self.inner = inner

    def encode(self, samples: np.ndarray) -> object:
        return self.inner.encode(samples)  # type: ignore[attr-defined]

    def hear_encoded(self, enc: object, prompt: str | None = None) -> object:
        return self.inner.hear_encoded(enc, prompt)  # type: ignore[attr-defined]

    def score_encoded(self, enc: object, texts: list[str]) -> np.ndarray:
        return self.inner.score_encoded(enc, texts, split=False)  # type: ignore[attr-defined]


@pytest.fixture(scope="module")
def clip() -> np.ndarray:
    from siftom.speech.noise import get_noise, mix_at_snr
    from siftom.speech.tts import synthesize

    return mix_at_snr(synthesize("could you pass me the sugar please", "flite-rms"), get_noise("babble"), 10.0, 3)


def test_a_split_batch_scores_as_one_call(clip):
    from siftom.speech.whisper_score import WhisperScorer

    ws = WhisperScorer(pad_s=3.0, inter_threads=2, cpu_threads=1)
    enc = ws.encode(clip)
    texts = [f"could you pass me the {f} please" for f in FOODS] + [""]
    together = ws.score_encoded(enc, texts, split=False)
    assert np.array_equal(ws.score_encoded(enc, texts), together)
    assert np.isneginf(together[-1]) and np.argmax(together) == FOODS.index("sugar")


def test_the_acoustic_likelihood_scores_as_without_side_calls_or_memos(clip):
    from siftom.likelihood.acoustic import AcousticLikelihood
    from siftom.speech.whisper_score import WhisperScorer

    cmds = [RobotCommand.parse(f"fetch({f})") for f in FOODS]
    said = Instruction(nbest=(Hypothesis("could you pass me the sugar please", -1.0),
                              Hypothesis("could you pass me the honey please", -2.0)), samples=clip)
    ws = WhisperScorer(pad_s=3.0, inter_threads=2, cpu_threads=1)
    fast = AcousticLikelihood(whisper=True, whisper_candidates=3)
    fast._whisper._scorer = ws  # type: ignore[union-attr]
    plain = AcousticLikelihood(whisper=True, whisper_candidates=3)
    plain._whisper._scorer = Plain(ws)  # type: ignore[union-attr]
    ctx = np.linspace(0.0, -1.0, len(cmds))
    forget_clips()
    want = plain.log_prob(said, cmds, ctx)
    got = fast.log_prob(said, cmds, ctx)
    assert np.array_equal(got.log_probs, want.log_probs)
    assert got.evidence["whisper_heard"] == want.evidence["whisper_heard"]
    assert got.evidence["whisper_texts"] == want.evidence["whisper_texts"] > 0
    # the second part of a request (the same clip again): nothing to encode, transcribe or score

    def no_work(*args: object, **kwargs: object) -> None:
        raise AssertionError("Whisper ran again on a clip it had scored")

    for name in ("encode", "hear_encoded", "score_encoded"):
        setattr(ws, name, no_work)
    again = fast.log_prob(said, cmds, ctx)
    assert np.array_equal(again.log_probs, want.log_probs)


def test_while_another_whisper_call_runs_a_clip_keeps_to_one_worker(clip, monkeypatch):
    """A busy server runs one utterance per CTranslate2 worker: no batch is split and nothing is
    scored ahead while another call of the process is in flight."""
    from siftom.likelihood.whisper_factor import WhisperFactor
    from siftom.speech import whisper_score
    from siftom.speech.whisper_score import WhisperScorer

    ws = WhisperScorer(pad_s=3.0, inter_threads=2, cpu_threads=1)
    enc = ws.encode(clip)
    texts = [f"could you pass me the {f} please" for f in FOODS]
    alone = ws.score_encoded(enc, texts)

    def no_side() -> None:
        raise AssertionError("a call went to the second worker while another call ran")

    monkeypatch.setattr(whisper_score, "side_pool", no_side)
    monkeypatch.setattr(whisper_score, "_BUSY", 1)
    assert not whisper_score.side_free()
    assert np.array_equal(ws.score_encoded(enc, texts), alone)
    forget_clips()
    said = Instruction(nbest=(Hypothesis("could you pass me the sugar please", -1.0),), samples=clip)
    cmds = [RobotCommand.parse(f"fetch({f})") for f in FOODS]
    wf = WhisperFactor(3.0, scorer=ws)
    assert wf.listen(clip, cmds, said, [0, 1, 2])[1]  # transcribed, with nothing scored on the side
