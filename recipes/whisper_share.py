"""Whisper's share of the pruned commands: MAP accuracy and Whisper texts per clip for each K.

The acoustic likelihood gives Whisper's teacher-forced score to at most K of the commands its
pruning keeps (``AcousticLikelihood(whisper_candidates=K)``: those Whisper heard named, then the
best by N-best x context; docs/likelihoods.md, "Whisper's share"). For every stimulus of a
dataset (``siftom dataset build``) and every K, the default audio path (``siftom.listen``: voice
activity, recognition, the acoustic likelihood, the posterior) answers the clip; the MAP command
is compared with the gold one, and the Whisper texts the clip cost are counted (the clip memos are
emptied before each K, so no K reuses another's scores). ``all`` scores
every kept command (the behaviour before the share). Choose K on one dataset and report it on
others (other world seed, voices and noise).

    python recipes/whisper_share.py --dataset DIR [--ks 2,3,4,5,all] [--limit N] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path
from typing import Any

ALL = 10**6  # more commands than any scene holds: every kept command is scored


def run(dataset: Path, ks: list[int], limit: int | None = None) -> dict[str, Any]:
    """Per K: clips, MAP accuracy (%), mean Whisper texts per clip, clips whose MAP differs from the largest K's."""
    import siftom
    from siftom.likelihood.acoustic import AcousticLikelihood
    from siftom.likelihood.whisper_factor import forget_clips
    from siftom.people.stimuli import resolve_scenario

    rows = [json.loads(line) for line in (dataset / "manifest.jsonl").read_text(encoding="utf-8").splitlines()
            if line.strip()][:limit]
    likelihoods = {k: AcousticLikelihood(whisper_candidates=k) for k in ks}
    tops: dict[int, list[str | None]] = {k: [] for k in ks}
    texts: dict[int, list[int]] = {k: [] for k in ks}
    for r in rows:
        scene = resolve_scenario(r["scenario"], r["domain"], r.get("scenario_seed"))
        for k, lk in likelihoods.items():
            forget_clips()  # each K hears the clip afresh: its texts are counted, not taken from another K's
            a = siftom.listen(dataset / r["audio"], scenario=scene, actions=r["observed_actions"], likelihood=lk)
            tops[k].append(None if a.top_command is None else str(a.top_command))
            texts[k].append(int(a.posterior.evidence.get("whisper_texts") or 0))
    gold = [r["gold_command"] for r in rows]
    ref = tops[max(ks)]
    return {"dataset": str(dataset), "clips": len(rows), "per_k": {
        ("all" if k >= ALL else str(k)): {
            "map_pct": round(100 * sum(t == g for t, g in zip(tops[k], gold, strict=True)) / max(1, len(rows)), 1),
            "texts_per_clip": round(statistics.mean(texts[k]), 2) if rows else 0.0,
            "map_differs": sum(t != u for t, u in zip(tops[k], ref, strict=True))}
        for k in ks}}


def main() -> None:
    """Parse the flags, run, print a table (or JSON)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", type=Path, required=True)
    ap.add_argument("--ks", default="2,3,4,5,all", help="comma-separated K values; 'all' scores every kept command")
    ap.add_argument("--limit", type=int, default=None, help="the first N stimuli only")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    ks = sorted({ALL if k.strip() == "all" else int(k) for k in args.ks.split(",") if k.strip()})
    out = run(args.dataset, ks, args.limit)
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(f"{out['dataset']}: {out['clips']} clips")
    print("K      MAP %   texts/clip   MAP differs from the largest K")
    for k, v in out["per_k"].items():
        print(f"{k:<6} {v['map_pct']:>5.1f}   {v['texts_per_clip']:>10.2f}   {v['map_differs']}")


if __name__ == "__main__":
    main()
