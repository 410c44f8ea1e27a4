"""Summaries, the Markdown report and figures of an evaluation (``siftom report RESULTS``).

Reads only ``RESULTS/results.jsonl`` (and ``run.json`` for context), so a report can be
re-rendered at any time, also from a partial run.
"""

from __future__ import annotations

import json
import os
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from siftom.bench.evaluate import RUN
from siftom.bench.figures import FIG_ASK, FIG_HIST, FIG_MAIN, FIG_PARETO, FIG_SNR, render_figures
from siftom.bench.metrics import (
    N_BOOT,
    ROOM_BREAKDOWNS,
    SEP,
    bootstrap_ci,
    breakdown,
    group_key,
    has_rooms,
    label_order,
    oracle_summary,
    regret,
    room_of,
    summarise_model,
)
from siftom.bench.models import ACOUSTIC_MODELS, MODELS, OPTIONAL_MODELS
from siftom.bench.results_io import load_results
from siftom.errors import DatasetError

SUMMARY = "summary.json"
REPORT = "report.md"
BREAKDOWNS = ("noise", "snr", "voice")
# The paper's numbers (Simulated Experiment, Results) for comparison in the report.
PAPER = {
    "base VLM (Gemini 2.5 Flash) accuracy": 0.681,
    "SIFToM accuracy": 0.810,
    "base VLM negative-speedup share": 0.242,
    "SIFToM negative-speedup share": 0.112,
    "SIFToM helpful-error share": 0.697,
}


def _models_in(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Model names present in the rows, known models first in their standard order."""
    seen: dict[str, None] = {}
    for r in rows:
        for m in r["models"]:
            seen[m] = None
    known = MODELS + ACOUSTIC_MODELS + OPTIONAL_MODELS
    return [m for m in known if m in seen] + [m for m in seen if m not in known]


def _summarise(rows: Sequence[dict[str, Any]], seed: int = 0, n_boot: int = N_BOOT) -> dict[str, Any]:
    """The summary.json content: per-model metrics with CIs, breakdowns, ASR word error rates."""
    if not rows:
        raise DatasetError("no evaluated stimuli to summarise; run 'siftom eval' first")
    models = _models_in(rows)
    out: dict[str, Any] = {"n_stimuli": len({r["id"] for r in rows}), "bootstrap": {"resamples": n_boot, "seed": seed, "level": 0.95},
                           "models": {}}
    for m in models:
        trials = [r["models"][m] for r in rows if m in r["models"]]
        out["models"][m] = summarise_model(trials, seed=seed, n_boot=n_boot).to_json()
        rg, rg_ci, n_rg = regret(rows, m, seed, n_boot)
        out["models"][m].update({"regret": None if not np.isfinite(rg) else round(rg, 4),
                                 "regret_ci": [None if not np.isfinite(c) else round(c, 4) for c in rg_ci]})
    oracle = oracle_summary(rows, seed, n_boot)
    out["goal_oracle"] = None if oracle is None else oracle.to_json()
    skipped: dict[str, dict[str, Any]] = {}
    for r in rows:
        for m, why in r.get("not_evaluable", {}).items():
            s = skipped.setdefault(m, {"n": 0, "reasons": {}})
            s["n"] += 1
            s["reasons"][why] = s["reasons"].get(why, 0) + 1
    out["not_evaluable"] = skipped  # model -> trials it could not be evaluated on, and why
    gold = np.array([np.nan if r.get("gold_speedup") is None else r["gold_speedup"] for r in rows], dtype=float)
    out["gold_command_speedup"] = round(float(np.nanmean(gold)), 4) if np.isfinite(gold).any() else None
    rooms = has_rooms(rows)  # a --rooms set: also by room, distance, and their crossings
    out["breakdowns"] = {by: {label: {m: g.to_json() for m, g in per.items()}
                              for label, per in breakdown(rows, models, by).items()}
                         for by in BREAKDOWNS + (ROOM_BREAKDOWNS if rooms else ())}
    out["asr_wer"] = {}
    for by in ("snr", "voice") + (("room", "distance") if rooms else ()):
        wer: dict[str, list[float]] = defaultdict(list)
        for r in rows:
            w = r.get("transcript", {}).get("wer")
            if w is not None:
                wer[group_key(r, by)].append(w)
        out["asr_wer"][by] = {k: round(float(np.mean(wer[k])), 4) for k in sorted(wer, key=label_order)}
    allw = [r["transcript"]["wer"] for r in rows if r.get("transcript", {}).get("wer") is not None]
    out["asr_wer"]["all"] = round(float(np.mean(allw)), 4) if allw else None
    return out


RECORDED = "human"  # the voice of a stimulus a person recorded (the dataset format's default)


def participants(rows: Sequence[dict[str, Any]], seed: int = 0, n_boot: int = N_BOOT) -> dict[str, Any]:
    """Per participant of a set of collected recordings (rows whose voice is a person's, by their
    ``speaker``), per model: accuracy, questions per trial and speedup, each with its bootstrap CI,
    and the trials. Synthetic voices are left out (their table is the per-voice one)."""
    by: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        if r.get("voice", RECORDED) == RECORDED:
            by[str(r.get("speaker", "?"))].append(r)
    out: dict[str, Any] = {}
    for who in sorted(by, key=label_order):
        out[who] = {}
        for m in _models_in(by[who]):
            trials = [r["models"][m] for r in by[who] if m in r["models"]]
            s = summarise_model(trials, seed=seed, n_boot=n_boot).to_json()
            asked = np.array([1.0 if t.get("asked") else 0.0 for t in trials])
            q_ci = bootstrap_ci(asked, n_boot, seed + 2)
            out[who][m] = {"accuracy": s["accuracy"], "accuracy_ci": s["accuracy_ci"],
                           "questions_per_trial": s["questions_per_trial"],
                           "questions_ci": [_round4(q_ci[0]), _round4(q_ci[1])],
                           "speedup": s["speedup"], "speedup_ci": s["speedup_ci"], "n": s["n"]}
    return out


def _round4(x: float) -> float | None:
    return None if not np.isfinite(x) else round(float(x), 4)


def participants_table(parts: dict[str, Any]) -> str:
    """The Markdown table of :func:`participants`: one row per participant and model."""
    lines = ["| participant | model | accuracy [95 % CI] | questions / trial [95 % CI] | speedup [95 % CI] | n |",
             "|---|---|---|---|---|---|"]
    for who, per in parts.items():
        for m, v in per.items():
            sp = "–" if v["speedup"] is None else f"{v['speedup']:+.3f}"
            q = "–" if v["questions_per_trial"] is None else f"{v['questions_per_trial']:.2f}"
            qci = "" if v["questions_ci"][0] is None else f"[{v['questions_ci'][0]:.2f}, {v['questions_ci'][1]:.2f}]"
            lines.append(f"| {who} | {m} | {_pct(v['accuracy'])} {_ci(v['accuracy_ci'])} | {q} {qci} "
                         f"| {sp} {_ci(v['speedup_ci'], False)} | {v['n']} |")
    return "\n".join(lines)


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.1f} %"


def _ci(ci: Sequence[float | None], pct: bool = True) -> str:
    if ci[0] is None or ci[1] is None:
        return ""
    return f"[{100 * ci[0]:.1f}, {100 * ci[1]:.1f}]" if pct else f"[{ci[0]:+.3f}, {ci[1]:+.3f}]"


def main_table(summary: dict[str, Any]) -> str:
    """The Markdown table of the main metrics, one row per model."""
    lines = ["| model | executed-command accuracy [95 % CI] | speedup [95 % CI] | negative speedup | helpful errors | n |",
             "|---|---|---|---|---|---|"]
    for m, s in summary["models"].items():
        sp = "–" if s["speedup"] is None else f"{s['speedup']:+.3f}"
        lines.append(f"| {m} | {_pct(s['accuracy'])} {_ci(s['accuracy_ci'])} | {sp} {_ci(s['speedup_ci'], False)} "
                     f"| {_pct(s['neg_speedup_share'])} | {_pct(s['helpful_error_share'])} ({s['wrong']} wrong) "
                     f"| {s['n']} |")
    return "\n".join(lines)


def _decision_table(summary: dict[str, Any]) -> str:
    """What decisions are for, one row per model and the goal-known oracle: speedup (CI), negative
    share, questions, confident errors, MAP accuracy, regret; executed-command accuracy labelled."""
    lines = ["| model | mean speedup [95 % CI] | negative speedup | questions / trial | confident wrong (P >= 0.8) "
             "| MAP accuracy (after the answer) | regret [95 % CI] | executed-command accuracy "
             "| accuracy after the answer | no speedup (why) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for m, s in summary["models"].items():
        acc = s.get("accuracy_after_answer")
        why = "; ".join(f"{k}: {v}" for k, v in (s.get("no_speedup_reasons") or {}).items())
        q = s.get("questions_per_trial")
        sp = "–" if s["speedup"] is None else f"{s['speedup']:+.3f}"
        rg = s.get("regret")
        lines.append(f"| {m} | {sp} {_ci(s['speedup_ci'], False)} | {_pct(s['neg_speedup_share'])} "
                     f"| {'–' if q is None else f'{q:.3f}'} | {_pct(s.get('confident_wrong_share'))} "
                     f"| {_pct(s.get('map_accuracy'))} | {'–' if rg is None else f'{rg:+.3f}'} "
                     f"{_ci(s.get('regret_ci', [None, None]), False)} | {_pct(s['accuracy'])} | {_pct(acc)} "
                     f"| {s.get('no_speedup', 0)}" + (f" ({why})" if why else "") + " |")
    o = summary.get("goal_oracle")
    if o:
        lines.append(f"| *goal-known oracle* | {o['speedup']:+.3f} {_ci(o['speedup_ci'], False)} "
                     f"| {_pct(o['neg_speedup_share'])} | – | – | – | 0 | (the requested command is the best "
                     f"action in {_pct(o.get('gold_is_best'))}) | – | |")
    return "\n".join(lines)


def _breakdown_table(bd: dict[str, dict[str, dict[str, Any]]], models: Sequence[str], key: str) -> str:
    header = "| " + key + " | n | " + " | ".join(models) + " |"
    lines = [header, "|---" * (len(models) + 2) + "|"]
    for label, per in bd.items():
        n = next(iter(per.values()))["n"] if per else 0
        cells = []
        for m in models:
            v = per.get(m)
            sp = "–" if v is None or v["speedup"] is None else f"{v['speedup']:+.2f}"
            cells.append("–" if v is None else f"{_pct(v['accuracy'])} / {sp}")
        lines.append(f"| {label} | {n} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _grid(bd: dict[str, dict[str, dict[str, Any]]], model: str, corner: str) -> str:
    """One model's accuracy (n) over a two-way breakdown (labels ``ROW @ COLUMN``) as a table; '' if none."""
    cells = {tuple(label.split(SEP, 1)): per[model] for label, per in bd.items() if model in per and SEP in label}
    rows = list(dict.fromkeys(r for r, _ in cells))
    cols = sorted({c for _, c in cells}, key=label_order)
    if not cells:
        return ""
    lines = [f"| {corner} | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for r in rows:
        lines.append(f"| {r} | " + " | ".join(
            f"{_pct(cells[(r, c)]['accuracy'])} ({cells[(r, c)]['n']})" if (r, c) in cells else "–" for c in cols) + " |")
    return "\n".join(lines)


def _rooms_section(summary: dict[str, Any], models: Sequence[str]) -> list[str]:
    """Accuracy by room, talker distance and SNR, for a set built with ``--rooms``; [] otherwise."""
    bd = summary["breakdowns"]
    if "room_distance" not in bd:
        return []
    parts = ["## By room and talker distance", "",
             "Each clip was heard in one simulated room at one talker distance (image-source responses, "
             "`siftom.speech.rooms`) before the noise; cells: executed-command accuracy (stimuli).", "",
             _breakdown_table(bd["room"], models, "room"), "", _breakdown_table(bd["distance"], models, "distance"), ""]
    for m in models:
        parts += [f"### {m}", "", _grid(bd["room_distance"], m, "room / distance"), "",
                  _grid(bd["distance_snr"], m, "distance / SNR"), ""]
    return parts


def _render_report(summary: dict[str, Any], run: dict[str, Any], figures: Sequence[Path]) -> str:
    """The Markdown report."""
    models = list(summary["models"])
    opts = run.get("options", {})
    parts = [
        "# siftom evaluation report", "",
        f"Dataset: `{run.get('dataset', '?')}` ({summary['n_stimuli']} stimuli). "
        f"ASR: `{opts.get('engine', '?')}`, N-best {opts.get('nbest', '?')}; instruction likelihood "
        f"`{opts.get('likelihood', '?')}`.",
        "",
        "## Main results", "",
        "Accuracy: object class and count exact. Speedup: L_single / L_team − 1, with remedy steps for "
        "wrong items. Helpful errors: wrong commands whose class is part of the goal, among wrong ones. "
        f"CIs: percentile bootstrap over stimuli, {summary['bootstrap']['resamples']} resamples.",
        "",
        main_table(summary), "",
        f"The gold command itself gives a mean speedup of {summary.get('gold_command_speedup')}.",
        "",
    ]
    for m, s in (summary.get("not_evaluable") or {}).items():
        why = "; ".join(f"{k} ({v})" for k, v in list(s["reasons"].items())[:3])
        parts += [f"Not evaluable for {m}: {s['n']} trials, left out of its row above: {why}", ""]
    names = [p.name for p in figures]
    if FIG_MAIN in names:
        parts += [f"![accuracy and speedup]({FIG_MAIN})", ""]
    if FIG_HIST in names:
        parts += [f"![speedup histograms]({FIG_HIST})", ""]
    parts += ["## Decisions and questions", "",
              "Scored by what decisions are for: the team's speedup and how often the robot made the team "
              "slower. Regret: the goal-known oracle's mean speedup (the best action for the true goal, which "
              "may be another action than the requested command) minus the model's. "
              "Questions: trials where the robot asked before acting (the answer is spoken and recognised "
              "like the instruction; the exchange costs the team steps). Confident wrong: the robot acted on "
              "a command it gave probability >= 0.8 and was wrong. MAP accuracy (decision-rule models): the most "
              "probable command after the answer is right, whatever the robot executed. No speedup: trials whose team simulation "
              "ran out of planning budget; they are left out of the speedup mean and the negative share.", "",
              _decision_table(summary), ""]
    if FIG_PARETO in names:
        parts += [f"![mean speedup vs negative-speedup share]({FIG_PARETO})", ""]
    if FIG_ASK in names:
        parts += [f"![speedup vs questions asked]({FIG_ASK})", ""]
    wer = summary.get("asr_wer", {})
    parts += ["## ASR word error rate (1-best against the reference)", "",
              f"All stimuli: {_pct(wer.get('all'))}.", "",
              "| condition | WER |", "|---|---|"]
    parts += [f"| {k} | {_pct(v)} |" for k, v in wer.get("snr", {}).items()]
    parts += ["", "| voice | WER |", "|---|---|"]
    parts += [f"| {k} | {_pct(v)} |" for k, v in wer.get("voice", {}).items()]
    parts += [""]
    titles = {"noise": "noise type", "snr": "SNR", "voice": "voice"}
    for by in BREAKDOWNS:
        parts += [f"## By {titles[by]} (accuracy / mean speedup)", "",
                  _breakdown_table(summary["breakdowns"][by], models, titles[by]), ""]
    if FIG_SNR in names:
        parts += [f"![accuracy by SNR]({FIG_SNR})", ""]
    if summary.get("participants"):
        parts += ["## By participant (collected recordings)", "",
                  "Each participant's recordings (the manifest's `speaker`; the voice table above has them "
                  "all as `human`). CIs: percentile bootstrap over that participant's stimuli; with a few "
                  "recordings each they are wide.", "",
                  participants_table(summary["participants"]), ""]
    parts += _rooms_section(summary, models)
    parts += ["## The paper, for comparison", "",
              "| paper (Simulated Experiment) | value |", "|---|---|"]
    parts += [f"| {k} | {_pct(v)} |" for k, v in PAPER.items()]
    hist = run.get("history", [])
    if hist:
        runs = "; ".join(f"{h['evaluated']} stimuli in {h['seconds']:.0f} s with {h['workers']} worker(s)"
                         for h in hist if h.get("evaluated"))
        parts += ["", f"Evaluation time: {runs or 'nothing left to evaluate'}."]
    return "\n".join(parts) + "\n"


def write_report(out: str | Path, seed: int | None = None, figures: bool = True) -> dict[str, Any]:
    """(Re-)write summary.json, report.md and the figures of a results folder; return the summary."""
    root = Path(out)
    rows = load_results(root)
    run: dict[str, Any] = {}
    if (root / RUN).is_file():
        run = json.loads((root / RUN).read_text(encoding="utf-8"))
    # manifest order, whatever order workers finished in: the bootstrap depends on it
    order, rooms = _manifest_order(run)
    for r in rows:  # a --rooms set: each row's room and talker distance, from the manifest's extra
        if r["id"] in rooms:
            r.setdefault("room_name", rooms[r["id"]][0])
            r.setdefault("distance_m", rooms[r["id"]][1])
    if order:
        rows = sorted(rows, key=lambda r: order.get(r["id"], len(order)))
    else:
        rows = sorted(rows, key=lambda r: r["id"])
    if seed is None:
        seed = int(run.get("seed", 0))
    from siftom.bench.human import human_summary, load_human, people_section, ratings_summary
    from siftom.bench.results_io import read_jsonl
    from siftom.people.ratings import RATINGS

    human = load_human(root)  # people's answers as trials of the model "human" (bench/human.py)
    ratings = read_jsonl(root / RATINGS)
    summary = _summarise(rows + human, seed=seed)
    people = human_summary(human, seed) if human else None
    rated = ratings_summary(ratings, seed) if ratings else {}
    if people is not None:
        summary["human"] = people.to_json()
    if rated:
        summary["ratings"] = {m: r.to_json() for m, r in rated.items()}
    summary["participants"] = participants(rows, seed)
    _write(root / "summary.json", json.dumps(summary, indent=2) + "\n")
    figs = render_figures(rows + human, summary, root) if figures else []
    from siftom.bench import reliability

    rel = reliability.reliability(rows, list(summary["models"]))
    summary["reliability"] = {m: {g: c.to_json() for g, c in res.items()} for m, res in rel.items()}
    _write(root / "summary.json", json.dumps(summary, indent=2) + "\n")
    rel_fig = reliability.render(rel, root) if figures else None
    _write(root / "report.md", _render_report(summary, run, figs) + "\n"
           + people_section(people, rated, summary["asr_wer"].get("all"), summary["asr_wer"].get("snr"))
           + reliability.section(rel, rel_fig))
    return summary


def _manifest_order(run: dict[str, Any]) -> tuple[dict[str, int], dict[str, tuple[str, float]]]:
    """The dataset's manifest: each stimulus' position, and (room, distance) of those built with --rooms."""
    ds = run.get("dataset")
    if not ds or not (Path(ds) / "manifest.jsonl").is_file():
        return {}, {}
    order, rooms = {}, {}
    for i, line in enumerate((Path(ds) / "manifest.jsonl").read_text(encoding="utf-8").splitlines()):
        try:
            d = json.loads(line)
            order[d["id"]] = i
            room = room_of(d)
        except (json.JSONDecodeError, KeyError, TypeError, ValueError, AttributeError):
            continue
        if room is not None:
            rooms[d["id"]] = room
    return order, rooms


def _write(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + f".{os.getpid()}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
