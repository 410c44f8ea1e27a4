"""``siftom dataset build --world-seed``: worlds nobody tuned on, reproducible from the manifest alone."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest

from siftom.errors import DatasetError
from siftom.people import stimuli
from siftom.people.stimuli import (
    BuildOptions,
    load_dataset,
    resolve_scenario,
    scenario_for,
    select_scenarios,
)
from siftom.scenarios.base import (
    WORLD_SEED_BASE,
    get_domain,
    get_scenario,
    is_world_seed,
    scenario_ids,
    world_scenario_seed,
)
from siftom.world.model import apply, check

DOMAINS = ("household-table-v0", "kitchen-v0")
flite = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")


def _actions(sc) -> tuple[str, ...]:
    return tuple(sc.world.format_action(a) for a in sc.actions)


def test_world_seeds_are_deterministic_json_safe_and_above_every_tuned_seed() -> None:
    grid = {(w, k): world_scenario_seed(w, k) for w in range(20) for k in range(30)}
    assert grid == {(w, k): world_scenario_seed(w, k) for w in range(20) for k in range(30)}
    assert len(set(grid.values())) == len(grid)
    assert all(WORLD_SEED_BASE <= s < 2**53 and is_world_seed(s) for s in grid.values())
    assert not any(is_world_seed(s) for s in range(1000))  # the registered and tuned seeds are small
    with pytest.raises(ValueError):
        world_scenario_seed(-1, 0)


@pytest.mark.parametrize("domain", DOMAINS)
def test_select_scenarios_with_a_world_seed_skips_the_registered_ones(domain: str) -> None:
    picked = select_scenarios(domain, 5, world_seed=7)
    assert [sid for sid, _ in picked] == [f"{domain}/w7-{k}" for k in range(5)]
    assert not {sid for sid, _ in picked} & set(scenario_ids())
    assert [seed for _, seed in picked] == [world_scenario_seed(7, k) for k in range(5)]
    assert select_scenarios(domain, 5, world_seed=7) == picked
    assert not {s for _, s in picked} & {s for _, s in select_scenarios(domain, 5, world_seed=8)}
    # without a world seed: as before, registered first
    assert select_scenarios(domain, 2) == [(sid, None) for sid in get_domain(domain).fixed()[:2]]
    with pytest.raises(DatasetError, match="--world-seed"):
        select_scenarios(domain, 1, world_seed=-3)


def test_registered_and_small_seed_scenarios_are_unchanged() -> None:
    """The wider generator only answers world seeds: every scenario existing results used is as before.

    The hash was taken from the generators before --world-seed existed; if it moves, existing
    result files no longer reproduce.
    """
    h = hashlib.sha1()
    for sid in scenario_ids():
        h.update(json.dumps(get_scenario(sid).to_json(), sort_keys=True).encode())
    for dom in DOMAINS:
        for seed in [*range(10, 40), 123, 10**9]:
            h.update(json.dumps(get_domain(dom).generate(seed).to_json(), sort_keys=True).encode())
    assert h.hexdigest()[:16] == "cdd18449c7bf9d7f"


@pytest.mark.parametrize("domain", DOMAINS)
def test_world_seed_worlds_are_valid_and_really_differ(domain: str) -> None:
    gen = get_domain(domain)
    scs = [gen.generate(seed, sid) for w in range(4) for sid, seed in select_scenarios(domain, 5, world_seed=w)]
    for sc in scs:  # valid as test_every_fixed_scenario_is_consistent means it
        s = sc.start
        assert sc.actions
        for a in sc.actions:
            assert a.agent == 0 and check(sc.world, s, a) is None
            s = apply(s, a)
        assert sc.command.obj_class in sc.goal.count_map
        assert sc.command.count <= sc.goal.count_map[sc.command.obj_class]
        assert sc.parse_command(str(sc.command)) == sc.command
        for g in sc.goals:
            for c, n in g.counts:
                assert sum(1 for it in sc.world.items if it.cls == c) >= n
        json.dumps(sc.to_json())
        assert sc.meta["generator"] == "wide"
    # 20 worlds: layouts, starts, goals and action sequences all differ (measured: 20/20 distinct
    # action sequences and layouts, 18-19 distinct goals per domain)
    assert len({_actions(sc) for sc in scs}) == len(scs)
    assert len({sc.start.item_at for sc in scs}) == len(scs)
    assert len({sc.goal.name for sc in scs}) >= 15
    assert len({(sc.start.agent_at, sc.start.open_mask) for sc in scs}) >= 10
    assert len({len(sc.actions) for sc in scs}) >= 5
    # and none is a registered world
    registered = {_actions(get_scenario(sid)) for sid in scenario_ids()}
    assert not {_actions(sc) for sc in scs} & registered


def test_kitchen_world_seeds_move_foods_between_places_of_their_room() -> None:
    gen = get_domain("kitchen-v0")
    places: dict[str, set[str]] = {}
    for sid, seed in select_scenarios("kitchen-v0", 20, world_seed=3):
        sc = gen.generate(seed, sid)
        for i, it in enumerate(sc.world.items):
            places.setdefault(it.cls, set()).add(sc.world.places[sc.start.item_at[i]].name)
    assert places["bowl"] == {"kitchen_cabinet", "kitchen_shelf"}
    assert places["cereal"] == {"kitchen_cabinet", "kitchen_shelf", "storage_shelf", "storage_counter"}
    assert places["milk"] <= {"fridge", "storage_fridge"}


def test_build_options_keep_their_json_without_a_world_seed() -> None:
    assert "world_seed" not in BuildOptions().to_json()
    assert BuildOptions(world_seed=11).to_json()["world_seed"] == 11
    with pytest.raises(DatasetError, match="--world-seed"):
        BuildOptions(world_seed=-1)


# -- built datasets (TTS) ----------------------------------------------------------------------

def _opts(world_seed: int | None, domain: str = "kitchen-v0") -> BuildOptions:
    return BuildOptions(domain=domain, scenarios=2, speakers=1, voices=("flite-slt",), snrs=(), seed=0,
                        world_seed=world_seed)


@flite
def test_same_world_seed_same_manifest_other_world_seed_other_worlds(tmp_path: Path) -> None:
    from siftom.bench.dataset import build_dataset

    a = build_dataset(_opts(5), tmp_path / "a")
    build_dataset(_opts(5), tmp_path / "b")
    c = build_dataset(_opts(6), tmp_path / "c")
    assert (tmp_path / "a" / "manifest.jsonl").read_text() == (tmp_path / "b" / "manifest.jsonl").read_text()
    assert [s.scenario for s in a.stimuli] == ["kitchen-v0/w5-0", "kitchen-v0/w5-1"]
    assert [s.extra for s in a.stimuli] == [{"world_seed": 5, "world": 0}, {"world_seed": 5, "world": 1}]
    assert all(is_world_seed(s.scenario_seed) for s in a.stimuli)
    assert {s.scenario_seed for s in a.stimuli}.isdisjoint({s.scenario_seed for s in c.stimuli})
    assert [s.observed_actions for s in a.stimuli] != [s.observed_actions for s in c.stimuli]
    spec = json.loads((tmp_path / "a" / "dataset.json").read_text())
    assert spec["options"]["world_seed"] == 5
    assert "--world-seed 5" in (tmp_path / "a" / "README.md").read_text()
    # the manifest alone rebuilds every world: forget every scenario, reload, compare
    stimuli._SCENARIOS.clear()
    for s in load_dataset(tmp_path / "a").stimuli:
        sc = resolve_scenario(s.scenario, s.domain, s.scenario_seed)
        assert _actions(sc) == s.observed_actions
        assert str(sc.command) == s.gold_command and sc.goal.name == s.gold_goal["name"]
        assert scenario_for(s) is sc


@flite
def test_a_world_seed_dataset_evaluates_end_to_end(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from siftom.cli import main

    ds, res = tmp_path / "ds", tmp_path / "res"
    assert main(["dataset", "build", "--domain", "household-table-v0", "--out", str(ds), "--world-seed", "2",
                 "--scenarios", "2", "--speakers", "1", "--voices", "flite-slt", "--snr", "none",
                 "--workers", "1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["stimuli"] == 2
    assert main(["dataset", "check", str(ds)]) == 0
    capsys.readouterr()
    stimuli._SCENARIOS.clear()
    assert main(["eval", "--dataset", str(ds), "--out", str(res), "--models", "action-only,siftom-oracle-text",
                 "--workers", "1", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert set(summary["models"]) == {"action-only", "siftom-oracle-text"}
    rows = [json.loads(line) for line in (res / "results.jsonl").read_text().splitlines()]
    assert {r["scenario"] for r in rows} == {"household-table-v0/w2-0", "household-table-v0/w2-1"}


# -- the plan ----------------------------------------------------------------------------------

def test_the_shipped_plan_has_unseen_world_sets_for_both_domains() -> None:
    from siftom.bench.reproduce import load_plan

    plan = load_plan(Path(__file__).resolve().parents[2] / "results" / "plan.toml")
    worlds = [s for s in plan.sets if s.world_seed is not None]
    assert {s.domain for s in worlds} == {"household-table-v0", "kitchen-v0"}
    assert all("unseen worlds" in s.title and f"world seed {s.world_seed}" in s.title for s in worlds)
    assert all(f"--world-seed {s.world_seed}" in s.build_command("D") for s in worlds)
    assert all("--world-seed" not in s.build_command("D") for s in plan.sets if s.world_seed is None)


def test_a_plan_world_seed_must_be_a_seed(tmp_path: Path) -> None:
    from siftom.bench.reproduce import load_plan

    p = tmp_path / "plan.toml"
    p.write_text('[[set]]\nname = "x"\ndomain = "kitchen-v0"\nmodels = ["siftom"]\nworld_seed = "a"\n')
    with pytest.raises(DatasetError, match="world_seed must be an integer"):
        load_plan(p)


def test_a_world_seed_results_page_says_so() -> None:
    from siftom.bench.pages import _worlds
    from siftom.bench.reproduce import SetData

    assert _worlds(SetData("f", 1, "kitchen-v0", 0)) == ""
    assert "world seed 101" in _worlds(SetData("f", 1, "kitchen-v0", 0, world_seed=101))


def test_a_sweep_takes_world_seeds_as_an_axis(tmp_path: Path) -> None:
    from siftom.bench.sweep import SweepConfig, plan

    cells = plan(SweepConfig({"domain": "kitchen-v0", "scenarios": 2}, {}, {"world_seeds": [1, 2]}), tmp_path)
    assert [c.build.world_seed for c in cells] == [1, 2]
    assert len({c.dataset_dir for c in cells}) == 2
