"""How often the fast cost-to-go equals the A* optimum, on random small worlds.

Run: .venv/bin/python benchmarks/costtogo_exactness.py [N]
Prints counts of exact / lower / higher values and checks that the relaxed value (the A*
heuristic) never exceeds the optimum. Worlds: 5 places (some closed containers), 5 objects of
3 classes, random goals, 40 % of states with an object in hand.
"""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from helpers import random_world  # noqa: E402
from siftom.planning.astar import plan_for_goal  # noqa: E402
from siftom.planning.costtogo import CostToGo  # noqa: E402
from siftom.world.model import HELD, NOTHING, Goal, State  # noqa: E402


def main(n: int = 400) -> None:
    diffs: Counter[float] = Counter()
    overestimates = skipped = 0
    for seed in range(n):
        rng = np.random.default_rng(seed)
        world, s = random_world(rng, n_places=5, n_items=5, n_classes=3)
        if rng.random() < 0.4:
            i = int(rng.integers(len(world.items)))
            item_at = list(s.item_at)
            item_at[i] = HELD
            s = State(s.agent_at, (i, NOTHING), tuple(item_at), s.open_mask)
        counts = {c: int(rng.integers(0, sum(it.cls == c for it in world.items) + 1)) for c in world.classes}
        goal = Goal("g", 0, tuple((c, k) for c, k in counts.items() if k > 0))
        ref = plan_for_goal(world, s, goal, use_heuristic=False, prune=False, max_nodes=300_000)
        if not ref.solved:
            skipped += 1
            continue
        ctg = CostToGo(world, 0, 5)
        overestimates += ctg.value(s, goal, relaxed=True) > ref.cost + 1e-9
        diffs[ctg.value(s, goal) - ref.cost] += 1
    total = sum(diffs.values())
    print(f"{total} states solved by uniform-cost search ({skipped} over the node budget, skipped)")
    for d, k in sorted(diffs.items()):
        print(f"  fast - optimal = {d:+g}: {k} ({100 * k / total:.1f} %)")
    print(f"relaxed value above the optimum (inadmissible): {overestimates}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 400)
