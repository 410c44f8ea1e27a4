"""Calibrate the acoustic likelihood's temperature on a dataset, and measure calibration.

For every stimulus the audio goes through the evaluator's acoustic path (recognition of the whole
clip, key-phrase alignment, the phone-loop gap) once; the raw alignment scores are kept and the
full model's posterior is recomputed for each base temperature T on a grid (the likelihood's
gap rule T * exp(kappa * max(gap, 0)) applies on top). When the likelihood uses the Whisper
factor instead of the alignment (the default with the whisper extra), the grid is over its
temperature T_w (``WHISPER_GRID``) and the Whisper scores are kept instead. The NLL of the gold command per SNR band
(a proper scoring rule: it is lowest when the posterior is neither over- nor under-confident)
says which T fits. Use a dataset built with another seed (and other voices and noise) than the
one you report on.

    python recipes/calibrate.py --dataset runs/kitchen-cal-seed1 [--json] [--out DIR] [--limit N]
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from siftom.speech.asr import DEFAULT_NBEST

GRID = (8.0, 12.0, 20.0, 30.0, 40.0, 55.0, 75.0, 100.0, 150.0, 200.0, 300.0, 500.0)
# with the Whisper factor and no alignment the grid is over T_w (likelihood/whisper_factor.py)
WHISPER_GRID = (1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 20.0)


def collect(dataset: str | Path, mode: str = "full", engine: str = "pocketsphinx-vocab", nbest: int = DEFAULT_NBEST,
            limit: int | None = None, combo: bool = False) -> list[dict[str, Any]]:
    """Per stimulus: condition, estimated SNR and, per temperature, (gold prob, top prob, correct).

    The likelihood is used as configured (by default the alignment times the N-best phonetic
    likelihood); ``combo=True`` adds the other choice under negative keys (-T). With the Whisper
    factor on, the temperatures are T_w's (``WHISPER_GRID``) and ``combo`` does not apply.
    """
    from siftom import Observer, Settings
    from siftom.bench.acoustic_models import heard
    from siftom.bench.engines import engine as get_engine
    from siftom.bench.trials import dataset_vocabulary
    from siftom.people.stimuli import load_dataset, scenario_for

    ds = load_dataset(dataset)
    vocab = dataset_vocabulary(ds.stimuli)  # every class of every scenario in the dataset
    asr = get_engine(engine, vocab)
    model = Observer(Settings.load(env={})).model(mode, "acoustic")
    lk: Any = model.likelihood  # an AcousticLikelihood (raw_scores, with_phonetic)
    # the Whisper factor replaces the alignment: then T_w is fitted instead (and there is no combo)
    aligns = getattr(lk, "aligns", True)
    attr, grid = ("temperature", GRID) if aligns else ("whisper_temperature", WHISPER_GRID)
    combo = combo and aligns
    original = lk.raw_scores, getattr(lk, attr)
    combo_default = lk.with_phonetic
    rows = []
    try:
        for s in ds.stimuli[:limit]:
            sc = scenario_for(s)
            instruction, _ = heard(ds.root / s.audio, asr, nbest)
            if instruction is None:
                continue
            lk.raw_scores = original[0]
            setattr(lk, attr, original[1])
            raw = lk.raw_scores(instruction, _commands(model, sc), _context(model, sc))
            lk.raw_scores = lambda *a, _raw=raw, **k: _raw  # noqa: E731 - one scoring per clip, every T reuses it
            per_t = _per_temperature(model, attr, grid, sc, instruction, s.gold_command)
            if combo:
                lk.with_phonetic = not combo_default
                other = _per_temperature(model, attr, grid, sc, instruction, s.gold_command)
                per_t.update({-T: v for T, v in other.items()})
                lk.with_phonetic = combo_default
            rows.append({"id": s.id, "snr": "clean" if s.snr_db is None else f"{s.snr_db:g} dB",
                         "snr_est": instruction.snr_db, "mode": raw.mode, "per_t": per_t})
    finally:
        lk.raw_scores = original[0]
        setattr(lk, attr, original[1])
        lk.with_phonetic = combo_default
    return rows


def _per_temperature(model: Any, attr: str, grid: Any, sc: Any, instruction: Any,
                     gold: str) -> dict[float, tuple[float, float, bool]]:
    """Per temperature T of the likelihood's ``attr``: (P(gold), P(chosen), chosen is right)."""
    from siftom.bench.scoring import is_correct
    from siftom.inference.model import Observation

    out = {}
    for T in grid:
        setattr(model.likelihood, attr, T)
        post = model.infer(Observation.from_scenario(sc, instruction))
        out[T] = (post.prob(gold), post.commands[0][1], is_correct(post.command, gold, sc.verb))
    return out


def _commands(model: Any, sc: Any) -> list[Any]:
    on = model.online(sc.world, sc.start, sc.goals, sc.verb)
    return on.candidates()[4]


def _context(model: Any, sc: Any) -> Any:
    if not model.config.uses_actions:
        return None
    on = model.online(sc.world, sc.start, sc.goals, sc.verb)
    for a in sc.actions:
        on.observe(a)
    gi, ci, rows, unk, cmds = on.candidates()
    return on._context(gi, ci, rows, unk, cmds)


def fit(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Best T per SNR band and overall by mean NLL of the gold command; accuracy and ECE there."""
    groups: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        groups[r["snr"]].append(r)
        groups["all"].append(r)
    out: dict[str, Any] = {}
    for g, rs in groups.items():
        grid = [T for T in rs[0]["per_t"]]
        nll = {T: float(np.mean([-np.log(max(r["per_t"][T][0], 1e-9)) for r in rs])) for T in grid}
        best = min(nll, key=nll.get)  # type: ignore[arg-type]
        out[g] = {"n": len(rs), "best_T": best, "nll": {str(k): round(v, 4) for k, v in nll.items()},
                  "accuracy": round(float(np.mean([r["per_t"][best][2] for r in rs])), 4),
                  "accuracy_by_T": {str(T): round(float(np.mean([r["per_t"][T][2] for r in rs])), 4) for T in grid},
                  "ece_at_best": round(ece([r["per_t"][best][1] for r in rs], [r["per_t"][best][2] for r in rs]), 4),
                  "snr_est_median": _median([r["snr_est"] for r in rs])}
    return out


def _median(v: list[float | None]) -> float | None:
    x = [a for a in v if a is not None]
    return round(float(np.median(x)), 1) if x else None


def ece(probs: list[float], correct: list[bool], bins: int = 10) -> float:
    """Expected calibration error: mean |accuracy - confidence| over equal-width bins, weighted."""
    p = np.asarray(probs, dtype=float)
    c = np.asarray(correct, dtype=float)
    if len(p) == 0:
        return float("nan")
    idx = np.minimum((p * bins).astype(int), bins - 1)
    total = 0.0
    for b in range(bins):
        m = idx == b
        if m.any():
            total += m.sum() / len(p) * abs(c[m].mean() - p[m].mean())
    return float(total)


def write(rows: list[dict[str, Any]], result: dict[str, Any], out: Path) -> None:
    """calibration.json with the fit and each stimulus's record."""
    out.mkdir(parents=True, exist_ok=True)
    recs = [{**r, "per_t": {str(k): v for k, v in r["per_t"].items()}} for r in rows]
    (out / "calibration.json").write_text(json.dumps({"fit": result, "rows": recs}, indent=1) + "\n",
                                          encoding="utf-8")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description="Fit the acoustic likelihood's temperature (NLL of the gold "
                                             "command per SNR).")
    ap.add_argument("--dataset", required=True, help="a dataset built with another seed than the one you report on")
    ap.add_argument("--out", default=None, help="write calibration.json here")
    ap.add_argument("--mode", choices=["full", "speech-only"], default="full", help="(default: full)")
    ap.add_argument("--limit", type=int, default=None, help="first N stimuli only")
    ap.add_argument("--json", dest="as_json", action="store_true", help="print JSON")
    a = ap.parse_args(argv)
    if not Path(a.dataset).is_dir():
        ap.error(f"--dataset {a.dataset}: no such folder")
    rows = collect(a.dataset, mode=a.mode, limit=a.limit)
    result = fit(rows)
    if a.out:
        write(rows, result, Path(a.out))
    if a.as_json:
        print(json.dumps(result, indent=2))
        return
    for g, v in result.items():
        print(f"{g:8s} n={v['n']:4d}  best T={v['best_T']:5.1f} nats  accuracy {v['accuracy']:.3f}  "
              f"ECE {v['ece_at_best']:.3f}  NLL@T: " + ", ".join(f"{k}:{x:.3f}" for k, x in v["nll"].items()))


if __name__ == "__main__":
    main()
