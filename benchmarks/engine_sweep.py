"""Compare scene ASR engine variants end to end without the team simulations.

Run: .venv/bin/python benchmarks/engine_sweep.py ENGINE OPTIONS_JSON OUT_DIR DATASET [DATASET ...]
      [--workers 2] [--nbest 5]
ENGINE is a registered scene engine (pocketsphinx-vocab, pocketsphinx-open, ...), OPTIONS_JSON
extra keyword arguments for it ('{}' for none). Each dataset is transcribed once (cached in
OUT_DIR/<dataset name>.jsonl; delete the file to redo it) with the evaluator's vocabulary
(every phrasing of every class of the dataset), then scored: 1-best WER, object-word error,
CPU-time RTF, and the accuracy of literal-asr, speech-only and siftom (the evaluator's models
and likelihood) by SNR, with the mean over clean/20/10/5 dB.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from siftom.bench.stimuli import load_dataset, scenario_for
from siftom.bench.trials import dataset_vocabulary, is_correct
from siftom.likelihood.background import lexicon_words
from siftom.likelihood.lexicon import default_lexicon
from siftom.speech.metrics import object_word_errors, wer

CONDS = ("clean", "20", "10", "5")
_ENGINE: Any = None


def _init(engine: str, options: dict[str, Any], vocab: tuple[str, ...]) -> None:
    global _ENGINE
    from siftom.speech.asr.base import get_engine

    _ENGINE = get_engine(engine, vocabulary=vocab, **options)


def _transcribe(job: tuple[str, str, int]) -> dict[str, Any]:
    sid, path, nbest = job
    c0 = time.process_time()
    t = _ENGINE.transcribe(path, nbest=nbest)
    cpu = time.process_time() - c0
    return {"id": sid, "text": t.text, "nbest": [{"text": h.text, "score": round(float(h.score), 4)} for h in t.nbest],
            "cpu_rtf": round(cpu / max(t.audio_s, 1e-3), 4), "rtf": round(t.rtf, 4), "audio_s": round(t.audio_s, 3)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("engine")
    ap.add_argument("options")
    ap.add_argument("out")
    ap.add_argument("datasets", nargs="+")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--nbest", type=int, default=5)
    a = ap.parse_args()
    options = json.loads(a.options)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    words = lexicon_words(default_lexicon())
    for d in a.datasets:
        ds = load_dataset(d, check_audio=False)
        cache = out / f"{Path(d).name}.jsonl"
        if not cache.is_file():
            vocab = dataset_vocabulary(ds.stimuli)
            jobs = [(s.id, str(Path(d) / s.audio), a.nbest) for s in ds.stimuli]
            with ProcessPoolExecutor(a.workers, initializer=_init, initargs=(a.engine, options, vocab)) as ex:
                rows = list(ex.map(_transcribe, jobs, chunksize=8))
            cache.write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
        trs = {r["id"]: r for r in map(json.loads, cache.read_text(encoding="utf-8").splitlines())}
        score(d, trs, out, f"{a.engine} {a.options}", words)


def score(d: str, trs: dict[str, dict[str, Any]], out: Path, label: str, words: set[str] | None = None,
          quiet: bool = False) -> dict[str, float]:
    """Score transcripts (``id -> {text, nbest, cpu_rtf}``) of dataset ``d`` as ``siftom eval`` does;
    print the table and return the mean accuracy per model (plus ``object_err``)."""
    from siftom.api import get_model
    from siftom.bench.literal import literal_command
    from siftom.inference.model import Observation
    from siftom.observation import Hypothesis, Instruction
    from siftom.world.commands import MAX_COUNT

    words = words if words is not None else lexicon_words(default_lexicon())
    ds = load_dataset(d, check_audio=False)
    acc: dict[str, dict[str, list[bool]]] = defaultdict(lambda: defaultdict(list))
    werc: dict[str, list[float]] = defaultdict(list)
    oe: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    rtf: list[float] = []
    full, speech = get_model("full", "phonetic"), get_model("speech-only", "phonetic")
    per: list[dict[str, Any]] = []
    for s in ds.stimuli:
        tr = trs[s.id]
        sc = scenario_for(s)
        c = "clean" if s.snr_db is None else f"{s.snr_db:g}"
        werc[c].append(wer(s.reference, tr["text"]))
        e, n = object_word_errors(s.reference, tr["text"], words)
        oe[c][0] += e
        oe[c][1] += n
        rtf.append(tr["cpu_rtf"])
        cmd = literal_command(tr["text"], sc, max_count=MAX_COUNT)
        acc["literal-asr"][c].append(cmd is not None and is_correct(str(cmd), s.gold_command, sc.verb))
        hyps = tuple(Hypothesis(h["text"], h["score"]) for h in tr["nbest"] if h["text"])
        for name, m in (("speech-only", speech), ("siftom", full)):
            if not hyps and name == "speech-only":
                ok = False
            else:
                post = m.infer(Observation.from_scenario(sc, Instruction(nbest=hyps) if hyps else None))
                ok = is_correct(post.command, s.gold_command, sc.verb)
            acc[name][c].append(ok)
        per.append({"id": s.id, "cond": c, "reference": s.reference, "gold": s.gold_command, "text": tr["text"],
                    **{m: acc[m][c][-1] for m in acc}})
    (out / f"{Path(d).name}.scored.jsonl").write_text("".join(json.dumps(r) + "\n" for r in per), encoding="utf-8")
    conds = [c for c in CONDS if werc[c]]
    rtf.sort()
    wall = sorted(trs[s.id].get("rtf", 0.0) for s in ds.stimuli)
    if not quiet:
        print(f"{label} {d} (n={len(ds.stimuli)}) cpu RTF mean {sum(rtf) / len(rtf):.3f} "
              f"p50 {rtf[len(rtf) // 2]:.3f}; wall RTF mean {sum(wall) / len(wall):.3f} p50 {wall[len(wall) // 2]:.3f}")
        print("  WER %          " + " ".join(f"{100 * sum(werc[c]) / len(werc[c]):5.0f}" for c in conds))
        print("  object err %   " + " ".join(f"{100 * oe[c][0] / max(1, oe[c][1]):5.0f}" for c in conds))
        for m, dd in acc.items():
            vals = [100 * sum(dd[c]) / len(dd[c]) for c in conds]
            print(f"  {m:14s} " + " ".join(f"{v:5.1f}" for v in vals) + f"  mean {sum(vals) / len(vals):5.1f}")

    res = {m: sum(100 * sum(dd[c]) / len(dd[c]) for c in conds) / len(conds) for m, dd in acc.items()}
    res["object_err"] = 100 * sum(oe[c][0] for c in conds) / max(1, sum(oe[c][1] for c in conds))
    return res


if __name__ == "__main__":
    main()
