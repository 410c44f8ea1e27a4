"""Compare ways of turning key-phrase alignment scores into a command posterior (research tool).

Reads the per-stimulus features of benchmarks/acoustic_features.py and, for each rule, the
full model's command posterior softmax(context + instruction term); prints accuracy and mean
NLL of the gold command per SNR, and pruning recall.

    python benchmarks/acoustic_rules.py FEATURES.jsonl [BASELINE_RESULTS.jsonl]
"""

from __future__ import annotations

import json
import sys
from collections import defaultdict

import numpy as np


def lse(v: np.ndarray) -> float:
    m = float(np.max(v))
    return m + float(np.log(np.sum(np.exp(v - m))))


def load(path: str) -> list[dict]:
    return [json.loads(line) for line in open(path) if line.strip()]


def prune_set(r: dict, mass: float = 0.995, most: int = 6, top: int = 3) -> list[int]:
    phon, ctx = np.array(r["phon"]), np.array(r["ctx"])
    q = phon + ctx
    p = np.exp(q - lse(q))
    order = np.argsort(-p, kind="stable")
    upto = int(np.searchsorted(np.cumsum(p[order]), mass) + 1)
    keep = set(order[: min(upto, most)].tolist())
    keep.update(np.argsort(-phon, kind="stable")[:top].tolist())
    return sorted(keep)


def acoustic(r: dict, keep: list[int], T: float, norm: str = "none", floor_rule: bool = True) -> np.ndarray:
    """Instruction term per command from the alignment scores of ``keep`` at temperature T."""
    n = len(r["cmds"])
    phon = np.array(r["phon"])
    vals = {}
    for i in keep:
        items = r["align"][str(i)]
        terms = []
        for s, lp, nk, nt in items:
            if s <= FAILED:
                s = good_min(r)
            if norm == "phone":
                s = s / max(nt, 1) * 10
            terms.append(s / T + lp)
        vals[i] = lse(np.array(terms))
    kk = np.array(keep)
    v = np.array([vals[i] for i in keep])
    floor = float(v.min())
    out = np.full(n, floor)
    if floor_rule and len(keep) < n:
        ref = float(phon[kk].min())
        out = floor + np.minimum(phon - ref, 0.0)
    out[kk] = v
    return out


FAILED = -1e5


def good_min(r: dict) -> float:
    """The worst alignment score that did not fail (a failed alignment says nothing)."""
    ok = [s for v in r["align"].values() for s, *_ in v if s > FAILED]
    return min(ok) if ok else 0.0


def post(ctx: np.ndarray, lik: np.ndarray) -> np.ndarray:
    z = ctx + lik
    return np.exp(z - lse(z))


def evaluate(rows: list[dict], rule) -> dict[str, tuple[float, float, int]]:  # noqa: ANN001
    acc: dict[str, list[tuple[bool, float]]] = defaultdict(list)
    for r in rows:
        ctx = np.array(r["ctx"])
        corr = np.array(r["correct"])
        if not r["speech"]:
            p = post(ctx, np.zeros(len(ctx)))
        else:
            p = post(ctx, rule(r))
        ok = bool(corr[int(np.argmax(p))])
        pg = float(p[corr].sum())
        acc[r["snr"]].append((ok, -np.log(max(pg, 1e-9))))
        acc["all"].append((ok, -np.log(max(pg, 1e-9))))
    return {k: (100 * np.mean([a for a, _ in v]), float(np.mean([b for _, b in v])), len(v)) for k, v in acc.items()}


ORDER = ["clean", "20 dB", "10 dB", "5 dB", "all"]


def show(name: str, res: dict) -> None:
    print(f"{name:38s} " + "  ".join(f"{k}:{res[k][0]:5.1f}/{res[k][1]:.2f}" for k in ORDER if k in res))


def main(path: str, base: str | None = None) -> None:
    rows = load(path)
    sp = [r for r in rows if r["speech"]]
    print(len(rows), "stimuli", len(sp), "with speech")
    # pruning recall
    for name, ks in (("prune (current)", lambda r: prune_set(r)), ("wide", lambda r: [int(k) for k in r["align"]])):
        rec = defaultdict(list)
        for r in sp:
            corr = np.array(r["correct"])
            hit = bool(corr[ks(r)].any())
            rec[r["snr"]].append(hit)
            rec["all"].append(hit)
        print(f"recall {name:20s}", {k: round(100 * np.mean(rec[k]), 1) for k in ORDER if k in rec})
    if base:
        b = {json.loads(line)["id"]: json.loads(line) for line in open(base)}
        res = defaultdict(list)
        for r in rows:
            m = b[r["id"]]["models"]["siftom"]
            res[r["snr"]].append(m["correct"])
            res["all"].append(m["correct"])
        print("siftom (eval)".ljust(38), "  ".join(f"{k}:{100 * np.mean(res[k]):5.1f}" for k in ORDER))
    show("phonetic (siftom rebuilt)", evaluate(rows, lambda r: np.array(r["phon"])))
    for T in (20, 40, 75, 150):
        show(f"acoustic current prune T={T}", evaluate(rows, lambda r, T=T: acoustic(r, prune_set(r), T)))
    for T in (20, 40, 75, 150):
        show(f"acoustic wide T={T}", evaluate(rows, lambda r, T=T: acoustic(r, [int(k) for k in r["align"]], T)))
    for T in (20, 40, 75, 150, 300):
        show(f"phon + acoustic wide T={T}",
             evaluate(rows, lambda r, T=T: np.array(r["phon"]) + acoustic(r, [int(k) for k in r["align"]], T)))




def extra(rows: list[dict]) -> None:
    """Mode split and combined rules."""
    wide = lambda r: [int(k) for k in r["align"]]  # noqa: E731
    n_sent = sum(1 for r in rows if r["speech"] and r["frame"] is None)
    print("sentence-mode stimuli:", n_sent)
    for T in (40, 75, 150):
        show(f"key-mode acoustic, else phon T={T}", evaluate(
            rows, lambda r, T=T: acoustic(r, wide(r), T) if r["frame"] is not None else np.array(r["phon"])))
    for T in (40, 75, 150, 300):
        show(f"key: phon+acoustic, else phon T={T}", evaluate(
            rows, lambda r, T=T: np.array(r["phon"]) + (acoustic(r, wide(r), T) if r["frame"] is not None else 0)))


if __name__ == "__main__":
    main(*sys.argv[1:])
    extra(load(sys.argv[1]))
