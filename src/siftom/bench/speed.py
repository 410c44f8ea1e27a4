"""Speed benchmarks of the hot paths: ``siftom bench inference`` and ``siftom bench planner``.

Numbers are wall-clock on one process (numpy may use more threads; set OMP_NUM_THREADS=1 for
one core). Every timed call starts from scratch unless it says "update".
"""

from __future__ import annotations

import functools
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from siftom.world.model import Goal, World

NBEST_SILVER = [
    ("can you pass me the silver", -2.0), ("can you pass me the cereal", -2.6), ("can you pass me the sugar", -3.1),
    ("can you pass me the seller", -3.3), ("can you pass me this silver", -3.6), ("can you pass me the salary", -3.9),
    ("could you pass me the silver", -4.0), ("can you pass me the so", -4.4), ("can you pass me to silver", -4.6),
    ("can you pass me the cellar", -4.9),
]


@dataclass(frozen=True)
class InferenceBench:
    """``siftom bench inference``: the kitchen scenario's size, the command inferred, the median
    milliseconds of full inference, of a one-action update and of the posterior alone, and the
    median of full inference per number of goals (``scaling``: (goals, ms))."""

    scenario: str
    num_items: int
    num_classes: int
    num_goals: int
    num_actions: int
    nbest: int
    command: str
    p50_ms: float
    update_p50_ms: float
    posterior_p50_ms: float
    scaling: tuple[tuple[int, float], ...]
    threads: str

    def to_json(self) -> dict[str, Any]:
        """The ``--json`` form."""
        return {"scenario": self.scenario, "num_items": self.num_items, "num_classes": self.num_classes,
                "num_goals": self.num_goals, "num_actions": self.num_actions, "nbest": self.nbest,
                "command": self.command, "p50_ms": self.p50_ms, "update_p50_ms": self.update_p50_ms,
                "posterior_p50_ms": self.posterior_p50_ms,
                "scaling": [{"goals": g, "p50_ms": t} for g, t in self.scaling], "threads": self.threads}


@dataclass(frozen=True)
class PlannerBench:
    """``siftom bench planner``: Q* values of the kitchen scenario and the median milliseconds of
    their table, A* nodes expanded (and per second) on household scenarios, one V*(s; g)'s time."""

    scenario: str
    num_goals: int
    num_actions: int
    q_values: int
    q_table_p50_ms: float
    v_per_second: float
    astar_nodes_expanded: int
    astar_nodes_per_second: float
    single_goal_value_ms: float

    def to_json(self) -> dict[str, Any]:
        """The ``--json`` form."""
        return dict(vars(self))


def _p50(fn: Callable[[], object], n: int) -> tuple[float, list[float]]:
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        ts.append((time.perf_counter() - t0) * 1000.0)
    return float(np.median(ts)), ts


def _random_goals(world: World, n: int, seed: int = 0) -> tuple[Goal, ...]:
    from siftom.world.model import Goal

    rng = np.random.default_rng(seed)
    classes = list(world.classes)
    out: list[Goal] = []
    seen: set[tuple[str, ...]] = set()
    while len(out) < n:
        k = int(rng.integers(3, 6))
        items = tuple(sorted(rng.choice(classes, size=k, replace=False).tolist()))
        if items in seen:
            continue
        seen.add(items)
        out.append(Goal(f"g{len(out)}", 0, tuple((c, 1) for c in items)))
    return tuple(out)


def run_inference_bench(repeats: int = 30) -> InferenceBench:
    """Time full inference, incremental updates and scaling with the number of goals."""
    from siftom.inference.model import Observation
    from siftom.memo import memo
    from siftom.observation import Instruction
    from siftom.observer import Observer
    from siftom.scenarios.base import get_scenario
    from siftom.settings import Settings

    sc = get_scenario("kitchen-cereal-v0")
    model = Observer(Settings.load(env={})).model("full", "phonetic")  # the model every door uses
    instr = Instruction.from_nbest(NBEST_SILVER)
    obs = Observation.from_scenario(sc, instr)
    post = model.infer(obs)  # warm-up: dictionaries, phrasing tables

    ctg = model.online(sc.world, sc.start, sc.goals, sc.verb).ctg

    def full() -> None:
        memo("phonetic.distances", 1).clear()  # a new instruction each time: no memoised distances
        memo("phonetic.heard", 1).clear()
        ctg.clear_state_cache()  # and no tables cached for these states
        model.infer(obs)

    p50, _ = _p50(full, repeats)

    # incremental: one more observed action on an inference that has seen the others
    def update_once() -> float:
        online = model.online(sc.world, sc.start, sc.goals, sc.verb)
        for a in sc.actions[:-1]:
            online.observe(a)
        t0 = time.perf_counter()
        online.observe(sc.actions[-1])
        return (time.perf_counter() - t0) * 1000.0

    upd = [update_once() for _ in range(repeats)]
    online = model.online(sc.world, sc.start, sc.goals, sc.verb)
    for a in sc.actions:
        online.observe(a)
    post_p50, _ = _p50(lambda: online.posterior(instr), repeats)

    scaling = []
    for n in (10, 100, 1000, 10000):
        goals = _random_goals(sc.world, n)
        goals = tuple(g for g in goals)
        o = Observation(sc.world, sc.start, sc.actions, goals, "fetch", instr)
        model.infer(o)
        reps = max(3, min(repeats, 3000 // n))
        t, _ = _p50(functools.partial(model.infer, o), reps)
        scaling.append((n, t))
    return InferenceBench(
        scenario=sc.id,
        num_items=len(sc.world.items),
        num_classes=len(sc.world.classes),
        num_goals=len(sc.goals),
        num_actions=len(sc.actions),
        nbest=len(NBEST_SILVER),
        command=post.command,
        p50_ms=p50,
        update_p50_ms=float(np.median(upd)),
        posterior_p50_ms=post_p50,
        scaling=tuple(scaling),
        threads=os.environ.get("OMP_NUM_THREADS", "default"),
    )


def run_planner_bench(repeats: int = 20) -> PlannerBench:
    """A* throughput and the time of the Q* table of a kitchen scenario (all goals x steps)."""
    from siftom.planning.astar import plan_for_goal
    from siftom.planning.costtogo import CostToGo, SparseGoals, goal_matrix, successor_values
    from siftom.scenarios.base import get_scenario
    from siftom.world.model import HUMAN, legal_actions

    sc = get_scenario("kitchen-cereal-v0")
    states = sc.states()
    N = goal_matrix(sc.world, sc.goals)
    sp = SparseGoals.from_dense(N)

    def table() -> int:
        ctg = CostToGo(sc.world, sc.target, int(N.max()))
        tabs = ctg.tables(states[0])
        n = 0
        for t, a in enumerate(sc.actions):
            s = states[t]
            acts = list(legal_actions(sc.world, s, HUMAN))
            Q = successor_values(ctg, s, tabs, acts, sp)
            n += Q.size
            from siftom.inference.model import _changed_classes

            tabs = ctg.retable(tabs, states[t + 1], _changed_classes(sc.world, s, a))
        return n

    n_q = table()
    q_p50, _ = _p50(table, repeats)
    # A*: household scenarios, human alone from the speaking state
    expanded, secs = 0, 0.0
    for i in range(6):
        hs = get_scenario(f"household-table-v0/{i}")
        res = plan_for_goal(hs.world, hs.now, hs.goal)
        expanded += res.nodes_expanded
        secs += res.seconds
    ctg = CostToGo(sc.world, sc.target, int(N.max()))
    return PlannerBench(
        scenario=sc.id,
        num_goals=len(sc.goals),
        num_actions=len(sc.actions),
        q_values=n_q,
        q_table_p50_ms=q_p50,
        v_per_second=n_q / (q_p50 / 1000.0),
        astar_nodes_expanded=expanded,
        astar_nodes_per_second=expanded / secs if secs else 0.0,
        single_goal_value_ms=_p50(lambda: ctg.value(sc.now, sc.goal), repeats)[0],
    )
