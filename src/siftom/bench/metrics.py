"""The paper's metrics over evaluated stimuli (paper, Simulated Experiment, Performance Metrics).

* accuracy: share of trials whose command has the gold object class and count (class only for
  ``fetch`` domains);
* speedup: mean over trials of ``L_single / L_team - 1`` (agents/team.py);
* negative-speedup share: trials where the robot made the team slower than the human alone;
* helpful-error share: among wrong trials, those whose class is part of the human's goal;
* 95 % confidence intervals by the percentile bootstrap over trials (1,000 resamples, seeded).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

N_BOOT = 1000
LEVEL = 0.95


def bootstrap_ci(
    values: Sequence[float] | np.ndarray,
    n_boot: int = N_BOOT,
    seed: int = 0,
    level: float = LEVEL,
    stat: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[float, float]:
    """Percentile bootstrap CI of the mean (or ``stat`` applied along axis 1) of ``values``.

    Resamples trials with replacement ``n_boot`` times with a generator seeded by ``seed``;
    returns (lo, hi) at ``level``. Empty input gives (nan, nan); one value gives (v, v).
    """
    x = np.asarray(values, dtype=np.float64)
    if x.size == 0:
        return (float("nan"), float("nan"))
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, x.size, size=(n_boot, x.size))
    samples = x[idx]
    means = stat(samples) if stat is not None else samples.mean(axis=1)
    a = (1.0 - level) / 2.0
    lo, hi = np.quantile(means, [a, 1.0 - a])
    return (float(lo), float(hi))


@dataclass(frozen=True)
class ModelSummary:
    """Metrics of one model over a set of trials."""

    accuracy: float
    accuracy_ci: tuple[float, float]
    speedup: float
    speedup_ci: tuple[float, float]
    neg_speedup_share: float
    helpful_error_share: float
    n: int
    wrong: int
    no_action: int
    n_speedup: int = 0

    def to_json(self) -> dict[str, Any]:
        """The documented summary.json entry (rounded to 4 decimals)."""
        r = _round
        return {
            "accuracy": r(self.accuracy), "accuracy_ci": [r(self.accuracy_ci[0]), r(self.accuracy_ci[1])],
            "speedup": r(self.speedup), "speedup_ci": [r(self.speedup_ci[0]), r(self.speedup_ci[1])],
            "neg_speedup_share": r(self.neg_speedup_share), "helpful_error_share": r(self.helpful_error_share),
            "n": self.n, "wrong": self.wrong, "no_action": self.no_action, "n_speedup": self.n_speedup,
        }


def _round(x: float) -> float | None:
    return None if not np.isfinite(x) else round(float(x), 4)


def summarise_model(trials: Sequence[Mapping[str, Any]], seed: int = 0, n_boot: int = N_BOOT) -> ModelSummary:
    """Summarise a model's per-trial results (``correct``, ``helpful``, ``speedup``, ``command``)."""
    correct = np.array([bool(t["correct"]) for t in trials], dtype=np.float64)
    # a trial whose team simulation ran out of planning budget has no speedup (None)
    speed = np.array([float(t["speedup"]) for t in trials if t.get("speedup") is not None], dtype=np.float64)
    helpful = np.array([bool(t["helpful"]) for t in trials])
    wrong = correct == 0
    n_wrong = int(wrong.sum())
    return ModelSummary(
        accuracy=float(correct.mean()) if len(trials) else float("nan"),
        accuracy_ci=bootstrap_ci(correct, n_boot, seed),
        speedup=float(speed.mean()) if len(speed) else float("nan"),
        speedup_ci=bootstrap_ci(speed, n_boot, seed + 1),
        neg_speedup_share=float((speed < -1e-9).mean()) if len(speed) else float("nan"),
        helpful_error_share=float(helpful[wrong].mean()) if n_wrong else float("nan"),
        n=len(trials),
        wrong=n_wrong,
        no_action=sum(1 for t in trials if t["command"] == "none"),
        n_speedup=len(speed),
    )


def group_key(row: Mapping[str, Any], by: str) -> str:
    """The breakdown label of a results row: by ``noise``, ``snr``, ``voice`` or ``speaker``."""
    if by == "noise":
        return row.get("noise") or "clean"
    if by == "snr":
        return "clean" if row.get("snr_db") is None else f"{row['snr_db']:g} dB"
    return str(row.get(by, "?"))


def breakdown(
    rows: Iterable[Mapping[str, Any]], models: Sequence[str], by: str
) -> dict[str, dict[str, dict[str, Any]]]:
    """{label: {model: {accuracy, speedup, n}}} for the rows grouped by ``by``."""
    groups: dict[str, list[Mapping[str, Any]]] = defaultdict(list)
    for r in rows:
        groups[group_key(r, by)].append(r)
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for label in sorted(groups, key=label_order):
        rs = groups[label]
        out[label] = {}
        for m in models:
            ts = [r["models"][m] for r in rs if m in r["models"]]
            if ts:
                out[label][m] = {"accuracy": _round(np.mean([t["correct"] for t in ts])),
                                 "speedup": _round(_mean([t["speedup"] for t in ts if t.get("speedup") is not None])),
                                 "n": len(ts)}
    return out


def _mean(xs: Sequence[float]) -> float:
    return float(np.mean(xs)) if len(xs) else float("nan")


def label_order(label: str) -> tuple[int, float, str]:
    if label == "clean":
        return (0, 0.0, "")
    if label.endswith(" dB"):
        return (1, -float(label[:-3]), "")
    return (2, 0.0, label)
