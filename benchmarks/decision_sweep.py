"""Decision rules on cached posteriors: variants of expected benefit and ask-or-act, offline.

For a development set's results folder (``siftom eval`` with the decision models): every
stimulus's posterior under one likelihood is computed once and pickled (the acoustic one hears
the clip as the evaluator does), then each variant (loss aversion, utility unit, the question
time model's parameters, an interruption penalty) decides every trial as bench/decisions.py
does, answers are spoken and heard as in the evaluator (cached per question), and each chosen
action goes through the team simulation (the results folder's cache). Prints, per variant,
mean speedup, negative share, questions per trial, confident-wrong share and regret against
the goal-known oracle recorded in the results rows.

    PYTHONPATH=src python benchmarks/decision_sweep.py DATASET RESULTS --likelihood acoustic \
        --cache runs/post-dev1-kitchen.pkl --variant base --variant lam2:loss_aversion=2
"""

from __future__ import annotations

import argparse
import json
import pickle
from pathlib import Path
from typing import Any

import numpy as np


def posteriors(dataset: str, results: str, likelihood: str, cache: str) -> dict[str, Any]:
    from siftom.bench import trials as tr
    from siftom.bench.decisions import decision_posterior

    p = Path(cache)
    if p.is_file():
        return pickle.loads(p.read_bytes())
    out = {}
    engine = None
    for s, sc, _r, instr in tr.saved_trials(dataset, results):
        if engine is None:
            from siftom.bench.stimuli import load_dataset

            ds = load_dataset(dataset, check_audio=False)
            engine = tr._engine("pocketsphinx-vocab", tr.dataset_vocabulary(ds.stimuli))
            root = ds.root
        audio = Path(s.audio) if Path(s.audio).is_absolute() else root / s.audio
        out[s.id] = decision_posterior(likelihood, sc, instr, audio, engine, 10)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_bytes(pickle.dumps(out))
    return out


def run_variant(dataset: str, results: str, posts: dict[str, Any], opts: dict[str, Any],
                heard_cache: dict[tuple[str, str], dict[str, Any]]) -> dict[str, float]:
    from siftom.assist.askcost import QuestionCost
    from siftom.assist.decide import DEFAULT_LOSS_AVERSION, Situation, decide, with_answer
    from siftom.assist.questions import answer_log_likelihood_cells
    from siftom.bench import answers as ans
    from siftom.bench import trials as tr

    lam = float(opts.get("loss_aversion", DEFAULT_LOSS_AVERSION))
    unit = opts.get("utility", "steps")
    rule = opts.get("rule", "ask-or-act")
    cm = QuestionCost(**{k: float(v) for k, v in opts.items()
                         if k in ("speaking_rate_wpm", "step_seconds", "turn_gap_s", "robot_latency_s")})
    penalty = float(opts.get("penalty", 0.0))
    rows = []
    for s, sc, r, _instr in tr.saved_trials(dataset, results):
        post = posts[s.id]
        rel = ans.answer_reliabilities(s.snr_db)
        where = Situation.from_scenario(sc, answer_reliability=rel)
        k = 0
        if rule == "map":
            cmd, prob, asked, spent, mapc = post.command, post.commands[0][1], False, 0.0, post.command
        else:
            kw: dict[str, Any] = {"loss_aversion": lam}
            if rule == "ask-or-act":
                kw.update(cost_model=cm, penalty=penalty, time_as_loss=opts.get("time_as_loss", "1") == "1",
                          utility=unit)
            else:
                kw.update(utility=unit)
            d = decide(post, where, rule, **kw)
            cmd, prob, asked, spent, mapc = d.command, d.prob, False, 0.0, post.command
            max_q = int(opts.get("max_questions", 1))
            k = 0
            while d.ask and d.asked is not None:
                q = d.asked
                cell = next((j for j, o in enumerate(q.options) if tr.is_correct(o, s.gold_command, sc.verb)),
                            q.n_cells - 1)
                key = (s.id, q.text) if k == 0 else (s.id, q.text, k)
                if key not in heard_cache:
                    def listen(x: Any, grammar: tuple[str, ...]) -> Any:
                        return tr._engine("pocketsphinx-vocab", grammar).transcribe(x, nbest=10)
                    heard_cache[key] = ans.ask_and_hear(q, cell, s, dataset, listen, salt=k)
                h = heard_cache[key]
                spent += cm.steps(q.text, h["answer"])
                ll = answer_log_likelihood_cells(q, [str(c) for c in post.joint.commands], h["heard_cell"],
                                                 where.reliability(q.kind))
                post = with_answer(post, ll)
                k += 1
                asked = True
                as_loss = opts.get("time_as_loss", "1") == "1"
                if k < max_q:
                    d = decide(post, where, "ask-or-act", **{**kw, "spent": spent if as_loss else 0.0})
                else:
                    d = decide(post, where, "expected-benefit", loss_aversion=lam, utility=unit,
                               spent=spent if as_loss else 0.0)
                cmd, prob, mapc = d.command, d.prob, post.command
        t = tr._simulate(tr.scenario_key(s), sc, cmd)
        if t["l_team"] is None:
            continue
        l_team = t["l_team"] + spent
        sp = t["l_single"] / l_team - 1.0
        rows.append({"sp": sp, "asked": asked, "nq": k if rule == "ask-or-act" else 0, "cw": cmd != "none" and prob >= 0.8
                     and not tr.is_correct(cmd, s.gold_command, sc.verb),
                     "map_ok": tr.is_correct(mapc, s.gold_command, sc.verb),
                     "regret": (r["oracle"]["speedup"] - sp) if (r.get("oracle") or {}).get("speedup") is not None
                     else np.nan})
    sp = np.array([x["sp"] for x in rows])
    return {"speedup": float(sp.mean()), "neg": float((sp < -1e-9).mean()),
            "q": float(np.mean([x["nq"] for x in rows])), "cw": float(np.mean([x["cw"] for x in rows])),
            "map_acc": float(np.mean([x["map_ok"] for x in rows])),
            "regret": float(np.nanmean([x["regret"] for x in rows])), "n": len(rows)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset")
    ap.add_argument("results")
    ap.add_argument("--likelihood", default="acoustic")
    ap.add_argument("--cache", required=True)
    ap.add_argument("--variant", action="append", default=[], help="NAME[:key=val,...]")
    ap.add_argument("--json")
    a = ap.parse_args()
    from siftom.bench import evaluate as ev
    from siftom.bench import trials as tr

    for t in ev._read_jsonl(Path(a.results) / ev.TEAM_CACHE):
        tr._TEAM.setdefault((t["key"], t["command"]), t)
    posts = posteriors(a.dataset, a.results, a.likelihood, a.cache)
    hc_path = Path(a.cache).with_suffix(".heard.pkl")
    heard = pickle.loads(hc_path.read_bytes()) if hc_path.is_file() else {}
    out = {}
    for v in a.variant or ["base"]:
        name, _, spec = v.partition(":")
        opts = dict(kv.split("=", 1) for kv in spec.split(",") if kv)
        res = run_variant(a.dataset, a.results, posts, opts, heard)
        out[name] = {"options": opts, **res}
        print(f"{name:28s} speedup {res['speedup']:+.4f} neg {100 * res['neg']:4.1f} % q {res['q']:.3f} "
              f"cw {100 * res['cw']:.1f} % map {100 * res['map_acc']:.1f} % regret {res['regret']:+.4f}", flush=True)
    hc_path.write_bytes(pickle.dumps(heard))
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
