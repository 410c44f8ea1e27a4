"""Whole trials scored in bulk: every registered scenario of a domain, seeds and decision rules.

:func:`siftom.agents.trial.simulate_trial` simulates one trial; this module gives it the
speakers that need the phrasing grammar (a layer above the agents) and scores many:

* ``oracle``: a phrasing drawn from P(u | command) (``siftom.likelihood.phrasing``, the world's
  lexicon), heard exactly;
* ``noisy``: the same phrasing through a text-level phonetic confusion channel
  (:func:`confusion_speaker`): with probability ``p_err`` the recogniser's best hypothesis names a
  phonetically near class instead (nearness: the weighted phoneme edit distance of the
  likelihoods), and the N-best lists the said phrasing and the near classes' phrasings below it.

:func:`run_trials` yields one JSON-able row per (scenario, seed, rule); :func:`summarise` gives
per-rule means (docs/team-simulation.md, "Whole trials").
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from functools import lru_cache
from typing import Any

import numpy as np

from siftom.agents.trial import ASK_FOR, MAX_REQUESTS, Speaker, simulate_trial
from siftom.errors import SiftomError, unknown_name
from siftom.observation import Instruction
from siftom.world.commands import RobotCommand
from siftom.world.model import World

CHANNELS = ("oracle", "noisy")
P_ERR = 0.3  # the noisy channel's chance that the best hypothesis names another class
NBEST = 3


def phrasing_speaker(world: World) -> Callable[[RobotCommand, np.random.Generator], str]:
    """Say a command with a phrasing drawn from P(u | command) in the world's lexicon; heard exactly."""
    from siftom.likelihood.lexicon import lexicon_for
    from siftom.likelihood.phrasing import sample_phrasing

    lex = lexicon_for(world)

    def speak(command: RobotCommand, rng: np.random.Generator) -> str:
        return sample_phrasing(command, lex, rng)

    return speak


@lru_cache(maxsize=4096)
def _spoken_phonemes(text: str) -> tuple[str, ...]:
    from siftom.likelihood.phonemes import text_phonemes

    return text_phonemes(text)


def near_classes(world: World, cls: str, k: int = NBEST) -> list[tuple[str, float]]:
    """The ``k`` classes of ``world`` whose names sound nearest to ``cls``'s, with the distance."""
    from siftom.likelihood.editdistance import edit_distance
    from siftom.likelihood.lexicon import spoken_form

    said = _spoken_phonemes(spoken_form(cls))
    d = [(edit_distance(said, _spoken_phonemes(spoken_form(c))), c) for c in world.classes if c != cls]
    return [(c, float(x)) for x, c in sorted(d)[:k]]


def confusion_speaker(world: World, p_err: float = P_ERR, nbest: int = NBEST) -> Speaker:
    """A text-level noisy channel (module doc): an N-best list whose best entry is, with
    probability ``p_err``, a phrasing of a phonetically near class (chosen in proportion to
    ``exp(-distance)`` among the ``nbest - 1`` nearest)."""
    if not 0.0 <= p_err <= 1.0:
        raise SiftomError(f"p_err must be a probability, got {p_err}")
    if nbest < 2:
        raise SiftomError(f"a confusion channel needs an N-best of at least 2, got {nbest}")
    say = phrasing_speaker(world)

    def speak(command: RobotCommand, rng: np.random.Generator) -> Instruction:
        said = say(command, rng)
        near = near_classes(world, command.obj_class, nbest - 1)
        others = [say(RobotCommand(command.verb, c, command.count), rng) for c, _d in near]
        if near and rng.random() < p_err:
            w = np.exp(-np.array([d for _c, d in near]))
            j = int(rng.choice(len(near), p=w / w.sum()))
            texts = [others[j], said] + [t for i, t in enumerate(others) if i != j]
        else:
            texts = [said, *others]
        return Instruction.from_nbest([(t, -float(i)) for i, t in enumerate(texts[:nbest])])

    return speak


def speaker_for(channel: str, world: World, p_err: float = P_ERR) -> Speaker:
    """The speaker of a channel name (:data:`CHANNELS`)."""
    if channel == "oracle":
        return phrasing_speaker(world)
    if channel == "noisy":
        return confusion_speaker(world, p_err)
    raise unknown_name("trial channel", channel, CHANNELS)


def run_trials(domain: str, seeds: Sequence[int], rules: Sequence[str], observer: Any, *,
               channels: Sequence[str] = ("oracle",), max_requests: int = MAX_REQUESTS, p_err: float = P_ERR,
               scenarios: Sequence[str] | None = None, ask_for: str | Sequence[str] = "plan",
               progress: Callable[[int, int], None] | None = None) -> Iterator[dict[str, Any]]:
    """One row per (scenario, channel, person policy, seed, rule) over the domain's registered
    scenarios; ``ask_for``: one person policy or several (agents/trial.py, ``ASK_FOR``)."""
    from siftom import __version__
    from siftom.bench.machine import Machine
    from siftom.scenarios.base import get_domain, get_scenario

    stamp = {"version": __version__, "machine": Machine.here().to_json("results")}
    policies = [ask_for] if isinstance(ask_for, str) else list(ask_for)
    for a in policies:
        if a not in ASK_FOR:
            raise unknown_name("person policy (ask_for)", a, ASK_FOR)
    ids = list(scenarios) if scenarios is not None else list(get_domain(domain).fixed())
    total = len(ids) * len(channels) * len(policies) * len(seeds) * len(rules)
    done = 0
    if progress is not None:
        progress(0, total)
    for sid in ids:
        sc = get_scenario(sid)
        for channel in channels:
            for policy in policies:
                for seed in seeds:
                    for rule in rules:
                        res = simulate_trial(sc, observer, seed=seed, rule=rule, max_requests=max_requests,
                                             speak=speaker_for(channel, sc.world, p_err), ask_for=policy)
                        done += 1
                        if progress is not None:
                            progress(done, total)
                        yield {"domain": domain, "channel": channel, "ask_for": policy, **res.metrics(),
                               "request_log": [r.to_json() for r in res.requests], **stamp}


def _mean_se(xs: Sequence[float]) -> tuple[float, float]:
    if not xs:
        return math.nan, math.nan
    a = np.asarray(xs, dtype=float)
    return float(a.mean()), float(a.std(ddof=1) / math.sqrt(len(a))) if len(a) > 1 else 0.0


def summarise(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per (domain, channel, person policy, rule): trials, mean speedup (and its standard error),
    wrong fetches, questions, refusals and requests per trial, the share of requests answered
    (carried out as asked, or asked about by a question naming what was asked for) and the
    requests turned down without a reason the robot can say; with two or more rules, each rule's
    mean paired difference in speedup from the first rule."""
    groups: dict[tuple[str, str, str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["domain"], r["channel"], r.get("ask_for", ""), r["rule"]), []).append(r)
    out = []
    for (domain, channel, ask_for, rule), rs in groups.items():
        sp, se = _mean_se([r["speedup"] for r in rs])
        n = len(rs)
        asked = sum(r["requests"] for r in rs)
        out.append({"domain": domain, "channel": channel, "ask_for": ask_for, "rule": rule, "trials": n,
                    "speedup": sp, "speedup_se": se, "wrong_fetches": sum(r["wrong_fetches"] for r in rs) / n,
                    "questions": sum(r["questions"] for r in rs) / n,
                    "refusals": sum(r["refusals"] for r in rs) / n,
                    "requests": asked / n,
                    "answered": sum(r.get("answered", 0) for r in rs) / asked if asked else math.nan,
                    "ignored": sum(r.get("ignored", 0) for r in rs),
                    "l_single": sum(r["l_single"] for r in rs) / n, "l_team": sum(r["l_team"] for r in rs) / n})
    # paired differences from the first rule of each (domain, channel, person policy)
    first: dict[tuple[str, str, str], str] = {}
    for r in rows:
        first.setdefault((r["domain"], r["channel"], r.get("ask_for", "")), r["rule"])
    key = {(r["domain"], r["channel"], r.get("ask_for", ""), r["rule"], r["scenario"], r["seed"]): r["speedup"]
           for r in rows}
    for s in out:
        base = first[(s["domain"], s["channel"], s["ask_for"])]
        if s["rule"] == base:
            continue
        diffs = [v - key[(d, c, a, base, sc, seed)] for (d, c, a, rule, sc, seed), v in key.items()
                 if (d, c, a, rule) == (s["domain"], s["channel"], s["ask_for"], s["rule"])
                 and (d, c, a, base, sc, seed) in key]
        s["vs"], (s["diff"], s["diff_se"]) = base, _mean_se(diffs)
    return out


def markdown(summary: Sequence[dict[str, Any]]) -> str:
    """The summary as a Markdown table."""
    lines = ["| domain | channel | person | rule | trials | speedup (± se) | wrong fetches / trial "
             "| questions / trial | refusals / trial | requests / trial | answered | ignored |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in summary:
        diff = f"; {s['diff']:+.3f} ± {s['diff_se']:.3f} vs {s['vs']}" if "vs" in s else ""
        lines.append(f"| {s['domain']} | {s['channel']} | {s['ask_for']} | {s['rule']} | {s['trials']} | "
                     f"{s['speedup']:+.3f} ± {s['speedup_se']:.3f}{diff} | {s['wrong_fetches']:.2f} | "
                     f"{s['questions']:.2f} | {s['refusals']:.2f} | {s['requests']:.2f} | "
                     f"{100 * s['answered']:.0f} % | {s['ignored']} |")
    return "\n".join(lines)
