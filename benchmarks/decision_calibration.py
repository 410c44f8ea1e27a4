"""Does calibrating the posterior let expected benefit keep siftom's speedup at <= 3 % negative? (issue 11)

Reads decision caches (benchmarks/decision_cache.py) and VAD SNR estimates
(benchmarks/snr_estimates.py) of development sets (seed 1) and evaluation sets. Calibration
maps, all a weight ``w`` on the instruction log-likelihood (a likelihood temperature 1/w):

* ``none``: w = 1 (the posterior as it is);
* ``global``: one w for every utterance, the one with the smallest NLL of the gold command on
  the development sets (both domains pooled);
* ``snr``: w linear in the VAD's speech-to-background estimate (the robot does not know the
  stimulus SNR), from w_lo at <= 12 dB to w_hi at >= 28 dB, fitted by NLL on the same sets;
* ``oracle-snr``: w per true SNR condition (not available to a robot; an upper bound for
  any SNR-based map), fitted by NLL per condition on the development sets.

For each map the loss aversion is chosen on the development sets as the issue's tuning rule
does (the smallest lambda with <= 3 % negative on both), then every set is scored: NLL and
ECE of the MAP command, and expected benefit's mean speedup and negative share (each chosen
action through the team simulation), next to the MAP command's.

    PYTHONPATH=src:benchmarks python benchmarks/decision_calibration.py
"""

from __future__ import annotations

import json

import decision_explore as de
import numpy as np

SETS = {
    "k1": ("/work/final/dev1/kitchen/dataset", "/work/final/dev1/kitchen/ask2"),
    "h1": ("/work/final/dev1/household/dataset", "/work/final/dev1/household/ask2"),
    "k0": ("/work/datasets/kitchen", "/work/s3/kitchen"),
    "h0": ("/work/datasets/household", "/work/s3/household"),
    "kh": ("/work/datasets/heldout-kitchen", "/work/s3/heldout-kitchen"),
    "k7": ("/work/final/s7-kitchen/dataset", "/work/final/s7-kitchen/results"),
    "h7": ("/work/final/s7-household/dataset", "/work/final/s7-household/results"),
}
DEV = ("k1", "h1")
LO, HI = 12.0, 28.0
LAMS = (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0)


def weight(params: tuple):
    kind = params[0]
    if kind == "global":
        return lambda r: params[1]
    if kind == "oracle-snr":
        table = params[1]
        return lambda r: table[r["snr"]]
    _, wl, wh = params
    return lambda r: wl + (wh - wl) * min(max((r["est"] - LO) / (HI - LO), 0.0), 1.0)


def nll(recs, f) -> float:
    out = []
    for r in recs:
        cm = de.cmd_marg(r, de.post(r, f(r)))
        g = [k for k, c in enumerate(r["commands"]) if de.correct(r, c)]
        out.append(-np.log(max(cm[g].sum(), 1e-12)))
    return float(np.mean(out))


def ece(recs, f) -> float:
    conf, ok = [], []
    for r in recs:
        cm = de.cmd_marg(r, de.post(r, f(r)))
        k = int(np.argmax(cm))
        conf.append(cm[k])
        ok.append(de.correct(r, r["commands"][k]))
    conf, ok = np.array(conf), np.array(ok, dtype=float)
    b = np.minimum((conf * 10).astype(int), 9)
    return float(sum(abs(conf[b == i].mean() - ok[b == i].mean()) * (b == i).sum() for i in range(10) if (b == i).any())
                 / len(conf))


def outcome(recs, f, lam=None) -> tuple[float, float]:
    sp = []
    for r in recs:
        p = de.post(r, f(r))
        if lam is None:
            a = r["commands"][int(np.argmax(de.cmd_marg(r, p)))]
        else:
            a = r["actions"][de.choose(r, p, lam)]
        sp.append(de.sim(r, a))
    sp = np.array(sp)
    return float(sp.mean()), float((sp < -1e-9).mean())


def main() -> None:
    R = {}
    for k, (ds, res) in SETS.items():
        R[k] = de.load(f"runs/cache/{k}.pkl", ds, res)
        with open(f"runs/cache/snr-{k}.json") as fh:
            est = json.load(fh)
        for r in R[k]:
            r["est"] = est[r["id"]] if est[r["id"]] is not None else 0.0
    dev = [r for k in DEV for r in R[k]]
    g = min((0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.5), key=lambda w: nll(dev, weight(("global", w))))
    grid = [(wl, wh) for wl in (0.6, 0.7, 0.8, 0.9, 1.0) for wh in (1.0, 1.2, 1.4, 1.6, 1.8, 2.0)]
    wl, wh = min(grid, key=lambda p: nll(dev, weight(("snr", *p))))
    oracle = {}
    for snr in (None, 20.0, 10.0, 5.0):
        sub = [r for r in dev if r["snr"] == snr]
        oracle[snr] = min((0.5, 0.7, 0.85, 1.0, 1.2, 1.4, 1.6, 2.0), key=lambda w: nll(sub, weight(("global", w))))
    maps = {"none": ("global", 1.0), "global": ("global", g), "snr": ("snr", wl, wh), "oracle-snr": ("oracle-snr", oracle)}
    print(f"fitted on {', '.join(DEV)}: global w = {g}; snr map w = {wl} (<= {LO:g} dB est.) .. {wh} (>= {HI:g} dB); "
          f"oracle per condition {oracle}")
    for name, params in maps.items():
        f = weight(params)
        ok = [lam for lam in LAMS if max(outcome(R[k], f, lam)[1] for k in DEV) <= 0.03]
        lam = ok[0] if ok else None
        print(f"== {name}: lambda chosen on dev = {lam}")
        for k in R:
            m_sp, m_neg = outcome(R[k], f)
            line = f"  {k}: NLL {nll(R[k], f):.3f} ECE {ece(R[k], f):.3f} | MAP {m_sp:+.3f} / {100 * m_neg:.1f} %"
            if lam is not None:
                e_sp, e_neg = outcome(R[k], f, lam)
                line += f" | EB {e_sp:+.3f} / {100 * e_neg:.1f} %"
            print(line, flush=True)


if __name__ == "__main__":
    main()
