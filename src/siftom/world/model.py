"""Symbolic fetch-and-place worlds: static layout, immutable states, actions, one transition.

A :class:`World` is the static part of a scene (places, walking costs, objects and their
classes). A :class:`State` is the dynamic part (where each agent stands, what it holds, where
each object is, which containers are open); it is immutable and hashable. :func:`transition`
is the single pure transition function shared by the planner, the simulated human, the
robot executor and the likelihoods.

Cost model (docs/world.md): walking from place ``p`` to ``q`` costs ``world.dist[p, q]``
integer steps (>= 1 between distinct places); every other action costs 1.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from siftom.errors import IllegalActionError, ObservationError
from siftom.world.distances import STEP_METRES as STEP_METRES
from siftom.world.distances import walking_costs

HUMAN, ROBOT = 0, 1
AGENT_NAMES = ("human", "robot")
NOTHING = -1
HELD = -1  # item location when carried by an agent
KINDS = ("walk", "open", "close", "grab", "put", "handover")
PLACE_KINDS = ("room", "surface", "container")


@dataclass(frozen=True, slots=True)
class Place:
    """A place an agent can stand at: a piece of furniture (surface or container) or a room."""

    name: str
    kind: str
    room: str
    pos: tuple[float, float] = (0.0, 0.0)
    closable: bool = False
    node_id: int | None = None

    def __post_init__(self) -> None:
        if self.kind not in PLACE_KINDS:
            raise ObservationError(f"place {self.name!r}: kind must be one of {PLACE_KINDS}, got {self.kind!r}")


@dataclass(frozen=True, slots=True)
class Item:
    """A grabbable object of a class (e.g. ``fork``)."""

    name: str
    cls: str
    node_id: int | None = None


@dataclass(frozen=True, slots=True)
class State:
    """The dynamic state. Immutable and hashable.

    Attributes:
        agent_at: place index of each agent (human, robot).
        held: item index each agent holds, or NOTHING (capacity one item per agent).
        item_at: place index of each item, or HELD when an agent carries it.
        open_mask: bit ``i`` set when place ``i`` (a closable container) is open.
    """

    agent_at: tuple[int, ...]
    held: tuple[int, ...]
    item_at: tuple[int, ...]
    open_mask: int

    def is_open(self, place: int) -> bool:
        return bool(self.open_mask >> place & 1)


@dataclass(frozen=True, slots=True, order=True)
class Action:
    """An action of one agent. ``obj`` is an item index, ``place`` a place index.

    walk(place), open(place), close(place), grab(obj), put(obj, place), handover(obj, to agent).
    """

    kind: str
    agent: int
    obj: int = NOTHING
    place: int = NOTHING
    to_agent: int = NOTHING


@dataclass(frozen=True)
class Goal:
    """At least ``counts[c]`` objects of class ``c`` on place ``target`` (fetch-and-place goal)."""

    name: str
    target: int
    counts: tuple[tuple[str, int], ...]

    @cached_property
    def count_map(self) -> dict[str, int]:
        return dict(self.counts)

    def satisfied(self, world: World, state: State) -> bool:
        return all(world.count_at(state, self.target, c) >= n for c, n in self.counts)

    def minus(self, cls: str, n: int) -> Goal:
        """The goal left when someone else brings ``n`` objects of ``cls``."""
        counts = tuple((c, k - n if c == cls else k) for c, k in self.counts)
        return Goal(self.name, self.target, tuple((c, k) for c, k in counts if k > 0))

    def describe(self) -> str:
        return ", ".join(f"{n} {c}" for c, n in self.counts) or "nothing"


@dataclass(frozen=True, eq=False)
class World:
    """Static layout: places, integer walking costs between them, and objects."""

    places: tuple[Place, ...]
    items: tuple[Item, ...]
    dist: np.ndarray = field(repr=False)
    left_out: dict[int, str] = field(default_factory=dict, repr=False)  # graph node id -> why it is not here
    # the world's own spoken names of its object classes, preferred first: (("coffee", ("iced coffee",
    # "ice coffee")), ...); they add to the built-in lexicon (siftom.likelihood.lexicon.lexicon_for)
    names: tuple[tuple[str, tuple[str, ...]], ...] = field(default=(), repr=False)

    def __post_init__(self) -> None:
        n = len(self.places)
        if n == 0:
            raise ObservationError("a world needs at least one place")
        if n > 62:
            raise ObservationError(f"at most 62 places are supported (open_mask is an int64 bitmask); got {n}")
        d = np.asarray(self.dist)
        if d.shape != (n, n):
            raise ObservationError(f"dist must be {n}x{n}, got {d.shape}")
        names = [p.name for p in self.places]
        if len(set(names)) != n:
            dup = sorted({x for x in names if names.count(x) > 1})
            raise ObservationError(f"duplicate place names {dup}; give each place a unique name")
        inames = [i.name for i in self.items]
        if len(set(inames)) != len(inames):
            dup = sorted({x for x in inames if inames.count(x) > 1})
            raise ObservationError(f"duplicate item names {dup}; give each item a unique name")
        d = d.astype(np.int64)
        d.setflags(write=False)
        object.__setattr__(self, "dist", d)

    # ----- lookups -------------------------------------------------------------------------
    @cached_property
    def place_index(self) -> dict[str, int]:
        return {p.name: i for i, p in enumerate(self.places)}

    @cached_property
    def item_index(self) -> dict[str, int]:
        return {it.name: i for i, it in enumerate(self.items)}

    @cached_property
    def classes(self) -> tuple[str, ...]:
        return tuple(sorted({it.cls for it in self.items}))

    @cached_property
    def item_class_idx(self) -> np.ndarray:
        idx = {c: k for k, c in enumerate(self.classes)}
        return np.array([idx[it.cls] for it in self.items], dtype=np.int64)

    @cached_property
    def closable_mask(self) -> int:
        return sum(1 << i for i, p in enumerate(self.places) if p.closable)

    def place(self, name: str) -> int:
        try:
            return self.place_index[name]
        except KeyError:
            from siftom.errors import unknown_name

            raise unknown_name("place", name, self.place_index) from None

    def item(self, name: str) -> int:
        try:
            return self.item_index[name]
        except KeyError:
            from siftom.errors import unknown_name

            raise unknown_name("object", name, self.item_index) from None

    def count_at(self, state: State, place: int, cls: str) -> int:
        return sum(1 for i, loc in enumerate(state.item_at) if loc == place and self.items[i].cls == cls)

    def items_at(self, state: State, place: int) -> list[int]:
        return [i for i, loc in enumerate(state.item_at) if loc == place]

    # ----- construction helpers ------------------------------------------------------------
    @staticmethod
    def distances_from_positions(
        places: Sequence[Place], doors: Mapping[frozenset[str], tuple[float, float]] | None = None,
        step: float = STEP_METRES,
    ) -> np.ndarray:
        """Integer walking costs: Euclidean within a room, shortest path through doors across rooms.

        Cost is ``max(1, ceil(metres / step))`` between distinct places. Rooms not linked by a
        door chain are linked directly through their centres (documented default).
        """
        return walking_costs(places, doors, step)

    # ----- formatting ----------------------------------------------------------------------
    def format_action(self, a: Action) -> str:
        """``Predicate(agent, object, location)`` form, e.g. ``grab(human, fork_1, drawer_1)``."""
        ag = AGENT_NAMES[a.agent]
        if a.kind in ("walk", "open", "close"):
            return f"{a.kind}({ag}, {self.places[a.place].name})"
        if a.kind == "grab":
            if a.place == NOTHING:
                return f"grab({ag}, {self.items[a.obj].name})"
            return f"grab({ag}, {self.items[a.obj].name}, {self.places[a.place].name})"
        if a.kind == "put":
            return f"put({ag}, {self.items[a.obj].name}, {self.places[a.place].name})"
        return f"handover({ag}, {self.items[a.obj].name}, {AGENT_NAMES[a.to_agent]})"

    def parse_action(self, text: str, state: State | None = None) -> Action:
        """Parse the ``Predicate(agent, object, location)`` form written by :meth:`format_action`."""
        import re

        m = re.match(r"^\s*(\w+)\s*\((.*)\)\s*$", text or "")
        if not m:
            raise ObservationError(
                f"cannot parse action {text!r}; write e.g. walk(human, kitchencounter), "
                "grab(human, milk_1, fridge), put(human, milk_1, kitchencounter)"
            )
        kind = m.group(1).lower()
        args = [a.strip() for a in m.group(2).split(",") if a.strip()]
        aliases = {"place": "put", "pick": "grab", "pickup": "grab", "walktowards": "walk", "give": "handover"}
        kind = aliases.get(kind, kind)
        if kind not in KINDS:
            raise ObservationError(f"unknown action {kind!r} in {text!r}; valid: {', '.join(KINDS)}")
        if not args or args[0] not in AGENT_NAMES:
            raise ObservationError(f"{text!r}: first argument must be an agent ({', '.join(AGENT_NAMES)})")
        agent = AGENT_NAMES.index(args[0])
        need = {"walk": 2, "open": 2, "close": 2, "grab": 2, "put": 3, "handover": 3}[kind]
        if len(args) < need:
            raise ObservationError(f"{text!r}: {kind} takes {need} arguments")
        if kind in ("walk", "open", "close"):
            return Action(kind, agent, place=self.place(args[1]))
        obj = self.item(args[1])
        if kind == "grab":
            place = self.place(args[2]) if len(args) > 2 else (state.item_at[obj] if state else NOTHING)
            return Action("grab", agent, obj=obj, place=place)
        if kind == "put":
            return Action("put", agent, obj=obj, place=self.place(args[2]))
        if args[2] not in AGENT_NAMES:
            raise ObservationError(f"{text!r}: handover goes to an agent ({', '.join(AGENT_NAMES)})")
        return Action("handover", agent, obj=obj, to_agent=AGENT_NAMES.index(args[2]))


# ----- dynamics ------------------------------------------------------------------------------
def check(world: World, s: State, a: Action) -> str | None:
    """Return why ``a`` is illegal in ``s``, or None when it is legal."""
    if a.kind not in KINDS:
        return f"unknown action kind {a.kind!r}"
    if not 0 <= a.agent < len(s.agent_at):
        return f"no agent {a.agent}"
    here = s.agent_at[a.agent]
    n_places, n_items = len(world.places), len(world.items)
    if a.kind == "walk":
        if not 0 <= a.place < n_places:
            return f"no place {a.place}"
        if a.place == here:
            return f"{AGENT_NAMES[a.agent]} is already at {world.places[a.place].name}"
        return None
    if a.kind in ("open", "close"):
        if not 0 <= a.place < n_places:
            return f"no place {a.place}"
        p = world.places[a.place]
        if not p.closable:
            return f"{p.name} cannot be opened or closed"
        if a.place != here:
            return f"{AGENT_NAMES[a.agent]} must walk to {p.name} first"
        if (a.kind == "open") == s.is_open(a.place):
            return f"{p.name} is already {'open' if a.kind == 'open' else 'closed'}"
        return None
    if not 0 <= a.obj < n_items:
        return f"no object {a.obj}"
    name = world.items[a.obj].name
    if a.kind == "grab":
        if s.held[a.agent] != NOTHING:
            return f"{AGENT_NAMES[a.agent]}'s hands are full (holds {world.items[s.held[a.agent]].name})"
        loc = s.item_at[a.obj]
        if loc == HELD:
            return f"{name} is being carried"
        if loc != here:
            return f"{name} is at {world.places[loc].name}, not where {AGENT_NAMES[a.agent]} stands"
        if a.place not in (NOTHING, loc):
            return f"{name} is not at {world.places[a.place].name}"
        if world.places[loc].closable and not s.is_open(loc):
            return f"{world.places[loc].name} is closed; open it first"
        return None
    if a.kind == "put":
        if s.held[a.agent] != a.obj:
            return f"{AGENT_NAMES[a.agent]} does not hold {name}"
        if a.place != here:
            return f"{AGENT_NAMES[a.agent]} must walk to {world.places[a.place].name if 0 <= a.place < n_places else a.place} first"
        p = world.places[a.place]
        if p.kind == "room":
            return f"cannot put {name} in a room; put it on a surface or in a container"
        if p.closable and not s.is_open(a.place):
            return f"{p.name} is closed; open it first"
        return None
    # handover
    if s.held[a.agent] != a.obj:
        return f"{AGENT_NAMES[a.agent]} does not hold {name}"
    if not 0 <= a.to_agent < len(s.agent_at) or a.to_agent == a.agent:
        return "handover needs the other agent"
    if s.agent_at[a.to_agent] != here:
        return f"{AGENT_NAMES[a.to_agent]} is not at the same place"
    if s.held[a.to_agent] != NOTHING:
        return f"{AGENT_NAMES[a.to_agent]}'s hands are full"
    return None


def cost(world: World, s: State, a: Action) -> int:
    """Duration of ``a`` in steps: walking distance for walk, 1 otherwise."""
    if a.kind == "walk":
        return int(world.dist[s.agent_at[a.agent], a.place])
    return 1


def apply(s: State, a: Action) -> State:
    """Apply a legal action without checking it (the planner's inner loop)."""
    k = a.kind
    if k == "walk":
        at = list(s.agent_at)
        at[a.agent] = a.place
        return State(tuple(at), s.held, s.item_at, s.open_mask)
    if k == "open":
        return State(s.agent_at, s.held, s.item_at, s.open_mask | (1 << a.place))
    if k == "close":
        return State(s.agent_at, s.held, s.item_at, s.open_mask & ~(1 << a.place))
    held = list(s.held)
    item_at = list(s.item_at)
    if k == "grab":
        held[a.agent] = a.obj
        item_at[a.obj] = HELD
    elif k == "put":
        held[a.agent] = NOTHING
        item_at[a.obj] = a.place
    else:  # handover
        held[a.agent] = NOTHING
        held[a.to_agent] = a.obj
    return State(s.agent_at, tuple(held), tuple(item_at), s.open_mask)


def transition(world: World, s: State, a: Action) -> tuple[State, int]:
    """The pure transition function: return (next state, cost) or raise IllegalActionError."""
    why = check(world, s, a)
    if why is not None:
        raise IllegalActionError(f"{_fmt(world, a)} is illegal: {why}")
    return apply(s, a), cost(world, s, a)


def _fmt(world: World, a: Action) -> str:
    try:
        return world.format_action(a)
    except (IndexError, TypeError):
        return repr(a)


def legal_actions(world: World, s: State, agent: int = HUMAN) -> Iterator[Action]:
    """All legal actions of ``agent`` in ``s`` (walks to every other place included)."""
    here = s.agent_at[agent]
    held = s.held[agent]
    for p in range(len(world.places)):
        if p != here:
            yield Action("walk", agent, place=p)
    pl = world.places[here]
    is_open = (not pl.closable) or s.is_open(here)
    if pl.closable:
        yield Action("close" if s.is_open(here) else "open", agent, place=here)
    if held == NOTHING:
        if is_open:
            for i, loc in enumerate(s.item_at):
                if loc == here:
                    yield Action("grab", agent, obj=i, place=here)
    else:
        if is_open and pl.kind != "room":
            yield Action("put", agent, obj=held, place=here)
        other = 1 - agent
        if other < len(s.agent_at) and s.agent_at[other] == here and s.held[other] == NOTHING:
            yield Action("handover", agent, obj=held, to_agent=other)
