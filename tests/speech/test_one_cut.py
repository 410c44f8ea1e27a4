"""One cut for every door: a file that stops just after the speech is cut as a microphone that
kept recording silence would cut it (``siftom listen --wav`` plays a file with silence after it)."""

from __future__ import annotations

import numpy as np

from siftom.speech.segment import FRAME, SegmentOptions, SpeechEnded, UtteranceSegmenter


class Scripted:
    """Speech probability per frame: the first ``speech`` frames after ``lead`` are speech."""

    def __init__(self, lead: int, speech: int) -> None:
        self.lead, self.speech, self.k = lead, speech, 0

    def __call__(self, frame: np.ndarray) -> float:
        p = 0.9 if self.lead <= self.k < self.lead + self.speech else 0.0
        self.k += 1
        return p

    def reset(self) -> None:
        self.k = 0


def _utterance(x: np.ndarray) -> np.ndarray:
    seg = UtteranceSegmenter(SegmentOptions(), Scripted(5, 40))
    ends = [e for e in seg.feed(x) + seg.finish() if isinstance(e, SpeechEnded)]
    assert len(ends) == 1
    return ends[0].utterance.samples


def test_a_file_that_ends_just_after_the_speech_is_cut_as_one_with_silence_after_it() -> None:
    rng = np.random.default_rng(0)
    x = (rng.standard_normal((5 + 40 + 3) * FRAME) * 0.1).astype(np.float32)  # 3 frames after the speech
    played = np.concatenate([x, np.zeros(16000, dtype=np.float32)])  # as `siftom listen --wav` plays it
    short, long = _utterance(x), _utterance(played)
    assert len(short) == len(long)  # the post-roll is there whether or not the file held it
    assert np.array_equal(short, long)


def test_the_utterance_a_file_ends_inside_says_the_stream_ended() -> None:
    seg = UtteranceSegmenter(SegmentOptions(), Scripted(2, 1000))
    events = seg.feed(np.zeros(30 * FRAME, dtype=np.float32)) + seg.finish()
    assert [e.utterance.reason for e in events if isinstance(e, SpeechEnded)] == ["end_of_stream"]
