"""The understanding benchmark's blind set, its scoring of replies, modifiers, refusals and counts
beyond supply, what went wrong per row, the gates, and the noisy conditions."""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from siftom.bench.understanding import (
    BLIND_KINDS,
    EXTRA_KINDS,
    GATES,
    KINDS,
    Expect,
    Item,
    add_noise,
    gates,
    load_items,
    outcome,
    scene_for,
    summary_path,
    understood,
)
from siftom.cli import main
from siftom.errors import DatasetError


@cache
def blind() -> tuple[Item, ...]:
    return tuple(load_items())


# -- the blind set -----------------------------------------------------------------------------------


def test_the_blind_set_covers_every_kind_with_its_own_ids() -> None:
    got = blind()
    assert len(got) >= 120
    assert len({i.id for i in got}) == len(got)
    per_kind = Counter(i.kind for i in got)
    assert set(per_kind) == set(BLIND_KINDS) - {"any_object"}
    assert all(n >= 5 for n in per_kind.values()), per_kind
    assert {i.domain for i in got} >= {"kitchen-v0", "household-table-v0", "world:office", "world:salad"}
    # any prefix mixes kinds (--limit)
    assert len({i.kind for i in got[:len(per_kind)]}) == len(per_kind)


def test_the_blind_set_holds_the_repairs_and_requests_people_make() -> None:
    by_text = {i.text: i for i in blind()}
    for text, target in [("the jam the honey", "honey"), ("get me the jam, scratch that, the honey", "honey"),
                         ("could you grab the jam, actually make that the honey", "honey"),
                         ("the jam. never mind, the honey", "honey")]:
        assert by_text[text].expect.targets == ((target, None),) and by_text[text].kind == "correction"
    assert by_text["anything but the sugar"].expect.refused == ("sugar",)
    assert by_text["could you grab the stapler for me"].expect.absent == "stapler"
    assert by_text["bring me three pens"].expect.over_supply
    assert by_text["can I have the cereal with a bit of sugar"].expect.optional == ("sugar",)
    replies = [i for i in blind() if i.kind == "reply"]
    assert replies and all(len(i.pending) == 2 for i in replies)
    assert any(not i.expect.request for i in replies)  # room talk while a question is open


def test_every_blind_item_is_true_of_its_world() -> None:
    for item in blind():
        world = scene_for(item).world
        have = Counter(it.cls for it in world.items)
        e = item.expect
        for c, n in e.targets:
            assert c in have, item
            if n is not None:
                assert (n > have[c]) == e.over_supply, item
        assert all(c in have for c in (*e.optional, *e.refused)), item
        if e.absent:
            assert not any(e.absent in c for c in have), item
        if item.kind in ("negation", "nonrequest") and not e.refused:
            assert not e.request, item


def _write(tmp_path: Path, **row: Any) -> Path:
    base: dict[str, Any] = {"id": "x/1", "kind": "plain", "scenario": "kitchen-v0/0", "text": "the milk",
                            "expected": {"request": True, "targets": [["milk", None]], "absent": None}}
    base.update(row)
    p = tmp_path / "items.jsonl"
    p.write_text(json.dumps(base) + "\n", encoding="utf-8")
    return p


@pytest.mark.parametrize(("row", "says"), [
    ({"kind": "chat"}, "unknown kind 'chat'"),
    ({"world": "office"}, "exactly one of 'scenario'"),
    ({"expected": {"request": True, "targets": [["stapler", None]]}}, "class 'stapler' is not in the world"),
    ({"scenario": None, "world": "attic"}, "no world 'attic'"),
    ({"expected": {"request": True, "targets": [["cup", 3]]}}, "set 'over_supply' true"),
    ({"expected": {"request": False, "targets": [["milk", None]]}}, "need 'request': true"),
    ({"pending": ["fetch(milk)"]}, "two commands"),
    ({"colour": "red"}, "unknown field(s) colour"),
])
def test_a_bad_item_line_is_refused_naming_the_line_and_the_problem(tmp_path: Path, row: dict[str, Any],
                                                                     says: str) -> None:
    with pytest.raises(DatasetError) as err:
        load_items(_write(tmp_path, **row))
    assert says in str(err.value) and "line 1" in str(err.value)


def test_a_file_of_items_in_the_same_format_loads(tmp_path: Path) -> None:
    (item,) = load_items(_write(tmp_path))
    assert item.domain == "kitchen-v0" and item.expect.targets == (("milk", None),)


# -- scoring -----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Cmd:
    obj_class: str
    count: int = 1

    def __str__(self) -> str:
        return f"deliver({self.obj_class},{self.count})"


@dataclass(frozen=True)
class Understood:
    request: bool


@dataclass(frozen=True)
class Decision:
    reason: str = ""
    options: tuple[str, ...] = ()
    declined: str = ""


@dataclass(frozen=True)
class FakeAnswer:
    action: str = "none"
    command: Cmd | None = None
    understanding: Understood | None = None
    parts: tuple[Cmd, ...] = ()
    decision: Decision = field(default_factory=Decision)
    carry_out: tuple[Cmd, ...] = ()


def did(*parts: Cmd) -> FakeAnswer:
    return FakeAnswer("act", parts[0], Understood(True), parts, carry_out=parts)


def asks(*options: str) -> FakeAnswer:
    return FakeAnswer("ask", None, Understood(True), (), Decision("not sure", options))


def item(kind: str, expect: Expect, pending: tuple[str, ...] = ()) -> Item:
    return Item(f"t/{kind}", kind, "household-table-v0", None, "words", expect, pending=pending)


def test_a_modifier_may_be_taken_as_asked_for_once_but_the_target_must_be() -> None:
    cereal = item("modifier", Expect(True, (("cereal", None),), optional=("sugar",)))
    assert understood(cereal, did(Cmd("cereal")))
    assert understood(cereal, did(Cmd("cereal"), Cmd("sugar")))
    assert not understood(cereal, did(Cmd("sugar")))
    assert not understood(cereal, did(Cmd("cereal"), Cmd("sugar"), Cmd("sugar")))
    assert not understood(cereal, FakeAnswer("none"))  # declined as a whole
    assert outcome(cereal, did(Cmd("cereal"), Cmd("sugar")))["other_object"] is False
    assert outcome(cereal, did(Cmd("honey")))["other_object"] is True


def test_a_refused_object_is_never_carried_out_nor_offered() -> None:
    anything = item("negation", Expect(True, refused=("sugar",)))
    assert understood(anything, did(Cmd("honey")))
    assert understood(anything, asks("fetch(honey)", "fetch(jam)"))
    assert not understood(anything, did(Cmd("sugar")))
    assert not understood(anything, asks("fetch(sugar)", "fetch(jam)"))
    assert outcome(anything, did(Cmd("sugar")))["other_object"] is True
    assert outcome(anything, did(Cmd("honey")))["nothing"] is None  # no object named: silence is not scored
    onion = item("reply", Expect(True, (("onion", None),), refused=("tomato",)), ("fetch(tomato)", "fetch(potato)"))
    assert understood(onion, FakeAnswer("act", Cmd("onion"), None, (), carry_out=(Cmd("onion"),)))  # a reply
    assert not understood(onion, did(Cmd("tomato")))


def test_more_than_the_world_holds_is_understood_as_what_there_is_of_that_object() -> None:
    pens = item("beyond_supply", Expect(True, (("pen", 3),), over_supply=True))
    assert understood(pens, did(Cmd("pen", 2)))
    assert understood(pens, did(Cmd("pen", 3)))
    assert not understood(pens, did(Cmd("tape", 1)))
    assert not understood(pens, did(Cmd("pen", 2), Cmd("tape", 1)))
    assert not understood(pens, FakeAnswer("none", None, Understood(True)))
    assert outcome(pens, did(Cmd("tape", 1)))["other_object"] is True
    assert outcome(pens, FakeAnswer("none"))["nothing"] is True
    assert outcome(pens, asks("deliver(pen,2)", "deliver(pen,1)"))["nothing"] is False


def test_an_object_outside_the_lexicon_is_understood_when_the_robot_says_it_is_not_here() -> None:
    stapler = item("unknown", Expect(True, absent="stapler"))
    # the record's explanation is not said to the person: silence ignores them
    assert not understood(stapler, FakeAnswer("none", decision=Decision("asked for a stapler: not here")))
    said = FakeAnswer("none", decision=Decision("no", declined="Sorry, there is no stapler here."))
    assert understood(stapler, said)
    assert outcome(stapler, said)["nothing"] is False
    assert not understood(stapler, did(Cmd("tape")))
    assert outcome(stapler, did(Cmd("tape")))["other_object"] is True
    assert outcome(stapler, FakeAnswer("none"))["nothing"] is True  # saying nothing ignores the person


def test_nobody_asked_counts_acting_and_asking_back_apart() -> None:
    talk = item("nonrequest", Expect(False))
    assert outcome(talk, did(Cmd("fork"))) == {"nothing": None, "other_object": None, "acted_unasked": True,
                                               "asked_unasked": False}
    assert outcome(talk, asks("fetch(a)", "fetch(b)"))["asked_unasked"] is True
    assert outcome(talk, FakeAnswer("none"))["acted_unasked"] is False
    fork = item("plain", Expect(True, (("fork", None),)))
    assert outcome(fork, FakeAnswer("none"))["nothing"] is True
    assert outcome(fork, asks("deliver(fork,2)", "deliver(fork,3)"))["nothing"] is False
    assert outcome(fork, did(Cmd("knife")))["other_object"] is True


# -- the summary's gates -----------------------------------------------------------------------------


def _cell(understood_: int, n: int, **measures: tuple[int, int]) -> dict[str, Any]:
    out: dict[str, Any] = {"n": n, "understood": understood_, "share": understood_ / n}
    for m in ("nothing", "other_object", "acted_unasked", "asked_unasked"):
        k, can = measures.get(m, (0, 0))
        out[m] = {"n": can, "count": k, "share": k / can if can else None}
    return out


def test_the_gates_name_the_kinds_that_miss() -> None:
    summary = {"set": "blind", "overall": {"text": _cell(95, 100), "10dB": _cell(90, 100)},
               "by_kind": {"text": {"plain": _cell(19, 20), "correction": _cell(17, 20)},
                           "10dB": {"plain": _cell(18, 20, nothing=(2, 20), other_object=(0, 20)),
                                    "nonrequest": _cell(20, 20, acted_unasked=(0, 20))}}}
    got = {(g["condition"], g["measure"]): g for g in gates(summary)}
    assert got[("text", "understood")]["missed"] == ["correction"] and not got[("text", "understood")]["holds"]
    assert got[("10dB", "nothing")]["worst"] == pytest.approx(0.1) and got[("10dB", "nothing")]["missed"] == ["plain"]
    assert got[("10dB", "other_object")]["holds"] and got[("10dB", "acted_unasked")]["holds"]
    assert ("5dB", "nothing") not in got  # not run
    assert all(g[0] != "blind" or g[1] == "text" for g in GATES)


# -- the noisy conditions ----------------------------------------------------------------------------


def test_five_db_is_the_same_noise_excerpt_louder_than_ten() -> None:
    t = np.arange(32000) / 16000.0
    clean = (0.3 * np.sin(2 * np.pi * 220 * t) * (np.sin(2 * np.pi * 2 * t) > 0)).astype(np.float32)
    probe = blind()[0]

    def snr(x: np.ndarray) -> float:
        noise = x.astype(np.float64) - clean
        return float(10 * np.log10(np.sum(clean.astype(np.float64) ** 2) / np.sum(noise ** 2)))

    ten, five = add_noise(clean, probe, 0, 10.0), add_noise(clean, probe, 0, 5.0)
    assert snr(ten) - snr(five) == pytest.approx(5.0, abs=0.5)
    ratio = (five - clean) / np.where(np.abs(ten - clean) > 1e-6, ten - clean, np.nan)
    assert np.nanstd(ratio) < 0.05  # one excerpt, scaled


# -- the command line ----------------------------------------------------------------------------------


def test_the_cli_runs_the_blind_set_and_writes_what_went_wrong(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "b.jsonl"
    n = len(set(BLIND_KINDS) - {"any_object"})
    assert main(["bench", "understanding", "--set", "blind", "--limit", str(n), "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    rows = [json.loads(line) for line in out.read_text(encoding="utf-8").splitlines()]
    assert [r["id"] for r in rows] == [i.id for i in blind()[:n]]
    assert {r["kind"] for r in rows} == set(BLIND_KINDS) - {"any_object"}
    keys = {"nothing", "other_object", "acted_unasked", "asked_unasked", "carried_out", "question", "options",
            "pending", "world"}
    assert all(keys <= set(r) for r in rows)
    assert next(r for r in rows if r["kind"] == "reply")["pending"]
    assert json.loads(summary_path(out).read_text(encoding="utf-8")) == summary
    assert summary["set"] == "blind" and summary["machine"]["version"] and summary["machine"]["cpus"]
    assert set(summary["by_kind"]["text"]) == {r["kind"] for r in rows}
    assert {"nothing", "other_object", "acted_unasked"} <= set(summary["by_kind"]["text"]["plain"])
    assert [g["condition"] for g in summary["gates"]] == ["text"]
    for r in rows:  # the row's flags are the summary's counts
        assert (r["nothing"] is None) == (not r["expected"]["request"]
                                          or not (r["expected"]["targets"] or r["expected"]["absent"]))


def test_the_cli_runs_only_the_kinds_asked_for_and_names_a_bad_one(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "understanding", "--set", "blind", "--kinds", "reply", "--limit", "2", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert list(summary["by_kind"]["text"]) == ["reply"] and summary["items"] == 2
    assert main(["bench", "understanding", "--set", "blind", "--kinds", "chat"]) == 2
    err = capsys.readouterr().err
    assert "chat" in err and "correction" in err
    assert main(["bench", "understanding", "--set", "blind", "--conditions", "10dB", "--voices", "nobody",
                 "--limit", "1"]) != 0
    assert "nobody" in capsys.readouterr().err


def test_the_generated_sets_keep_their_kinds() -> None:
    assert BLIND_KINDS[:len(KINDS)] == KINDS and not set(EXTRA_KINDS) & set(KINDS)


def test_the_cli_renders_a_table_from_earlier_result_files(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "b.jsonl"
    assert main(["bench", "understanding", "--set", "blind", "--kinds", "plain,nonrequest", "--limit", "4",
                 "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert main(["bench", "understanding", "--from", str(summary_path(out))]) == 0
    text = capsys.readouterr().out
    plain = summary["by_kind"]["text"]["plain"]
    assert "| kind | blind, text |" in text
    assert f"| plain | {100 * plain['share']:.0f} % ({plain['understood']}/{plain['n']}) |" in text
    assert main(["bench", "understanding", "--from", str(summary_path(out)), "--measure", "acted_unasked"]) == 0
    talk = summary["by_kind"]["text"]["nonrequest"]["acted_unasked"]
    text = capsys.readouterr().out
    assert f"| nonrequest | {100 * talk['share']:.0f} % ({talk['count']}/{talk['n']}) |" in text
    assert "| plain |" not in text  # a request cannot be "nobody asked": no row
    assert main(["bench", "understanding", "--from", str(out)]) == 2  # the rows, not the summary
    assert "not a summary" in capsys.readouterr().err
