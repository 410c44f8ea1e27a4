"""Content-free debiasing of the Whisper factor: log P(t | audio) - lambda * log P(t | silence)."""

from __future__ import annotations

import numpy as np
import pytest

from siftom.likelihood.whisper_factor import (
    WhisperFactor,
    candidate_texts,
    content_free_scores,
    null_seconds,
)
from siftom.observation import Hypothesis, Instruction
from siftom.world.commands import RobotCommand

CMDS = [RobotCommand.parse(c) for c in ("fetch(cereal)", "fetch(tea)", "fetch(milk)")]
HEARD = Instruction(nbest=(Hypothesis("can you pass me the serial please", 0.0),))


@pytest.fixture(autouse=True)
def _fresh_memos():
    """The content-free memos are the process's; a stand-in scorer is keyed by its id, which a new one may reuse."""
    from siftom.likelihood import whisper_factor

    whisper_factor._NULL_SCORES.clear()
    whisper_factor._NULL_ENCODED.clear()


class Stub:
    """A WhisperScorer stand-in: a text's score depends on the text and on whether the clip is silent."""

    def __init__(self) -> None:
        self.encoded: list[tuple[bool, int]] = []  # (silent, samples) per encode call
        self.scored = 0  # texts scored against silence

    def encode(self, samples: np.ndarray) -> tuple[object, int]:
        silent = not np.any(samples)
        self.encoded.append((silent, len(samples)))
        return ("silence" if silent else "speech", len(samples)), len(samples) // 160

    def score_encoded(self, encoded: tuple[object, int], texts: list[str]) -> np.ndarray:
        kind = encoded[0][0]  # type: ignore[index]
        if kind == "silence":
            self.scored += len(texts)
            return np.array([-0.5 * len(t.split()) - (1.0 if "tea" in t else 3.0) for t in texts])
        return np.array([-float(len(t)) / 7 - (0.0 if "cereal" in t else 2.0) for t in texts])


def _factor(weight: float, stub: Stub) -> WhisperFactor:
    return WhisperFactor(3.0, prior_weight=weight, scorer=stub, listen=False)


def _expected(weight: float, samples: np.ndarray) -> np.ndarray:
    from siftom.logspace import logsumexp

    texts, _ = candidate_texts(HEARD, CMDS, range(len(CMDS)))
    speech, silence = Stub(), Stub()
    enc, null = speech.encode(samples), silence.encode(np.zeros(null_seconds(len(samples), 3.0) * 16000))
    out = []
    for items in texts:
        t = [x for x, _ in items]
        v = speech.score_encoded(enc, t) - weight * silence.score_encoded(null, t)
        out.append(float(logsumexp(v + np.array([lp for _, lp in items]))))
    return np.array(out)


@pytest.mark.parametrize("weight", [0.5, 1.0])
def test_a_debiased_score_is_the_audio_score_minus_lambda_times_the_content_free_score(weight):
    samples = np.full(24000, 0.1, dtype=np.float32)
    got = _factor(weight, Stub()).scores(HEARD, CMDS, [0, 1, 2], samples).values
    assert np.allclose(got, _expected(weight, samples))
    # the silence prefers "tea": debiasing takes that preference out
    plain = _factor(0.0, Stub()).scores(HEARD, CMDS, [0, 1, 2], samples).values
    assert (got[1] - got[0]) < (plain[1] - plain[0])


def test_lambda_zero_scores_as_before_and_never_scores_silence():
    stub = Stub()
    samples = np.full(24000, 0.1, dtype=np.float32)
    got = _factor(0.0, stub).scores(HEARD, CMDS, [0, 1, 2], samples).values
    assert np.array_equal(got, _expected(0.0, samples))
    assert stub.scored == 0 and all(not silent for silent, _ in stub.encoded)


def test_the_content_free_score_is_memoised_per_text_and_length():
    stub = Stub()
    first = content_free_scores(stub, ["pass me the tea", "pass me the cereal"], 3)
    again = content_free_scores(stub, ["pass me the cereal", "pass me the tea", "pass me the milk"], 3)
    assert stub.scored == 3 and np.allclose(again[:2], first[::-1])
    assert sum(silent for silent, _ in stub.encoded) == 1  # the silence is encoded once per length
    content_free_scores(stub, ["pass me the tea"], 5)
    assert stub.scored == 4 and stub.encoded[-1] == (True, 5 * 16000)


def test_the_content_free_input_covers_the_clip_in_whole_seconds():
    assert null_seconds(16000, 3.0) == 3  # a short clip: the 3 s feature window
    assert null_seconds(3 * 16000, 3.0) == 3
    assert null_seconds(3 * 16000 + 1, 3.0) == 4
    assert null_seconds(16000, 0.5) == 1


def test_lambda_is_validated_and_reaches_the_likelihood_from_the_settings(tmp_path):
    from siftom import Observer, Settings
    from siftom.errors import SiftomError
    from siftom.likelihood.acoustic import AcousticLikelihood

    with pytest.raises(SiftomError, match="whisper_prior"):
        AcousticLikelihood(whisper=False, whisper_prior=-0.5)
    f = tmp_path / "siftom.toml"
    f.write_text("[likelihoods.acoustic]\nwhisper_prior = 0.5\n")
    s = Settings.load(f, env={})
    assert s.likelihood_options("acoustic") == {"whisper_prior": 0.5}
    lk = Observer(s).model("full", "acoustic").likelihood
    assert isinstance(lk, AcousticLikelihood) and lk.whisper_prior == 0.5
    if lk.uses_whisper:
        assert lk._whisper is not None and lk._whisper.prior_weight == 0.5
    assert Observer(Settings.load(env={})).model("full", "acoustic").likelihood.whisper_prior == 0.0  # type: ignore[union-attr]
