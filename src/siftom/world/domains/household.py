"""``household-table-v0``: set the dining table in a four-room apartment (paper, Simulated Experiment).

## Description
A kitchen, a dining room, a living room and a bedroom, linked by doors. Plates, forks,
knives, spoons, wine glasses, water glasses, mugs and bowls are stored in cabinets, drawers,
the dishwasher and shelves across the rooms. The human sets the table; part way through, the
human asks the robot to bring all of one type of object.

## Goal space
``N`` of each of a subset of 2 or 3 object types on the dining table, the same ``N`` for every
type (N in 2..4), as in the paper: 252 goals per scenario.

## Robot commands
``deliver(TYPE,N)``: bring ``N`` objects of ``TYPE`` to the dining table.
"""

from __future__ import annotations

import itertools

from siftom.world.model import Goal, Place, World

DOMAIN_ID = "household-table-v0"
TYPES = ("plate", "fork", "knife", "spoon", "wineglass", "waterglass", "mug", "bowl")
N_FIXED = 26

PLACES = (
    Place("dining_table", "surface", "dining_room", (0.0, 0.0)),
    Place("dining_cabinet", "container", "dining_room", (-2.0, 2.0), closable=True),
    Place("kitchen_counter", "surface", "kitchen", (7.0, 2.0)),
    Place("kitchen_cabinet", "container", "kitchen", (9.0, 1.0), closable=True),
    Place("kitchen_drawer", "container", "kitchen", (6.0, 2.5), closable=True),
    Place("dishwasher", "container", "kitchen", (9.0, -1.0), closable=True),
    Place("kitchen_shelf", "surface", "kitchen", (5.5, -2.0)),
    Place("coffee_table", "surface", "living_room", (0.0, -7.0)),
    Place("living_shelf", "surface", "living_room", (-2.0, -8.5)),
    Place("living_cabinet", "container", "living_room", (2.0, -9.0), closable=True),
    Place("bedroom_shelf", "surface", "bedroom", (8.0, -9.0)),
    Place("bedroom_cabinet", "container", "bedroom", (9.0, -6.0), closable=True),
)
DOORS = {
    frozenset({"dining_room", "kitchen"}): (3.5, 0.0),
    frozenset({"dining_room", "living_room"}): (0.0, -3.5),
    frozenset({"living_room", "bedroom"}): (4.0, -7.5),
}
STORAGE = {
    "plate": ("kitchen_cabinet", "dishwasher", "dining_cabinet", "kitchen_shelf", "living_shelf"),
    "bowl": ("kitchen_cabinet", "dishwasher", "kitchen_shelf", "living_cabinet"),
    "fork": ("kitchen_drawer", "dishwasher", "dining_cabinet", "living_cabinet"),
    "knife": ("kitchen_drawer", "dishwasher", "dining_cabinet", "living_cabinet"),
    "spoon": ("kitchen_drawer", "dishwasher", "dining_cabinet", "living_cabinet"),
    "wineglass": ("dining_cabinet", "kitchen_shelf", "living_shelf", "bedroom_shelf"),
    "waterglass": ("kitchen_cabinet", "dishwasher", "living_shelf", "bedroom_cabinet"),
    "mug": ("kitchen_shelf", "kitchen_cabinet", "coffee_table", "bedroom_shelf"),
}
_DIST = World.distances_from_positions(PLACES, DOORS)


def goal_space(target: int = 0) -> tuple[Goal, ...]:
    """All subsets of 2-3 types, N in 2..4 of each, on the dining table."""
    goals = []
    for size in (2, 3):
        for combo in itertools.combinations(TYPES, size):
            for n in (2, 3, 4):
                goals.append(Goal(f"{n}x {'+'.join(combo)}", target, tuple((c, n) for c in combo)))
    return tuple(goals)
