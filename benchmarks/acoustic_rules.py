"""Compare ways of turning key-phrase alignment scores into a command posterior (research tool).

Reads the per-stimulus features of benchmarks/acoustic_features.py and prints, per SNR,
accuracy and mean NLL of the gold command under the full model's command posterior
softmax(context + instruction term) for:

* ``phonetic``: the N-best phonetic likelihood alone (what ``siftom`` uses);
* ``acoustic T``: the key-phrase alignment alone at temperature T (pruned as the likelihood prunes);
* ``product T``: alignment / T plus the N-best phonetic likelihood (the default since issue 12);
* ``product T k``: the same with T * exp(k * max(gap, 0)) (the default: T = 75, k = 4);

and the diagnostics behind the choice: pruning recall (is the gold command among the aligned
ones), the within-utterance slope of alignment score against the key phrase's phone count, and
how well the per-frame gap between a free phone loop and the best alignment predicts that the
best alignment is right (AUC).

    python benchmarks/acoustic_rules.py FEATURES.jsonl [FEATURES.jsonl ...]
"""

from __future__ import annotations

import json
import sys
from collections import defaultdict
from collections.abc import Callable

import numpy as np

FAILED = -1e5
ORDER = ["clean", "20 dB", "10 dB", "5 dB", "all"]
GRID = (20, 40, 75, 150, 300)


def lse(v: np.ndarray) -> float:
    """log-sum-exp."""
    m = float(np.max(v))
    return m + float(np.log(np.sum(np.exp(v - m))))


def load(path: str) -> list[dict]:
    """The feature records of one file."""
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def prune_set(r: dict, mass: float = 0.995, most: int = 6, top: int = 3) -> list[int]:
    """The commands AcousticLikelihood aligns (its default pruning rule)."""
    phon, ctx = np.array(r["phon"]), np.array(r["ctx"])
    q = phon + ctx
    p = np.exp(q - lse(q))
    order = np.argsort(-p, kind="stable")
    upto = int(np.searchsorted(np.cumsum(p[order]), mass) + 1)
    keep = set(order[: min(upto, most)].tolist())
    keep.update(np.argsort(-phon, kind="stable")[:top].tolist())
    return sorted(keep)


def good_min(r: dict) -> float:
    """The worst alignment score that did not fail (a failed alignment says nothing)."""
    ok = [s for v in r["align"].values() for s, *_ in v if s > FAILED]
    return min(ok) if ok else 0.0


def gap(r: dict) -> float:
    """(phone loop - best alignment) per frame over the aligned audio (0 when unknown)."""
    ok = [s for v in r["align"].values() for s, *_ in v if s > FAILED]
    if not ok or r["loop"] != r["loop"]:
        return 0.0
    return (r["loop"] - max(ok)) / r["frames"]


def acoustic(r: dict, T: float, with_phonetic: bool, kappa: float = 0.0) -> np.ndarray:
    """The instruction term of AcousticLikelihood.combine for one stimulus."""
    T = T * float(np.exp(kappa * max(gap(r), 0.0)))
    keep = prune_set(r)
    phon = np.array(r["phon"])
    worst = good_min(r)
    v = np.array([lse(np.array([(s if s > FAILED else worst) / T + lp for s, lp, _, _ in r["align"][str(i)]]))
                  for i in keep])
    out = np.full(len(phon), float(v.min()))
    if not with_phonetic:
        out = out + np.minimum(phon - phon[np.array(keep)].min(), 0.0)
    out[np.array(keep)] = v
    return out + phon if with_phonetic else out


def evaluate(rows: list[dict], rule: Callable[[dict], np.ndarray]) -> dict[str, tuple[float, float, int]]:
    """Per SNR: (accuracy %, mean NLL of the gold command, n)."""
    acc: dict[str, list[tuple[bool, float]]] = defaultdict(list)
    for r in rows:
        ctx = np.array(r["ctx"])
        corr = np.array(r["correct"])
        z = ctx + (rule(r) if r["speech"] else 0.0)
        p = np.exp(z - lse(z))
        item = (bool(corr[int(np.argmax(p))]), -float(np.log(max(float(p[corr].sum()), 1e-9))))
        acc[r["snr"]].append(item)
        acc["all"].append(item)
    return {k: (100 * float(np.mean([a for a, _ in v])), float(np.mean([b for _, b in v])), len(v))
            for k, v in acc.items()}


def show(name: str, res: dict) -> None:
    """One line: accuracy/NLL per SNR."""
    print(f"{name:22s} " + "  ".join(f"{k} {res[k][0]:5.1f}/{res[k][1]:.2f}" for k in ORDER if k in res))


def diagnostics(rows: list[dict]) -> None:
    """Pruning recall, phone-count slope, phone-loop gap AUC."""
    sp = [r for r in rows if r["speech"]]
    rec: dict[str, list[bool]] = defaultdict(list)
    for r in sp:
        hit = bool(np.array(r["correct"])[prune_set(r)].any())
        rec[r["snr"]].append(hit)
        rec["all"].append(hit)
    print("pruning recall (gold among the aligned commands): "
          + ", ".join(f"{k} {100 * np.mean(rec[k]):.1f} %" for k in ORDER if k in rec))
    xs, ys = [], []
    for r in sp:
        if r["frame"] is None:
            continue
        items = [(s, nk) for v in r["align"].values() for s, _, nk, _ in v if s > FAILED]
        s = np.array([a for a, _ in items], dtype=float)
        n = np.array([b for _, b in items], dtype=float)
        xs += list(n - n.mean())
        ys += list(s - s.mean())
    x, y = np.array(xs), np.array(ys)
    print(f"alignment score vs key-phrase phones (within utterance): {np.sum(x * y) / np.sum(x * x):.1f} nats "
          f"per phone, r = {np.corrcoef(x, y)[0, 1]:.2f}")
    gaps, right = [], []
    for r in sp:
        al = {int(k): max(s for s, *_ in v) for k, v in r["align"].items()}
        best = max(al, key=al.get)  # type: ignore[arg-type]
        if al[best] <= FAILED or r["loop"] != r["loop"]:
            continue
        gaps.append((r["loop"] - al[best]) / r["frames"])
        right.append(bool(np.array(r["correct"])[best]))
    g, c = np.array(gaps), np.array(right)
    auc = float(np.mean([(a < b) + 0.5 * (a == b) for a in g[c] for b in g[~c]]))
    print(f"best alignment right {100 * c.mean():.1f} %; AUC of the phone-loop gap for that: {auc:.2f}")


def main(paths: list[str]) -> None:
    """Print the tables for each features file."""
    for path in paths:
        rows = load(path)
        print(f"== {path}: {len(rows)} stimuli, {sum(r['speech'] for r in rows)} with words")
        diagnostics(rows)
        show("phonetic", evaluate(rows, lambda r: np.array(r["phon"])))
        for T in GRID:
            show(f"acoustic T={T}", evaluate(rows, lambda r, T=T: acoustic(r, T, False)))
        for T in GRID:
            show(f"product T={T}", evaluate(rows, lambda r, T=T: acoustic(r, T, True)))
        for T in (40, 75):
            for kappa in (2, 4, 8):
                show(f"product T={T} k={kappa}", evaluate(rows, lambda r, T=T, k=kappa: acoustic(r, T, True, k)))


if __name__ == "__main__":
    main(sys.argv[1:])
