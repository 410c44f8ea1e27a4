"""Whisper's share of the pruned commands, and each clip's encoding and texts scored once."""

from __future__ import annotations

import numpy as np
import pytest

from siftom.errors import SiftomError
from siftom.likelihood.acoustic import AcousticLikelihood, RawScores
from siftom.likelihood.alignscores import whisper_term
from siftom.likelihood.whisper_factor import WhisperFactor, clip_digest
from siftom.observation import Hypothesis, Instruction
from siftom.world.commands import RobotCommand

CMDS = [RobotCommand.parse(f"fetch({c})") for c in ("cereal", "tea", "milk", "sugar", "honey", "flour")]
HEARD = Instruction(nbest=(Hypothesis("can you pass me the milk please", 0.0),))


class Stub:
    """A WhisperScorer stand-in that counts its work; ``fingerprint`` makes it memoisable."""

    def __init__(self, fingerprint: object | None = None) -> None:
        if fingerprint is not None:
            self.fingerprint = fingerprint
        self.encodes = 0
        self.hears = 0
        self.texts: list[str] = []

    def encode(self, samples: np.ndarray) -> tuple[object, int]:
        self.encodes += 1
        return "enc", len(samples) // 160

    def hear_encoded(self, encoded: tuple[object, int], prompt: str | None = None) -> tuple[list[str], float]:
        self.hears += 1
        return ["pass", "me", "the", "honey"], -0.3

    def score_encoded(self, encoded: tuple[object, int], texts: list[str]) -> np.ndarray:
        self.texts += list(texts)
        return np.array([-float(len(t)) / 5 - (0.0 if "milk" in t else 1.5) for t in texts])


def _lk(k: int | None = None) -> AcousticLikelihood:
    return AcousticLikelihood(whisper=False, whisper_candidates=k)


def test_whisper_scores_the_commands_it_heard_then_the_best_by_nbest_and_context():
    lk = _lk(3)
    keep = np.array([0, 1, 2, 3, 4])
    phon = np.array([-1.0, -5.0, -0.5, -2.0, -9.0, -3.0])
    assert lk.whisper_share(keep, [4], phon, None).tolist() == [0, 2, 4]
    # the context (action term and prior) ranks as much as the N-best does
    ctx = np.array([0.0, 6.0, 0.0, 0.0, 0.0, 0.0])
    assert lk.whisper_share(keep, [], phon, ctx).tolist() == [0, 1, 2]
    # a command Whisper named outside the kept set is not added here (raw_scores adds it to keep first)
    assert lk.whisper_share(keep, [5], phon, None).tolist() == [0, 2, 3]
    # more named commands than the share: every one of them
    assert lk.whisper_share(keep, [1, 3, 4, 0], phon, None).tolist() == [0, 1, 3, 4]
    # few enough, or no N-best to rank by: all of the kept commands
    assert lk.whisper_share(keep[:3], [], phon, None).tolist() == [0, 1, 2]
    assert lk.whisper_share(keep, [], None, None).tolist() == keep.tolist()


def test_whisper_candidates_is_validated():
    with pytest.raises(SiftomError, match="whisper_candidates"):
        _lk(0)


def test_a_command_whisper_did_not_score_gets_the_worst_scored_w():
    raw = RawScores(np.array([0, 1, 2, 3]), (), "whisper-key", np.zeros(5), whisper=np.array([-4.0, -10.0]),
                    whisper_keep=np.array([1, 3]))
    w = whisper_term(raw, 5, 2.0)
    assert np.allclose(w, [-5.0, -2.0, -5.0, -5.0, -5.0])
    # without whisper_keep, the kept commands are the scored ones (as before)
    raw = RawScores(np.array([1, 3]), (), "whisper-key", np.zeros(5), whisper=np.array([-4.0, -10.0]))
    assert np.allclose(whisper_term(raw, 5, 2.0), w)


def test_a_clip_is_encoded_and_transcribed_once_and_each_text_scored_once():
    """A request of several parts scores one clip once per part: the encoding, the transcript and
    every text already scored on the clip are reused, and the values are those of a fresh scorer."""
    x = np.linspace(-0.1, 0.1, 32000, dtype=np.float32)
    stub = Stub(fingerprint=("stub", clip_digest(np.arange(3))))  # a key no other test uses
    wf = WhisperFactor(3.0, scorer=stub)
    first = wf.scores(HEARD, CMDS, [0, 2, 4], x)
    assert (stub.encodes, stub.hears) == (1, 1) and first.scored == first.texts == len(stub.texts) > 0
    n = len(stub.texts)
    again = wf.scores(HEARD, CMDS, [0, 1, 2, 4], x)  # one more command: only its texts are new
    assert (stub.encodes, stub.hears) == (1, 1)
    assert 0 < again.scored == len(stub.texts) - n < n and len(set(stub.texts)) == len(stub.texts)
    assert again.texts == len(stub.texts)
    fresh = WhisperFactor(3.0, scorer=Stub()).scores(HEARD, CMDS, [0, 1, 2, 4], x)  # not memoised
    assert np.array_equal(again.values, fresh.values) and again.heard == fresh.heard
    # another clip is another key
    other = wf.scores(HEARD, CMDS, [0, 2, 4], x[::-1].copy())
    assert stub.encodes == 2 and other.scored == first.scored


def test_clip_digest_tells_clips_apart():
    x = np.zeros(16000, dtype=np.float32)
    y = x.copy()
    y[100] = 1e-6
    assert clip_digest(x) == clip_digest(x.copy()) != clip_digest(y)
    assert clip_digest(x) != clip_digest(x.astype(np.float64))


def test_the_share_is_counted_in_objects_and_keeps_every_count_of_one():
    """Counts of one object alone would leave the worst scored w no worse than theirs: the share
    takes objects, with every kept count of each."""
    cmds = [RobotCommand.parse(c) for c in ("deliver(bowl,1)", "deliver(bowl,2)", "deliver(bowl,4)",
                                            "deliver(spoon,2)", "deliver(fork,3)", "deliver(knife,1)")]
    lk = _lk(2)
    keep = np.arange(6)
    phon = np.array([-1.0, -1.1, -1.2, -3.0, -2.0, -5.0])
    assert lk.whisper_share(keep, [], phon, None, cmds).tolist() == [0, 1, 2, 4]
    # an object Whisper named comes first, with all its kept counts
    assert lk.whisper_share(keep, [3], phon, None, cmds).tolist() == [0, 1, 2, 3]
    assert lk.whisper_share(np.array([0, 2, 3, 4, 5]), [], phon, None, cmds).tolist() == [0, 2, 4]
