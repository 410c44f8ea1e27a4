"""Reliability of the models' confidence: predicted probability of the chosen command vs accuracy.

For each model and SNR the stimuli are binned by the posterior probability of the command the
model chose (10 equal-width bins); a calibrated model's accuracy in each bin equals the bin's
mean probability. ECE is the stimulus-weighted mean |accuracy - confidence| over bins.
Models whose choice carries no probability (``literal-asr``, which always says 1.0) are shown
too: their ECE is their error rate.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from siftom.bench.metrics import group_key, label_order

FIG = "reliability.png"
BINS = 10


def _bins(probs: np.ndarray, correct: np.ndarray) -> list[tuple[float, float, int]]:
    idx = np.minimum((probs * BINS).astype(int), BINS - 1)
    return [(float(probs[idx == b].mean()), float(correct[idx == b].mean()), int((idx == b).sum()))
            for b in range(BINS) if (idx == b).any()]


@dataclass(frozen=True)
class Calibration:
    """One model's calibration in one group of trials: mean P(chosen command) against accuracy.

    Attributes:
        n: trials.
        confidence: mean probability of the chosen command.
        accuracy: share of the trials that were right.
        ece: expected calibration error over the bins.
        bins: (mean probability, accuracy, trials) per non-empty bin.
    """

    n: int
    confidence: float
    accuracy: float
    ece: float
    bins: tuple[tuple[float, float, int], ...]

    def to_json(self) -> dict[str, Any]:
        """The ``summary.json`` entry (``reliability``)."""
        return {"n": self.n, "confidence": self.confidence, "accuracy": self.accuracy, "ece": self.ece,
                "bins": [list(b) for b in self.bins]}


Reliability = dict[str, dict[str, Calibration]]  # model -> SNR label (and 'all') -> its calibration


def reliability(rows: Sequence[dict[str, Any]], models: Sequence[str]) -> Reliability:
    """model -> SNR label (and 'all') -> :class:`Calibration` (trials with a probability)."""
    out: Reliability = {}
    for m in models:
        groups: dict[str, list[tuple[float, bool]]] = defaultdict(list)
        for r in rows:
            t = r["models"].get(m)
            if t is None or t.get("prob") is None or not np.isfinite(t["prob"]):
                continue
            groups[group_key(r, "snr")].append((float(t["prob"]), bool(t["correct"])))
            groups["all"].append((float(t["prob"]), bool(t["correct"])))
        res = {}
        for g in sorted(groups, key=lambda k: (k == "all", label_order(k))):
            p = np.array([a for a, _ in groups[g]])
            c = np.array([b for _, b in groups[g]], dtype=float)
            bins = _bins(p, c)
            ece = sum(n / len(p) * abs(acc - conf) for conf, acc, n in bins)
            res[g] = Calibration(len(p), round(float(p.mean()), 4), round(float(c.mean()), 4), round(float(ece), 4),
                                 tuple((round(a, 4), round(b, 4), n) for a, b, n in bins))
        out[m] = res
    return out


def render(rel: Reliability, out: Path) -> Path | None:
    """reliability.png: one panel per SNR, one line per model, the diagonal for reference."""
    if not rel:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = [g for g in next(iter(rel.values())) if g != "all"] + ["all"]
    fig, axes = plt.subplots(1, len(groups), figsize=(3.2 * len(groups), 3.4), squeeze=False)
    colors = plt.get_cmap("tab10")(np.arange(len(rel)) % 10)
    for ax, g in zip(axes[0], groups, strict=True):
        ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--")
        for (m, res), col in zip(rel.items(), colors, strict=True):
            if g not in res:
                continue
            b = np.array(res[g].bins, dtype=float)
            ax.plot(b[:, 0], b[:, 1], marker="o", ms=3, color=col, label=f"{m} (ECE {res[g].ece:.2f})")
        ax.set_title(g)
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1)
        ax.set_xlabel("predicted P(chosen command)")
        ax.legend(fontsize=6, loc="upper left")
    axes[0][0].set_ylabel("observed accuracy")
    fig.tight_layout()
    path = out / FIG
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def section(rel: Reliability, figure: Path | None) -> str:
    """Markdown: ECE and confidence vs accuracy per model and SNR, and the figure."""
    if not rel:
        return ""
    groups = list(next(iter(rel.values())))
    lines = ["## Calibration: predicted probability vs observed accuracy", "",
             "Per SNR: mean P(chosen command) / accuracy, and ECE (10 bins; 0 = calibrated).", "",
             "| model | " + " | ".join(groups) + " |", "|---" * (len(groups) + 1) + "|"]
    for m, res in rel.items():
        cells = [f"{res[g].confidence:.2f} / {res[g].accuracy:.2f}, ECE {res[g].ece:.2f}" if g in res else "—"
                 for g in groups]
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    if figure is not None:
        lines += ["", f"![reliability diagram]({figure.name})"]
    return "\n".join(lines) + "\n"
