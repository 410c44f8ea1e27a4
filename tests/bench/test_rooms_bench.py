"""``siftom dataset build --rooms --distances``: each clip in one room at one distance, every pair
equally often, recorded in the manifest; the evaluation is broken down by room, distance and SNR."""

from __future__ import annotations

import json
import shutil
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from siftom.bench.dataset import plan_units
from siftom.bench.metrics import breakdown, group_key
from siftom.errors import DatasetError
from siftom.people.stimuli import BuildOptions, Stimulus, load_dataset

flite = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
ROOMS = ("kitchen", "living", "open")


def _opts(**kw: Any) -> BuildOptions:
    base: dict[str, Any] = {"domain": "kitchen-v0", "scenarios": 12, "speakers": 2,
                            "voices": ("flite-slt", "flite-awb"), "snrs": (10.0,), "noises": ("pink",),
                            "seed": 71, "rooms": ROOMS, "distances": (1.0, 3.0)}
    return BuildOptions(**{**base, **kw})


def test_every_room_and_distance_pair_meets_every_speaker_equally_often() -> None:
    units = plan_units(_opts())
    assert Counter(u.room for u in units) == {(r, d): 4 for r in ROOMS for d in (1.0, 3.0)}
    for spk in ("s1", "s2"):
        assert Counter(u.room for u in units if u.speaker.id == spk) == {(r, d): 2 for r in ROOMS for d in (1.0, 3.0)}
    assert [u.room for u in plan_units(_opts())] == [u.room for u in units]  # seeded
    assert [u.room for u in plan_units(_opts(seed=72))] != [u.room for u in units]
    assert all(u.room is None for u in plan_units(_opts(rooms=(), distances=())))


@pytest.mark.parametrize(("kw", "match"), [
    ({"rooms": ("garage",)}, "unknown room 'garage'.*kitchen, living, open"),
    ({"distances": (7.0,)}, "0.5-6 m"),
    ({"distances": (0.2,)}, "0.5-6 m"),
    ({"distances": (1.0, 5.0)}, "kitchen .*at most 3.2 m"),
    ({"distances": ()}, "give both"),
    ({"rooms": ()}, "give both"),
    ({"rooms": ("open", "open")}, "listed twice"),
    ({"room": 0.6}, "--room RT60 .* or --rooms, not both"),
])
def test_rooms_and_distances_are_checked_with_what_is_valid(kw: dict[str, Any], match: str) -> None:
    with pytest.raises(DatasetError, match=match):
        _opts(**kw)


def test_build_options_without_rooms_keep_their_json() -> None:
    assert "rooms" not in _opts(rooms=(), distances=()).to_json()
    assert _opts().to_json()["rooms"] == list(ROOMS) and _opts().to_json()["distances"] == [1.0, 3.0]


def test_an_old_manifest_line_without_rooms_loads_and_is_dry() -> None:
    line = {"id": "000-s1-clean", "scenario": "kitchen-v0/0", "domain": "kitchen-v0", "observed_actions": [],
            "audio": "audio/x.wav", "reference": "get me the milk", "gold_goal": {"name": "g", "counts": {}},
            "gold_command": "fetch(milk)", "speaker": "s1", "voice": "flite-slt"}
    s = Stimulus.from_json(line)
    assert s.extra == {} and "extra" not in s.to_json()
    assert group_key({**line, "snr_db": None}, "room_distance") == "dry @ dry"


@flite
def test_the_builder_hears_each_clip_in_its_room_and_says_so_in_the_manifest(tmp_path: Path) -> None:
    pytest.importorskip("pyroomacoustics", reason='pip install "siftom[rooms]"')
    from siftom.bench.dataset import build_dataset

    opts = _opts(scenarios=2, speakers=1, voices=("flite-slt",), rooms=("kitchen", "open"), distances=(1.0,))
    a = build_dataset(opts, tmp_path / "a")
    assert build_dataset(opts, tmp_path / "b").stimuli == a.stimuli
    rooms = {s.id: (s.extra["room_name"], s.extra["distance_m"], s.extra["rt60_s"]) for s in a.stimuli}
    assert sorted(set(rooms.values())) == [("kitchen", 1.0, 0.4), ("open", 1.0, 0.6)]
    lines = (tmp_path / "a" / "manifest.jsonl").read_text().splitlines()
    assert json.loads(lines[0])["extra"].keys() == {"room_name", "distance_m", "rt60_s"}
    for s in a.stimuli:  # same seed, same audio
        assert (tmp_path / "a" / s.audio).read_bytes() == (tmp_path / "b" / s.audio).read_bytes()
    assert load_dataset(tmp_path / "a").stimuli == a.stimuli
    sheet = (tmp_path / "a" / "README.md").read_text()
    assert "--rooms kitchen,open --distances 1" in sheet and "kitchen at 1 m 2" in sheet


def test_the_evaluator_keeps_each_clips_room_in_its_results_row(tmp_path: Path) -> None:
    """The room breakdown reads the results alone: a moved dataset folder loses nothing."""
    pytest.importorskip("pyroomacoustics", reason='pip install "siftom[rooms]"')
    from siftom.bench.dataset import build_dataset
    from siftom.bench.evaluate import EvalOptions, evaluate, load_results

    opts = _opts(scenarios=2, speakers=1, voices=("flite-slt",), rooms=("living",), distances=(3.0,))
    build_dataset(opts, tmp_path / "ds")
    evaluate(tmp_path / "ds", tmp_path / "out", EvalOptions(models=("action-only",)), workers=1)
    rows = load_results(tmp_path / "out")
    assert rows and all((r["room_name"], r["distance_m"], r["rt60_s"]) == ("living", 3.0, 0.45) for r in rows)


def _row(i: int, room: str | None, distance: float | None, snr: float | None, correct: bool) -> dict[str, Any]:
    trial = {"correct": correct, "helpful": False, "speedup": 0.1 if correct else -0.1,
             "command": "fetch(milk)", "prob": 0.5}
    row: dict[str, Any] = {"id": f"r{i}", "voice": "flite-slt", "noise": None if snr is None else "pink",
                           "snr_db": snr, "models": {"siftom": trial}}
    if room is not None:
        row.update(room_name=room, distance_m=distance)
    return row


def test_the_breakdown_groups_by_room_distance_and_snr() -> None:
    rows = [_row(0, "kitchen", 1.0, None, True), _row(1, "kitchen", 3.0, 10.0, False),
            _row(2, "open", 3.0, None, True), _row(3, "open", 3.0, 10.0, False)]
    by = breakdown(rows, ["siftom"], "room_distance")
    assert list(by) == ["kitchen @ 1 m", "kitchen @ 3 m", "open @ 3 m"]
    assert by["open @ 3 m"]["siftom"].accuracy == 0.5 and by["open @ 3 m"]["siftom"].n == 2
    assert list(breakdown(rows, ["siftom"], "distance")) == ["1 m", "3 m"]
    assert list(breakdown(rows, ["siftom"], "distance_snr")) == ["1 m @ clean", "3 m @ clean", "3 m @ 10 dB"]
    assert group_key({"extra": {"room_name": "living", "distance_m": 2}}, "room") == "living"


def _results(tmp_path: Path, rooms: bool) -> Path:
    """A results folder and its dataset's manifest (the rooms only in the manifest, as siftom eval writes)."""
    ds, res = tmp_path / "ds", tmp_path / "res"
    ds.mkdir(parents=True)
    res.mkdir(parents=True)
    plan = [("kitchen", 1.0, None, True), ("kitchen", 1.0, 10.0, True), ("open", 3.0, None, True),
            ("open", 3.0, 10.0, False)]
    rows = [_row(i, None, None, snr, ok) for i, (_r, _d, snr, ok) in enumerate(plan)]
    extra = [{"room_name": r, "distance_m": d, "rt60_s": 0.4} if rooms else {} for r, d, _s, _ok in plan]
    (ds / "manifest.jsonl").write_text("".join(json.dumps({"id": f"r{i}", "extra": e}) + "\n"
                                               for i, e in enumerate(extra)))
    (res / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    (res / "run.json").write_text(json.dumps({"dataset": str(ds), "seed": 0}))
    return res


def test_the_report_adds_room_breakdowns_only_for_a_rooms_set(tmp_path: Path) -> None:
    from siftom.bench.report import write_report

    summary = write_report(_results(tmp_path / "a", rooms=True), figures=False)
    assert summary["breakdowns"]["room"]["open"]["siftom"]["accuracy"] == 0.5
    assert list(summary["breakdowns"]["room_distance"]) == ["kitchen @ 1 m", "open @ 3 m"]
    report = (tmp_path / "a" / "res" / "report.md").read_text()
    assert "## By room and talker distance" in report and "| kitchen | 100.0 % (2) | – |" in report
    plain = write_report(_results(tmp_path / "b", rooms=False), figures=False)
    assert set(plain["breakdowns"]) == {"noise", "snr", "voice"} and set(plain["asr_wer"]) == {"snr", "voice", "all"}
    assert "By room" not in (tmp_path / "b" / "res" / "report.md").read_text()


def test_a_results_page_shows_rooms_only_when_the_summary_has_them() -> None:
    from siftom.bench.pages import _set_page
    from siftom.bench.reproduce import Machine, SetData, SetResult

    cell = {"accuracy": 0.5, "speedup": 0.1, "n": 4}
    summary: dict[str, Any] = {"models": {"siftom": {"accuracy": 0.5, "n": 8, "speedup": 0.1}},
                               "breakdowns": {"room_distance": {"kitchen @ 1 m": {"siftom": cell}},
                                              "distance_snr": {"1 m @ clean": {"siftom": cell}}}}

    def page(s: dict[str, Any]) -> str:
        return _set_page(SetResult("s", "s", "0", "?", SetData("f", 1, "kitchen-v0", 0), Machine(),
                                   ("siftom eval D --out R --models siftom",), (0.0, 0.0), s))

    text = page(summary)
    assert "## Accuracy by room and talker distance" in text and "| kitchen, 1 m | 4 | 50.0 % |" in text
    assert "| 1 m, clean | 4 | 50.0 % |" in text
    assert "room" not in page({"models": summary["models"]})


@pytest.mark.parametrize(("flags", "words"), [
    (["--rooms", "garage", "--distances", "1"], "unknown room 'garage'"),
    (["--rooms", "kitchen", "--distances", "1,far"], "--distances must be comma-separated metres"),
    (["--rooms", "kitchen", "--distances", "4"], "at most 3.2 m"),
])
def test_the_build_flags_refuse_bad_rooms_and_distances_before_any_work(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], flags: list[str], words: str) -> None:
    from siftom.cli import main

    out = tmp_path / "ds"
    assert main(["dataset", "build", "--domain", "kitchen-v0", "--out", str(out), *flags]) == 2
    assert words in capsys.readouterr().err and not out.exists()
