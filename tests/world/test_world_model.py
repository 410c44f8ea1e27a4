"""The symbolic world: one pure transition that explains every refusal, immutable states, costs."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helpers import three_room_house
from siftom.errors import IllegalActionError, ObservationError, UnknownNameError
from siftom.world.model import (
    HELD,
    HUMAN,
    NOTHING,
    ROBOT,
    Action,
    Item,
    Place,
    State,
    World,
    apply,
    check,
    cost,
    legal_actions,
    transition,
)

# three_room_house: 0 table (dining), 1 counter (kitchen), 2 drawer (kitchen, closed),
# 3 shelf (pantry); fork_1, fork_2 in the drawer, plate_1 on the counter, cup_1 on the shelf;
# the human stands at the counter, the robot at the table.
TABLE, COUNTER, DRAWER, SHELF = range(4)
FORK1, FORK2, PLATE, CUP = range(4)


@pytest.fixture
def house():
    return three_room_house()


def walk(place, agent=HUMAN):
    return Action("walk", agent, place=place)


def grab(obj, place=NOTHING, agent=HUMAN):
    return Action("grab", agent, obj=obj, place=place)


def put(obj, place, agent=HUMAN):
    return Action("put", agent, obj=obj, place=place)


def run(world, s, *actions):
    for a in actions:
        s, _c = transition(world, s, a)
    return s


# ----------------------------------------------------------------------------- transition
def test_a_legal_sequence_moves_objects_and_costs_its_duration(house):
    world, s = house
    total = 0
    for a in (walk(DRAWER), Action("open", HUMAN, place=DRAWER), grab(FORK1, DRAWER), walk(TABLE),
              put(FORK1, TABLE)):
        s2, c = transition(world, s, a)
        assert c == cost(world, s, a)
        total += c
        s = s2
    assert s.item_at[FORK1] == TABLE and s.held == (NOTHING, NOTHING) and s.is_open(DRAWER)
    assert total == world.dist[COUNTER, DRAWER] + 1 + 1 + world.dist[DRAWER, TABLE] + 1


@pytest.mark.parametrize(
    ("prepare", "action", "reason"),
    [
        ((walk(DRAWER),), grab(FORK1, DRAWER), "closed; open it first"),
        ((), grab(PLATE, COUNTER), None),  # control: legal
        ((grab(PLATE, COUNTER), walk(DRAWER), Action("open", HUMAN, place=DRAWER)), grab(FORK1, DRAWER),
         "hands are full"),
        ((grab(PLATE, COUNTER),), put(PLATE, TABLE), "must walk to table first"),
        ((), walk(COUNTER), "already at counter"),
        ((grab(PLATE, COUNTER),), Action("handover", HUMAN, obj=PLATE, to_agent=ROBOT), "not at the same place"),
        ((), grab(CUP, SHELF), "not where human stands"),
        ((), put(PLATE, COUNTER), "does not hold plate_1"),
        ((), Action("open", HUMAN, place=TABLE), "cannot be opened"),
        ((), Action("open", HUMAN, place=DRAWER), "must walk to drawer first"),
        ((walk(DRAWER), Action("open", HUMAN, place=DRAWER)), Action("open", HUMAN, place=DRAWER),
         "already open"),
        ((walk(DRAWER),), Action("close", HUMAN, place=DRAWER), "already closed"),
        ((walk(DRAWER), Action("open", HUMAN, place=DRAWER), grab(FORK1, DRAWER),
          Action("close", HUMAN, place=DRAWER)), put(FORK1, DRAWER), "closed; open it first"),
        ((grab(PLATE, COUNTER),), Action("handover", HUMAN, obj=PLATE, to_agent=HUMAN), "other agent"),
        ((), Action("fly", HUMAN, place=TABLE), "unknown action kind"),
        ((), walk(99), "no place 99"),
    ],
    ids=lambda v: v if isinstance(v, str) else None,
)
def test_transition_rejects_illegal_actions_with_the_reason(house, prepare, action, reason):
    world, s = house
    s = run(world, s, *prepare)
    if reason is None:
        assert check(world, s, action) is None
        return
    assert reason in check(world, s, action)
    with pytest.raises(IllegalActionError, match="is illegal") as info:
        transition(world, s, action)
    assert reason in str(info.value)


def test_cannot_grab_an_object_another_agent_carries(house):
    world, s = house
    s = run(world, s, grab(PLATE, COUNTER))
    robot_there = State((COUNTER, COUNTER), s.held, s.item_at, s.open_mask)
    assert "being carried" in check(world, robot_there, grab(PLATE, agent=ROBOT))


def test_put_in_a_room_is_refused():
    places = (Place("hall", "room", "hall"), Place("table", "surface", "hall", (1.0, 0.0)))
    world = World(places, (Item("cup_1", "cup"),), World.distances_from_positions(places))
    s = State((1, 1), (NOTHING, NOTHING), (1,), 0)
    s = run(world, s, grab(0, 1), walk(0))
    assert "cannot put cup_1 in a room" in check(world, s, put(0, 0))
    assert all(a.kind != "put" for a in legal_actions(world, s))


def test_handover_between_agents_at_the_same_place(house):
    world, s = house
    s = run(world, s, grab(PLATE, COUNTER), walk(TABLE))
    s2 = run(world, s, Action("handover", HUMAN, obj=PLATE, to_agent=ROBOT))
    assert s2.held == (NOTHING, PLATE) and s2.item_at[PLATE] == HELD
    assert Action("handover", HUMAN, obj=PLATE, to_agent=ROBOT) in set(legal_actions(world, s))


def test_legal_actions_are_exactly_the_actions_check_accepts(house):
    world, s = house
    rng = np.random.default_rng(0)
    for _ in range(60):
        acts = list(legal_actions(world, s, HUMAN))
        assert acts, "an agent can always walk somewhere"
        for a in acts:
            assert check(world, s, a) is None, world.format_action(a)
        # every well-formed action outside the list is refused
        candidates = [walk(p) for p in range(4)] + [Action(k, HUMAN, place=p) for k in ("open", "close")
                                                    for p in range(4)]
        candidates += [grab(i, s.item_at[i]) for i in range(4) if s.item_at[i] >= 0]
        candidates += [put(s.held[HUMAN], p) for p in range(4) if s.held[HUMAN] >= 0]
        for a in candidates:
            assert (check(world, s, a) is None) == (a in acts)
        s = apply(s, acts[int(rng.integers(len(acts)))])


# ----------------------------------------------------------------------------- states
def test_states_are_immutable_and_hashable(house):
    world, s = house
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.agent_at = (0, 0)  # type: ignore[misc]
    same = State(tuple(s.agent_at), tuple(s.held), tuple(s.item_at), s.open_mask)
    assert same == s and hash(same) == hash(s) and len({s, same}) == 1
    s2, _ = transition(world, s, walk(TABLE))
    assert s.agent_at[HUMAN] == COUNTER, "transition must not change its input"
    assert s2 != s and len({s, s2}) == 2


def test_actions_are_hashable_values(house):
    world, s = house
    assert len(set(legal_actions(world, s)) | set(legal_actions(world, s))) == len(list(legal_actions(world, s)))


# ----------------------------------------------------------------------------- costs
def test_walking_cost_grows_with_distance():
    places = tuple(Place(f"p{k}", "surface", "room", (float(x), 0.0)) for k, x in enumerate((0, 1, 3, 7.5)))
    d = World.distances_from_positions(places)
    assert d.tolist()[0] == [0, 1, 3, 8]  # ceil(metres / 1 m), at least 1 between distinct places
    assert (d == d.T).all()
    near = Place("near", "surface", "room", (0.2, 0.0))
    assert World.distances_from_positions((places[0], near))[0, 1] == 1


def test_walking_between_rooms_goes_through_the_door():
    # two rooms side by side; the wall between them has one door far up at y = 10
    places = (Place("a", "surface", "left", (0.0, 0.0)), Place("b", "surface", "right", (2.0, 0.0)))
    d = World.distances_from_positions(places, {frozenset({"left", "right"}): (1.0, 10.0)})
    assert d[0, 1] == d[1, 0] == int(np.ceil(2 * np.hypot(1.0, 10.0)))
    straight = World.distances_from_positions(places)  # no door: straight line (documented default)
    assert straight[0, 1] == 2


def test_walk_cost_comes_from_the_distance_table_and_other_actions_cost_one(house):
    world, s = house
    assert cost(world, s, walk(SHELF)) == world.dist[COUNTER, SHELF] > world.dist[COUNTER, DRAWER]
    assert cost(world, s, grab(PLATE, COUNTER)) == 1
    # table -> pantry passes the kitchen: no shortcut through the wall
    assert world.dist[TABLE, SHELF] >= world.dist[TABLE, COUNTER]


def test_world_rejects_inconsistent_layouts():
    p = (Place("a", "surface", "r"), Place("a", "surface", "r", (1.0, 0.0)))
    with pytest.raises(ObservationError, match="duplicate place names"):
        World(p, (), np.ones((2, 2)))
    with pytest.raises(ObservationError, match="dist must be 1x1"):
        World(p[:1], (), np.ones((2, 2)))
    with pytest.raises(ObservationError, match="kind must be one of"):
        Place("x", "shelfish", "r")
    with pytest.raises(ObservationError, match="duplicate item names"):
        World(p[:1], (Item("i", "c"), Item("i", "c")), np.zeros((1, 1)))


# ----------------------------------------------------------------------------- text form
def test_format_and_parse_round_trip_every_legal_action(house):
    world, s = house
    rng = np.random.default_rng(1)
    seen = set()
    for _ in range(80):
        acts = list(legal_actions(world, s, HUMAN))
        for a in acts:
            text = world.format_action(a)
            assert world.parse_action(text, s) == a
            seen.add(a.kind)
        s = apply(s, acts[int(rng.integers(len(acts)))])
    s = run(world, three_room_house()[1], grab(PLATE, COUNTER), walk(TABLE))
    give = Action("handover", HUMAN, obj=PLATE, to_agent=ROBOT)
    assert world.format_action(give) == "handover(human, plate_1, robot)"
    assert world.parse_action("handover(human, plate_1, robot)") == give
    assert {"walk", "open", "grab", "put"} <= seen


def test_parse_action_reads_the_documented_form_and_aliases(house):
    world, s = house
    assert world.parse_action("grab(human, plate_1, counter)") == grab(PLATE, COUNTER)
    assert world.parse_action("  pick ( human , plate_1 )", s) == grab(PLATE, COUNTER)  # place from the state
    assert world.parse_action("walktowards(robot, shelf)") == walk(SHELF, agent=ROBOT)
    assert world.format_action(walk(SHELF)) == "walk(human, shelf)"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "cannot parse action"),
        ("walk human table", "cannot parse action"),
        ("jump(human, table)", "unknown action 'jump'"),
        ("walk(alice, table)", "first argument must be an agent"),
        ("put(human, plate_1)", "put takes 3 arguments"),
        ("walk(human, tabel)", "Did you mean 'table'"),
        ("grab(human, fork_9, drawer)", "unknown object 'fork_9'"),
        ("handover(human, plate_1, table)", "handover goes to an agent"),
    ],
)
def test_parse_action_errors_say_what_is_wrong(house, text, message):
    world, _s = house
    with pytest.raises((ObservationError, UnknownNameError), match=message):
        world.parse_action(text)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_random_walks_only_ever_see_legal_actions_and_round_trip(seed):
    world, s = three_room_house()
    rng = np.random.default_rng(seed)
    for _ in range(12):
        acts = list(legal_actions(world, s, HUMAN)) + list(legal_actions(world, s, ROBOT))
        a = acts[int(rng.integers(len(acts)))]
        assert world.parse_action(world.format_action(a), s) == a
        s2, c = transition(world, s, a)
        assert c >= 1
        # object conservation: every object is somewhere or held by exactly one agent
        carried = [i for i, loc in enumerate(s2.item_at) if loc == HELD]
        assert sorted(carried) == sorted(h for h in s2.held if h != NOTHING)
        s = s2
