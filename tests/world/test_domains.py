"""The built-in domains: registered ids, fixed scenarios, seeded generators, the paper's story."""

import json
import subprocess
import sys

import pytest

# Import both domain modules explicitly (the registry also does this itself).
import siftom.world.domains.household  # noqa: F401
import siftom.world.domains.kitchen  # noqa: F401
from siftom.errors import CommandParseError, UnknownNameError
from siftom.scenarios.base import (
    domains,
    get_domain,
    get_scenario,
    scenario_domain,
    scenario_ids,
)
from siftom.world.domains.kitchen import library
from siftom.world.model import HELD, apply, check


def test_both_domains_are_registered():
    ids = [d.name for d in domains()]
    assert ids == ["household-table-v0", "kitchen-v0"]
    assert all(d.summary for d in domains())


def test_registry_lists_both_domains_whatever_was_imported_first():
    code = ("from siftom.world.domains.kitchen import library\n"
            "from siftom.scenarios.base import domains\n"
            "print(','.join(d.name for d in domains()))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "household-table-v0,kitchen-v0"


def test_unknown_ids_suggest_close_matches():
    with pytest.raises(UnknownNameError, match="Did you mean 'kitchen-v0'"):
        get_domain("kitchen-v1")
    with pytest.raises(UnknownNameError, match="kitchen-cereal-v0"):
        get_scenario("kitchen-cereal")


def test_fixed_scenarios_are_registered():
    household = get_domain("household-table-v0").fixed()
    kitchen = get_domain("kitchen-v0").fixed()
    assert len(household) == 26
    assert "kitchen-cereal-v0" in kitchen
    assert set(household) | set(kitchen) <= set(scenario_ids())
    assert all(scenario_domain(sid) == "household-table-v0" for sid in household)


@pytest.mark.parametrize("sid", scenario_ids())
def test_every_fixed_scenario_is_consistent(sid):
    sc = get_scenario(sid)
    world = sc.world
    # the observed actions are legal, one after the other, and all the human's
    s = sc.start
    for a in sc.actions:
        assert a.agent == 0
        assert check(world, s, a) is None, f"{sid}: {world.format_action(a)} is illegal"
        s = apply(s, a)
    assert s == sc.now
    # the gold command names a class the true goal needs, at most as many as it needs
    goal = sc.goal
    assert sc.command.obj_class in goal.count_map
    assert sc.command.count <= goal.count_map[sc.command.obj_class]
    assert sc.command.verb == sc.verb
    assert sc.parse_command(str(sc.command)) == sc.command
    # every goal of the space is reachable with the objects of the world
    for g in sc.goals:
        assert g.target == sc.target
        for c, n in g.counts:
            assert sum(1 for it in world.items if it.cls == c) >= n, (g.name, c)
    json.dumps(sc.to_json())


def test_household_layout_and_goal_space():
    sc = get_scenario("household-table-v0/0")
    rooms = {p.room for p in sc.world.places}
    assert len(rooms) >= 4
    assert sc.world.places[sc.target].name == "dining_table"
    # N of each of a subset of types, the same N for every type
    for g in sc.goals:
        assert len({n for _c, n in g.counts}) == 1
        assert 2 <= len(g.counts) <= 3
    assert {"plate", "fork", "knife", "spoon", "wineglass", "waterglass"} <= set(sc.world.classes)
    storage = {sc.world.places[i].kind for i in set(sc.start.item_at)}
    assert "container" in storage and "surface" in storage


def test_kitchen_library_has_39_foods_and_at_least_100_recipes():
    lib = library()
    foods = [c for c, v in lib["items"].items() if v["kind"] == "food"]
    assert len(foods) == 39
    assert {"cereal", "milk", "coffee", "sugar", "tea", "pasta", "egg", "flour", "bread", "bacon"} <= set(foods)
    assert len(lib["recipes"]) >= 100
    recipes = {r["id"]: set(r["items"]) for r in lib["recipes"]}
    assert recipes["breakfast_cereal"] == {"cereal", "bowl", "milk"}
    assert all(set(r["items"]) <= set(lib["items"]) for r in lib["recipes"])
    assert len(get_scenario("kitchen-v0/0").goals) == len(lib["recipes"])


def test_kitchen_cereal_matches_the_paper_story():
    sc = get_scenario("kitchen-cereal-v0")
    w, now = sc.world, sc.now

    def where(name):
        loc = now.item_at[w.item(name)]
        return "held" if loc == HELD else w.places[loc].name

    assert where("milk") == "kitchen_counter"
    assert "bowl" in {w.items[i].cls for i in w.items_at(now, sc.target)}
    for item in ("cereal", "sugar", "oatmeal"):
        assert w.places[now.item_at[w.item(item)]].room == "storage"
    assert sc.goal.name == "breakfast_cereal"
    assert str(sc.command) == "fetch(cereal)"
    assert w.places[sc.target].name == "kitchen_counter"


@pytest.mark.parametrize("domain", ["household-table-v0", "kitchen-v0"])
def test_generators_are_deterministic_per_seed(domain):
    gen = get_domain(domain)
    a, b = gen.generate(123), gen.generate(123)
    assert a.to_json() == b.to_json()
    assert a.start == b.start and a.actions == b.actions
    others = [gen.generate(s).to_json() for s in (124, 125, 126)]
    assert any(o != a.to_json() for o in others)


def test_parse_command_checks_the_scenario():
    sc = get_scenario("kitchen-cereal-v0")
    with pytest.raises(CommandParseError, match="no object of class 'spaceship'"):
        sc.parse_command("fetch(spaceship)")
    with pytest.raises(CommandParseError, match="only 1 cereal"):
        sc.parse_command("fetch(cereal,5)")
