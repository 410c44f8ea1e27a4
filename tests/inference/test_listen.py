"""siftom.api.listen: audio in, posterior out; no speech -> the actions alone; pruned = full scorer."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from siftom.api import listen
from siftom.speech.audio import write_wav

needs_flite = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
SCENARIO = "kitchen-cereal-v0"


@pytest.fixture(scope="module")
def silence_wav(tmp_path_factory):
    return write_wav(tmp_path_factory.mktemp("listen") / "silence.wav", np.zeros(48_000, dtype=np.float32))


@pytest.fixture(scope="module")
def noise_wav(tmp_path_factory):
    from siftom.speech.noise import get_noise

    x = np.asarray(get_noise("pink").sample(40_000, 2), dtype=np.float32)
    return write_wav(tmp_path_factory.mktemp("listen") / "pink.wav", 0.1 * x / np.sqrt(np.mean(x**2)))


@pytest.fixture(scope="module")
def cereal_wav(tmp_path_factory):
    if shutil.which("flite") is None:
        pytest.skip("flite is not installed")
    from siftom.speech.noise import get_noise, mix_at_snr
    from siftom.speech.tts import synthesize

    x = mix_at_snr(synthesize("can you pass me the cereal", "flite-slt"), get_noise("babble"), 20, 0)
    return write_wav(tmp_path_factory.mktemp("listen") / "cereal.wav", x)


@pytest.mark.parametrize("which", ["silence_wav", "noise_wav"])
def test_no_speech_gives_the_action_only_posterior(which, request):
    from siftom.api import infer_scenario

    heard = listen(request.getfixturevalue(which), scenario=SCENARIO, likelihood="acoustic")
    assert not heard.speech and heard.message == "no speech heard"
    assert heard.asr is None and heard.posterior.transcript == ""
    assert heard.action == "none" and heard.command is None
    ref = infer_scenario(SCENARIO, None, mode="action-only")
    assert [c for c, _ in heard.posterior.commands] == [c for c, _ in ref.commands]
    np.testing.assert_allclose([p for _, p in heard.posterior.commands], [p for _, p in ref.commands], rtol=1e-9)
    body = heard.to_json()
    assert body["speech_heard"] is False and body["asr"] is None


@needs_flite
@pytest.mark.parametrize("likelihood", ["phonetic", "acoustic"])
def test_listen_hears_the_command(cereal_wav, likelihood):
    heard = listen(cereal_wav, scenario=SCENARIO, likelihood=likelihood)
    assert heard.speech and heard.command == "fetch(cereal)"
    evidence = heard.to_json()["evidence"]
    assert evidence["likelihood"] == likelihood and evidence["likelihood_reason"] == "asked for"
    if likelihood == "phonetic":
        assert set(evidence) == {"likelihood", "likelihood_reason", "speech_heard", "instruction_heard",
                                 "instruction_check", "understanding", "parts"}
        assert evidence["understanding"]["request"] and evidence["parts"] == ["fetch(cereal)"]
        assert evidence["instruction_check"] == "nbest"  # no open-vocabulary words: the N-best decides
    else:  # what the acoustic likelihood used is reported: its mode and, with Whisper, Whisper's own words
        from siftom.likelihood.whisper_factor import whisper_available

        assert evidence["acoustic_mode"] and evidence["commands_scored"] >= 1
        if whisper_available():
            assert evidence["acoustic_mode"].startswith("whisper-")
            assert "pass me the" in evidence["whisper_heard"]
            assert evidence["instruction_check"] == "whisper"  # Whisper's own words decide it was a request
            assert evidence["whisper_use"] in ("carrier", "guesses", "none")
    assert heard.posterior.likelihood == likelihood
    assert set(heard.timings) >= {"load", "vad", "asr", "infer"}


@needs_flite
def test_the_default_likelihood_for_a_recording_is_the_best_installed(cereal_wav, monkeypatch):
    """No likelihood named: acoustic with the whisper extra, phonetic without it; the answer says which and why."""
    import siftom.likelihood.whisper_factor as wf

    heard = listen(cereal_wav, scenario=SCENARIO)
    want = "acoustic" if wf.whisper_available() else "phonetic"
    assert heard.posterior.likelihood == want and heard.command == "fetch(cereal)"
    assert heard.to_json()["evidence"]["likelihood"] == want
    monkeypatch.setattr(wf, "whisper_available", lambda: False)  # as without the whisper extra
    heard = listen(cereal_wav, scenario=SCENARIO)
    assert heard.posterior.likelihood == "phonetic"
    assert "siftom[whisper]" in heard.posterior.evidence["likelihood_reason"]


@needs_flite
def test_cli_infer_audio_defaults_to_the_acoustic_likelihood(cereal_wav):
    from click.testing import CliRunner

    from siftom.cli import root as main
    from siftom.likelihood.whisper_factor import whisper_available

    r = CliRunner().invoke(main, ["infer", "--scenario", SCENARIO, "--audio", str(cereal_wav), "--json"])
    assert r.exit_code == 0, r.output
    body = json.loads(r.output[r.output.index("{"):])
    want = "acoustic" if whisper_available() else "phonetic"
    assert body["likelihood"] == want and body["evidence"]["likelihood"] == want
    r = CliRunner().invoke(main, ["infer", "--scenario", SCENARIO, "--transcript", "pass me the cereal", "--json"])
    assert r.exit_code == 0 and json.loads(r.output)["likelihood"] == "phonetic"  # no sound to score


@needs_flite
def test_transcription_is_accepted_as_an_nbest_list(cereal_wav):
    from siftom.api import make_instruction, transcribe_for
    from siftom.scenarios.base import get_scenario

    sc = get_scenario(SCENARIO)
    tr = transcribe_for(cereal_wav, sc.world, sc.verb)
    a = make_instruction(nbest=tr)
    assert a.nbest == tr.nbest and a.words
    assert make_instruction(nbest=tr.nbest).nbest == tr.nbest  # Hypothesis objects
    assert make_instruction(nbest=tr.to_json()).text == tr.text  # the JSON form
    assert make_instruction(tr).nbest == tr.nbest  # given as the transcript


def test_cli_says_no_speech_was_heard(silence_wav):
    from click.testing import CliRunner

    from siftom.cli import root as main

    r = CliRunner().invoke(main, ["infer", "--scenario", SCENARIO, "--audio", str(silence_wav)])
    assert r.exit_code == 0, r.output
    assert "no speech heard" in r.output
    r = CliRunner().invoke(main, ["infer", "--scenario", SCENARIO, "--audio", str(silence_wav), "--json"])
    body = json.loads(r.output)
    assert body["speech_heard"] is False and body["message"] == "no speech heard" and body["mode"] == "action-only"


@needs_flite
@pytest.mark.slow
def test_pruned_and_full_acoustic_scorers_choose_the_same_command(tmp_path):
    """On recordings of several voices, objects and noise levels the pruned scorer picks what the
    full one (every command aligned) picks whenever either is sure; when both are unsure (the
    pooled experts are normalised over the commands kept, so pruning moves them a little) the
    pruned choice is among the full scorer's first three."""
    from siftom.api import engine_for
    from siftom.inference.listen import hear
    from siftom.inference.model import ModelConfig, Observation, SIFToM
    from siftom.likelihood.acoustic import AcousticLikelihood
    from siftom.scenarios.base import get_scenario
    from siftom.speech.noise import get_noise, mix_at_snr
    from siftom.speech.tts import synthesize

    sc = get_scenario(SCENARIO)
    asr = engine_for(sc.world, sc.verb)
    pruned = SIFToM(ModelConfig("full"), AcousticLikelihood(prune=True))
    full = SIFToM(ModelConfig("full"), AcousticLikelihood(prune=False))
    cases = [("can you pass me the cereal", "flite-slt", None), ("bring me the milk", "flite-rms", 10.0),
             ("i need the sugar", "flite-awb", 5.0), ("pass me the silver", "flite-slt", 10.0),
             ("could you grab the oatmeal", "espeak-en-us+klatt", 20.0), ("get me some honey", "flite-rms", 5.0)]
    for k, (text, voice, snr) in enumerate(cases):
        x = synthesize(text, voice)
        if snr is not None:
            x = mix_at_snr(x, get_noise("babble"), snr, k)
        instruction, *_ = hear(x, asr, 10)
        assert instruction is not None
        obs = Observation.from_scenario(sc, instruction)
        a, b = pruned.infer(obs), full.infer(obs)
        why = (text, voice, snr, a.commands[:3], b.commands[:3])
        if max(a.commands[0][1], b.commands[0][1]) >= 0.8:  # an answer the robot would act on
            assert a.command == b.command, why
        else:  # both unsure (the robot asks): the pruned choice is among the full scorer's first three
            assert a.command in [c for c, _ in b.commands[:3]], why
