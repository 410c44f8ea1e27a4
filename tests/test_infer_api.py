"""siftom.infer: one call from a scene, actions and what was heard to a typed posterior."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import siftom
from siftom.errors import ObservationError, SettingsError, UnknownNameError
from siftom.settings import Settings
from siftom.world.commands import RobotCommand

ROOT = Path(__file__).resolve().parents[1]
SALAD = ROOT / "docs" / "examples" / "salad"
WORLD, ACTIONS = SALAD / "world.json", SALAD / "actions.txt"
SENTENCE = "can you get me the potato"


@pytest.fixture(scope="module")
def potato_wav(tmp_path_factory):
    out = tmp_path_factory.mktemp("say") / "potato.wav"
    r = subprocess.run([sys.executable, "-m", "siftom.cli", "say", SENTENCE, "-o", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return out


def test_the_done_when_line_prints_fetch_tomato():
    code = (f"import siftom; p = siftom.infer({str(WORLD)!r}, {str(ACTIONS)!r}, {SENTENCE!r}); "
            "print(p.command)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "fetch(tomato)"


def test_a_transcript_gives_a_typed_command():
    p = siftom.infer(str(WORLD), str(ACTIONS), SENTENCE)
    assert isinstance(p.command, RobotCommand)
    assert (p.command.verb, p.command.obj_class, p.command.count) == ("fetch", "tomato", 1)
    assert str(p.command) == "fetch(tomato)" and p.command == "fetch(tomato)"
    assert p.commands[0][0] == p.command and p.prob("fetch(tomato)") == p.commands[0][1]
    assert [g for g, _ in p.goals] and p.decision.rule == "teammate"  # the default rule
    assert p.action == "act" and p.top_command == p.command
    assert json.loads(json.dumps(p.to_json()))["command"] == "fetch(tomato)"


def test_the_actions_change_the_answer():
    """Without the salad actions 'potato' cannot become tomato: the words alone decide."""
    alone = siftom.infer(str(WORLD), None, SENTENCE)
    assert alone.command != "fetch(tomato)" or alone.commands[0][1] < siftom.infer(
        str(WORLD), str(ACTIONS), SENTENCE).commands[0][1]


def test_audio_path_and_samples_give_the_same_command(potato_wav):
    from siftom.speech.audio import as_audio

    by_path = siftom.infer(str(WORLD), str(ACTIONS), str(potato_wav))
    # a clear recording of "potato" where a potato is: the salad makes the tomato likely enough
    # that the robot fetches it or asks which one; it never fetches the potato unasked-about
    assert (by_path.action == "act" and str(by_path.command) == "fetch(tomato)") or (
        by_path.action == "ask" and "fetch(tomato)" in by_path.decision.options), by_path.decision
    assert by_path.evidence["speech_heard"] is True and by_path.transcript
    by_samples = siftom.infer(str(WORLD), str(ACTIONS), as_audio(potato_wav))
    assert by_samples.command == by_path.command and by_samples.action == by_path.action


def test_silence_falls_back_to_the_actions():
    p = siftom.infer(str(WORLD), str(ACTIONS), np.zeros(16000, dtype=np.float32))
    assert p.mode == "action-only" and p.evidence["speech_heard"] is False


def test_nbest_forms_virtualhome_lines_and_a_decision():
    vh = SALAD / "actions_vh.txt"
    texts = siftom.infer(str(WORLD), str(vh), [SENTENCE, "can you get me the lettuce"])
    pairs = siftom.infer(str(WORLD), vh, [(SENTENCE, 0.0), ("can you get me the lettuce", -1.0)])
    assert texts.command == pairs.command == "fetch(tomato)"
    d = siftom.infer(str(WORLD), str(ACTIONS), SENTENCE, decide="map")
    assert d.decision is not None and d.decision.command == d.command
    assert d.to_json()["decision"]["rule"] == "map"


def test_a_scenario_id_uses_its_own_actions():
    p = siftom.infer("kitchen-cereal-v0", heard="can you pass me the cereal")
    assert p.command == "fetch(cereal)" and p.n_actions > 0


def test_bad_inputs_are_named_errors():
    with pytest.raises(UnknownNameError, match="kitchen-cereal-v0"):
        siftom.infer("kitchen-cereal-v9", heard="x")
    with pytest.raises(ObservationError, match="no such file"):
        siftom.infer("missing/world.json", heard="x")
    with pytest.raises(ObservationError, match="no such audio file"):
        siftom.infer(str(WORLD), None, "missing.wav")
    with pytest.raises(ObservationError, match="N-best list is empty"):
        siftom.infer(str(WORLD), None, [])
    with pytest.raises(ObservationError, match=r"actions\[0\].*not where human stands"):
        siftom.infer(str(WORLD), ["grab(human, tomato_1, fridge)"], SENTENCE)


def test_the_package_lists_its_public_names():
    names = dir(siftom)
    for n in ("infer", "listen", "Posterior", "RobotCommand", "Settings", "SiftomError", "Answer", "Observer"):
        assert n in names
    assert "importlib" not in names and "TYPE_CHECKING" not in names and "Heard" not in names  # one name: Answer
    assert siftom.RobotCommand is RobotCommand


def test_settings_precedence_and_unknown_keys(tmp_path):
    f = tmp_path / "siftom.toml"
    f.write_text('[infer]\nlikelihood = "acoustic"\nnbest = 3\n[model]\nbetas = [1.0, 2.0]\n')
    s = Settings.load(f, env={"SIFTOM_INFER_NBEST": "5"}, flags={"infer.nbest": 7})
    assert s.infer.likelihood == "acoustic" and s.infer.nbest == 7 and s.model.betas == (1.0, 2.0)
    assert s.sources["infer.nbest"] == "flag" and s.sources["infer.likelihood"] == f"file {f}"
    s = Settings.load(f, env={"SIFTOM_INFER_NBEST": "5"})
    assert s.infer.nbest == 5 and s.sources["infer.nbest"] == "env SIFTOM_INFER_NBEST"
    shown = {k: (v, src) for k, v, src in s.show()}
    assert shown["model.epsilon"][1] == "default" and shown["infer.nbest"] == (5, "env SIFTOM_INFER_NBEST")
    f.write_text("[infer]\nlikelihod = 'acoustic'\n")
    with pytest.raises(SettingsError, match="likelihod"):
        Settings.load(f, env={})
    with pytest.raises(SettingsError, match="SIFTOM_MODEL_BETA"):
        Settings.load(env={"SIFTOM_MODEL_BETA": "1"})
    with pytest.raises(SettingsError, match="infer.nbest"):
        Settings.load(env={}, flags={"infer.nbest": "many"})
    f.write_text("[rules.ask-or-act]\nask_kost = 1.0\n")
    with pytest.raises(SettingsError, match="ask_kost"):
        Settings.load(f, env={})


def test_settings_reach_the_model():
    s = Settings.load(env={}, flags={"model.mode": "action-only"})
    p = siftom.infer(str(WORLD), str(ACTIONS), SENTENCE, settings=s)
    assert p.mode == "action-only" and p.likelihood == "none"


def test_all_lists_exactly_the_lazy_names():
    assert set(siftom.__all__) == {"__version__", *siftom._PUBLIC}


def test_likelihood_options_are_settings(tmp_path):
    f = tmp_path / "siftom.toml"
    f.write_text("[likelihoods.phonetic]\ncache_size = 16\n")
    s = Settings.load(f, env={})
    assert s.likelihood_options("phonetic") == {"cache_size": 16}
    assert siftom.infer(str(WORLD), str(ACTIONS), SENTENCE, settings=s).command == "fetch(tomato)"
    f.write_text("[likelihoods.phonetic]\ncache_sise = 16\n")
    with pytest.raises(SettingsError, match="cache_sise"):
        Settings.load(f, env={})


def test_the_cli_reads_the_settings_file_and_flags_beat_it(tmp_path):
    from siftom.cli import main

    f = tmp_path / "siftom.toml"
    f.write_text('[model]\nmode = "action-only"\n')
    args = ["infer", "--scene", str(WORLD), "--actions", str(ACTIONS), "--transcript", SENTENCE, "--json"]
    r = subprocess.run([sys.executable, "-m", "siftom.cli", *args, "--config", str(f)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["mode"] == "action-only"
    r = subprocess.run([sys.executable, "-m", "siftom.cli", *args, "--config", str(f), "--model", "full"],
                       capture_output=True, text=True, timeout=120)
    assert json.loads(r.stdout)["mode"] == "full"
    f.write_text('[modle]\nmode = "full"\n')
    assert main([*args, "--config", str(f)]) == 2
