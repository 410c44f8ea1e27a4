"""Benchmarks of the audio path: ASR WER/RTF by engine x voice x noise x SNR, and the acoustic
scorer's ranking accuracy and cost. Used by ``siftom bench asr`` / ``siftom bench acoustic``.
"""

from __future__ import annotations

import json
import time
from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from siftom.errors import BackendUnavailableError, SiftomError
from siftom.speech.asr.base import get_engine, normalise_text
from siftom.speech.metrics import word_errors
from siftom.speech.noise import get_noise, mix_at_snr
from siftom.speech.tts import synthesize

KITCHEN_FOODS = (
    "cereal", "milk", "sugar", "coffee", "tea", "pasta", "flour", "bread", "bacon", "egg",
    "lettuce", "butter",
)
# (sentence, in the biased vocabulary?) -- the last two ask for objects the scene lacks
ASR_SENTENCES = (
    ("can you pass me the cereal", True),
    ("bring me the milk", True),
    ("could you get the sugar", True),
    ("i need the flour", True),
    ("pass me the ketchup please", False),
    ("bring me the spoon", False),
)
# Requests outside siftom's phrasing grammar: carriers of the shipped free-v0 set
# (siftom/data/phrasings) around the same foods.
FREE_SENTENCES = (
    "um could you get the cereal for me",
    "i think we're out of milk on the table could you bring some",
    "do me a favor and get the sugar",
    "let me have some bread when you get a chance",
    "the recipe says we need the flour",
    "oh and the butter too",
)
ENGINES = ("pocketsphinx", "pocketsphinx-vocab", "pocketsphinx-open", "pocketsphinx-dual", "whisper")  # registered ASR engines compared
DEFAULT_VOICES = ("flite-slt", "flite-rms", "espeak-en-us+klatt", "espeak-es")
QUICK_VOICES = ("flite-slt", "espeak-en-us+klatt")
DEFAULT_SNRS: tuple[float | None, ...] = (None, 20.0, 10.0, 5.0, 0.0)
QUICK_SNRS: tuple[float | None, ...] = (None, 10.0)
ACOUSTIC_TEMPLATES = ("can you pass me the {x}", "bring me the {x}", "i need the {x}")
ACOUSTIC_VOICES = ("flite-slt", "flite-rms", "flite-awb", "flite-kal16", "espeak-en-us+klatt")


@dataclass(frozen=True)
class AsrRow:
    """WER and RTF of one engine on one condition (voice, noise, SNR; None = clean)."""

    engine: str
    voice: str
    noise: str
    snr_db: float | None
    wer: float
    wer_in_vocab: float
    wer_out_of_vocab: float
    rtf: float
    utterances: int
    wer_free: float = float("nan")
    ower_grammar: float = float("nan")
    ower_free: float = float("nan")


@dataclass(frozen=True)
class AsrBench:
    """All rows of an ASR benchmark run plus what was run."""

    rows: tuple[AsrRow, ...]
    sentences: tuple[str, ...]
    seconds: float
    skipped: tuple[str, ...] = field(default=())

    def to_json(self) -> dict[str, Any]:
        """Plain dict for JSON output."""
        return {
            "rows": [asdict(r) for r in self.rows], "sentences": list(self.sentences),
            "seconds": round(self.seconds, 1), "skipped": list(self.skipped),
        }


def _vocabulary() -> list[str]:
    """The scene vocabulary as ``siftom infer``/``eval`` build it (every phrasing of every command)."""
    from siftom.likelihood.phrasing import command_vocabulary

    return command_vocabulary(KITCHEN_FOODS, "fetch")


def _engine(name: str) -> Any:
    from siftom.speech.asr.base import is_scene_engine

    return get_engine(name, vocabulary=_vocabulary() if is_scene_engine(name) else None)


def run_asr_bench(
    engines: Sequence[str] = ENGINES,
    voices: Sequence[str] = DEFAULT_VOICES,
    noises: Sequence[str] = ("babble",),
    snrs: Sequence[float | None] = DEFAULT_SNRS,
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
) -> AsrBench:
    """Synthesise the fixed sentences, mix at each SNR, transcribe with each engine, score WER.

    The scene engines' vocabulary is every phrasing of ``fetch`` for KITCHEN_FOODS
    (``command_vocabulary``, as in ``siftom infer``/``eval``); sentences marked out-of-vocabulary
    ask for objects outside it, and FREE_SENTENCES say in-scene objects with carriers outside the
    grammar. Besides WER, the object-word error rate (ower_*: object names and counts of the
    reference missing from the 1-best) is reported for grammar and free sentences.
    """
    from siftom.likelihood.background import lexicon_words
    from siftom.likelihood.lexicon import default_lexicon
    from siftom.speech.metrics import object_word_errors

    object_words = lexicon_words(default_lexicon())
    sentences = [*ASR_SENTENCES, *((f, None) for f in FREE_SENTENCES)]
    t0 = time.perf_counter()
    conditions: list[tuple[str, float | None]] = [("none", None)] if None in snrs else []
    conditions += [(n, s) for n in noises for s in snrs if s is not None]
    clips: dict[tuple[str, str, float | None], list[np.ndarray]] = {}
    for vi, voice in enumerate(voices):
        clean = [synthesize(s, voice) for s, _ in sentences]
        for noise, snr in conditions:
            if snr is None:
                clips[(voice, noise, snr)] = clean
                continue
            src = get_noise(noise)
            clips[(voice, noise, snr)] = [
                mix_at_snr(x, src, snr, np.random.default_rng([seed, vi, i, int(snr * 10)]))
                for i, x in enumerate(clean)
            ]
    rows: list[AsrRow] = []
    skipped: list[str] = []
    for engine_name in engines:
        try:
            engine = _engine(engine_name)
        except BackendUnavailableError as exc:
            skipped.append(f"{engine_name}: {exc}")
            continue
        for (voice, noise, snr), xs in clips.items():
            if progress:
                progress(f"{engine_name} {voice} {noise} {snr}")
            err: defaultdict[str, int] = defaultdict(int)
            words: defaultdict[str, int] = defaultdict(int)
            dec_s = audio_s = 0.0
            for (ref, inv), x in zip(sentences, xs, strict=True):
                tr = engine.transcribe(x)
                e, n = word_errors(ref, tr.text)
                key = "free" if inv is None else "in" if inv else "out"
                err[key] += e
                words[key] += n
                if inv is not False:
                    oe, on = object_word_errors(ref, tr.text, object_words)
                    err["o" + key] += oe
                    words["o" + key] += on
                dec_s += tr.rtf * tr.audio_s
                audio_s += tr.audio_s
            total_e, total_n = err["in"] + err["out"], words["in"] + words["out"]
            rows.append(AsrRow(
                engine_name, voice, noise, snr, total_e / total_n,
                err["in"] / max(1, words["in"]), err["out"] / max(1, words["out"]),
                dec_s / audio_s, len(xs), err["free"] / max(1, words["free"]),
                err["oin"] / max(1, words["oin"]), err["ofree"] / max(1, words["ofree"]),
            ))
    return AsrBench(tuple(rows), tuple(s for s, _ in sentences), time.perf_counter() - t0, tuple(skipped))


def summarise_wer(bench: AsrBench) -> dict[str, dict[str, float]]:
    """Mean WER per engine and SNR label ('clean', '20', ...) over voices and noises."""
    acc: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for r in bench.rows:
        acc[r.engine]["clean" if r.snr_db is None else f"{r.snr_db:g}"].append(r.wer)
    return {e: {k: float(np.mean(v)) for k, v in d.items()} for e, d in acc.items()}


def plot_wer_vs_snr(bench: AsrBench, path: str | Path) -> Path:
    """Write a PNG of mean WER against SNR, one line per engine (clean drawn at 30 dB)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for engine, by_snr in summarise_wer(bench).items():
        pts = sorted((30.0 if k == "clean" else float(k), v * 100) for k, v in by_snr.items())
        ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=engine)
    ax.set_xlabel("SNR (dB, babble; 30 = clean)")
    ax.set_ylabel("WER (%)")
    ax.set_title("siftom bench asr: WER vs SNR (mean over voices)")
    ax.grid(alpha=0.3)
    ax.legend()
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(p, dpi=120)
    plt.close(fig)
    return p


@dataclass(frozen=True)
class AcousticBench:
    """Ranking accuracy of the acoustic scorer vs a 1-best transcript baseline, and its cost.

    Attributes:
        accuracy: share of utterances where the true phrasing scores highest among the
            candidates that swap the object (same template, every food).
        baseline_accuracy: share where the biased-LM pocketsphinx 1-best names the true food.
        phonetic_accuracy: share where the N-best phonetic likelihood (siftom.likelihood.phonetic,
            on the biased-LM 10-best) ranks the true food first.
        ms_per_candidate: mean alignment time per candidate.
        utterances: number of test utterances; candidates: candidates per utterance.
        snr_db: None for clean.
        by_voice: accuracy per voice.
        confusions: (true, chosen) pairs of the errors.
    """

    accuracy: float
    baseline_accuracy: float
    phonetic_accuracy: float
    ms_per_candidate: float
    baseline_ms: float
    phonetic_ms: float
    utterances: int
    candidates: int
    snr_db: float | None
    by_voice: dict[str, float]
    confusions: tuple[tuple[str, str], ...]
    seconds: float

    def to_json(self) -> dict[str, Any]:
        """Plain dict for JSON output."""
        d = asdict(self)
        d["confusions"] = [list(c) for c in self.confusions]
        return d


def run_acoustic_bench(
    voices: Sequence[str] = ACOUSTIC_VOICES,
    foods: Sequence[str] = KITCHEN_FOODS,
    templates: Sequence[str] = ACOUSTIC_TEMPLATES,
    snr_db: float | None = None,
    noise: str = "babble",
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
) -> AcousticBench:
    """Speak every template x food with every voice; rank the swapped-object candidates."""
    from siftom.likelihood.phonetic import PhoneticLikelihood
    from siftom.speech.acoustic import ForcedAligner
    from siftom.world.commands import RobotCommand

    t0 = time.perf_counter()
    aligner = ForcedAligner()
    asr = get_engine("pocketsphinx", vocabulary=list(foods))
    phonetic = PhoneticLikelihood()
    commands = [RobotCommand("fetch", f.replace(" ", "_")) for f in foods]
    correct = base_correct = phon_correct = n = 0
    align_s = asr_s = phon_s = 0.0
    n_cand = 0
    per_voice: dict[str, list[int]] = defaultdict(list)
    confusions: list[tuple[str, str]] = []
    src = get_noise(noise) if snr_db is not None else None
    for vi, voice in enumerate(voices):
        if progress:
            progress(voice)
        for ti, tpl in enumerate(templates):
            cands = [tpl.format(x=f) for f in foods]
            for fi, food in enumerate(foods):
                x = synthesize(cands[fi], voice)
                if src is not None and snr_db is not None:
                    x = mix_at_snr(x, src, snr_db, np.random.default_rng([seed, vi, ti, fi]))
                r = aligner.score(x, cands)
                align_s += r.seconds
                n_cand += len(cands)
                chosen = foods[int(np.argmax(r.scores))]
                ok = chosen == food
                correct += ok
                per_voice[voice].append(ok)
                if not ok:
                    confusions.append((food, chosen))
                tr = asr.transcribe(x, nbest=10)
                asr_s += tr.rtf * tr.audio_s
                heard = [f for f in foods if f in normalise_text(tr.text).split()]
                base_correct += bool(heard) and heard[0] == food
                if any(h.text for h in tr.nbest):
                    tp = time.perf_counter()
                    lp = phonetic.log_prob(tr.to_instruction(), commands).log_probs
                    phon_s += time.perf_counter() - tp
                    phon_correct += int(np.argmax(lp)) == fi
                n += 1
    if n == 0:
        raise SiftomError("the acoustic benchmark needs at least one voice, template and food")
    return AcousticBench(
        correct / n, base_correct / n, phon_correct / n, 1000 * align_s / n_cand, 1000 * asr_s / n,
        1000 * phon_s / n, n, len(foods),
        snr_db, {v: float(np.mean(k)) for v, k in per_voice.items()}, tuple(confusions),
        time.perf_counter() - t0,
    )


def write_json(obj: Any, path: str | Path) -> Path:
    """Write JSON (creating the folder)."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps(obj, indent=2) + "\n", encoding="utf-8")
    return p
