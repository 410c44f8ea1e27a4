"""The figures of an evaluation report (:mod:`siftom.bench.report`): accuracy and speedup with
their bootstrap CIs, speedup histograms, speedup against questions asked and against the
negative-speedup share, and accuracy by SNR.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

FIG_MAIN = "accuracy_speedup.png"
FIG_HIST = "speedup_hist.png"
FIG_SNR = "accuracy_by_snr.png"
FIG_ASK = "speedup_vs_questions.png"
FIG_PARETO = "speedup_vs_negative.png"


def render_figures(rows: Sequence[dict[str, Any]], summary: dict[str, Any], out: Path) -> list[Path]:
    """Write the bar charts with CI error bars, speedup histograms and accuracy by SNR."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    models = list(summary["models"])
    colors = plt.get_cmap("tab10")(np.arange(len(models)) % 10)
    paths = [_main_figure(summary, models, colors, out / FIG_MAIN),
             _histograms(rows, models, colors, out / FIG_HIST),
             _questions_figure(summary, models, colors, out / FIG_ASK)]
    domains = sorted({str(r.get("scenario", "")).split("/")[0] for r in rows} - {""})
    pareto = _pareto_figure(summary, colors, out / FIG_PARETO, ", ".join(domains))
    if pareto is not None:
        paths.append(pareto)
    snr = _snr_figure(summary, models, colors, out / FIG_SNR)
    if snr is not None:
        paths.append(snr)
    return paths


def _save(fig: Any, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _main_figure(summary: dict[str, Any], models: list[str], colors: Any, path: Path) -> Path:
    """Accuracy and speedup per model, with the 95 % bootstrap CIs as error bars."""
    import matplotlib.pyplot as plt

    S = summary["models"]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    x = np.arange(len(models))
    for ax, key, label, scale in ((axes[0], "accuracy", "accuracy (%)", 100.0),
                                  (axes[1], "speedup", "speedup (L_single / L_team − 1)", 1.0)):
        vals = np.array([np.nan if S[m][key] is None else S[m][key] for m in models]) * scale
        cis = np.array([[np.nan if c is None else c for c in S[m][f"{key}_ci"]] for m in models]) * scale
        err = np.abs(np.stack([vals - cis[:, 0], cis[:, 1] - vals]))
        ax.bar(x, vals, color=colors, yerr=err, capsize=4, edgecolor="black", linewidth=0.5)
        ax.set_xticks(x, models, rotation=25, ha="right")
        ax.set_ylabel(label)
        ax.axhline(0, color="black", linewidth=0.6)
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylim(0, 100)
    fig.suptitle(f"{summary['n_stimuli']} stimuli; error bars: 95 % bootstrap CI ({summary['bootstrap']['resamples']} resamples)",
                 fontsize=9)
    return _save(fig, path)


def _histograms(rows: Sequence[dict[str, Any]], models: list[str], colors: Any, path: Path) -> Path:
    """A histogram of the speedups of each model, with its share below zero."""
    import matplotlib.pyplot as plt

    cols = min(3, len(models))
    nrows = int(np.ceil(len(models) / cols))
    fig, axes = plt.subplots(nrows, cols, figsize=(3.4 * cols, 2.6 * nrows), squeeze=False, sharex=True)
    allv = [t["speedup"] for r in rows for t in r["models"].values() if t.get("speedup") is not None]
    lo, hi = (min(allv + [-0.5]), max(allv + [0.5]))
    bins = np.linspace(lo, hi, 26)
    for k, m in enumerate(models):
        ax = axes[k // cols][k % cols]
        v = np.array([r["models"][m]["speedup"] for r in rows
                      if m in r["models"] and r["models"][m].get("speedup") is not None])
        ax.hist(v, bins=bins, color=colors[k], edgecolor="black", linewidth=0.4)
        ax.axvline(0, color="black", linewidth=0.8, linestyle="--")
        ax.set_title(f"{m}: {100 * float((v < -1e-9).mean()) if len(v) else 0:.0f} % < 0", fontsize=9)
        ax.set_xlabel("speedup")
    for k in range(len(models), nrows * cols):
        axes[k // cols][k % cols].axis("off")
    return _save(fig, path)


def _questions_figure(summary: dict[str, Any], models: list[str], colors: Any, path: Path) -> Path:
    """Mean speedup against questions per trial, for the models that ask."""
    import matplotlib.pyplot as plt

    S = summary["models"]
    fig, ax = plt.subplots(figsize=(5.2, 3.6))
    for k, m in enumerate(models):
        q, sp, ci = S[m].get("questions_per_trial"), S[m]["speedup"], S[m]["speedup_ci"]
        if q is None or sp is None:
            continue
        lo, hi = (sp if c is None else c for c in ci)
        ax.errorbar([q], [sp], yerr=[[sp - lo], [hi - sp]], fmt="o", color=colors[k], capsize=4, label=m)
    ax.set_xlabel("questions per trial")
    ax.set_ylabel("mean speedup")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return _save(fig, path)


def _snr_figure(summary: dict[str, Any], models: list[str], colors: Any, path: Path) -> Path | None:
    """Accuracy by condition (SNR) per model; None when there is one condition."""
    import matplotlib.pyplot as plt

    bd = summary["breakdowns"]["snr"]
    labels = list(bd)
    if len(labels) <= 1:
        return None
    fig, ax = plt.subplots(figsize=(6, 3.6))
    for k, m in enumerate(models):
        ys = [100 * bd[lab][m]["accuracy"] if m in bd[lab] else np.nan for lab in labels]
        ax.plot(labels, ys, marker="o", color=colors[k], label=m)
    ax.set_ylabel("accuracy (%)")
    ax.set_xlabel("condition")
    ax.set_ylim(0, 100)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def _pareto_figure(summary: dict[str, Any], colors: Any, path: Path, domain: str = "") -> Path | None:
    """Mean speedup against negative-speedup share, every model and the goal-known oracle."""
    import matplotlib.pyplot as plt

    S = summary["models"]
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for k, (m, s) in enumerate(S.items()):
        if s["speedup"] is None or s["neg_speedup_share"] is None:
            continue
        lo, hi = (s["speedup"] if c is None else c for c in s["speedup_ci"])
        x, y = 100 * s["neg_speedup_share"], s["speedup"]
        ax.errorbar([x], [y], yerr=[[y - lo], [hi - y]], fmt="o", color=colors[k], capsize=3, label=m)
    o = summary.get("goal_oracle")
    if o:
        ax.plot([100 * o["neg_speedup_share"]], [o["speedup"]], marker="*", markersize=14, color="black",
                linestyle="none", label="goal-known oracle")
    ax.set_xlabel("negative-speedup share (%)")
    ax.set_ylabel("mean speedup (95 % CI)")
    ax.set_title(f"{domain + ': ' if domain else ''}{summary['n_stimuli']} stimuli; up and to the left is better",
                 fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
