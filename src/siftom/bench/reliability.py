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


def reliability(rows: Sequence[dict[str, Any]], models: Sequence[str]) -> dict[str, dict[str, dict[str, Any]]]:
    """model -> SNR label (and 'all') -> {n, confidence, accuracy, ece, bins}."""
    out: dict[str, dict[str, dict[str, Any]]] = {}
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
            res[g] = {"n": len(p), "confidence": round(float(p.mean()), 4), "accuracy": round(float(c.mean()), 4),
                      "ece": round(float(ece), 4), "bins": [[round(a, 4), round(b, 4), n] for a, b, n in bins]}
        out[m] = res
    return out


def render(rel: dict[str, dict[str, dict[str, Any]]], out: Path) -> Path | None:
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
            b = np.array(res[g]["bins"], dtype=float)
            ax.plot(b[:, 0], b[:, 1], marker="o", ms=3, color=col, label=f"{m} (ECE {res[g]['ece']:.2f})")
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


def section(rel: dict[str, dict[str, dict[str, Any]]], figure: Path | None) -> str:
    """Markdown: ECE and confidence vs accuracy per model and SNR, and the figure."""
    if not rel:
        return ""
    groups = list(next(iter(rel.values())))
    lines = ["## Calibration: predicted probability vs observed accuracy", "",
             "Per SNR: mean P(chosen command) / accuracy, and ECE (10 bins; 0 = calibrated).", "",
             "| model | " + " | ".join(groups) + " |", "|---" * (len(groups) + 1) + "|"]
    for m, res in rel.items():
        cells = [f"{res[g]['confidence']:.2f} / {res[g]['accuracy']:.2f}, ECE {res[g]['ece']:.2f}" if g in res else "—"
                 for g in groups]
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    if figure is not None:
        lines += ["", f"![reliability diagram]({figure.name})"]
    return "\n".join(lines) + "\n"
