"""Whisper teacher-forced scoring: an acoustic model independent of pocketsphinx ranks the words said first."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from siftom.likelihood.whisper_factor import candidate_texts, whisper_available
from siftom.observation import Hypothesis, Instruction
from siftom.speech.whisper_score import whisper_text
from siftom.world.commands import RobotCommand

needs_whisper = pytest.mark.skipif(not whisper_available(), reason="needs the whisper extra")
needs_flite = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
FOODS = ("cereal", "oatmeal", "milk", "sugar", "coffee", "honey", "flour", "pasta")


@pytest.fixture(scope="module")
def scorer():  # noqa: ANN201
    from siftom.speech.whisper_score import WhisperScorer

    return WhisperScorer(pad_s=3.0)


def test_candidates_are_written_as_whisper_writes():
    assert whisper_text("can you pass me the cereal") == " Can you pass me the cereal."
    assert whisper_text("olive_oil please?") == " Olive oil please?"
    assert whisper_text("  ") == ""


def test_only_the_heard_object_words_change_between_commands():
    """Free carriers: every command is scored in the words that were heard, only the key phrase
    differs, so the carrier costs every command the same."""
    heard = Instruction(nbest=(Hypothesis("could you maybe pass me the serial please", -1.0),))
    cmds = [RobotCommand.parse(f"fetch({f})") for f in ("cereal", "milk", "olive_oil")]
    texts, mode = candidate_texts(heard, cmds)
    assert mode == "sentence"  # "serial" is no command's word: each command's closest phrasing
    heard = Instruction(nbest=(Hypothesis("could you maybe pass me the milk please", -1.0),))
    texts, mode = candidate_texts(heard, cmds)
    assert mode == "key"
    assert texts[0][0][0] == "could you maybe pass me the cereal please"
    assert texts[1][0][0] == "could you maybe pass me the milk please"
    assert all(t.startswith("could you maybe pass me the ") and t.endswith(" please")
               for items in texts for t, _ in items)
    # pruning: only the kept commands are returned, in the order asked
    kept, _ = candidate_texts(heard, cmds, [2, 0])
    assert [items[0][0] for items in kept] == [texts[2][0][0], texts[0][0][0]]



def test_a_lost_object_is_guessed_after_the_heard_words_or_in_place_of_the_last():
    """No command's word was heard ("we still need the", "i'm"): besides its closest phrasing,
    every command is scored with its key phrase after the heard words and in place of the last
    one, and every command gets the same kinds of guess."""
    cmds = [RobotCommand.parse(f"fetch({f})") for f in ("onion", "milk")]
    texts, mode = candidate_texts(Instruction(nbest=(Hypothesis("we still need the", -1.0),)), cmds)
    assert mode == "sentence"
    onion = [t for t, _ in texts[0]]
    assert "we still need the onion" in onion and "we still need onion" in onion
    assert not any("milk" in t for t in onion)
    # each kind of guess weighs the same for every command: its key-phrase priors sum to 1
    for items in texts:
        assert np.isclose(np.logaddexp.reduce([lp for _, lp in items]), np.log(3.0))
    texts, _ = candidate_texts(Instruction(nbest=(Hypothesis("i'm", -1.0),)), cmds)
    assert "onion" in [t for t, _ in texts[0]] and "i'm onion" in [t for t, _ in texts[0]]
    # nothing heard at all ("no speech" keeps an empty 1-best): only the closest phrasing is scored
    texts, _ = candidate_texts(Instruction(nbest=(Hypothesis("", -1.0),)), cmds)
    assert [len(items) for items in texts] == [1, 1]

def test_another_transcript_gives_its_carrier_when_the_1best_lost_the_object():
    """pocketsphinx heard "i'm" but Whisper heard the request: every command is scored in
    Whisper's carrier (the same carrier for all), not only by guesses around "i'm"."""
    cmds = [RobotCommand.parse(f"fetch({f})") for f in ("onion", "milk")]
    lost = Instruction(nbest=(Hypothesis("i'm", -1.0),))
    texts, mode = candidate_texts(lost, cmds, also_heard=[["could", "you", "bring", "me", "an", "onion"]])
    assert mode == "key"
    assert "could you bring me an onion" in [t for t, _ in texts[0]]
    assert "could you bring me an milk" in [t for t, _ in texts[1]]
    assert all(t.startswith("could you bring me an ") for items in texts for t, _ in items)
    # both transcripts hold a key word: both carriers, for every command alike
    heard = Instruction(nbest=(Hypothesis("get me milk", -1.0),))
    texts, _ = candidate_texts(heard, cmds, also_heard=[["get", "me", "onion", "please"]])
    assert {"get me onion", "get me onion please"} <= {t for t, _ in texts[0]}
    assert {"get me milk", "get me milk please"} <= {t for t, _ in texts[1]}
    # neither holds one: each transcript adds its own guesses ("has me some will" -> "has me some onion")
    texts, mode = candidate_texts(lost, cmds, also_heard=[["has", "me", "some", "will"]])
    assert mode == "sentence"
    assert {"i'm onion", "has me some will onion", "has me some onion"} <= {t for t, _ in texts[0]}
    # a key word heard in the plural still marks where the object was said
    texts, mode = candidate_texts(lost, [RobotCommand.parse("fetch(orange_juice)"), cmds[1]],
                                  also_heard=[["i", "still", "need", "the", "oranges"]])
    assert mode == "key" and "i still need the orange juice" in [t for t, _ in texts[0]]
    # an empty second transcript changes nothing
    assert candidate_texts(lost, cmds, also_heard=[[]]) == candidate_texts(lost, cmds)


@needs_whisper
@needs_flite
def test_whisper_transcribes_a_clear_request(scorer):
    """Whisper's own words (the second carrier) for a clean TTS request: lowercase, no punctuation."""
    from siftom.speech.tts import synthesize

    words = scorer.transcribe_encoded(scorer.encode(synthesize("could you bring me some milk", "flite-slt")))
    assert words[-1] == "milk" and words[:2] == ["could", "you"]
    assert all(w == w.lower() and w.isalpha() for w in words)


@needs_whisper
@needs_flite
def test_a_long_prompt_of_object_names_leaves_room_for_the_transcript(scorer):
    """CTranslate2 counts the prompt in max_length: the transcript's cap is raised by it."""
    from siftom.scenarios.base import get_scenario
    from siftom.speech.tts import synthesize

    names = ", ".join(c.replace("_", " ") for c in get_scenario("kitchen-cereal-v0").world.classes)
    assert len(scorer.tokenizer.encode(names)) > 40  # longer than the cap for a 2 s clip
    words = scorer.transcribe_encoded(scorer.encode(synthesize("could you bring me some milk", "flite-slt")),
                                      prompt=names)
    assert "milk" in words


@needs_whisper
def test_a_local_model_folder_is_the_whisper_model_setting(tmp_path, monkeypatch):
    """whisper_model: the packaged tiny.en given by its folder (argument, setting, flag) is what runs;
    a folder that is not a model is refused with the fix."""
    from click.testing import CliRunner

    from siftom.cli import root
    from siftom.errors import BackendUnavailableError
    from siftom.likelihood.acoustic import AcousticLikelihood
    from siftom.speech.asr.whisper import WHISPER_MODEL_ENV, WhisperEngine, default_model_dir
    from siftom.speech.whisper_score import WhisperScorer

    folder = default_model_dir()
    lk = AcousticLikelihood(whisper_model=folder)
    assert lk._whisper.scorer.model_dir == folder
    monkeypatch.setenv(WHISPER_MODEL_ENV, str(folder))
    assert WhisperScorer(pad_s=3.0).model_dir == folder and WhisperEngine().model_dir == folder
    with pytest.raises(BackendUnavailableError, match="ct2-transformers-converter"):
        AcousticLikelihood(whisper_model=tmp_path)
    monkeypatch.setenv(WHISPER_MODEL_ENV, str(tmp_path))
    with pytest.raises(BackendUnavailableError, match="not a CTranslate2 whisper folder"):
        WhisperScorer(pad_s=3.0)
    monkeypatch.delenv(WHISPER_MODEL_ENV)
    r = CliRunner().invoke(root, ["infer", "--whisper-model", str(tmp_path), "--scenario", "kitchen-cereal-v0",
                                  "--transcript", "pass me the cereal"])
    assert r.exit_code == 2 and "not a CTranslate2 whisper folder" in r.output
    r = CliRunner().invoke(root, ["infer", "--whisper-model", str(folder), "--scenario", "kitchen-cereal-v0",
                                  "--transcript", "pass me the cereal", "--json"])
    assert r.exit_code == 0, r.output
    import os

    assert os.environ.pop(WHISPER_MODEL_ENV) == str(folder.resolve())  # the flag set the setting


@needs_whisper
@needs_flite
@pytest.mark.parametrize(("said", "voice", "snr"), [("can you pass me the cereal", "flite-slt", None),
                                                    ("bring me the sugar", "flite-rms", 10.0),
                                                    ("i need the coffee", "flite-awb", 10.0)])
def test_the_spoken_sentence_scores_best(scorer, said, voice, snr):
    """On real TTS clips (clean and in babble) the sentence said outscores the same carrier with
    any other food, including near homophones of what a pocketsphinx recogniser confuses."""
    from siftom.speech.noise import get_noise, mix_at_snr
    from siftom.speech.tts import synthesize

    x = synthesize(said, voice)
    if snr is not None:
        x = mix_at_snr(x, get_noise("babble"), snr, 3)
    said_food = next(f for f in FOODS if said.endswith(f))
    texts = [said.replace(said_food, f) for f in FOODS]
    scores = scorer.score(x, texts)
    assert np.all(np.isfinite(scores))
    assert texts[int(np.argmax(scores))] == said, dict(zip(texts, np.round(scores, 1), strict=True))


@needs_whisper
@needs_flite
def test_padding_does_not_change_the_ranking_much(scorer):
    """Scores of the encoder on a few seconds of features rank like the 30 s window Whisper was trained on."""
    from siftom.speech.tts import synthesize
    from siftom.speech.whisper_score import WhisperScorer

    x = synthesize("pass me the honey", "flite-slt")
    texts = [f"pass me the {f}" for f in FOODS]
    short, full = scorer.score(x, texts), WhisperScorer(pad_s=30.0).score(x, texts)
    assert np.argmax(short) == np.argmax(full) == FOODS.index("honey")


def test_bad_padding_is_refused():
    from siftom.errors import SiftomError
    from siftom.speech.whisper_score import WhisperScorer

    with pytest.raises(SiftomError, match="pad_s"):
        WhisperScorer(pad_s=0)


def test_a_transcript_that_starts_over_is_cut_where_it_does():
    from siftom.speech.whisper_score import cut_repeat

    loop = ["the", "wineglass", "is", "please", "the", "wine", "glass", "is", "please", "the", "wine", "glass's", "please"]
    assert cut_repeat(loop) == ["the", "wineglass", "is", "please"]
    once = ["could", "you", "get", "me", "the", "cereal", "and", "the", "sugar", "please"]
    assert cut_repeat(once) == once
