"""Mix two engines' saved N-best lists offline and score them like ``siftom eval``.

Run: .venv/bin/python benchmarks/mix_sweep.py CLOSED_DIR OPEN_DIR DATASET [DATASET ...]
      [--weights 0.5] [--per-list 5] [--nbest 5]
CLOSED_DIR and OPEN_DIR are ``benchmarks/engine_sweep.py`` output folders (decoded with a larger
``--nbest``, e.g. 10, so shorter lists can be cut from them). For each weight w of the open list
(``pocketsphinx-dual`` is w = 0.5, 5 per list, 5 kept) the lists are mixed with
``siftom.speech.asr.dual.mix_nbest`` and scored by ``engine_sweep.score``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from engine_sweep import score  # noqa: E402

from siftom.observation import Hypothesis  # noqa: E402
from siftom.speech.asr.dual import mix_nbest  # noqa: E402

TEXT_RULE = "mixed"  # the 1-best text: the mixed list's first, or "free-open" (see --text-rule)


def _load(folder: str, d: str) -> dict[str, dict[str, Any]]:
    path = Path(folder) / f"{Path(d).name}.jsonl"
    return {r["id"]: r for r in map(json.loads, path.read_text(encoding="utf-8").splitlines())}


def mixed(a: dict[str, Any], b: dict[str, Any], w: float, per_list: int, nbest: int,
          phrase_words: set[str] | None = None, w_free: float | None = None) -> dict[str, Any]:
    """One stimulus' mixed transcript row (same keys as engine_sweep's cache). With
    ``phrase_words`` and ``w_free``: the open list's weight is ``w_free`` when its 1-best holds a
    word outside the phrasings (the request is free speech), else ``w``."""
    if phrase_words is not None and w_free is not None and any(t not in phrase_words for t in b["text"].split()):
        w = w_free
    la = [Hypothesis(h["text"], h["score"]) for h in a["nbest"][:per_list]]
    lb = [Hypothesis(h["text"], h["score"]) for h in b["nbest"][:per_list]]
    if w in (0.0, 1.0):
        hyps = tuple(mix_nbest([lb if w else la], nbest))
    else:
        hyps = _weighted([la, lb], [1 - w, w], nbest)
    text = hyps[0].text if hyps else ""
    if TEXT_RULE == "free-open" and phrase_words is not None:
        free = any(t not in phrase_words for t in b["text"].split())
        text = b["text"] if free else a["text"]
    return {"text": text, "nbest": [{"text": h.text, "score": h.score} for h in hyps],
            "cpu_rtf": a["cpu_rtf"] + b["cpu_rtf"], "rtf": max(a.get("rtf", 0.0), b.get("rtf", 0.0))}


def _weighted(lists: list[list[Hypothesis]], weights: list[float], nbest: int) -> tuple[Hypothesis, ...]:
    import numpy as np

    acc: dict[str, list[float]] = {}
    for lst, wt in zip(lists, weights, strict=True):
        if not lst:
            continue
        s = np.array([h.score for h in lst])
        z = s.max() + math.log(float(np.exp(s - s.max()).sum()))
        seen: set[str] = set()
        for h in lst:
            if h.text not in seen:
                seen.add(h.text)
                acc.setdefault(h.text, []).append(math.log(wt) + h.score - z)
    out = sorted(((t, float(np.logaddexp.reduce(v))) for t, v in acc.items()), key=lambda kv: -kv[1])
    return tuple(Hypothesis(t, s) for t, s in out[:nbest])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("closed")
    ap.add_argument("open")
    ap.add_argument("datasets", nargs="+")
    ap.add_argument("--weights", default="0.5")
    ap.add_argument("--per-list", default="5")
    ap.add_argument("--nbest", default="5")
    ap.add_argument("--out", default="runs/mix")
    ap.add_argument("--w-free", default="", help="open weight(s) when the open 1-best has a non-phrasing word")
    ap.add_argument("--text-rule", default="mixed", choices=["mixed", "free-open"],
                    help="free-open: the open 1-best when it holds a non-phrasing word, else the closed 1-best")
    a = ap.parse_args()
    global TEXT_RULE
    TEXT_RULE = a.text_rule
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    from siftom.bench.stimuli import load_dataset
    from siftom.bench.trials import dataset_vocabulary

    for d in a.datasets:
        ca, cb = _load(a.closed, d), _load(a.open, d)
        pw = {t for p in dataset_vocabulary(load_dataset(d, check_audio=False).stimuli) for t in p.split()}
        for w in map(float, a.weights.split(",")):
          for wf in ([None] if not a.w_free else [float(x) for x in a.w_free.split(",")]):
            for k in map(int, a.per_list.split(",")):
                for n in map(int, a.nbest.split(",")):
                    trs = {sid: mixed(ca[sid], cb[sid], w, k, n, pw, wf) for sid in ca}
                    r = score(d, trs, out, f"w={w} per_list={k} nbest={n}", quiet=True)
                    print(f"{Path(d).name:22s} w={w:.2f} wf={wf} per_list={k:2d} nbest={n:2d}  literal {r['literal-asr']:5.1f}"
                          f"  speech-only {r['speech-only']:5.1f}  siftom {r['siftom']:5.1f}  obj_err {r['object_err']:5.1f}",
                          flush=True)


if __name__ == "__main__":
    main()
