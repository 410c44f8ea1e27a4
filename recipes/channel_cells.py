"""Count the cells of each recogniser's readings on recordings, and fit how far each is trusted.

The utterance model weighs every recogniser's words for "did anybody ask?" through a *channel*:
two distributions over the reading cells (a request frame or none, crossed with what the target
slots do; ``siftom.language.understand.CELLS``), one under a request and one under nobody asked,
and a reliability. This recipe runs ``siftom bench understanding`` on a set's recordings, keeps
every hearing the observer weighed (the scene recogniser's N-best with its weights, Whisper's
transcript with its confidence), and prints:

* the cells of each recogniser's first hypothesis, counted per hypothesis (request or not), with
  half a count added per cell: the tables ``SCENE_CELLS`` and ``TRANSCRIPT_CELLS`` are these;
* the log loss of P(somebody asked) over the set with the tables in the source and with the
  counted ones, and the reliabilities (scene, and Whisper's slope and midpoint over its mean token
  log-probability) that minimise it;
* with ``--check OTHER``, the same log loss and shares on another set's recordings with the
  fitted values (the set they were not counted on).

    python recipes/channel_cells.py [--set dev] [--conditions clean,10dB] [--out /tmp/cells.jsonl]
                                    [--check heldout]

The recordings are kept beside ``--out`` (``FILE.audio/``) and reused when the run is repeated.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections import Counter
from pathlib import Path
from typing import Any


def capture(set_name: str, conditions: list[str], out: Path) -> list[dict[str, Any]]:
    """Run the benchmark on ``set_name`` and return one record per row: the item's label and
    every hearing the observer weighed for it (the last call of the row)."""
    import siftom.language.understand as und
    from siftom.bench.understanding import DEFAULT_WORLDS, WORLD_SEEDS, items_of, run_benchmark

    seen: list[tuple[list[Any], tuple[str, ...]]] = []
    real = und.understand_heard

    def spy(hearings: Any, classes: Any, lexicon: Any = None) -> Any:
        seen.append((list(hearings), tuple(classes)))
        return real(hearings, classes, lexicon)

    und.understand_heard = spy  # type: ignore[assignment]
    per_row: list[tuple[list[Any], tuple[str, ...]] | None] = []

    def progress(done: int, total: int) -> None:
        per_row.append(seen[-1] if seen else None)
        seen.clear()
        print(f"\r{done}/{total}", end="", file=sys.stderr)

    items = items_of(set_name, WORLD_SEEDS.get(set_name), DEFAULT_WORLDS, 0)
    run = run_benchmark(items, conditions, out=out, progress=progress)
    und.understand_heard = real  # type: ignore[assignment]
    print(file=sys.stderr)
    records = []
    for row, got in zip(run.rows, per_row, strict=True):
        if got is None:
            continue
        hearings, classes = got
        records.append({"id": row["id"], "condition": row["condition"], "request": bool(row["expected"]["request"]),
                        "classes": list(classes),
                        "hearings": [{"texts": list(h.texts), "weights": list(h.weights), "channel": h.channel.name,
                                      "reliability": h.reliability, "who": h.who} for h in hearings]})
    return records


def _logprob_of(reliability: float) -> float | None:
    """Whisper's mean token log-probability from the reliability it was given (its inverse)."""
    from siftom.inference.understood import TRANSCRIPT_MIDPOINT, TRANSCRIPT_SLOPE

    r = min(max(reliability, 1e-9), 1 - 1e-9)
    return TRANSCRIPT_MIDPOINT + math.log(r / (1 - r)) / TRANSCRIPT_SLOPE


def cells(records: list[dict[str, Any]], who: str) -> tuple[dict[str, float], dict[str, float], int, int]:
    """The first hypothesis's cells of ``who``'s hearings: (P(cell | request), P(cell | nobody
    asked)) with half a count added per cell, and the two counts."""
    from siftom.language.parse import read
    from siftom.language.understand import CELLS, cue_cell, namer

    got: dict[bool, Counter[str]] = {True: Counter(), False: Counter()}
    for rec in records:
        nm = namer(tuple(rec["classes"]))
        for h in rec["hearings"]:
            if h["who"] == who:
                got[rec["request"]][cue_cell(read(h["texts"][0]), nm)[0]] += 1
    n1, n0 = sum(got[True].values()), sum(got[False].values())
    p1 = {c: (got[True][c] + 0.5) / (n1 + 0.5 * len(CELLS)) for c in CELLS}
    p0 = {c: (got[False][c] + 0.5) / (n0 + 0.5 * len(CELLS)) for c in CELLS}
    return p1, p0, n1, n0


def log_odds(records: list[dict[str, Any]], transcript: Any, scene_r: float, slope: float, mid: float) -> list[float]:
    """log-odds(request) of each record with the transcript channel ``transcript`` and the given
    reliabilities (siftom.language.understand.understand_heard's sum)."""
    from siftom.language.understand import OPEN, SCENE, Hearing, hearing_log_odds

    out = []
    for rec in records:
        lo = 0.0
        for h in rec["hearings"]:
            if h["who"] == "Whisper":
                lp = _logprob_of(h["reliability"])
                r = 1.0 / (1.0 + math.exp(-slope * (lp - mid))) if lp is not None else 1.0
                ch = transcript
            else:
                ch = SCENE if h["channel"] == "scene" else OPEN
                r = scene_r if h["channel"] == "scene" else h["reliability"]
            lo += hearing_log_odds(Hearing(tuple(h["texts"]), tuple(h["weights"]), ch, r, h["who"]), rec["classes"])
        out.append(lo)
    return out


def loss(records: list[dict[str, Any]], los: list[float]) -> tuple[float, float, float]:
    """(mean log loss, share of requests below 1/3, share of the rest at or above 1/3)."""
    ll = 0.0
    low = high = 0
    n1 = sum(r["request"] for r in records)
    n0 = len(records) - n1
    for rec, lo in zip(records, los, strict=True):
        z = max(-50.0, min(50.0, lo))
        ll += math.log1p(math.exp(-z)) if rec["request"] else math.log1p(math.exp(z))
        p = 1 / (1 + math.exp(-z))
        low += rec["request"] and p < 1 / 3
        high += (not rec["request"]) and p >= 1 / 3
    return ll / len(records), low / max(n1, 1), high / max(n0, 1)


def main() -> None:
    from scipy.optimize import minimize

    from siftom.inference.understood import SCENE_RELIABILITY, TRANSCRIPT_MIDPOINT, TRANSCRIPT_SLOPE
    from siftom.language.understand import OPEN, make_channel

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--set", default="dev")
    ap.add_argument("--conditions", default="clean,10dB")
    ap.add_argument("--out", default="/tmp/siftom-cells/dev.jsonl")
    ap.add_argument("--check", default=None, help="another set to check the fitted values on")
    ap.add_argument("--hearings", default=None, help="a JSON file of captured hearings to read instead of running")
    args = ap.parse_args()
    conds = args.conditions.split(",")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    cache = out.with_suffix(".hearings.json")
    if args.hearings:
        records = json.loads(Path(args.hearings).read_text())
    elif cache.exists():
        records = json.loads(cache.read_text())
    else:
        records = capture(args.set, conds, out)
        cache.write_text(json.dumps(records))
    for who in ("the recogniser", "Whisper"):
        p1, p0, n1, n0 = cells(records, who)
        print(f"{who}: {n1} requests, {n0} that asked nothing")
        print("  " + ", ".join(f'"{c}": ({p1[c]:.3f}, {p0[c]:.3f})' for c in p1))
    p1, p0, _, _ = cells(records, "Whisper")
    counted = make_channel("transcript", p1, p0, as_said=False)
    now = (SCENE_RELIABILITY, TRANSCRIPT_SLOPE, TRANSCRIPT_MIDPOINT)
    print("log loss, requests < 1/3, asked-nothing >= 1/3:")
    print("  stated open cells, source reliabilities:", loss(records, log_odds(records, OPEN, *now)))
    print("  counted transcript cells, source reliabilities:", loss(records, log_odds(records, counted, *now)))

    def f(t: Any) -> float:
        return loss(records, log_odds(records, counted, float(t[0]), float(t[1]), float(t[2])))[0]

    fit = minimize(f, list(now), method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-4, "maxiter": 200})
    best = (min(1.0, max(0.0, float(fit.x[0]))), float(fit.x[1]), float(fit.x[2]))  # a weight is in [0, 1]
    print("  counted cells, fitted reliabilities", tuple(round(x, 3) for x in best), loss(records, log_odds(records, counted, *best)))
    if args.check:
        other = out.with_name(f"{args.check}.jsonl")
        ocache = other.with_suffix(".hearings.json")
        orecs = json.loads(ocache.read_text()) if ocache.exists() else capture(args.check, conds, other)
        ocache.write_text(json.dumps(orecs))
        print(f"on {args.check} (not counted on):")
        print("  stated open cells, source reliabilities:", loss(orecs, log_odds(orecs, OPEN, *now)))
        print("  counted cells, source reliabilities:", loss(orecs, log_odds(orecs, counted, *now)))
        print("  counted cells, fitted reliabilities:", loss(orecs, log_odds(orecs, counted, *best)))


if __name__ == "__main__":
    main()
