"""``kitchen-v0``: gather ingredients for a recipe (paper, Real-World Robot Experiment).

## Description
A kitchen and a storage room. 39 food items plus bowls, plates and cups sit on the kitchen
counter, in the fridge and cabinet, or on the storage shelves and in the storage fridge. The
human gathers a recipe's items on the kitchen counter and asks the robot for an item that is in
storage.

## Goal space
The recipe library in ``siftom/data/kitchen_recipes.json`` (>= 100 recipes, each a set of
items, one of each on the kitchen counter).

## Robot commands
``fetch(ITEM)``: bring one ``ITEM`` to the kitchen counter.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from functools import cache
from importlib import resources

import numpy as np

from siftom.agents.human import simulate_human
from siftom.world.commands import RobotCommand
from siftom.world.domains.base import Scenario
from siftom.world.model import NOTHING, Action, Goal, Item, Place, State, World

DOMAIN_ID = "kitchen-v0"
N_FIXED = 10

PLACES = (
    Place("kitchen_counter", "surface", "kitchen", (0.0, 0.0)),
    Place("fridge", "container", "kitchen", (-2.5, 1.5), closable=True),
    Place("kitchen_cabinet", "container", "kitchen", (2.0, 2.0), closable=True),
    Place("kitchen_shelf", "surface", "kitchen", (-2.0, -2.0)),
    Place("storage_counter", "surface", "storage", (10.5, -0.5)),
    Place("storage_shelf", "surface", "storage", (13.5, -2.5)),
    Place("storage_fridge", "container", "storage", (13.5, 2.0), closable=True),
)
DOORS = {frozenset({"kitchen", "storage"}): (6.0, 0.0)}
COLD = {"milk", "egg", "butter", "cheese", "ham", "yogurt", "orange_juice", "bacon", "chicken", "lettuce",
        "cucumber", "tomato", "dressing"}
_DIST = World.distances_from_positions(PLACES, DOORS)


@cache
def library() -> dict:
    """The recipe library (items and recipes) shipped with the package."""
    text = resources.files("siftom.data").joinpath("kitchen_recipes.json").read_text()
    return json.loads(text)


def goal_space(target: int = 0) -> tuple[Goal, ...]:
    return tuple(Goal(r["id"], target, tuple((c, 1) for c in sorted(r["items"]))) for r in library()["recipes"])


def _world(storage: set[str]) -> tuple[World, tuple[int, ...]]:
    lib = library()
    pidx = {p.name: i for i, p in enumerate(PLACES)}
    items, item_at = [], []
    for cls, info in sorted(lib["items"].items()):
        copies = 2 if info["kind"] == "dishware" else 1
        for k in range(copies):
            items.append(Item(f"{cls}_{k + 1}" if copies > 1 else cls, cls))
            if info["kind"] == "dishware":
                place = "kitchen_cabinet"
            elif cls in storage:
                place = "storage_fridge" if cls in COLD else ("storage_shelf" if len(cls) % 2 else "storage_counter")
            else:
                place = "fridge" if cls in COLD else ("kitchen_shelf" if len(cls) % 2 else "kitchen_cabinet")
            item_at.append(pidx[place])
    return World(PLACES, tuple(items), _DIST), tuple(item_at)


class Kitchen:
    """Scenario generator for ``kitchen-v0``."""

    id = DOMAIN_ID
    verb = "fetch"

    def generate(self, seed: int, sid: str | None = None) -> Scenario:
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

    def fixed(self) -> list[str]:
        return [f"{DOMAIN_ID}/{i}" for i in range(N_FIXED)] + ["kitchen-cereal-v0"]

    def scenarios(self) -> dict[str, Callable[[], Scenario]]:
        """The registered scenarios: the generated fixed ones and the Figure 2 story."""
        out: dict[str, Callable[[], Scenario]] = {
            f"{DOMAIN_ID}/{i}": (lambda i=i: self.generate(i, sid=f"{DOMAIN_ID}/{i}")) for i in range(N_FIXED)}
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
