"""A dereverberation front end (single-channel WPE, speech/dereverb.py) before the default path:
accuracy, confident wrong answers and the recogniser's WER per room and distance, with and without.

For every stimulus the evaluator's ``siftom`` path runs twice: on the clip as it is and on the clip
after ``dereverberate`` (the same samples then go to the voice-activity detector, the recogniser's
N-best and Whisper, as ``siftom.listen`` hears them). That path is the one of
bench/acoustic_models.py: the whole clip to the evaluator's recogniser (pocketsphinx on the
dataset's vocabulary, 10-best), the full model with the acoustic likelihood through the
evaluator's observer, MAP; a clip where nothing was recognised is answered from the actions alone.
Per group (each room at each distance, ``dry`` for clips heard in no room, each SNR band and
``all``): accuracy %, the share answered wrongly with P >= 0.8, and the recogniser's 1-best WER %;
and the front end's seconds per clip. Choose settings on one dataset and report them on others.

    python recipes/dereverb_front_end.py --dataset DIR [--taps 10 --delay 3 --iterations 3]
        [--limit N] [--out ROWS.jsonl] [--json]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

CONFIDENT = 0.8
VARIANTS = ("as-is", "wpe")


def room_of(stimulus: Any) -> str:
    """``kitchen 3 m`` for a clip heard in a simulated room, ``dry`` otherwise."""
    extra = stimulus.extra or {}
    if extra.get("room_name"):
        return f"{extra['room_name']} {float(extra['distance_m']):g} m"
    return "dry"


def hear_and_answer(x: np.ndarray, stimulus: Any, scenario: Any, asr: Any, observer: Any) -> dict[str, Any]:
    """The default path on the samples ``x``: chosen command's correctness, its probability, WER."""
    from siftom.bench.scoring import is_correct
    from siftom.speech.asr import DEFAULT_NBEST
    from siftom.speech.metrics import wer
    from siftom.speech.vad import detect_speech

    vad = detect_speech(x)
    tr = asr.transcribe(x, nbest=DEFAULT_NBEST)
    if tr.text:
        instruction = dataclasses.replace(tr.to_instruction(samples=x), snr_db=vad.snr_db)
        post = observer.infer(scenario, None, instruction, likelihood="acoustic", decide="map",
                              gate=False).posterior
    else:
        post = observer.infer(scenario, None, None, mode="action-only", decide="map", gate=False).posterior
    return {"correct": bool(is_correct(post.command, stimulus.gold_command, scenario.verb)),
            "prob": round(float(post.commands[0][1]), 4), "heard": tr.text,
            "wer": round(float(wer(stimulus.reference, tr.text)), 4)}


def collect(dataset: str | Path, limit: int | None = None, taps: int = 10, delay: int = 3,
            iterations: int = 3, engine: str = "pocketsphinx-vocab") -> list[dict[str, Any]]:
    """Per stimulus: its room, band, and per front end the default path's answer (module doc)."""
    from siftom.bench.engines import engine as get_engine
    from siftom.bench.models import eval_settings
    from siftom.bench.trials import dataset_vocabulary
    from siftom.observer import observer_for
    from siftom.people.stimuli import load_dataset, scenario_for
    from siftom.speech.audio import SAMPLE_RATE, load_audio
    from siftom.speech.dereverb import dereverberate

    ds = load_dataset(dataset)
    asr = get_engine(engine, dataset_vocabulary(ds.stimuli))
    observer = observer_for(eval_settings("full"))
    rows = []
    for s in ds.stimuli[:limit]:
        sc = scenario_for(s)
        x = load_audio(ds.root / s.audio)
        t0 = time.perf_counter()
        clean = dereverberate(x, taps=taps, delay=delay, iterations=iterations)
        seconds = time.perf_counter() - t0
        per = {"as-is": hear_and_answer(x, s, sc, asr, observer),
               "wpe": hear_and_answer(clean, s, sc, asr, observer)}
        rows.append({"id": s.id, "room": room_of(s), "snr": "clean" if s.snr_db is None else f"{s.snr_db:g} dB",
                     "audio_s": round(len(x) / SAMPLE_RATE, 3), "front_end_s": round(seconds, 4), "per": per})
    return rows


def summarise(rows: list[dict[str, Any]]) -> dict[str, dict[str, dict[str, float]]]:
    """Per group (room, band, ``all``), per front end: n, accuracy %, confident-wrong %, WER %."""
    groups: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        groups[r["room"]].append(r)
        groups[r["snr"]].append(r)
        groups["all"].append(r)
    out: dict[str, dict[str, dict[str, float]]] = {}
    for name in sorted(groups, key=lambda g: (g == "all", g in ("clean",) or g.endswith(" dB"), g)):
        rs = groups[name]
        out[name] = {}
        for v in VARIANTS:
            got = [r["per"][v] for r in rs]
            out[name][v] = {"n": len(got), "accuracy": round(100 * float(np.mean([g["correct"] for g in got])), 1),
                            "confident_wrong": round(100 * float(np.mean(
                                [(not g["correct"]) and g["prob"] >= CONFIDENT for g in got])), 1),
                            "wer": round(100 * float(np.mean([g["wer"] for g in got])), 1)}
    return out


def front_end_cost(rows: list[dict[str, Any]]) -> dict[str, float]:
    """The front end's mean seconds per clip and its real-time factor."""
    s = float(np.sum([r["front_end_s"] for r in rows]))
    audio = float(np.sum([r["audio_s"] for r in rows]))
    return {"seconds_per_clip": round(s / max(1, len(rows)), 4), "rtf": round(s / audio, 4) if audio else 0.0}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description="WPE dereverberation before the default path, per room and distance.")
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--taps", type=int, default=10)
    ap.add_argument("--delay", type=int, default=3)
    ap.add_argument("--iterations", type=int, default=3)
    ap.add_argument("--limit", type=int, default=None, help="first N stimuli only")
    ap.add_argument("--out", default=None, help="write the per-stimulus rows here (JSON lines)")
    ap.add_argument("--json", dest="as_json", action="store_true", help="print JSON")
    a = ap.parse_args(argv)
    if not Path(a.dataset).is_dir():
        ap.error(f"--dataset {a.dataset}: no such folder")
    rows = collect(a.dataset, a.limit, a.taps, a.delay, a.iterations)
    if a.out:
        Path(a.out).write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
    result, cost = summarise(rows), front_end_cost(rows)
    if a.as_json:
        print(json.dumps({"groups": result, "front_end": cost}, indent=2))
        return
    print("group          n   acc % as-is / wpe   conf-wrong % as-is / wpe   WER % as-is / wpe")
    for name, per in result.items():
        o, w = per["as-is"], per["wpe"]
        print(f"{name:12s} {o['n']:4.0f}   {o['accuracy']:5.1f} / {w['accuracy']:5.1f}   "
              f"{o['confident_wrong']:10.1f} / {w['confident_wrong']:5.1f}   {o['wer']:8.1f} / {w['wer']:5.1f}")
    print(f"front end: {cost['seconds_per_clip']:.3f} s per clip (real-time factor {cost['rtf']:.3f})")


if __name__ == "__main__":
    main()
