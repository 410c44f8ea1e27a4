"""Offline study of expected benefit on decision caches (benchmarks/decision_cache.py)."""

from __future__ import annotations

import pickle

import numpy as np

_SC: dict = {}


def load(path: str, dataset: str, results: str) -> list[dict]:
    from pathlib import Path

    from siftom.bench import evaluate as ev
    from siftom.bench import trials as tr
    from siftom.bench.stimuli import load_dataset, scenario_for

    with open(path, "rb") as f:
        recs = pickle.load(f)
    c = Path(results) / ev.TEAM_CACHE
    if c.exists():
        for t in ev._read_jsonl(c):
            tr._TEAM.setdefault((t["key"], t["command"]), t)
    st = {s.id: s for s in load_dataset(dataset, check_audio=False).stimuli}
    for r in recs:
        r["sc"] = scenario_for(st[r["id"]])
    return recs


def sim(r: dict, a: str) -> float:
    from siftom.bench import trials as tr

    return tr._simulate(r["skey"], r["sc"], a)["speedup"]


def post(r: dict, w: float = 1.0, T: float = 1.0) -> np.ndarray:
    lj = (r["lj0"] + w * r["instr"]) / T
    p = np.exp(lj - lj.max())
    return p / p.sum()


def cmd_marg(r: dict, p: np.ndarray) -> np.ndarray:
    return np.bincount(r["cmd_idx"], weights=p, minlength=len(r["commands"]))


def choose(r: dict, p: np.ndarray, lam: float, utility: str = "steps") -> int:
    b = r["benefit"].astype(np.float64)
    if utility == "speedup":
        ls = r["prefix"] + r["single"][:, None]
        lt = ls - b
        b = np.where(lt > 0, ls / np.maximum(lt, 1e-9) - 1.0, 0.0)
    u = b - lam * np.maximum(0.0, -b)
    eu = p @ u
    best = int(np.argmax(eu))
    return len(eu) - 1 if eu[-1] >= eu[best] - 1e-12 else best


def correct(r: dict, a: str) -> bool:
    from siftom.bench.trials import is_correct

    return is_correct(a, r["gold"], r["verb"])


def evaluate(recs: list[dict], w: float = 1.0, T: float = 1.0, lam: float = 3.0, utility: str = "steps",
             rule: str = "eb") -> dict:
    sp, acc, none = [], [], []
    for r in recs:
        p = post(r, w, T)
        if rule == "map":
            cm = cmd_marg(r, p)
            a = r["commands"][int(np.argmax(cm))]
        else:
            a = r["actions"][choose(r, p, lam, utility)]
        sp.append(sim(r, a))
        acc.append(correct(r, a))
        none.append(a == "none")
    sp = np.array(sp)
    return {"speedup": sp.mean(), "neg": (sp < -1e-9).mean(), "acc": np.mean(acc), "none": np.mean(none)}


def calib(recs: list[dict], w: float = 1.0, T: float = 1.0) -> dict:
    """NLL of the gold command, ECE of the MAP probability, mean confidence and accuracy."""
    nll, conf, ok = [], [], []
    for r in recs:
        p = post(r, w, T)
        cm = cmd_marg(r, p)
        g = [k for k, c in enumerate(r["commands"]) if correct(r, c)]
        nll.append(-np.log(max(cm[g].sum(), 1e-12)))
        k = int(np.argmax(cm))
        conf.append(cm[k])
        ok.append(correct(r, r["commands"][k]))
    conf, ok = np.array(conf), np.array(ok, dtype=float)
    bins = np.minimum((conf * 10).astype(int), 9)
    ece = sum(abs(conf[bins == b].mean() - ok[bins == b].mean()) * (bins == b).sum() for b in range(10) if (bins == b).any()) / len(conf)
    return {"nll": float(np.mean(nll)), "ece": float(ece), "conf": float(conf.mean()), "acc": float(ok.mean())}
