"""The fast cost-to-go against A* on the built-in scenarios of both domains.

Run: python recipes/costtogo_scenarios.py [--goals now|all|none] [--json OUT]

States: every state an observed action sequence of a built-in scenario visits (``sc.states()``,
start to the moment the human speaks), seen by either agent (the human and the robot plan from
their own places; the other agent's object in hand is out of play). Goals:

* single objects: for every class with objects off the target and every count n up to what is
  available, "n more of the class on the target" (the robot's commands; also the human's);
* goals: the scenario's goal space, for the human (``--goals now``: at the state when the human
  speaks, the default; ``all``: at every state; household goals take ~0.15 s of A* each).

A* is ``plan_for_goal`` with the admissible heuristic (optimal; tests/planning compare it with
uniform-cost search). Prints the counts of ``fast - A*`` per domain and kind, and the first few
states that differ, described.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter, defaultdict

import numpy as np

from siftom.planning.astar import plan_for_goal
from siftom.planning.costtogo import CostToGo
from siftom.scenarios.base import get_scenario, scenario_domain, scenario_ids
from siftom.world.model import AGENT_NAMES, HELD, HUMAN, ROBOT, Goal, State


def single_goals(world, s: State, target: int, agent: int) -> list[Goal]:
    out = []
    for c in world.classes:
        on_t = world.count_at(s, target, c)
        held = int(s.held[agent] >= 0 and world.items[s.held[agent]].cls == c)  # the other's is out of play
        free = sum(1 for i, loc in enumerate(s.item_at)
                   if loc not in (HELD, target) and world.items[i].cls == c)
        for n in range(1, free + held + 1):
            out.append(Goal(f"{c}+{n}", target, ((c, on_t + n),)))
    return out


def describe(world, s: State, agent: int, goal: Goal) -> str:
    """Where the agent stands, what it holds, and where the goal's objects are (closed: *)."""
    at = world.places[s.agent_at[agent]].name
    held = world.items[s.held[agent]].name if s.held[agent] >= 0 else "-"
    locs = []
    for c, n in goal.counts:
        spots = [world.places[loc].name + ("*" if world.places[loc].closable and not s.is_open(loc) else "")
                 for i, loc in enumerate(s.item_at) if world.items[i].cls == c and loc >= 0]
        locs.append(f"{c}x{n}: {', '.join(sorted(spots))}")
    return f"{AGENT_NAMES[agent]} at {at} holding {held}; " + "; ".join(locs)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--goals", choices=("now", "all", "none"), default="now")
    ap.add_argument("--scenarios", default="", help="comma-separated ids (default: every built-in one)")
    ap.add_argument("--json", default=None, help="write every differing case here")
    ap.add_argument("--goal-stride", type=int, default=1, help="every n-th goal of the goal space")
    ap.add_argument("--show", type=int, default=8)
    ap.add_argument("--reference", default=None,
                    help="a --json file written with --all: reuse its A* costs (compare another cost-to-go fast)")
    ap.add_argument("--all", action="store_true", help="--json keeps every case's A* cost, not only the differing")
    a = ap.parse_args()
    ids = a.scenarios.split(",") if a.scenarios else scenario_ids()
    diffs: dict[tuple[str, str], Counter] = defaultdict(Counter)
    cases = []
    seen: set = set()
    t0 = time.perf_counter()
    ctgs: dict = {}
    known = {}
    if a.reference:
        with open(a.reference) as f:
            known = {(r["scenario"], r["step"], r["agent"], r["goal"]): r["astar"] for r in json.load(f)["all"]}
    every = []
    for sid in ids:
        sc = get_scenario(sid)
        dom = scenario_domain(sid)
        world, target = sc.world, sc.target
        states = sc.states()
        for k, s in enumerate(states):
            jobs = [(agent, "single", g) for agent in (HUMAN, ROBOT) for g in single_goals(world, s, target, agent)]
            if a.goals == "all" or (a.goals == "now" and k == len(states) - 1):
                jobs += [(HUMAN, "goal", g) for g in sc.goals[::a.goal_stride]]
            for agent, kind, goal in jobs:
                key = (id(world), s.agent_at[agent], s.held[agent], s.item_at, s.open_mask, agent, goal.counts)
                if key in seen:
                    continue
                seen.add(key)
                kmax = max(n for _c, n in goal.counts)
                ck = (id(world), target, max(kmax, 8), agent)
                if ck not in ctgs:
                    ctgs[ck] = CostToGo(world, target, max(kmax, 8), agent=agent)
                fast = ctgs[ck].value(s, goal)
                rk = (sid, k, AGENT_NAMES[agent], goal.describe())
                if rk in known:
                    ref_cost = known[rk]
                else:
                    ref = plan_for_goal(world, s, goal, agent=agent, max_nodes=400_000, max_time=60.0)
                    if not ref.solved:
                        diffs[(dom, kind)]["unsolved"] += 1
                        continue
                    ref_cost = ref.cost
                every.append({"scenario": sid, "step": k, "agent": AGENT_NAMES[agent], "goal": goal.describe(),
                              "astar": ref_cost})
                d = fast - ref_cost
                diffs[(dom, kind)][f"{d:+g}"] += 1
                if d != 0:
                    cases.append({"scenario": sid, "step": k, "agent": AGENT_NAMES[agent], "kind": kind,
                                  "goal": goal.describe(), "fast": fast, "astar": ref_cost,
                                  "where": describe(world, s, agent, goal)})
    print(f"{len(seen)} (state, agent, goal) cases from {len(ids)} scenarios in {time.perf_counter() - t0:.0f} s")
    for (dom, kind), cnt in sorted(diffs.items()):
        tot = sum(cnt.values())
        parts = ", ".join(f"{d}: {n} ({100 * n / tot:.2f} %)" for d, n in sorted(cnt.items()))
        print(f"  {dom:20s} {kind:6s} {tot:6d}  fast - A* = {parts}")
    for c in cases[: a.show]:
        print(f"- {c['scenario']} step {c['step']} {c['kind']} {c['goal']}: fast {c['fast']:g}, A* {c['astar']:g}"
              f"\n    {c['where']}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"counts": {f"{d}/{k}": dict(v) for (d, k), v in diffs.items()}, "cases": cases,
                       "all": every if a.all else []}, f, indent=1)
    print("differing cases:", len(cases), "by sign:", dict(Counter(np.sign([c["fast"] - c["astar"] for c in cases]))))


if __name__ == "__main__":
    main()
