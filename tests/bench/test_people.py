"""Recording people, mixing noise, the human baseline and ratings, without a browser.

tests/service/test_browser_people.py drives the same through the pages in Chromium.
"""

from __future__ import annotations

import json
from collections import Counter

import numpy as np
import pytest

from siftom.bench.human import ratings_summary, score_answers
from siftom.bench.mix import MixOptions, mix_dataset
from siftom.errors import AudioError, DatasetError
from siftom.people.annotate import AnnotateOptions, Annotation, answer_command, plan_assignments
from siftom.people.collect import Collection, CollectOptions, ask_words, goal_words
from siftom.people.ratings import check_scores, import_ratings, session_model
from siftom.people.stimuli import load_dataset, resolve_scenario, scenario_for
from siftom.speech.audio import load_audio, wav_bytes


def _tone(seconds: float = 1.0, amp: float = 0.3) -> np.ndarray:
    t = np.arange(int(16000 * seconds)) / 16000
    return (amp * np.sin(2 * np.pi * 220 * t) * (0.6 + 0.4 * np.sin(2 * np.pi * 3 * t))).astype(np.float32)


@pytest.fixture()
def collection(tmp_path):
    c = Collection(tmp_path / "ds", CollectOptions(domain="kitchen-v0", scenarios=2))
    c.agree("p1")
    for k in range(2):
        c.save("p1", k, wav_bytes(_tone(1.0 + 0.2 * k)), f"bring me item {k}")
    return c


def test_goal_and_request_in_words():
    sc = resolve_scenario("household-table-v0/0", "household-table-v0", None)
    assert goal_words(sc) == "Set the table with 4 knives and 4 bowls."
    assert ask_words(sc) == "You want the robot to bring the bowls (4)."
    kitchen = resolve_scenario("kitchen-v0/0", "kitchen-v0", None)
    assert goal_words(kitchen) == "Make breakfast cereal: you need bowl, cereal and milk."
    assert ask_words(kitchen) == "You want the robot to bring you the milk."


def test_recordings_become_a_dataset_that_loads(collection):
    ds = load_dataset(collection.root)
    assert [s.id for s in ds.stimuli] == ["000-p1-clean", "001-p1-clean"]
    s = ds.stimuli[1]
    sc = scenario_for(s)  # the manifest's actions replay in the scenario
    assert s.gold_command == str(sc.command) and s.speaker == "p1" and s.voice == "human"
    assert s.reference == "bring me item 1" and s.duration_s == pytest.approx(1.2, abs=0.01)
    assert load_audio(ds.audio_path(s)).shape == (int(16000 * 1.2),)
    assert collection.done("p1") == [0, 1] and collection.done("p2") == []


def test_recording_again_replaces_the_take(collection):
    collection.save("p1", 0, wav_bytes(_tone(2.0)), "a second take")
    ds = load_dataset(collection.root)
    assert len(ds.stimuli) == 2
    assert ds.stimuli[0].reference == "a second take" and ds.stimuli[0].duration_s == pytest.approx(2.0)


def test_no_recording_without_consent_or_with_a_dead_microphone(collection):
    with pytest.raises(DatasetError, match="has not agreed"):
        collection.save("p2", 0, wav_bytes(_tone()), "hello")
    with pytest.raises(AudioError, match="silent"):
        collection.save("p1", 0, wav_bytes(np.zeros(16000, dtype=np.float32)), "hello")
    with pytest.raises(AudioError, match="cannot read"):
        collection.save("p1", 0, b"not audio at all", "hello")
    with pytest.raises(DatasetError, match="type what you said"):
        collection.save("p1", 0, wav_bytes(_tone()), "  ")
    with pytest.raises(DatasetError, match="not valid"):
        collection.agree("Jane Doe")
    with pytest.raises(DatasetError, match="holds recordings of kitchen-v0"):
        Collection(collection.root, CollectOptions(domain="household-table-v0", scenarios=1))
    built = collection.root.parent / "built"
    built.mkdir()
    (built / "dataset.json").write_text(json.dumps({"options": {"domain": "kitchen-v0", "voices": ["flite-slt"]}}))
    with pytest.raises(DatasetError, match="built by 'siftom dataset build'"):
        Collection(built, CollectOptions(domain="kitchen-v0", scenarios=1))


def test_mix_adds_noisy_copies_at_the_snr_and_is_repeatable(collection):
    from siftom.speech.noise import measure_snr

    ds, written = mix_dataset(collection.root, MixOptions(snrs=(20.0, 5.0), seed=4))
    assert written == 4 and [s.condition.split("@")[0] for s in ds.stimuli][:3] == ["clean", ds.stimuli[1].noise,
                                                                                    ds.stimuli[2].noise]
    assert Counter(s.snr_db for s in ds.stimuli) == {None: 2, 20.0: 2, 5.0: 2}
    clean = load_audio(ds.audio_path(ds.stimuli[0]))
    noisy = load_audio(ds.audio_path(ds.stimuli[2]))
    assert measure_snr(clean, noisy - clean) == pytest.approx(5.0, abs=0.5)
    first = {s.id: ds.audio_path(s).read_bytes() for s in ds.stimuli}
    again, _ = mix_dataset(collection.root, MixOptions(snrs=(20.0, 5.0), seed=4))
    assert {s.id: again.audio_path(s).read_bytes() for s in again.stimuli} == first  # same bytes
    other, _ = mix_dataset(collection.root, MixOptions(snrs=(10.0,), seed=4))  # a new mix replaces the old
    assert len(other.stimuli) == 4 and {s.snr_db for s in other.stimuli} == {None, 10.0}
    assert len(list((collection.root / "audio").glob("*.wav"))) == 4
    spec = json.loads((collection.root / "dataset.json").read_text())
    assert spec["mix"]["snrs"] == [10.0] and spec["options"]["noise_dir"]


def test_mix_refuses_unknown_noise(collection):
    with pytest.raises(DatasetError, match="categories"):
        mix_dataset(collection.root, MixOptions(noises=("thunder",)))
    with pytest.raises(DatasetError, match="SNR"):
        MixOptions(snrs=())


@pytest.mark.parametrize("per_annotator", [None, 2])
def test_every_stimulus_gets_k_annotators_never_the_same_recording_twice(per_annotator):
    # 5 recordings: 4 in 4 conditions, one clean only
    items = [(f"r{r}-c{c}", f"r{r}") for r in range(4) for c in range(4)] + [("r4-c0", "r4")]
    plan = plan_assignments(items, 3, per_annotator, seed=7)
    assert Counter(i for a in plan for i in a) == {i: 3 for i, _ in items}
    assert all(len({i.split("-")[0] for i in a}) == len(a) for a in plan)  # a recording at most once
    if per_annotator is None:
        assert sorted(len(a) for a in plan) == [4] * 9 + [5] * 3  # one layer per condition and round
    else:
        assert max(len(a) for a in plan) == 2
    assert plan == plan_assignments(items, 3, per_annotator, seed=7)
    assert plan != plan_assignments(items, 3, per_annotator, seed=8)


def test_answers_are_commands_of_the_scene():
    kitchen = resolve_scenario("kitchen-v0/0", "kitchen-v0", None)
    table = resolve_scenario("household-table-v0/0", "household-table-v0", None)
    assert answer_command(kitchen, "milk", None) == "fetch(milk)"
    assert answer_command(table, "bowl", 4) == "deliver(bowl,4)"
    assert answer_command(table, "none", None) == "none"
    with pytest.raises(DatasetError, match="how many"):
        answer_command(table, "bowl", None)
    with pytest.raises(DatasetError, match="not in this scene"):
        answer_command(table, "milk", 1)


def test_scored_answers_are_a_human_model(collection, tmp_path):
    from siftom.bench.report import write_report

    ds, _ = mix_dataset(collection.root, MixOptions(snrs=(10.0,), seed=1))
    ann = Annotation(ds, tmp_path / "ann", AnnotateOptions(per_stimulus=2, seed=3))
    assert len(ann.assignments) == 4  # 2 rounds x 2 layers (clean, 10 dB), each with both recordings
    names = []
    for _ in range(4):
        who = ann.join(None).annotator
        names.append(who)
        while (pos := ann.next_position(who)) is not None:
            s = ann.stimulus_at(who, pos)
            item = scenario_for(s).command.obj_class if s.scenario.endswith("/0") else "milk"
            ann.answer(who, pos, s.reference if who in names[::2] else "bring me", item, None)
    with pytest.raises(DatasetError, match="every assignment is taken"):
        ann.join(None)
    with pytest.raises(DatasetError, match="already answered"):
        ann.answer(names[0], 0, "x", "milk", None)
    res = tmp_path / "res"
    rows = score_answers(tmp_path / "ann", res)
    assert len(rows) == 8 and {r["annotator"] for r in rows} == set(names)
    # right on scenario 0 (its gold class), wrong on scenario 1 ("milk" is not in its goal: not helpful)
    assert all(r["models"]["human"]["correct"] == r["scenario"].endswith("/0") for r in rows)
    assert not any(r["models"]["human"]["helpful"] for r in rows if r["scenario"].endswith("/1"))
    (res / "results.jsonl").write_text("".join(json.dumps({**r, "models": {"stub": r["models"]["human"]}}) + "\n"
                                               for r in rows[::2]))
    summary = write_report(res, figures=False)
    assert summary["models"]["human"]["accuracy"] == 0.5 and summary["models"]["human"]["n"] == 8
    assert summary["human"]["wer"] == pytest.approx(np.mean([r["wer"] for r in rows]))
    assert summary["human"]["wer"] > 0 and summary["human"]["answers_per_stimulus"] == 2


def test_an_annotation_folder_belongs_to_one_dataset(collection, tmp_path):
    Annotation(collection.root, tmp_path / "ann", AnnotateOptions(per_stimulus=1))
    with pytest.raises(DatasetError, match="another dataset or with other options"):
        Annotation(collection.root, tmp_path / "ann", AnnotateOptions(per_stimulus=2))


def test_ratings():
    assert session_model("full", "auto") == "siftom" and session_model("full", "phonetic") == "siftom-phonetic"
    assert session_model("speech-only", "phonetic") == "speech-only"
    assert check_scores([1, 4, 7]) == [1, 4, 7]
    for bad in ([1, 2], [0, 4, 7], [1, 2, 8], [1.5, 2, 3], "123", [True, 2, 3]):
        with pytest.raises(DatasetError, match="from 1"):
            check_scores(bad)
    s = ratings_summary([{"model": "siftom", "scores": [6, 5, 7]}, {"model": "siftom", "scores": [4, 4, 4]},
                         {"model": "action-only", "scores": [2, 3, 1]}])
    assert s["siftom"].mean == 5.0 and s["siftom"].statements == (5.0, 4.5, 5.5)
    assert s["action-only"].mean == 2.0 and s["action-only"].n == 1


def test_importing_ratings_twice_adds_them_once(tmp_path):
    src = tmp_path / "ratings.jsonl"
    src.write_text(json.dumps({"id": "r1", "model": "siftom", "scores": [7, 7, 6]}) + "\n")
    (tmp_path / "res").mkdir()
    assert import_ratings(src, tmp_path / "res") == 1
    assert import_ratings(tmp_path, tmp_path / "res") == 0
    src.write_text(json.dumps({"id": "r2", "model": "siftom", "scores": [9, 7, 6]}) + "\n")
    with pytest.raises(DatasetError, match="from 1"):
        import_ratings(src, tmp_path / "res")


def test_the_tutorials_commands_parse(monkeypatch):
    """Every `siftom ...` line of docs/tutorials/own-participants.md names real commands and options."""
    import re
    import shlex
    from pathlib import Path

    import click

    from siftom.cli import root

    doc = (Path(__file__).parents[2] / "docs" / "tutorials" / "own-participants.md").read_text()
    lines = [ln.strip().rstrip("&").strip() for block in re.findall(r"```bash\n(.*?)```", doc, re.S)
             for ln in block.replace("\\\n", " ").splitlines() if ln.strip().startswith("siftom ")]
    assert len(lines) >= 12
    ran: list[str] = []

    def stub(group: click.Group) -> None:
        for name, cmd in group.commands.items():
            if isinstance(cmd, click.Group):
                stub(cmd)
            else:
                monkeypatch.setattr(cmd, "callback", lambda _n=name, **kw: ran.append(_n))

    stub(root)
    for line in lines:
        root.main(args=shlex.split(line)[1:], prog_name="siftom", standalone_mode=False)
    assert set(ran) >= {"collect", "mix", "check", "eval", "annotate", "report", "serve", "say"}


def test_actions_in_words():
    from siftom.people.collect import action_words

    sc = resolve_scenario("household-table-v0/0", "household-table-v0", None)
    words = [action_words(sc.world, a) for a in sc.actions]
    assert words[:3] == ["You walked to the living cabinet.", "You opened the living cabinet.",
                         "You took a knife from the living cabinet."]
    assert words[5] == "You put a knife on the dining table."
    assert action_words(sc.world, sc.actions[0], "The person") == "The person walked to the living cabinet."


def test_answers_of_another_version_of_the_dataset_are_refused(collection, tmp_path):
    ann = Annotation(collection.root, tmp_path / "ann", AnnotateOptions(per_stimulus=1))
    who = ann.join("x1").annotator
    ann.answer(who, 0, "milk", "milk", None)
    assert len(score_answers(tmp_path / "ann", tmp_path / "res")) == 1
    collection.save("p1", 0, wav_bytes(_tone(1.5)), "another take")  # the manifest changes
    with pytest.raises(DatasetError, match="not the one annotated"):
        score_answers(tmp_path / "ann", tmp_path / "res")
