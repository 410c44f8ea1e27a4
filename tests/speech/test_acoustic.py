"""The acoustic instruction likelihood ranks the spoken command first on clean audio."""

from __future__ import annotations

import numpy as np
import pytest

from siftom.errors import ObservationError, SiftomError
from siftom.likelihood.acoustic import AcousticLikelihood, temperature_for_snr
from siftom.likelihood.base import Instruction, InstructionLikelihood
from siftom.speech.acoustic import FAILED_SCORE, split_compound
from siftom.speech.audio import write_wav
from siftom.world.commands import RobotCommand

FOODS = ("cereal", "milk", "sugar", "coffee", "tea", "pasta", "flour", "bread")


def phrasings(c: RobotCommand) -> list[tuple[str, float]]:
    return [(f"pass me the {c.obj_class}", np.log(0.5)), (f"bring me the {c.obj_class}", np.log(0.5))]


COMMANDS = [RobotCommand("fetch", f) for f in FOODS]


def test_ranks_true_command_first_from_a_file(cereal_clip, aligner, tmp_path):
    lik = AcousticLikelihood(phrasings, aligner=aligner)
    assert isinstance(lik, InstructionLikelihood)
    path = write_wav(tmp_path / "cereal.wav", cereal_clip)
    lp = lik.log_prob(Instruction(audio=path), COMMANDS).log_probs
    assert lp.shape == (len(COMMANDS),) and np.all(np.isfinite(lp))
    assert COMMANDS[int(np.argmax(lp))].obj_class == "cereal"


def test_ranks_true_command_first_other_voice(aligner):
    from siftom.speech.tts import synthesize

    x = synthesize("could you bring me the coffee", "flite-rms")
    lik = AcousticLikelihood(phrasings, aligner=aligner, temperature=temperature_for_snr(None))
    scored = lik.log_prob_audio(x, COMMANDS)
    assert COMMANDS[int(np.argmax(scored.log_probs))].obj_class == "coffee"
    assert scored.evidence["phrases_aligned"] == 2 * len(COMMANDS)


def test_temperature_flattens(cereal_clip, aligner):
    sharp = AcousticLikelihood(phrasings, temperature=5.0, aligner=aligner).log_prob_audio(cereal_clip, COMMANDS).log_probs
    flat = AcousticLikelihood(phrasings, temperature=50.0, aligner=aligner).log_prob_audio(cereal_clip, COMMANDS).log_probs
    assert np.ptp(sharp) > np.ptp(flat) > 0


def test_needs_audio_and_valid_temperature():
    with pytest.raises(ObservationError, match="audio"):
        AcousticLikelihood(phrasings).log_prob(Instruction.from_text("pass me the milk"), COMMANDS)
    with pytest.raises(SiftomError, match="temperature"):
        AcousticLikelihood(phrasings, temperature=0.0)
    assert temperature_for_snr(20) == pytest.approx(12.0) and temperature_for_snr(0) == pytest.approx(30.0)


def test_compounds_and_unknown_words(cereal_clip, aligner):
    assert split_compound("cuttingboard") == ["cutting", "board"]
    r = aligner.score(cereal_clip, ["pass me the cereal", "pass me the xqzzv", "pass me the cutting_board"])
    assert r.best == "pass me the cereal"
    assert "xqzzv" in aligner.skipped_words
    assert all(s > FAILED_SCORE for s in r.scores)
