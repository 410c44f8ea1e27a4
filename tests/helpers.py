"""Small hand-built worlds shared by the tests."""

from __future__ import annotations

from typing import Any

import numpy as np

from siftom.world.model import NOTHING, Item, Place, State, World


def random_world(rng: np.random.Generator, n_places: int = 4, n_items: int = 4, n_classes: int = 2,
                 closable_p: float = 0.4) -> tuple[World, State]:
    """A random metric world: places on a grid in one room, integer walking costs."""
    places = []
    for i in range(n_places):
        closable = bool(rng.random() < closable_p) and i > 0
        places.append(Place(f"p{i}", "container" if closable else "surface", "room",
                            (float(rng.integers(0, 6)), float(rng.integers(0, 6))), closable))
    dist = World.distances_from_positions(places)
    classes = [chr(ord("a") + k) for k in range(n_classes)]
    items = [Item(f"{classes[i % n_classes]}_{i}", classes[i % n_classes]) for i in range(n_items)]
    world = World(tuple(places), tuple(items), dist)
    item_at = tuple(int(rng.integers(0, n_places)) for _ in items)
    open_mask = sum(1 << i for i, p in enumerate(places) if p.closable and rng.random() < 0.3)
    s = State((int(rng.integers(0, n_places)), 0), (NOTHING, NOTHING), item_at, open_mask)
    return world, s


def three_room_house() -> tuple[World, State]:
    """Kitchen with a drawer (closed) and counter, dining room with the table, a pantry shelf."""
    places = (
        Place("table", "surface", "dining", (0.0, 0.0)),
        Place("counter", "surface", "kitchen", (4.0, 0.0)),
        Place("drawer", "container", "kitchen", (5.0, 1.0), closable=True),
        Place("shelf", "surface", "pantry", (9.0, 0.0)),
    )
    doors = {frozenset({"dining", "kitchen"}): (2.0, 0.0), frozenset({"kitchen", "pantry"}): (7.0, 0.0)}
    dist = World.distances_from_positions(places, doors)
    items = (Item("fork_1", "fork"), Item("fork_2", "fork"), Item("plate_1", "plate"), Item("cup_1", "cup"))
    world = World(places, items, dist)
    s = State((1, 0), (NOTHING, NOTHING), (2, 2, 1, 3), 0)
    return world, s


def model_for(mode: str = "full", likelihood: Any = "phonetic") -> Any:
    """The model for ``mode`` and ``likelihood`` (a name or an object), built by the observer every
    door uses (default settings, not the ``SIFTOM_*`` environment)."""
    from siftom.observer import observer_for
    from siftom.settings import Settings

    return observer_for(Settings.load(env={})).model(mode, likelihood)


def phonetic_model() -> Any:
    """The default model with the phonetic likelihood (:func:`model_for`)."""
    return model_for("full", "phonetic")
