"""Scenario generation for ``kitchen`` (the world and goal library: siftom.world.domains.kitchen)."""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from siftom.agents.human import simulate_human
from siftom.scenarios.base import Scenario, is_world_seed
from siftom.world.commands import RobotCommand
from siftom.world.domains.kitchen import (
    COLD,
    DOMAIN_ID,
    N_FIXED,
    PLACES,
    _world,
    goal_space,
    library,
)
from siftom.world.model import NOTHING, Action, State


class Kitchen:
    """Scenario generator for ``kitchen-v0``."""

    id = DOMAIN_ID
    verb = "fetch"

    def generate(self, seed: int, sid: str | None = None) -> Scenario:
        """A random scenario; the same seed gives the same scenario.

        Seeds drawn by ``--world-seed`` (``is_world_seed``) use :meth:`generate_wide`; the
        others keep this generator bit for bit (the registered scenarios and tuned results).
        """
        if is_world_seed(seed):
            return self.generate_wide(seed, sid)
        rng = np.random.default_rng([7002, seed])
        foods = sorted(c for c, v in library()["items"].items() if v["kind"] == "food")
        storage = {f for f in foods if rng.random() < 0.5}
        world, item_at = _world(storage)
        goals = goal_space(0)
        candidates = [g for g, goal in enumerate(goals) if any(c in storage for c, _ in goal.counts)]
        true = int(candidates[int(rng.integers(len(candidates)))])
        goal = goals[true]
        in_storage = [c for c, _ in goal.counts if c in storage]
        cls = in_storage[int(rng.integers(len(in_storage)))]
        start = State((0, 4), (NOTHING, NOTHING), item_at, 0)
        # enough actions to gather the kitchen part; fewer when that part is small
        k = int(rng.integers(4, 11))
        traj = simulate_human(world, start, goal.minus(cls, 1), k, beta=3.0, seed=rng)
        return Scenario(
            id=sid or f"{DOMAIN_ID}/seed{seed}", domain=DOMAIN_ID, world=world, start=start, goals=goals,
            true_goal=true, command=RobotCommand("fetch", cls, 1), actions=traj.actions, verb="fetch",
            description=f"make {goal.name.replace('_', ' ')}; the human asks the robot for the {cls.replace('_', ' ')}",
            meta={"seed": seed},
        )

    def generate_wide(self, seed: int, sid: str | None = None) -> Scenario:
        """The wider generator of ``--world-seed`` worlds; the same seed gives the same scenario.

        Beyond :meth:`generate`: the share of foods in storage varies (30-70 %), each food sits
        in a random place of the right kind in its room (cold ones in that room's fridge, the
        others on the shelf or in the cabinet / on the counter, not by the length of their
        name), dishes are split between the kitchen cabinet and shelf, the fridge and cabinet
        may start open, the human starts anywhere in the kitchen and the robot anywhere, and
        the human has acted 2-12 steps (not 4-10).
        """
        rng = np.random.default_rng([7002, 1, seed])
        lib = library()
        foods = sorted(c for c, v in lib["items"].items() if v["kind"] == "food")
        p_storage = float(rng.uniform(0.3, 0.7))
        storage = {f for f in foods if rng.random() < p_storage}
        world, _ = _world(storage)
        pidx = {p.name: i for i, p in enumerate(PLACES)}
        spots = {  # (kind, in storage, cold) -> places
            ("dishware", False, False): ("kitchen_cabinet", "kitchen_shelf"),
            ("food", False, True): ("fridge",), ("food", True, True): ("storage_fridge",),
            ("food", False, False): ("kitchen_cabinet", "kitchen_shelf"),
            ("food", True, False): ("storage_shelf", "storage_counter"),
        }
        item_at = []
        for it in world.items:
            kind = lib["items"][it.cls]["kind"]
            options = spots[(kind, it.cls in storage, kind == "food" and it.cls in COLD)]
            item_at.append(pidx[options[int(rng.integers(len(options)))]])
        goals = goal_space(0)
        candidates = [g for g, goal in enumerate(goals) if any(c in storage for c, _ in goal.counts)]
        true = int(candidates[int(rng.integers(len(candidates)))])
        goal = goals[true]
        in_storage = [c for c, _ in goal.counts if c in storage]
        cls = in_storage[int(rng.integers(len(in_storage)))]
        open_mask = 0
        for name in ("fridge", "kitchen_cabinet"):
            if rng.random() < 0.25:
                open_mask |= 1 << pidx[name]
        kitchen = [i for i, p in enumerate(PLACES) if p.room == "kitchen"]
        agents = (kitchen[int(rng.integers(len(kitchen)))], int(rng.integers(len(PLACES))))
        start = State(agents, (NOTHING, NOTHING), tuple(item_at), open_mask)
        k = int(rng.integers(2, 13))
        traj = simulate_human(world, start, goal.minus(cls, 1), k, beta=3.0, seed=rng)
        return Scenario(
            id=sid or f"{DOMAIN_ID}/seed{seed}", domain=DOMAIN_ID, world=world, start=start, goals=goals,
            true_goal=true, command=RobotCommand("fetch", cls, 1), actions=traj.actions, verb="fetch",
            description=f"make {goal.name.replace('_', ' ')}; the human asks the robot for the {cls.replace('_', ' ')}",
            meta={"seed": seed, "generator": "wide"},
        )

    def fixed(self) -> list[str]:
        return [f"{DOMAIN_ID}/{i}" for i in range(N_FIXED)] + ["kitchen-cereal-v0"]

    def scenarios(self) -> dict[str, Callable[[], Scenario]]:
        """The registered scenarios: the generated fixed ones and the Figure 2 story."""
        out: dict[str, Callable[[], Scenario]] = {
            f"{DOMAIN_ID}/{i}": functools.partial(self.generate, i, sid=f"{DOMAIN_ID}/{i}") for i in range(N_FIXED)}
        out["kitchen-cereal-v0"] = kitchen_cereal
        return out


def kitchen_cereal() -> Scenario:
    """The paper's Figure 2 story: milk and a bowl taken; cereal, sugar, oatmeal in storage."""
    storage = {"cereal", "sugar", "oatmeal", "honey", "chocolate", "banana", "flour", "coffee", "tea", "syrup",
               "jam", "rice", "salt", "bread", "pasta", "tortilla", "apple", "yogurt", "orange_juice"}
    world, item_at = _world(storage)
    goals = goal_space(0)
    true = [g.name for g in goals].index("breakfast_cereal")
    start = State((0, 4), (NOTHING, NOTHING), item_at, 0)
    p, i = world.place, world.item
    H = 0
    acts = (
        Action("walk", H, place=p("fridge")), Action("open", H, place=p("fridge")),
        Action("grab", H, obj=i("milk"), place=p("fridge")), Action("walk", H, place=p("kitchen_counter")),
        Action("put", H, obj=i("milk"), place=p("kitchen_counter")), Action("walk", H, place=p("kitchen_cabinet")),
        Action("open", H, place=p("kitchen_cabinet")), Action("grab", H, obj=i("bowl_1"), place=p("kitchen_cabinet")),
        Action("walk", H, place=p("kitchen_counter")), Action("put", H, obj=i("bowl_1"), place=p("kitchen_counter")),
    )
    return Scenario(
        id="kitchen-cereal-v0", domain=DOMAIN_ID, world=world, start=start, goals=goals, true_goal=true,
        command=RobotCommand("fetch", "cereal", 1), actions=acts, verb="fetch",
        description="the human has taken milk and a bowl; cereal, sugar and oatmeal are in storage",
    )
