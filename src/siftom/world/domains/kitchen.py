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
from functools import cache
from importlib import resources
from typing import TypedDict

from siftom.world.model import Goal, Item, Place, World

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


class ItemInfo(TypedDict):
    """One item class of the recipe library."""

    kind: str  # "food" or "dishware"
    spoken: str


class Recipe(TypedDict):
    """One recipe: its id, display name and the item classes it needs (one of each)."""

    id: str
    name: str
    items: list[str]


class RecipeLibrary(TypedDict):
    """``siftom/data/kitchen_recipes.json``."""

    version: int
    items: dict[str, ItemInfo]
    recipes: list[Recipe]


@cache
def library() -> RecipeLibrary:
    """The recipe library (items and recipes) shipped with the package."""
    text = resources.files("siftom.data").joinpath("kitchen_recipes.json").read_text()
    lib: RecipeLibrary = json.loads(text)
    return lib


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
