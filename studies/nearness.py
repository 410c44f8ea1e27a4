"""How near random words come to a scene's commands: ``python studies/nearness.py [N] [SEED]``.

Draws N random words (alphabetic, 2+ letters, not filler or number words) from CMUdict with a
seed, and rates each against the command words of every built-in scene (both domains) with
:func:`siftom.likelihood.nearness.word_costs`. Prints, per word length in phonemes, the 1st
percentile of the relative cost r: the chance level ``CHANCE_R`` in
``siftom/likelihood/nearness.py`` (a heard word nearer than that is unlikely by chance).
"""

from __future__ import annotations

import json
import sys
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from siftom.world.commands import RobotCommand

LENGTHS = (1, 2, 3, 4, 5, 6, 7, 8)


def scene_command_sets() -> list[tuple[str, tuple[RobotCommand, ...]]]:
    """(scenario id, its commands) for every built-in scenario."""
    from siftom.observer import observer_for
    from siftom.scenarios.base import get_scenario, scenario_ids
    from siftom.settings import Settings

    model = observer_for(Settings.load(env={})).model("full", "phonetic")
    out: list[tuple[str, tuple[RobotCommand, ...]]] = []
    for sid in scenario_ids():
        sc = get_scenario(sid)
        online = model.online(sc.world, sc.start, sc.goals, sc.verb)
        out.append((sid, tuple(online.candidates()[4])))
    return out


def measure(n: int = 4000, seed: int = 0, quantile: float = 0.01) -> dict[str, object]:
    """Chance levels of r per phoneme length (see module doc)."""
    from siftom.likelihood.nearness import scene_words, word_costs
    from siftom.likelihood.phonemes import cmudict
    from siftom.likelihood.phrasing import FILLER_WORDS, NUMBER_WORDS

    pool = sorted(w for w in cmudict() if w.isalpha() and len(w) > 1 and w not in FILLER_WORDS
                  and w not in NUMBER_WORDS)
    rng = np.random.default_rng(seed)
    sample = [pool[i] for i in rng.choice(len(pool), size=n, replace=False)]
    by_len: dict[int, list[float]] = {}
    sets = {frozenset(scene_words(cmds)) for _sid, cmds in scene_command_sets()}
    for words in sets:
        for w in sample:
            if w in words:
                continue
            for _w, k, r in word_costs(w, words):
                by_len.setdefault(min(k, LENGTHS[-1]), []).append(r)
    levels = {k: round(float(np.quantile(v, quantile)), 3) for k, v in sorted(by_len.items()) if len(v) >= 50}
    return {"words": n, "seed": seed, "scenes": len(sets), "quantile": quantile, "chance_r": levels,
            "counts": {k: len(v) for k, v in sorted(by_len.items())}}


if __name__ == "__main__":
    args = [int(a) for a in sys.argv[1:3]]
    print(json.dumps(measure(*args), indent=2))
