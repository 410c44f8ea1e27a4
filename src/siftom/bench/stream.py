"""``siftom bench stream``: how fast a listening robot answers, and whether noise makes it answer.

**Delay.** Instructions spoken by TTS voices (phrasings and voices of :data:`CLIPS`, none of
them used to set the segmentation defaults) are laid end to end with pauses of 1.0-1.6 s
(seeded) into one stream, optionally over a recorded noise bed at an SNR, and streamed **in
real time** in 20 ms chunks into :class:`~siftom.listener.HomeListener`, as a
microphone would deliver them, so recognising early overlaps with the audio still arriving
exactly as it does live. For each instruction the delay is the wall time from the moment its
last speech sample was fed (the end of its voiced part in the clean TTS audio, above -40 dB of
its peak) to the decision event.

**Segmentation.** Each true utterance is matched with the detected ones that overlap it:
*cut* when two or more do, or the one that does ends more than 0.15 s before the speech
does; *merged* when one detected utterance covers two instructions; *missed* when none does.

**False triggers.** Each recorded noise clip (``siftom.speech.noise.RECORDED_NOISE_DIR``) is
looped to ``noise_s`` seconds and streamed; a false trigger is a ``decision`` event (an
utterance answered); utterances cut but without words (``no_speech``) are counted apart.
Segmentation uses stream time only, so these streams are fed as fast as the detector runs (a
simulated clock): the count is what the same audio gives live.
"""

from __future__ import annotations

import statistics
import threading
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from siftom.errors import OptionsError

if TYPE_CHECKING:
    from siftom.listener import HomeListener

SCENARIO = "kitchen-cereal-v0"
RATE = 16_000
CHUNK = 320  # 20 ms
# (text, voice): kitchen instructions of 1-4 s; a comma makes the voice pause mid-sentence
CLIPS = (
    ("could you get me the sugar", "flite-awb"),
    ("pass the milk please", "flite-rms"),
    ("i would like the cereal, from the shelf", "flite-slt"),
    ("hand me a bowl", "flite-kal16"),
    ("bring the oatmeal over here please", "flite-awb"),
    ("the coffee, thanks", "flite-rms"),
    ("can i have the bread please", "flite-slt"),
    ("get me the butter from the fridge", "espeak-en-us"),
)
CUT_TOLERANCE_S = 0.15


@dataclass(frozen=True)
class StreamBenchOptions:
    """What to stream.

    Attributes:
        likelihoods: instruction likelihoods to time.
        bed: a recorded noise clip's stem (e.g. ``fan_01``) under the instructions, or '' for none.
        snr_db: the bed's level under the speech.
        noise_s: seconds each noise clip is streamed for the false-trigger count (0: skip).
        noise_clips: stems of the noise clips to stream (empty: all of them).
        seed: pauses and the bed's offset.
        quick: four instructions and the first three noise clips of each category.
    """

    likelihoods: tuple[str, ...] = ("phonetic", "acoustic")
    bed: str = ""
    snr_db: float = 10.0
    noise_s: float = 60.0
    noise_clips: tuple[str, ...] = ()
    seed: int = 2
    quick: bool = False

    def __post_init__(self) -> None:
        if not self.likelihoods:
            raise OptionsError("give at least one likelihood")
        if self.noise_s < 0:
            raise OptionsError("noise_s must be >= 0")
        if self.seed < 0:
            raise OptionsError(f"a seed is a whole number >= 0, got {self.seed}; give e.g. --seed 2")


@dataclass(frozen=True)
class SpokenInstruction:
    """An instruction of the benchmark's stream: its text, its voice, and where its speech starts
    and ends (seconds from the start of the stream)."""

    text: str
    voice: str
    start_s: float
    end_s: float


@dataclass
class StreamBenchResult:
    options: dict[str, Any]
    stream_s: float
    utterances: list[SpokenInstruction]
    likelihoods: dict[str, dict[str, Any]] = field(default_factory=dict)
    noise: list[dict[str, Any]] = field(default_factory=list)

    @property
    def false_triggers(self) -> int:
        return sum(n["decisions"] for n in self.noise)

    def to_json(self) -> dict[str, Any]:
        return {**asdict(self), "false_triggers": self.false_triggers}

    def meets(self, likelihood: str = "acoustic", p50_s: float = 0.6) -> bool:
        r = self.likelihoods.get(likelihood)
        return bool(r and r["p50_s"] is not None and r["p50_s"] <= p50_s and self.false_triggers == 0)


def _speech_extent(x: np.ndarray) -> tuple[float, float]:
    """First and last sample above -40 dB of the clip's peak (a 10 ms moving RMS), in seconds."""
    env = np.sqrt(np.convolve(x.astype(np.float64) ** 2, np.ones(160) / 160, "same"))
    on = np.nonzero(env > env.max() * 0.01)[0]
    return on[0] / RATE, on[-1] / RATE


def build_stream(opts: StreamBenchOptions) -> tuple[np.ndarray, list[SpokenInstruction]]:
    """The instructions with pauses (and the bed), and each one's text and true speech extent."""
    from siftom.speech.tts import synthesize

    rng = np.random.default_rng(opts.seed)
    parts, t = [np.zeros(int(0.8 * RATE), np.float32)], 0.8
    truths: list[SpokenInstruction] = []
    for text, voice in CLIPS[:4] if opts.quick else CLIPS:
        x = synthesize(text, voice)
        a, b = _speech_extent(x)
        truths.append(SpokenInstruction(text, voice, round(t + a, 3), round(t + b, 3)))
        gap = float(rng.uniform(1.0, 1.6))
        parts += [x, np.zeros(int(gap * RATE), np.float32)]
        t += len(x) / RATE + int(gap * RATE) / RATE
    y = np.concatenate(parts)
    if opts.bed:
        from siftom.speech.noise import RECORDED_NOISE_DIR, FileNoise, mix_at_snr

        path = RECORDED_NOISE_DIR / f"{opts.bed}.wav"
        if not path.is_file():
            raise OptionsError(f"no recorded noise {opts.bed!r}; one of: "
                               + ", ".join(sorted(p.stem for p in RECORDED_NOISE_DIR.glob("*.wav"))))
        y = mix_at_snr(y, FileNoise(path), opts.snr_db, opts.seed)
    return y.astype(np.float32), truths


def _home(likelihood: str) -> HomeListener:
    from siftom.listener import HomeListener, load_home

    return HomeListener(load_home(SCENARIO), likelihood=likelihood)


def _warm(home: HomeListener, x: np.ndarray, truth: SpokenInstruction) -> None:
    """One answer before timing: the recogniser, Whisper and the caches are built, as in a robot
    that has been listening for a while."""
    from siftom.speech.segment import Utterance

    a, b = int(truth.start_s * RATE) - 4800, int(truth.end_s * RATE) + 2400
    home.respond(Utterance(-1, x[max(0, a):b], truth.start_s, truth.end_s, truth.end_s, "silence"))


def _stream_delays(likelihood: str, x: np.ndarray, truths: Sequence[SpokenInstruction]) -> dict[str, Any]:
    """Stream ``x`` in real time; per true utterance: segments, decision, delay."""
    from siftom.speech.segment import SpeechEnded

    home = _home(likelihood)
    _warm(home, x, truths[0])
    pool = ThreadPoolExecutor(1)
    answers: list[tuple[Any, dict[str, Any], float]] = []
    lock = threading.Lock()

    def answer(utt: Any) -> None:
        out = home.respond(utt).to_json()
        with lock:
            answers.append((utt, out, time.perf_counter()))

    t0 = time.perf_counter()
    for k in range(0, len(x), CHUNK):
        time.sleep(max(0.0, t0 + k / RATE - time.perf_counter()))
        for ev in home.feed(x[k:k + CHUNK]):
            if isinstance(ev, SpeechEnded):
                pool.submit(answer, ev.utterance)
    for ev in home.finish():
        if isinstance(ev, SpeechEnded):
            pool.submit(answer, ev.utterance)
    pool.shutdown(wait=True)
    home.close()
    return _score(answers, truths, t0)


def _score(answers: Sequence[tuple[Any, dict[str, Any], float]], truths: Sequence[SpokenInstruction],
           t0: float) -> dict[str, Any]:
    rows, delays, cut, merged, missed = [], [], 0, 0, 0
    segs = [(u.start_s, u.end_s) for u, _, _ in answers]
    for tr in truths:
        hits = [j for j, (a, b) in enumerate(segs) if a < tr.end_s and b > tr.start_s]
        row: dict[str, Any] = {"text": tr.text, "segments": [[round(v, 3) for v in segs[j]] for j in hits]}
        if not hits:
            missed += 1
            row["outcome"] = "missed"
        elif any(sum(1 for t2 in truths if segs[j][0] < t2.end_s and segs[j][1] > t2.start_s) > 1 for j in hits):
            merged += 1
            row["outcome"] = "merged"
        elif len(hits) > 1 or segs[hits[0]][1] < tr.end_s - CUT_TOLERANCE_S:
            cut += 1
            row["outcome"] = "cut"
        else:
            row["outcome"] = "ok"
        if len(hits) == 1:
            utt, out, at = answers[hits[0]]
            row.update({"event": out["event"], "heard": out.get("heard", ""), "command": out.get("command"),
                        "action": out.get("action"), "timings": out.get("timings")})
            if row["outcome"] == "ok" and out["event"] == "decision":
                d = at - (t0 + tr.end_s)
                row["delay_s"] = round(d, 4)
                delays.append(d)
        rows.append(row)
    n = len(truths)
    q = statistics.quantiles(delays, n=10) if len(delays) > 1 else delays * 9
    return {"p50_s": round(statistics.median(delays), 4) if delays else None,
            "p90_s": round(q[-1], 4) if delays else None,
            "cut_share": round(cut / n, 4), "merged_share": round(merged / n, 4), "missed": missed,
            "answered": len(delays), "utterances": rows}


def noise_files(opts: StreamBenchOptions) -> list[Path]:
    from siftom.speech.noise import RECORDED_NOISE_DIR

    files = sorted(RECORDED_NOISE_DIR.glob("*.wav"))
    if opts.noise_clips:
        files = [f for f in files if f.stem in opts.noise_clips]
    elif opts.quick:
        by_cat: dict[str, list[Path]] = {}
        for f in files:
            by_cat.setdefault(f.stem.rsplit("_", 1)[0], []).append(f)
        files = [f for fs in by_cat.values() for f in fs[:1]]
    return files


def _noise_triggers(path: Path, seconds: float, home: HomeListener) -> dict[str, Any]:
    """Stream ``seconds`` of the looped clip as fast as the detector runs; answer what it cuts."""
    from siftom.speech.audio import load_audio
    from siftom.speech.segment import SpeechEnded

    x = np.resize(load_audio(path, max_seconds=600), int(seconds * RATE)).astype(np.float32)
    home.listener.segmenter.reset()
    outs = []
    for k in range(0, len(x), CHUNK):
        for ev in home.feed(x[k:k + CHUNK]):
            if isinstance(ev, SpeechEnded):
                outs.append(home.respond(ev.utterance).to_json())
    for ev in home.finish():
        if isinstance(ev, SpeechEnded):
            outs.append(home.respond(ev.utterance).to_json())
    dec = [o for o in outs if o["event"] == "decision"]
    return {"clip": path.stem, "seconds": seconds, "segments": len(outs), "decisions": len(dec),
            "heard": [o.get("heard", "") for o in dec]}


def run_stream_bench(opts: StreamBenchOptions | None = None) -> StreamBenchResult:
    """Delays per likelihood (real time), then false triggers on the noise clips (see module doc)."""
    opts = opts or StreamBenchOptions()
    x, truths = build_stream(opts)
    res = StreamBenchResult(asdict(opts), round(len(x) / RATE, 2), truths)
    for lk in opts.likelihoods:
        res.likelihoods[lk] = _stream_delays(lk, x, truths)
    if opts.noise_s > 0:
        home = _home(opts.likelihoods[0])
        for f in noise_files(opts):
            res.noise.append(_noise_triggers(f, opts.noise_s, home))
        home.close()
    return res
