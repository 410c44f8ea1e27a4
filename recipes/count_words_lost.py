"""How often the recogniser loses or misplaces the count word, against the object word, per SNR.

    python recipes/count_words_lost.py RESULTS_DIR... [--model siftom]

Over the stimuli whose reference says a count ("four spoons", "spoons, four of them"), from the
1-best of each ``siftom eval`` results folder: the share whose count word is missing, whose count
word is another number, or stands on the other side of the object word than it was said; and, over
all stimuli, the share whose object word (any name of the gold class, singular or plural) is
missing. The last rows: how often the model's answer has the right class but the wrong count,
and how often that happens with P >= 0.8.
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path

COUNTS = {"one": 1, "two": 2, "three": 3, "four": 4, "1": 1, "2": 2, "3": 3, "4": 4}


def names_of(cls: str) -> set[str]:
    from siftom.likelihood.lexicon import LexEntry, default_lexicon

    lex = default_lexicon()
    entry = lex.entry(cls) if cls in lex else LexEntry.default(cls)
    return {w for n in entry.names for w in (n.singular, n.plural)}


def position(words: list[str], names: set[str]) -> int | None:
    text = f" {' '.join(words)} "
    hits = [text.find(f" {n} ") for n in names if f" {n} " in text]
    return min(hits) if hits else None


def main() -> None:
    from siftom.world.commands import RobotCommand

    ap = argparse.ArgumentParser()
    ap.add_argument("results", nargs="+")
    ap.add_argument("--model", default="siftom")
    a = ap.parse_args()
    by: dict[str, dict[str, int]] = defaultdict(lambda: defaultdict(int))
    for res in a.results:
        for line in (Path(res) / "results.jsonl").read_text().splitlines():
            r = json.loads(line)
            b = "clean" if r["snr_db"] is None else f"{r['snr_db']:g} dB"
            gold = RobotCommand.parse(r["gold_command"])
            names = names_of(gold.obj_class)
            ref, hyp = r["reference"].split(), r["transcript"]["text"].split()
            d = by[b]
            d["n"] += 1
            d["object word lost"] += position(hyp, names) is None
            said = [(i, COUNTS[w]) for i, w in enumerate(ref) if w in COUNTS]
            if said:
                d["count said"] += 1
                heard = [(i, COUNTS[w]) for i, w in enumerate(hyp) if w in COUNTS]
                if not heard:
                    d["count word lost"] += 1
                elif said[0][1] not in [c for _, c in heard]:
                    d["count word wrong"] += 1
                else:
                    pr, ph = position(ref, names), position(hyp, names)
                    i_ref = len(" ".join(ref[: said[0][0]]))
                    i_hyp = len(" ".join(hyp[: next(i for i, c in heard if c == said[0][1])]))
                    if pr is not None and ph is not None and (i_ref < pr) != (i_hyp < ph):
                        d["count word misplaced"] += 1
            m = r["models"].get(a.model)
            if m is not None and m["command"] != "none":
                c = RobotCommand.parse(m["command"])
                if c.obj_class == gold.obj_class and c.count != gold.count:
                    d["answer: class right, count wrong"] += 1
                    d["... with P >= 0.8"] += m["prob"] >= 0.8
    bands = [b for b in ("clean", "20 dB", "10 dB", "5 dB") if b in by]
    keys = ["n", "object word lost", "count said", "count word lost", "count word wrong", "count word misplaced",
            "answer: class right, count wrong", "... with P >= 0.8"]
    print("| | " + " | ".join(bands) + " |\n|---|" + "---|" * len(bands))
    for k in keys:
        cells = []
        for b in bands:
            d = by[b]
            base = d["count said"] if k.startswith("count word") else d["n"]
            cells.append(f"{d[k]}" if k in ("n", "count said") else f"{100 * d[k] / max(base, 1):.1f} %")
        print(f"| {k} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
