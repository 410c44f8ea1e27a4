"""Compare ways of combining the Whisper factor with the acoustic likelihood, offline (research tool).

Reads the per-stimulus dumps of benchmarks/whisper_features.py and prints accuracy per SNR
band for: the context with the phonetic likelihood (``siftom``), with the shipped acoustic
likelihood (``acoustic``), and the acoustic likelihood plus w / T_w for each temperature and
padding (only the acoustic scorer's pruned candidates scored, the rest at the worst kept
score, as ``AcousticLikelihood`` does), plus the phonetic likelihood plus w / T_w.

    python benchmarks/whisper_rules.py DUMP.jsonl [DUMP2.jsonl ...] [--temps 1,2,3,5,8]
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict

import numpy as np
from scipy.special import logsumexp


def wscore(items: list[list[float]]) -> float:
    return float(logsumexp([s + lp for s, lp in items]))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("dumps", nargs="+")
    ap.add_argument("--temps", default="1,1.5,2,3,4,6,10")
    ap.add_argument("--prune", type=int, default=1)
    ap.add_argument("--betas", default="0,0.5,1")
    ap.add_argument("--only", default="", help="comma-separated rule-name prefixes to print")
    a = ap.parse_args()
    rows = []
    for d in a.dumps:
        with open(d, encoding="utf-8") as f:
            rows += [json.loads(line) for line in f if line.strip()]
    temps = [float(t) for t in a.temps.split(",")]
    acc: dict[str, dict[str, list[bool]]] = defaultdict(lambda: defaultdict(list))
    nll: dict[str, list[float]] = defaultdict(list)
    for r in rows:
        ctx = np.array(r["ctx"])
        corr = np.array(r["correct"])

        def add(name: str, lik: np.ndarray | None, ctx: np.ndarray = ctx, corr: np.ndarray = corr,
                r: dict = r) -> None:
            q = ctx if lik is None else ctx + lik
            ok = bool(corr[int(np.argmax(q))])
            acc[name][r["snr"]].append(ok)
            acc[name]["all"].append(ok)
            p = np.exp(q - logsumexp(q))
            nll[name].append(-float(np.log(max(p[corr].sum(), 1e-12))))

        if not r.get("speech"):
            for name in ["siftom", "acoustic"]:
                add(name, None)
            continue
        phon, ac = np.array(r["phon"]), np.array(r["ac"])
        add("siftom", phon)
        add("acoustic", ac)
        keep = np.array(r["keep"]) if a.prune else np.arange(len(phon))
        for pad, per in r["w"].items():
            for beta in [float(b) for b in a.betas.split(",")]:
                w0 = r.get("w0", {}).get(pad)
                if beta and w0 is None:
                    continue
                wide = np.array(r.get("wide", range(len(phon))))
                w = np.full(len(phon), -np.inf)
                w[wide] = [float(logsumexp([s - beta * s0 + lp for (s, lp), (s0, _) in zip(it, it0, strict=True)]))
                           for it, it0 in zip(per, w0 or per, strict=True)]
                if not a.prune:
                    keep = wide
                wk = np.full(len(w), np.min(w[keep]))
                wk[keep] = w[keep]
                for T in temps:
                    add(f"ac+w/{T:g} b{beta:g} pad{pad}", ac + wk / T)
                    add(f"phon+w/{T:g} b{beta:g} pad{pad}", phon + wk / T)
    bands = ["clean", "20 dB", "10 dB", "5 dB", "all"]
    print(f"{'rule':28s} " + " ".join(f"{b:>7s}" for b in bands) + "   NLL")
    only = [o for o in a.only.split(",") if o]
    for name, d in acc.items():
        if only and name not in ("siftom", "acoustic") and not any(name.startswith(o) for o in only):
            continue
        print(f"{name:28s} " + " ".join(f"{100 * np.mean(d[b]):7.1f}" if d[b] else "      -" for b in bands)
              + f"  {np.mean(nll[name]):.3f}")


if __name__ == "__main__":
    main()
