"""Scenario generation for ``household`` (the world and goal library: siftom.world.domains.household)."""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from siftom.agents.human import simulate_human
from siftom.scenarios.base import Scenario, is_world_seed
from siftom.world.commands import RobotCommand
from siftom.world.domains.household import (
    _DIST,
    DOMAIN_ID,
    N_FIXED,
    PLACES,
    STORAGE,
    TYPES,
    goal_space,
)
from siftom.world.model import NOTHING, Item, State, World


class Household:
    """Scenario generator for ``household-table-v0``."""

    id = DOMAIN_ID
    verb = "deliver"

    def generate(self, seed: int, sid: str | None = None) -> Scenario:
        """A random scenario; the same seed gives the same scenario.

        Seeds drawn by ``--world-seed`` (``is_world_seed``) use :meth:`generate_wide`; the
        others keep this generator bit for bit (the registered scenarios and tuned results).
        """
        if is_world_seed(seed):
            return self.generate_wide(seed, sid)
        rng = np.random.default_rng([7001, seed])
        pidx = {p.name: i for i, p in enumerate(PLACES)}
        items, item_at = [], []
        for t in TYPES:
            n = int(rng.integers(4, 7))
            spots = rng.choice(len(STORAGE[t]), size=2, replace=False)
            for k in range(n):
                items.append(Item(f"{t}_{k + 1}", t))
                item_at.append(pidx[STORAGE[t][int(spots[k % 2 if rng.random() < 0.8 else 0])]])
        world = World(PLACES, tuple(items), _DIST)
        goals = goal_space(pidx["dining_table"])
        true = int(rng.integers(len(goals)))
        goal = goals[true]
        # the robot is asked for the type the human is least likely to fetch first: a random one
        cls, n = goal.counts[int(rng.integers(len(goal.counts)))]
        open_mask = (1 << pidx["dishwasher"]) if rng.random() < 0.3 else 0
        start_places = ("kitchen_counter", "dining_table", "coffee_table", "kitchen_shelf")
        start = State((pidx[start_places[int(rng.integers(len(start_places)))]], pidx["coffee_table"]),
                      (NOTHING, NOTHING), tuple(item_at), open_mask)
        k = int(rng.integers(6, 13))
        traj = simulate_human(world, start, goal.minus(cls, n), k, beta=3.0, seed=rng)
        return Scenario(
            id=sid or f"{DOMAIN_ID}/seed{seed}", domain=DOMAIN_ID, world=world, start=start,
            goals=goals, true_goal=true, command=RobotCommand("deliver", cls, n), actions=traj.actions,
            verb="deliver",
            description=f"set the table with {goal.describe()}; the human asks the robot for the {_plural(cls)}",
            meta={"seed": seed},
        )

    def generate_wide(self, seed: int, sid: str | None = None) -> Scenario:
        """The wider generator of ``--world-seed`` worlds; the same seed gives the same scenario.

        Beyond :meth:`generate`: each type is spread over 1-3 of its storage spots with random
        shares (not 2 spots at 80/20), every closable container may start open, the human and
        the robot start anywhere, and the human has acted 3-15 steps (not 6-12).
        """
        rng = np.random.default_rng([7001, 1, seed])
        pidx = {p.name: i for i, p in enumerate(PLACES)}
        items, item_at = [], []
        for t in TYPES:
            n = int(rng.integers(4, 7))  # goals need up to 4 of a type
            m = int(rng.integers(1, 4))
            spots = rng.choice(len(STORAGE[t]), size=m, replace=False)
            share = rng.dirichlet(np.ones(m))
            for k in range(n):
                items.append(Item(f"{t}_{k + 1}", t))
                item_at.append(pidx[STORAGE[t][int(spots[int(rng.choice(m, p=share))])]])
        world = World(PLACES, tuple(items), _DIST)
        goals = goal_space(pidx["dining_table"])
        true = int(rng.integers(len(goals)))
        goal = goals[true]
        cls, n = goal.counts[int(rng.integers(len(goal.counts)))]
        open_mask = 0
        for i, p in enumerate(PLACES):
            if p.closable and rng.random() < 0.25:
                open_mask |= 1 << i
        agents = (int(rng.integers(len(PLACES))), int(rng.integers(len(PLACES))))
        start = State(agents, (NOTHING, NOTHING), tuple(item_at), open_mask)
        k = int(rng.integers(3, 16))
        traj = simulate_human(world, start, goal.minus(cls, n), k, beta=3.0, seed=rng)
        return Scenario(
            id=sid or f"{DOMAIN_ID}/seed{seed}", domain=DOMAIN_ID, world=world, start=start,
            goals=goals, true_goal=true, command=RobotCommand("deliver", cls, n), actions=traj.actions,
            verb="deliver",
            description=f"set the table with {goal.describe()}; the human asks the robot for the {_plural(cls)}",
            meta={"seed": seed, "generator": "wide"},
        )

    def fixed(self) -> list[str]:
        return [f"{DOMAIN_ID}/{i}" for i in range(N_FIXED)]

    def scenarios(self) -> dict[str, Callable[[], Scenario]]:
        """The registered scenarios: the fixed ones, by id."""
        return {sid: functools.partial(self.generate, i, sid=sid) for i, sid in enumerate(self.fixed())}


def _plural(noun: str) -> str:
    """English plural of an object class: bowls, waterglasses, knives."""
    if noun.endswith("fe"):
        return noun[:-2] + "ves"
    return noun + ("es" if noun.endswith(("s", "sh", "ch", "x")) else "s")
