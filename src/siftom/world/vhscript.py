"""Observed actions in either format: siftom's own or VirtualHome's script lines.

siftom's form is ``walk(human, fridge)``, ``grab(human, milk_1, fridge)``, ``put(human, milk_1, table)``
(:meth:`siftom.world.model.World.parse_action`). VirtualHome writes a program one step a line::

    <char0> [Walk] <kitchen> (11)
    [Walk] <fridge> (165)
    [Open] <fridge> (165)
    [Grab] <milk> (195)
    [PutBack] <milk> (195) <kitchentable> (130)

The number in parentheses is the node id of the scene graph the world was built from (each
place and object keeps its ``node_id``); for a world without node ids (siftom's world JSON,
the built-in domains) the ``<name>`` is matched against place and object names instead and
the number is ignored. The mapping (docs/world.md has the table):

* ``[Walk]``/``[Run]``/``[Find]``/``[WalkTowards]`` to a place: ``walk``; to an object: walk to
  the place where the object is; to a room (no place in a siftom world stands for a room) or
  to where the human already is: nothing.
* ``[Open]``/``[Close]``: ``open``/``close``; ``[Grab]``: ``grab``; ``[PutBack]``/``[PutIn]``/
  ``[PutObjBack]``: ``put``. VirtualHome's executor walks the character there first; so does
  this mapping (a ``walk`` is inserted when the human is elsewhere).
* ``[LookAt]``, ``[TurnTo]``, ``[PointAt]``, ``[Watch]``, ``[Wait]``: nothing (no state change).
* Anything else (``[SwitchOn]``, ``[Cut]``, ...), an id that is not in the world, a name that
  does not match the node's class, or a character other than ``<char0>`` (the human) is an
  :class:`~siftom.errors.ObservationError` naming the line and what would map.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from siftom.errors import ObservationError, UnknownNameError
from siftom.world.model import HELD, HUMAN, Action, Item, Place, State, World, apply, check

_ARG = r"<\s*([^<>]+?)\s*>\s*(?:\(\s*(\d+(?:\.\d+)?)\s*\))?"
VH_LINE = re.compile(rf"^\s*(?:<\s*(char\d+)\s*>\s*)?\[\s*(\w+)\s*\]\s*(?:{_ARG})?\s*(?:{_ARG})?\s*$")

WALKS = frozenset({"walk", "run", "find", "walktowards", "goto"})
PUTS = frozenset({"putback", "putin", "putobjback", "put"})
NO_OPS = frozenset({"lookat", "turnto", "pointat", "watch", "wait", "lookat_short", "lookat_long"})
SUPPORTED = ("Walk", "Run", "Find", "Open", "Close", "Grab", "PutBack", "PutIn", "LookAt", "TurnTo",
             "PointAt", "Watch", "Wait")


def is_vh_line(text: str) -> bool:
    """Whether ``text`` looks like a VirtualHome script line (``[Verb] <obj> (id)``)."""
    t = text.lstrip()
    return t.startswith("[") or t.startswith("<char")


class _Ref:
    """A ``<name> (id)`` argument resolved against the world."""

    def __init__(self, world: World, name: str, num: str | None, line: str) -> None:
        self.name, self.num = name, num
        self.place: int | None = None
        self.item: int | None = None
        self.room: str | None = None
        has_ids = any(p.node_id is not None for p in world.places) or any(i.node_id is not None for i in world.items)
        if has_ids and num is not None and num.isdigit():
            nid = int(num)
            pl = _by_node(world.places, nid)
            it = _by_node(world.items, nid)
            if pl is None and it is None:
                rooms = {p.room for p in world.places}
                if name in rooms:
                    self.room = name
                    return
                if nid in world.left_out:
                    raise ObservationError(f"{line!r}: node {nid} ({name}) is in the graph but was left out of this "
                                           f"world: {world.left_out[nid]}")
                raise ObservationError(
                    f"{line!r}: no place or object of this world has scene-graph id {nid}; "
                    f"use an id of the graph the session was created from ({_examples(world)})")
            if pl is not None:
                node_name = world.places[pl].name
            else:
                assert it is not None  # both None raised above
                node_name = world.items[it].name
            if _cls(node_name) != name.lower() and node_name.lower() != name.lower():
                raise ObservationError(
                    f"{line!r}: node {nid} is {node_name!r}, not a {name!r}; check the id or the class name")
            self.place, self.item = pl, it
            return
        low = name.lower()
        for i, p in enumerate(world.places):
            if p.name.lower() == low or (num is not None and p.name.lower() == f"{low}.{num}"):
                self.place = i
                return
        for i, obj in enumerate(world.items):
            if obj.name.lower() == low or (num is not None and obj.name.lower() in (f"{low}.{num}", f"{low}_{num}")):
                self.item = i
                return
        if low in {p.room.lower() for p in world.places}:
            self.room = name
            return
        raise ObservationError(
            f"{line!r}: no place, object or room named {name!r} in this world; valid names include "
            f"{_examples(world)}")


def _cls(node_name: str) -> str:
    return node_name.rsplit(".", 1)[0].lower()


def _by_node(seq: Sequence[Place | Item], nid: int) -> int | None:
    for i, x in enumerate(seq):
        if x.node_id == nid:
            return i
    return None


def _examples(world: World) -> str:
    def fmt(x: Place | Item) -> str:
        return f"<{_cls(x.name)}> ({x.node_id})" if x.node_id is not None else f"<{x.name}>"

    shown = [fmt(p) for p in world.places[:3]] + [fmt(i) for i in world.items[:3]]
    return ", ".join(shown)


def vh_line_to_actions(world: World, state: State, line: str) -> list[Action]:
    """The siftom actions (zero, one or two) that one VirtualHome script line stands for."""
    m = VH_LINE.match(line)
    if not m:
        raise ObservationError(f"cannot read {line!r} as a VirtualHome script line; write e.g. "
                               "[Walk] <fridge> (165), [Grab] <milk> (195), [PutBack] <milk> (195) <kitchentable> (130)")
    char, verb, n1, i1, n2, i2 = m.groups()
    if char not in (None, "char0"):
        raise ObservationError(f"{line!r}: only the human's actions (<char0>) are observed; drop the other "
                               "characters' lines")
    v = verb.lower()
    if v in NO_OPS:
        return []
    args = [_Ref(world, n, i, line) for n, i in ((n1, i1), (n2, i2)) if n is not None]
    here = state.agent_at[HUMAN]

    def walk_to(place: int) -> list[Action]:
        return [] if place == here else [Action("walk", HUMAN, place=place)]

    if v in WALKS:
        if len(args) != 1:
            raise ObservationError(f"{line!r}: [{verb}] takes one argument, e.g. [Walk] <fridge> (165)")
        a = args[0]
        if a.room is not None:
            return []
        if a.item is not None:
            loc = state.item_at[a.item]
            return [] if loc == HELD else walk_to(loc)
        return walk_to(a.place)  # type: ignore[arg-type]
    if v in ("open", "close"):
        if len(args) != 1 or args[0].place is None:
            raise ObservationError(f"{line!r}: [{verb}] takes one container, e.g. [Open] <fridge> (165)")
        p = args[0].place
        return walk_to(p) + [Action(v, HUMAN, place=p)]
    if v == "grab":
        if len(args) != 1 or args[0].item is None:
            raise ObservationError(f"{line!r}: [Grab] takes one object, e.g. [Grab] <milk> (195)")
        obj = args[0].item
        loc = state.item_at[obj]
        if loc == HELD:
            raise ObservationError(f"{line!r}: {world.items[obj].name} is already being carried")
        return walk_to(loc) + [Action("grab", HUMAN, obj=obj, place=loc)]
    if v in PUTS:
        if len(args) != 2 or args[0].item is None or args[1].place is None:
            raise ObservationError(f"{line!r}: [{verb}] takes an object and a place, e.g. "
                                   "[PutBack] <milk> (195) <kitchentable> (130)")
        return walk_to(args[1].place) + [Action("put", HUMAN, obj=args[0].item, place=args[1].place)]
    raise ObservationError(f"{line!r}: [{verb}] has no counterpart in a fetch-and-place world; "
                           f"supported: {', '.join(f'[{s}]' for s in SUPPORTED)}")


def parse_actions(world: World, start: State, lines: Sequence[str], first: int = 0,
                  label: str = "actions[{k}]") -> tuple[list[Action], State]:
    """Parse and check actions (either format, mixed freely) from ``start``: the human's, and in
    siftom's format the robot's own (``walk(robot, fridge)``: what the robot did).

    Returns the siftom actions and the state after them. Raises ObservationError naming the
    line (``label`` with k counted from ``first``: ``actions[0]`` for an API list, ``action 1``
    for a file) that cannot be read, mapped or done, and why.
    """
    acts: list[Action] = []
    s = start
    for k, text in enumerate(lines, start=first):
        if not isinstance(text, str) or not text.strip():
            raise ObservationError(f"{label.format(k=k)} must be a non-empty string like 'walk(human, fridge)' "
                                   "or '[Walk] <fridge> (165)'")
        if is_vh_line(text):
            step = vh_line_to_actions(world, s, text)
        else:
            try:
                a = world.parse_action(text, s)
            except UnknownNameError as exc:  # a name in the line, not a missing resource
                raise ObservationError(f"{label.format(k=k)} {text!r}: {exc}") from None
            step = [a]  # the human's, or the robot's own (it changes the world, not the belief)
        for a in step:
            why = check(world, s, a)
            if why is not None:
                raise ObservationError(f"{label.format(k=k)} {text!r} is impossible here: {why}")
            acts.append(a)
            s = apply(s, a)
    return acts, s
