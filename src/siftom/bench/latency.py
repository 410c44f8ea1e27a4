"""``siftom bench latency``: time from an audio file to the chosen command, per likelihood.

Clips of 1-4 s (TTS voices, recorded or synthetic babble at 10 dB, fixed seeds) are written to
WAV files; each is passed to ``siftom.api.listen`` as a path, so the time covers reading the file,
voice-activity detection, recognition, the instruction likelihood and the posterior. Process
start-up is excluded and the per-home set-up (recogniser, model, action term) is built by one
warm-up call first, as a robot that lives in one home would; what is memoised per clip (Whisper's
encoding, transcript and scored texts) is forgotten before every run, so a repeat costs what a new
recording would. ``ratio_p50`` is the median over all
runs (every clip, every repeat: not the fastest of several) of seconds / clip length;
``default`` names the likelihood ``listen`` runs when none is named (acoustic with the whisper
extra); ``machine`` says where it ran. ``cpu_ratio_p50`` uses the process's CPU time instead of wall
time (the same on an idle machine; on a shared one it leaves out the time spent waiting for a
core).
"""

from __future__ import annotations

import statistics
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from siftom.bench.machine import Machine

SCENARIO = "kitchen-cereal-v0"
CLIPS = (  # (text, voice): 1-4 s of speech
    ("cereal please", "flite-slt"),
    ("bring me the milk", "flite-rms"),
    ("can you pass me the cereal", "flite-slt"),
    ("i need the sugar", "flite-awb"),
    ("could you grab me the coffee please", "flite-rms"),
    ("can you bring me the bowl", "espeak-en-us+klatt"),
    ("would you please hand me the oatmeal from the cabinet", "flite-slt"),
    ("we still need some milk for the cereal so please get it", "flite-awb"),
)
LIKELIHOODS = ("phonetic", "acoustic")


def make_clips(folder: Path, noise: str, snr: float, quick: bool = False) -> list[tuple[Path, float, str]]:
    """Write the clips as WAVs; return (path, seconds, text)."""
    from siftom.speech.audio import duration_s, write_wav
    from siftom.speech.noise import get_noise, mix_at_snr
    from siftom.speech.tts import synthesize

    nz = get_noise(noise)
    out = []
    for k, (text, voice) in enumerate(CLIPS[:4] if quick else CLIPS):
        x = mix_at_snr(synthesize(text, voice), nz, snr, k)
        p = write_wav(folder / f"clip{k}.wav", x)
        out.append((p, duration_s(x), text))
    return out


@dataclass(frozen=True)
class LikelihoodLatency:
    """One likelihood's timings over every clip and repeat: median seconds, median and 90th
    percentile of seconds / clip length (wall and CPU time), every run's seconds, each clip's command."""

    p50_s: float
    ratio_p50: float
    ratio_p90: float
    cpu_ratio_p50: float
    seconds: tuple[float, ...]
    commands: tuple[str | None, ...]  # None: no command chosen

    def to_json(self) -> dict[str, Any]:
        """The entry in ``likelihoods``."""
        return {"p50_s": self.p50_s, "ratio_p50": self.ratio_p50, "ratio_p90": self.ratio_p90,
                "cpu_ratio_p50": self.cpu_ratio_p50, "seconds": list(self.seconds), "commands": list(self.commands)}


@dataclass(frozen=True)
class LatencyResult:
    """``siftom bench latency``'s result (module doc): the clips, where it ran, each likelihood's timings."""

    scenario: str
    noise: str
    snr_db: float
    repeats: int
    default: str
    machine: Machine
    likelihoods: dict[str, LikelihoodLatency]
    clip_seconds: tuple[float, ...]

    def to_json(self) -> dict[str, Any]:
        """The ``--json`` form (``results/service/latency.json``)."""
        return {"scenario": self.scenario, "noise": self.noise, "snr_db": self.snr_db, "repeats": self.repeats,
                "default": self.default, "machine": self.machine.to_json("latency"),
                "likelihoods": {k: v.to_json() for k, v in self.likelihoods.items()},
                "clip_seconds": list(self.clip_seconds)}


def _time_likelihood(lk: str, clips: list[tuple[Path, float, str]], repeats: int) -> LikelihoodLatency:
    """Time ``listen`` with likelihood ``lk`` on every clip, ``repeats`` times each, after one warm-up."""
    from siftom.api import listen
    from siftom.likelihood.whisper_factor import forget_clips

    listen(clips[0][0], scenario=SCENARIO, likelihood=lk)  # per-home set-up, cached
    secs, ratios, cpu_ratios = [], [], []
    chosen: list[str | None] = []
    for path, dur, _ in clips:
        for _ in range(repeats):  # every run counts (the median of all of them, not the fastest)
            forget_clips()  # each run hears the clip for the first time (no memo keyed by the clip)
            t0, c0 = time.perf_counter(), time.process_time()
            heard = listen(path, scenario=SCENARIO, likelihood=lk)
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            secs.append(wall)
            ratios.append(wall / dur)
            cpu_ratios.append(cpu / dur)
        chosen.append(heard.command)
    q = statistics.quantiles(ratios, n=10) if len(ratios) > 1 else ratios * 9
    return LikelihoodLatency(round(statistics.median(secs), 4), round(statistics.median(ratios), 4),
                             round(q[-1], 4), round(statistics.median(cpu_ratios), 4),
                             tuple(round(s, 4) for s in secs), tuple(chosen))


def run_latency(noise: str = "babble", snr: float = 10.0, repeats: int = 3, quick: bool = False) -> LatencyResult:
    """Per likelihood: p50 seconds, ratio_p50 (and p90), chosen commands."""
    from siftom.likelihood.registry import resolve_likelihood

    default = resolve_likelihood(None, has_audio=True)[0]
    where = Machine.here()
    with tempfile.TemporaryDirectory(prefix="siftom-latency-") as tmp:
        clips = make_clips(Path(tmp), noise, snr, quick)
        timed = {lk: _time_likelihood(lk, clips, repeats) for lk in LIKELIHOODS}
    return LatencyResult(SCENARIO, noise, snr, repeats, default, where, timed,
                         tuple(round(d, 2) for _, d, _ in clips))
