"""The understanding benchmark: its items, its scoring and ``siftom bench understanding``."""

from __future__ import annotations

import json
import re
import shutil
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import pytest

from siftom.bench.understanding import (
    COUNTED,
    DOMAINS,
    KINDS,
    TEMPLATES,
    Expect,
    Item,
    generate_items,
    outcome,
    summary_path,
    understood,
)
from siftom.cli import main
from siftom.likelihood.lexicon import default_lexicon, lexicon_for
from siftom.people.stimuli import resolve_scenario


@cache
def items(set_name: str) -> tuple[Item, ...]:
    return tuple(generate_items(set_name))


def world_of(item: Item) -> Any:
    return resolve_scenario(item.scenario, item.domain, item.scenario_seed)


def names_in(text: str, item: Item) -> set[str]:
    """The classes of the item's world that some words of ``text`` name (longest names first:
    "wine glasses" is a wine glass, not also a "glass")."""
    words = re.sub(r"[^a-z' ]+", " ", text.lower()).split()
    sc = world_of(item)
    lex = lexicon_for(sc.world)
    names = sorted(((n.split(), c) for c in sc.world.classes for e in lex.entry(c).names
                    for n in (e.singular, e.plural)), key=lambda p: -len(p[0]))
    found, taken = set(), [False] * len(words)
    for name, c in names:
        for i in range(len(words) - len(name) + 1):
            if words[i:i + len(name)] == name and not any(taken[i:i + len(name)]):
                found.add(c)
                taken[i:i + len(name)] = [True] * len(name)
    return found


# -- the items -------------------------------------------------------------------------------------


@pytest.mark.parametrize("set_name", ["dev", "heldout"])
def test_a_set_covers_every_kind_in_both_domains_over_ten_worlds(set_name: str) -> None:
    got = items(set_name)
    assert len(got) >= 150
    assert len({i.scenario for i in got}) >= 10
    assert len({i.id for i in got}) == len(got)
    for domain in DOMAINS:
        kinds = {i.kind for i in got if i.domain == domain}
        assert kinds == (set(KINDS) if domain in COUNTED else set(KINDS) - {"count"})
    assert {i.scenario.split("/")[1].split("-")[0] for i in got} == {"w201" if set_name == "dev" else "w202"}


def test_the_same_seed_gives_the_same_items_and_another_seed_others() -> None:
    assert tuple(generate_items("dev")) == items("dev")
    other = generate_items("dev", seed=1)
    assert [i.id for i in other] == [i.id for i in items("dev")]
    assert [i.text for i in other] != [i.text for i in items("dev")]
    assert {i.scenario for i in generate_items("dev", world_seed=7, worlds=1)} == {
        "kitchen-v0/w7-0", "household-table-v0/w7-0"}


@pytest.mark.parametrize("set_name", ["dev", "heldout", "unseen"])
def test_the_items_of_one_world_and_kind_name_different_objects(set_name: str) -> None:
    seen: dict[tuple[str, str], set[str]] = {}
    for i in items(set_name):
        if i.kind in ("plain", "misheard", "count", "any_object", "absent"):
            what = i.expect.absent or i.expect.targets[0][0]
            group = seen.setdefault((i.scenario, i.kind), set())
            assert what not in group, i
            group.add(what)


def test_heldout_wordings_share_no_template_with_dev() -> None:
    def norm(t: str) -> str:
        return re.sub(r"[^a-z{} ]+", "", t.lower()).strip()

    dev = {norm(t) for ts in TEMPLATES["dev"].values() for t in ts}
    held = {norm(t) for ts in TEMPLATES["heldout"].values() for t in ts}
    assert not dev & held
    assert set(TEMPLATES["dev"]) == set(TEMPLATES["heldout"]) == set(KINDS)
    for set_name in ("dev", "heldout"):
        assert all(i.template in TEMPLATES[set_name][i.kind] for i in items(set_name))


def test_the_unseen_set_covers_every_kind_and_shares_no_template_with_the_others() -> None:
    def norm(t: str) -> str:
        return re.sub(r"[^a-z{} ]+", "", t.lower()).strip()

    got = items("unseen")
    assert len(got) >= 150
    assert len({i.id for i in got}) == len(got)
    for domain in DOMAINS:
        kinds = {i.kind for i in got if i.domain == domain}
        assert kinds == (set(KINDS) if domain in COUNTED else set(KINDS) - {"count"})
    assert {i.scenario.split("/")[1].split("-")[0] for i in got} == {"w203"}
    assert set(TEMPLATES["unseen"]) == set(KINDS)
    assert all(5 <= len(ts) <= 8 for ts in TEMPLATES["unseen"].values())
    assert all(i.template in TEMPLATES["unseen"][i.kind] for i in got)
    unseen = {norm(t) for ts in TEMPLATES["unseen"].values() for t in ts}
    for other in ("dev", "heldout"):
        assert not unseen & {norm(t) for ts in TEMPLATES[other].values() for t in ts}


@pytest.mark.parametrize("set_name", ["dev", "heldout", "unseen"])
def test_objects_are_present_or_absent_as_the_kind_demands(set_name: str) -> None:
    for item in items(set_name):
        sc = world_of(item)
        classes = set(sc.world.classes)
        said = names_in(item.text, item)
        e = item.expect
        assert all(c in classes for c, _ in e.targets), item
        counts = [n for _, n in e.targets if n is not None]
        if item.domain not in COUNTED:
            assert not counts, item
        for c, n in e.targets:
            if n is not None:
                assert 2 <= n <= sum(1 for it in sc.world.items if it.cls == c), item
        if item.kind in ("correction", "context", "compound"):
            assert len(said) == 2, item  # X and Y, two objects of the world
            assert {c for c, _ in e.targets} <= said
        if item.kind == "compound":
            assert len(e.targets) == 2 and e.targets[0][0] != e.targets[1][0]
        elif item.kind in ("plain", "count", "any_object", "correction", "context"):
            assert len(e.targets) == 1 and e.request and not e.absent
        if item.kind in ("plain", "count", "any_object"):
            assert said == {e.targets[0][0]}, item
        if item.kind == "count":
            assert item.domain in COUNTED and e.targets[0][1] is not None
        if item.kind == "any_object":
            assert e.targets[0][0] not in dict(sc.goal.counts), item
        if item.kind == "misheard":
            assert not said, item  # the word heard names no object of the world
        if item.kind == "absent":
            assert e.absent and not e.targets and not said, item
            assert e.absent in item.text
            known = [c for c in default_lexicon().classes if default_lexicon().entry(c).singular == e.absent]
            assert known and not set(known) & classes
        if item.kind in ("negation", "nonrequest"):
            assert not e.request and not e.targets and not e.absent
        if item.kind == "negation":
            assert len(said) == 1


# -- scoring -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Cmd:
    obj_class: str
    count: int = 1

    def __str__(self) -> str:
        return f"fetch({self.obj_class},{self.count})"


@dataclass(frozen=True)
class Understood:
    request: bool


@dataclass(frozen=True)
class Decision:
    reason: str = ""
    declined: str = ""


@dataclass(frozen=True)
class FakeAnswer:
    action: str = "none"
    command: Cmd | None = None
    understanding: Understood | None = None
    parts: tuple[Cmd, ...] = ()
    decision: Decision = field(default_factory=Decision)


def item(kind: str, expect: Expect, domain: str = "household-table-v0") -> Item:
    return Item(f"t/{kind}", kind, domain, 0, "words", expect)


def asked(*parts: Cmd, action: str = "act") -> FakeAnswer:
    return FakeAnswer(action, parts[0] if parts and action == "act" else None, Understood(True), parts)


@pytest.mark.parametrize("kind", ["plain", "misheard", "any_object", "context", "correction"])
def test_one_target_is_understood_by_its_class_and_the_count_said(kind: str) -> None:
    said = item(kind, Expect(True, (("fork", 3),)))
    unsaid = item(kind, Expect(True, (("fork", None),)))
    assert understood(said, asked(Cmd("fork", 3)))
    assert understood(said, asked(Cmd("fork", 3), action="none"))  # understood, whatever the rule decides
    assert understood(unsaid, asked(Cmd("fork", 2)))
    assert not understood(said, asked(Cmd("fork", 2)))  # the count said is not the part's
    assert not understood(said, asked(Cmd("knife", 3)))  # another object
    assert not understood(said, asked(Cmd("fork", 3), Cmd("plate", 3)))  # one too many
    assert not understood(said, asked())
    assert not understood(said, FakeAnswer("act", Cmd("fork", 3), Understood(False), (Cmd("fork", 3),)))
    assert not understood(said, FakeAnswer("act", Cmd("fork", 3), None, (Cmd("fork", 3),)))  # no understanding yet


@pytest.mark.parametrize("kind", ["compound", "count"])
def test_several_targets_are_a_multiset(kind: str) -> None:
    both = item(kind, Expect(True, (("fork", 3), ("plate", 3))))
    assert understood(both, asked(Cmd("plate", 3), Cmd("fork", 3)))
    assert not understood(both, asked(Cmd("fork", 3)))
    assert not understood(both, asked(Cmd("fork", 3), Cmd("fork", 3)))
    assert not understood(both, asked(Cmd("fork", 3), Cmd("plate", 2)))
    kitchen = item(kind, Expect(True, (("cereal", None), ("milk", None))), "kitchen-v0")
    assert understood(kitchen, asked(Cmd("milk"), Cmd("cereal")))
    assert not understood(kitchen, asked(Cmd("milk"), Cmd("cereal"), Cmd("cereal")))


@pytest.mark.parametrize("kind", ["negation", "nonrequest"])
def test_no_request_is_understood_when_the_robot_does_nothing(kind: str) -> None:
    nothing = item(kind, Expect(False))
    assert understood(nothing, FakeAnswer("none"))
    assert understood(nothing, FakeAnswer("none", None, Understood(False)))
    assert not understood(nothing, asked(Cmd("fork", 2)))
    assert not understood(nothing, FakeAnswer("ask"))  # asking back is doing something
    assert not understood(nothing, FakeAnswer("none", Cmd("fork")))


def test_an_absent_object_is_understood_when_the_robot_does_nothing_and_says_why() -> None:
    banana = item("absent", Expect(True, (), absent="banana"))
    assert understood(banana, FakeAnswer("none", decision=Decision(declined="Sorry, there is no banana here.")))
    assert not understood(banana, FakeAnswer("none", decision=Decision("no instruction heard")))
    assert not understood(banana, FakeAnswer("act", Cmd("bowl"), decision=Decision("banana? a bowl then")))
    glass = item("absent", Expect(True, (), absent="wine glass"))
    assert understood(glass, FakeAnswer("none", decision=Decision(declined="there is no wineglass here")))


def test_silence_to_a_request_for_an_absent_object_ignores_the_person() -> None:
    # an explanation in the record names the object, but the robot said nothing: the person was ignored
    banana = item("absent", Expect(True, (), absent="banana"))
    silent = FakeAnswer("none", decision=Decision("no instruction heard (Whisper heard 'the banana')"))
    assert not understood(banana, silent)
    assert outcome(banana, silent)["nothing"] is True
    declined = FakeAnswer("none", decision=Decision("there is no banana here", "Sorry, there is no banana here."))
    assert outcome(banana, declined)["nothing"] is False
    assert outcome(banana, FakeAnswer("ask"))["nothing"] is False


# -- the command line ------------------------------------------------------------------------------


def test_the_cli_runs_a_few_items_and_writes_json_lines(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "u.jsonl"
    assert main(["bench", "understanding", "--limit", "3", "--conditions", "text", "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    rows = [json.loads(line) for line in out.read_text(encoding="utf-8").splitlines()]
    assert len(rows) == 3 and {r["condition"] for r in rows} == {"text"}
    keys = {"id", "kind", "domain", "condition", "text", "heard", "expected", "understanding", "parts", "action",
            "command", "reason", "seconds", "understood"}
    assert all(keys <= set(r) and isinstance(r["understood"], bool) for r in rows)
    assert [r["id"] for r in rows] == [i.id for i in items("dev")[:3]]
    assert json.loads(summary_path(out).read_text(encoding="utf-8")) == summary
    assert summary["overall"]["text"]["n"] == 3 and summary["set"] == "dev" and summary["world_seed"] == 201
    assert not (tmp_path / "u.audio").exists()  # text: nothing recorded


def test_the_cli_names_a_bad_condition_and_the_fix(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "understanding", "--limit", "1", "--conditions", "text,20dB"]) == 2
    err = capsys.readouterr().err
    assert "20dB" in err and "text, clean, 10dB" in err


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("flite") is None and shutil.which("espeak-ng") is None,
                    reason="no TTS engine installed (flite or espeak-ng)")
def test_recorded_conditions_speak_and_mix_each_item(tmp_path: Path) -> None:
    from siftom.bench.understanding import add_noise, record, run_benchmark, voices_available

    first = items("dev")[:2]
    voice = voices_available()[0]
    clean = record(first[0], "clean", voice)
    noisy = record(first[0], "10dB", voice, seed=3)
    assert clean.size > 8000 and noisy.shape == clean.shape
    assert (noisy == add_noise(clean, first[0], seed=3)).all()
    out = tmp_path / "r.jsonl"
    run = run_benchmark(first, ("clean", "10dB"), out=out)
    assert [(r["id"], r["condition"]) for r in run.rows] == [(i.id, c) for i in first for c in ("clean", "10dB")]
    assert all(r["voice"] for r in run.rows) and len(list((tmp_path / "r.audio").glob("*.wav"))) == 4
    again = run_benchmark(first, ("clean", "10dB"), out=out)  # the recordings are reused
    assert [r["heard"] for r in again.rows] == [r["heard"] for r in run.rows]
