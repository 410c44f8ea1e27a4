"""The paper's metrics over evaluated stimuli (paper, Simulated Experiment, Performance Metrics).

* accuracy: share of trials whose command has the gold object class and count (class only for
  ``fetch`` domains);
* speedup: mean over trials of ``L_single / L_team - 1`` (agents/team.py);
* negative-speedup share: trials where the robot made the team slower than the human alone;
* helpful-error share: among wrong trials, those whose class is part of the human's goal;
* MAP accuracy (decision-rule models): the share of trials whose most probable command (after
  the answer, when the robot asked) is right, whatever the robot chose to execute;
* questions per trial (models that may ask, bench/decisions.py), and accuracy after the
  answer: among the trials where the robot asked, the share whose final command is right;
* confident-wrong share: trials where the robot acted on a command it gave probability
  >= 0.8 and was wrong (doing nothing is never confident-wrong);
* no-speedup trials: a trial whose team simulation ran out of planning budget has no speedup
  and is left out of the speedup mean and the negative share; they are counted, with the reason;
* regret: the goal-known oracle's mean speedup (the best action for the true goal, which may be
  another action than the requested command; every row's ``oracle``) minus the model's, over
  the trials where both have a speedup (0 for a model that always acts as the oracle);
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
CONFIDENT = 0.8  # a command given at least this probability is a confident one


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
    questions_per_trial: float = 0.0
    confident_wrong_share: float = float("nan")
    accuracy_after_answer: float | None = None
    no_speedup_reasons: tuple[tuple[str, int], ...] = ()
    map_accuracy: float | None = None

    def to_json(self) -> dict[str, Any]:
        """The documented summary.json entry (rounded to 4 decimals)."""
        r = _round
        return {
            "accuracy": r(self.accuracy), "accuracy_ci": [r(self.accuracy_ci[0]), r(self.accuracy_ci[1])],
            "speedup": r(self.speedup), "speedup_ci": [r(self.speedup_ci[0]), r(self.speedup_ci[1])],
            "neg_speedup_share": r(self.neg_speedup_share), "helpful_error_share": r(self.helpful_error_share),
            "n": self.n, "wrong": self.wrong, "no_action": self.no_action, "n_speedup": self.n_speedup,
            "questions_per_trial": r(self.questions_per_trial),
            "confident_wrong_share": r(self.confident_wrong_share),
            "accuracy_after_answer": None if self.accuracy_after_answer is None else r(self.accuracy_after_answer),
            "no_speedup": self.n - self.n_speedup,
            "no_speedup_reasons": dict(self.no_speedup_reasons),
            "map_accuracy": None if self.map_accuracy is None else r(self.map_accuracy),
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
    asked = [t for t in trials if t.get("asked")]
    prob = np.array([float(t.get("prob", float("nan"))) for t in trials], dtype=np.float64)
    acted = np.array([t["command"] != "none" for t in trials])
    confident = acted & (np.nan_to_num(prob, nan=0.0) >= CONFIDENT)
    reasons: dict[str, int] = defaultdict(int)
    for t in trials:
        if t.get("speedup") is None:
            reasons[_reason(t.get("speedup_error"))] += 1
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
        questions_per_trial=len(asked) / len(trials) if len(trials) else float("nan"),
        confident_wrong_share=float((confident & wrong).mean()) if len(trials) else float("nan"),
        accuracy_after_answer=(float(np.mean([bool(t["correct"]) for t in asked])) if asked
                               else (None if not any("asked" in t for t in trials) else float("nan"))),
        no_speedup_reasons=tuple(sorted(reasons.items())),
        # a model that executes its most probable command has MAP accuracy = its accuracy
        map_accuracy=(float(np.mean([bool(t.get("map_correct", t["correct"])) for t in trials]))
                      if trials else None),
    )


def regret(rows: Sequence[Mapping[str, Any]], model: str, seed: int = 0,
           n_boot: int = N_BOOT) -> tuple[float, tuple[float, float], int]:
    """(mean regret, its 95 % CI, trials): oracle speedup minus the model's, per trial."""
    d = np.array([float(r["oracle"]["speedup"]) - float(r["models"][model]["speedup"]) for r in rows
                  if model in r["models"] and r["models"][model].get("speedup") is not None
                  and (r.get("oracle") or {}).get("speedup") is not None], dtype=np.float64)
    if not len(d):
        return float("nan"), (float("nan"), float("nan")), 0
    return float(d.mean()), bootstrap_ci(d, n_boot, seed + 2), len(d)


@dataclass(frozen=True)
class OracleSummary:
    """The goal-known oracle over a set of trials: mean speedup with its CI, negative share, trials
    with a speedup, and the share of them whose best action is the requested command (rounded)."""

    speedup: float | None
    speedup_ci: tuple[float | None, float | None]
    neg_speedup_share: float | None
    n: int
    gold_is_best: float | None

    def to_json(self) -> dict[str, Any]:
        """The ``goal_oracle`` entry of summary.json."""
        return {"speedup": self.speedup, "speedup_ci": list(self.speedup_ci),
                "neg_speedup_share": self.neg_speedup_share, "n": self.n, "gold_is_best": self.gold_is_best}


def oracle_summary(rows: Sequence[Mapping[str, Any]], seed: int = 0, n_boot: int = N_BOOT) -> OracleSummary | None:
    """Mean speedup (with CI) and negative share of the goal-known oracle, or None without one."""
    sp = np.array([float(r["oracle"]["speedup"]) for r in rows if (r.get("oracle") or {}).get("speedup") is not None])
    if not len(sp):
        return None
    lo, hi = bootstrap_ci(sp, n_boot, seed + 1)
    return OracleSummary(_round(float(sp.mean())), (_round(lo), _round(hi)), _round(float((sp < -1e-9).mean())),
                         len(sp), _round(float(np.mean([r["oracle"]["command"] == r.get("gold_command") for r in rows
                                                        if (r.get("oracle") or {}).get("speedup") is not None]))))


def _reason(error: str | None) -> str:
    """A short reason for a missing speedup (the planner's status when it says one)."""
    if not error:
        return "team simulation failed (reason not recorded)"
    if "node_limit" in error or "time_limit" in error:
        return "planner budget exhausted (" + ("node_limit" if "node_limit" in error else "time_limit") + ")"
    if "unsolvable" in error:
        return "no plan exists (unsolvable)"
    return error


ROOM_BREAKDOWNS = ("room", "distance", "room_distance", "distance_snr")
SEP = " @ "  # between the parts of a two-way label: ``kitchen @ 3 m``, ``3 m @ 10 dB``


def room_of(row: Mapping[str, Any]) -> tuple[str, float] | None:
    """(room preset, talker distance in m) of a results row from a ``--rooms`` set, else None: the
    row's ``room_name``/``distance_m`` (the report copies them from the manifest) or its ``extra``'s."""
    for d in (row, row.get("extra") or {}):
        if d.get("room_name") is not None and d.get("distance_m") is not None:
            return str(d["room_name"]), float(d["distance_m"])
    return None


def group_key(row: Mapping[str, Any], by: str) -> str:
    """The breakdown label of a results row: by ``noise``, ``snr``, ``voice`` or ``speaker``; by
    ``room``, ``distance`` (``3 m``), ``room_distance`` or ``distance_snr`` (rows without a room: ``dry``)."""
    if by == "noise":
        return row.get("noise") or "clean"
    if by == "snr":
        return "clean" if row.get("snr_db") is None else f"{row['snr_db']:g} dB"
    if by in ROOM_BREAKDOWNS:
        room = room_of(row)
        parts = {"room": room[0] if room else "dry", "distance": f"{room[1]:g} m" if room else "dry"}
        parts["snr"] = group_key(row, "snr")
        return SEP.join(parts[p] for p in by.split("_"))
    return str(row.get(by, "?"))


def has_rooms(rows: Iterable[Mapping[str, Any]]) -> bool:
    """Whether any row comes from a set built with ``--rooms``."""
    return any(room_of(r) is not None for r in rows)


@dataclass(frozen=True)
class GroupMetrics:
    """One model in one group of trials (a noise, an SNR, a voice): accuracy, mean speedup, trials."""

    accuracy: float | None
    speedup: float | None
    n: int

    def to_json(self) -> dict[str, Any]:
        """The entry of summary.json's ``breakdowns``."""
        return {"accuracy": self.accuracy, "speedup": self.speedup, "n": self.n}


def breakdown(
    rows: Iterable[Mapping[str, Any]], models: Sequence[str], by: str
) -> dict[str, dict[str, GroupMetrics]]:
    """{label: {model: its metrics}} for the rows grouped by ``by``, labels in :func:`label_order`."""
    groups: dict[str, list[Mapping[str, Any]]] = defaultdict(list)
    for r in rows:
        groups[group_key(r, by)].append(r)
    out: dict[str, dict[str, GroupMetrics]] = {}
    for label in sorted(groups, key=lambda g: [label_order(p) for p in g.split(SEP)]):
        rs = groups[label]
        out[label] = {}
        for m in models:
            ts = [r["models"][m] for r in rs if m in r["models"]]
            if ts:
                out[label][m] = GroupMetrics(_round(np.mean([t["correct"] for t in ts])),
                                             _round(_mean([t["speedup"] for t in ts if t.get("speedup") is not None])),
                                             len(ts))
    return out


def _mean(xs: Sequence[float]) -> float:
    return float(np.mean(xs)) if len(xs) else float("nan")


def label_order(label: str) -> tuple[int, float, str]:
    if label == "clean":
        return (0, 0.0, "")
    if label.endswith(" dB"):
        return (1, -float(label[:-3]), "")
    if label.endswith(" m") and label[:-2].replace(".", "", 1).isdigit():
        return (1, float(label[:-2]), "")  # talker distance, near first
    return (2, 0.0, label)
