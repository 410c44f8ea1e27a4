"""A world names its own objects: ``"names": {"cheese": ["parmesan"]}`` reaches every likelihood and door."""

from __future__ import annotations

import copy
import json
import shutil
from pathlib import Path

import pytest

import siftom
from siftom.errors import ObservationError
from siftom.likelihood.lexicon import default_lexicon, lexicon_for
from siftom.world.io import scene_from_json, scene_to_json

SALAD = Path(__file__).resolve().parents[2] / "docs" / "examples" / "salad"
ACTIONS = ["walk(human, fridge)", "open(human, fridge)"]


def salad(names: dict[str, object] | None = None, rename: tuple[str, str] | None = None) -> dict[str, object]:
    """The salad example, with the cucumber's class renamed (``rename``) and ``names`` added."""
    w = json.loads((SALAD / "world.json").read_text())
    if rename is not None:
        old, new = rename
        for it in w["items"]:
            if it["class"] == old:
                it["class"] = new
        for g in w["goals"]:
            if old in g["counts"]:
                g["counts"][new] = g["counts"].pop(old)
    if names is not None:
        w["names"] = names
    return w


def write(tmp_path: Path, world: dict[str, object]) -> str:
    path = tmp_path / "world.json"
    path.write_text(json.dumps(world))
    return str(path)


def test_names_are_read_checked_and_written_back():
    scene = scene_from_json(salad({"cheese": ["Parmesan", "parmesan", "hard  cheese"], "bowl": "salad bowl"}))
    assert scene.world.names == (("bowl", ("salad bowl",)), ("cheese", ("parmesan", "hard cheese")))
    again = scene_to_json(scene.world, scene.start, scene.goals, scene.verb)
    assert again["names"] == {"bowl": ["salad bowl"], "cheese": ["parmesan", "hard cheese"]}
    assert scene_from_json(again).world.names == scene.world.names


@pytest.mark.parametrize(("names", "says"), [
    ({"pizza": ["pizza"]}, "unknown object class of this world 'pizza'"),
    ({"cheese": []}, "a name or a non-empty list of names"),
    ({"cheese": ["parmesan2"]}, "write numbers as words"),
    (["cheese"], "must map an object class"),
])
def test_bad_names_say_what_is_wrong(names, says):
    with pytest.raises(ObservationError, match=says):
        scene_from_json(salad(names))


def test_a_class_that_cannot_be_said_needs_a_name():
    with pytest.raises(ObservationError, match=r'cannot be said.*"names"'):
        scene_from_json(salad(rename=("cucumber", "veg3")))
    assert scene_from_json(salad({"veg3": ["zucchini"]}, rename=("cucumber", "veg3"))).world.names


def test_a_worlds_names_add_to_the_built_in_ones():
    lex = lexicon_for(scene_from_json(salad({"cheese": ["parmesan"], "veg3": ["zucchini", "courgette"]},
                                            rename=("cucumber", "veg3"))).world)
    assert [n.singular for n in lex.entry("cheese").names] == [
        *[n.singular for n in default_lexicon().entry("cheese").names], "parmesan"]
    assert [n.singular for n in lex.entry("veg3").names] == ["zucchini", "courgette"]
    assert lexicon_for(scene_from_json(salad()).world) is default_lexicon()


def test_the_words_people_say_for_an_object_fetch_it(tmp_path):
    named = write(tmp_path, salad({"cheese": ["parmesan"], "veg3": ["zucchini"]}, rename=("cucumber", "veg3")))
    got = siftom.infer(named, ACTIONS, "pass me the parmesan")
    assert (got.action, got.command) == ("act", "fetch(cheese)")
    assert siftom.infer(named, ACTIONS, "could you get me the zucchini").command == "fetch(veg3)"
    plain = write(tmp_path / "plain", salad()) if (tmp_path / "plain").mkdir() is None else ""
    assert siftom.infer(plain, ACTIONS, "pass me the parmesan").command != "fetch(cheese)"


def test_a_session_on_a_world_with_names_reads_them(tmp_path):
    pytest.importorskip("fastapi")
    from siftom.service.app import create_app
    from support.client import local_client

    with local_client(create_app(tmp_path / "serve")) as c:
        r = c.post("/v1/sessions", json={"world": salad({"cheese": ["parmesan"]})})
        assert r.status_code == 201, r.text
        sid = r.json()["id"]
        assert c.post(f"/v1/sessions/{sid}/actions", json={"actions": ACTIONS}).status_code == 200
        got = c.post(f"/v1/sessions/{sid}/instruction", json={"transcript": "pass me the parmesan"}).json()
        assert got["command"] == "fetch(cheese)", got
        bad = c.post("/v1/sessions", json={"world": salad(rename=("cucumber", "veg3"))})
        assert bad.status_code == 422 and "names" in bad.text


@pytest.mark.skipif(shutil.which("flite") is None, reason="needs flite (make sysdeps)")
def test_spoken_names_are_heard_in_a_recording(tmp_path):
    from siftom.speech import synthesize, write_wav

    named = write(tmp_path, salad({"cheese": ["parmesan"]}))
    clip = write_wav(tmp_path / "say.wav", synthesize("pass me the parmesan please", "flite-slt"))
    got = siftom.listen(clip, named, actions=ACTIONS)
    assert (got.action, got.command) == ("act", "fetch(cheese)"), (got.asr.text if got.asr else "", got.decision)


def test_the_world_file_example_is_unchanged_without_names():
    w = salad()
    assert "names" not in scene_to_json(*(lambda s: (s.world, s.start, s.goals, s.verb))(scene_from_json(copy.deepcopy(w))))
