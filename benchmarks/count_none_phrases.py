"""Which "anything else" answer to a count question is heard right? (issue 11)

For a seeded sample of a development set's stimuli, ask "How many X?" about a class the goal
does not need, say every phrase of each candidate "anything else" cell in the stimulus's voice,
noise and SNR, recognise it with the question's grammar and count how often it names that
cell; also one number answer per stimulus through the same grammar.

    PYTHONPATH=src python benchmarks/count_none_phrases.py /work/final/dev1/household/dataset 100
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace

import numpy as np

from siftom.assist.questions import count_question
from siftom.bench import trials
from siftom.bench.answers import answer_audio
from siftom.bench.llm_baselines import command_space
from siftom.bench.stimuli import load_dataset, scenario_for
from siftom.world.commands import RobotCommand

VARIANTS = {
    "no (before)": (("no {p}", "no thanks", "none of them"), ("no", "none")),
    "nothing (now)": (("nothing", "nothing thanks", "i don't need any"), ("nothing", "don't", "any")),
    "dontneed": (("i don't need {p}", "i don't need any", "not any {p}"), ("don't", "any", "not")),
    "zero": (("zero", "zero {p}", "i don't need any"), ("zero", "don't", "any")),
}


def listen(x: np.ndarray, grammar: tuple[str, ...]):
    return trials._engine("pocketsphinx-vocab", grammar).transcribe(x, nbest=5)


def heard(q, tr) -> int | None:
    for h in [x.text for x in tr.nbest] or [tr.text]:
        hc = q.heard_cell(h)
        if hc is not None:
            return hc
    return None


def main() -> None:
    ds = load_dataset(sys.argv[1])
    st = list(ds.stimuli)
    idx = sorted(np.random.default_rng(0).choice(len(st), int(sys.argv[2]), replace=False))
    none_ok: dict = {v: {} for v in VARIANTS}
    num_ok: dict = {v: {} for v in VARIANTS}
    t0 = time.time()
    for i in idx:
        s = st[i]
        sc = scenario_for(s)
        cmds = [str(c) for c in command_space(sc)]
        gold = RobotCommand.parse(s.gold_command).obj_class
        others = sorted({RobotCommand.parse(c).obj_class for c in cmds} - {gold} - {c for c, _ in sc.goal.counts})
        if not others:
            continue
        cls = others[int(np.random.default_rng(i).integers(len(others)))]
        q0 = count_question(cls, cmds)
        plural = q0.text[len("How many "):-1]
        snr = float("inf") if s.snr_db is None else s.snr_db
        for v, (phrases, keys) in VARIANTS.items():
            cells = (*q0.answers[:-1], tuple(p.format(p=plural) for p in phrases))
            q = replace(q0, answers=cells, keys=(*q0.keys[:-1], keys))
            for k, ph in enumerate(q.answers[-1]):
                tr = listen(answer_audio(s, ph, str(ds.root), salt=k), q.grammar())
                none_ok[v].setdefault(snr, []).append(heard(q, tr) == q.n_cells - 1)
            tr = listen(answer_audio(s, q.answers[0][0], str(ds.root), salt=9), q.grammar())
            num_ok[v].setdefault(snr, []).append(heard(q, tr) == 0)
    print(f"{time.time() - t0:.0f} s")
    for v in VARIANTS:
        a = " ".join(f"{k:g}: {np.mean(x):.2f} (n {len(x)})" for k, x in sorted(none_ok[v].items()))
        b = " ".join(f"{k:g}: {np.mean(x):.2f}" for k, x in sorted(num_ok[v].items()))
        print(f"{v}: anything-else cell {a} | a number {b}")


if __name__ == "__main__":
    main()
