"""Does the robot keep still when no one asks it for anything, and act when someone does?

    python recipes/instruction_gate.py --out runs/gate [--domain kitchen-v0] [--scenarios 6]
        [--speakers 3] [--snr none,10,5] [--seed 1]

Builds two sets with the same voices, noise and scenes, nothing of which siftom was tuned on:

* requests: ``siftom dataset build`` with the carriers of ``recipes/data/carriers-check.txt``
  (each speaker asks for the scenario's robot command);
* off-topic speech: the sentences of ``recipes/data/off-topic.txt`` (weather, keys, traffic …),
  each said by one of the same voices, in one of the same scenes, clean and in the same noise.

Every clip goes through ``siftom.listen`` (the default path, as every door runs it). The report
gives, per condition, how often the robot acts on off-topic speech (it should not) and, for the
requests, how often it refuses them as "no instruction heard", acts on the right command or on
a wrong one. Each line of ``OUT/gate.jsonl`` keeps what each recogniser heard and which one the
no-instruction check read (``instruction_check``); ``OUT/summary.json`` holds the rates.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
OFF_TOPIC = HERE / "data" / "off-topic.txt"
CARRIERS = HERE / "data" / "carriers-check.txt"


def sentences(path: Path) -> list[str]:
    """Non-empty, non-comment lines."""
    return [ln.strip() for ln in path.read_text(encoding="utf-8").splitlines() if ln.strip() and not ln.startswith("#")]


def off_topic_clips(ds: Any, out: Path, seed: int) -> list[dict[str, Any]]:
    """One off-topic clip per request clip's speaker, scene and condition (same voice, same noise)."""
    from siftom.speech.audio import write_wav
    from siftom.speech.noise import get_noise, mix_at_snr
    from siftom.speech.tts import synthesize

    lines = sentences(OFF_TOPIC)
    rng = np.random.default_rng([seed, 7])
    order = rng.permutation(len(lines))
    rows: list[dict[str, Any]] = []
    clean: dict[tuple[str, str], np.ndarray] = {}
    (out / "off-topic").mkdir(parents=True, exist_ok=True)
    speakers = sorted({(s.scenario, s.speaker) for s in ds.stimuli})
    pick = {key: lines[int(order[i % len(lines)])] for i, key in enumerate(speakers)}
    for s in ds.stimuli:
        text = pick[(s.scenario, s.speaker)]
        key = (s.scenario, s.speaker)
        if key not in clean:
            clean[key] = synthesize(text, s.voice, rate=s.rate, pitch=s.pitch)
        x = clean[key]
        if s.noise is not None and s.snr_db is not None:
            x = mix_at_snr(x, get_noise(s.noise), s.snr_db, np.random.default_rng([seed, len(rows), 2]))
        path = out / "off-topic" / f"{s.id}.wav"
        write_wav(path, x)
        rows.append({"kind": "off-topic", "id": s.id, "scenario": s.scenario, "scenario_seed": s.scenario_seed,
                     "actions": list(s.observed_actions), "audio": str(path), "said": text,
                     "condition": s.condition, "voice": s.voice, "gold": None})
    return rows


def answer_row(row: dict[str, Any], domain: str) -> dict[str, Any]:
    """Run the clip through siftom.listen; keep what was decided and what each recogniser heard."""
    import siftom
    from siftom.people.stimuli import resolve_scenario

    sc = resolve_scenario(row["scenario"], domain, row["scenario_seed"])
    ans = siftom.listen(row["audio"], scenario=sc, actions=row["actions"])
    ev = ans.posterior.evidence
    nbest = [(h.text, h.score) for h in (ans.asr.nbest if ans.asr is not None else ())]
    return {**row, "action": ans.action, "command": str(ans.command) if ans.command else None,
            "top_command": str(ans.top_command), "top_prob": round(ans.top_prob, 4),
            "instruction_heard": ans.instruction_heard, "speech_heard": ans.speech_heard,
            "nbest": nbest, "whisper_heard": ev.get("whisper_heard"),
            "no_instruction_reason": ev.get("no_instruction_reason", ""),
            "instruction_check": ev.get("instruction_check", "")}


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Rates per kind and condition (see module doc)."""
    by: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        by[(r["kind"], r["condition"])].append(r)
        by[(r["kind"], "all")].append(r)
    out: dict[str, Any] = {}
    for (kind, cond), rs in sorted(by.items()):
        n = len(rs)
        acts = [r for r in rs if r["action"] == "act"]
        entry: dict[str, Any] = {"n": n, "acts": round(len(acts) / n, 4)}
        if kind == "off-topic":
            entry["asks"] = round(sum(r["action"] == "ask" for r in rs) / n, 4)
        else:
            entry["refused_no_instruction"] = round(sum(not r["instruction_heard"] for r in rs) / n, 4)
            entry["acts_right"] = round(sum(r["command"] == r["gold"] for r in acts) / n, 4)
            entry["acts_wrong"] = round(sum(r["command"] != r["gold"] for r in acts) / n, 4)
        out.setdefault(kind, {})[cond] = entry
    return out


def main(argv: list[str] | None = None) -> int:
    """Build, answer, report (module doc)."""
    from siftom.bench.dataset import build_dataset
    from siftom.people.stimuli import BuildOptions

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--domain", default="kitchen-v0")
    ap.add_argument("--scenarios", type=int, default=6)
    ap.add_argument("--speakers", type=int, default=3)
    ap.add_argument("--snr", default="none,10,5", help="'none' = clean, then one condition per SNR")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    snrs = tuple(float(s) for s in args.snr.split(",") if s.strip() and s.strip() != "none")
    opts = BuildOptions(domain=args.domain, scenarios=args.scenarios, speakers=args.speakers, snrs=snrs,
                        seed=args.seed, phrasings=str(CARRIERS))
    ds = build_dataset(opts, args.out / "requests", workers=1)
    rows = [{"kind": "request", "id": s.id, "scenario": s.scenario, "scenario_seed": s.scenario_seed,
             "actions": list(s.observed_actions), "audio": str(args.out / "requests" / s.audio),
             "said": s.reference, "condition": s.condition, "voice": s.voice, "gold": s.gold_command}
            for s in ds.stimuli]
    rows += off_topic_clips(ds, args.out, args.seed)
    from rich.progress import track

    done = [answer_row(r, args.domain) for r in track(rows, description="answering")]
    with open(args.out / "gate.jsonl", "w", encoding="utf-8") as f:
        for r in done:
            f.write(json.dumps(r) + "\n")
    summary = {"domain": args.domain, "seed": args.seed, "clips": len(done), "rates": summarise(done)}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    print(table(summary["rates"]))
    return 0


def table(rates: dict[str, Any]) -> str:
    """The rates as a plain-text table, one line per kind and condition."""
    lines = [f"{'speech':<10} {'condition':<14} {'n':>4} {'acts':>6} {'asks':>6} {'refused':>8} {'right':>6} {'wrong':>6}"]
    for kind, conds in rates.items():
        for cond, e in conds.items():
            def pct(k: str, e: dict[str, Any] = e) -> str:
                return f"{100 * e[k]:5.1f}%" if k in e else "     -"
            lines.append(f"{kind:<10} {cond:<14} {e['n']:>4} {pct('acts'):>6} {pct('asks'):>6} "
                         f"{pct('refused_no_instruction'):>8} {pct('acts_right'):>6} {pct('acts_wrong'):>6}")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
