"""``siftom bench latency``: time from an audio file to the chosen command, per likelihood.

Clips of 1-4 s (TTS voices, recorded or synthetic babble at 10 dB, fixed seeds) are written to
WAV files; each is passed to ``siftom.api.listen`` as a path, so the time covers reading the file,
voice-activity detection, recognition, the instruction likelihood and the posterior. Process
start-up is excluded and the per-home set-up (recogniser, model, action term) is built by one
warm-up call first, as a robot that lives in one home would. ``ratio_p50`` is the median over all
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
from pathlib import Path
from typing import Any

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


def run_latency(noise: str = "babble", snr: float = 10.0, repeats: int = 3, quick: bool = False) -> dict[str, Any]:
    """Per likelihood: p50 seconds, ratio_p50 (and p90), chosen commands."""
    import os
    import platform

    from siftom.api import listen
    from siftom.likelihood.registry import resolve_likelihood

    result: dict[str, Any] = {"scenario": SCENARIO, "noise": noise, "snr_db": snr, "repeats": repeats,
                              "default": resolve_likelihood(None, has_audio=True)[0],
                              "machine": {"cpus": os.cpu_count(), "processor": _cpu_name() or platform.machine(),
                                          "load_1min": round(os.getloadavg()[0], 2)},
                              "likelihoods": {}}
    with tempfile.TemporaryDirectory(prefix="siftom-latency-") as tmp:
        clips = make_clips(Path(tmp), noise, snr, quick)
        result["clip_seconds"] = [round(d, 2) for _, d, _ in clips]
        for lk in LIKELIHOODS:
            listen(clips[0][0], scenario=SCENARIO, likelihood=lk)  # per-home set-up, cached
            secs, ratios, cpu_ratios, chosen = [], [], [], []
            for path, dur, _ in clips:
                for _ in range(repeats):  # every run counts (the median of all of them, not the fastest)
                    t0, c0 = time.perf_counter(), time.process_time()
                    heard = listen(path, scenario=SCENARIO, likelihood=lk)
                    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
                    secs.append(wall)
                    ratios.append(wall / dur)
                    cpu_ratios.append(cpu / dur)
                chosen.append(heard.command)
            q = statistics.quantiles(ratios, n=10) if len(ratios) > 1 else ratios * 9
            result["likelihoods"][lk] = {
                "p50_s": round(statistics.median(secs), 4), "ratio_p50": round(statistics.median(ratios), 4),
                "ratio_p90": round(q[-1], 4), "cpu_ratio_p50": round(statistics.median(cpu_ratios), 4),
                "seconds": [round(s, 4) for s in secs], "commands": chosen}
    return result


def _cpu_name() -> str:
    try:
        text = Path("/proc/cpuinfo").read_text(encoding="utf-8")
    except OSError:
        return ""
    return next((ln.split(":", 1)[1].strip() for ln in text.splitlines() if ln.startswith("model name")), "")
