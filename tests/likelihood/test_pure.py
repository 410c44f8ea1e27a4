"""Likelihoods are pure: log_prob returns scores and evidence together, and keeps nothing."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from siftom.likelihood.base import Scores, as_scores
from siftom.likelihood.phonetic import PhoneticLikelihood
from siftom.observation import Instruction
from siftom.world.commands import RobotCommand

CMDS = [RobotCommand("fetch", c) for c in ("milk", "cereal", "sugar", "coffee", "bowl", "spoon")]
SAID = ["pass me the milk", "pass me the cereal", "get the sugar", "the coffee please", "a bowl", "spoon"]


def test_scores_are_a_frozen_record():
    s = PhoneticLikelihood().log_prob(Instruction.from_text("pass me the milk"), CMDS)
    assert isinstance(s, Scores) and s.log_probs.shape == (len(CMDS),)
    assert not s.log_probs.flags.writeable
    assert np.argmax(s) == 0  # usable where an array is expected
    assert as_scores(np.zeros(3)).evidence == {}


def test_no_attribute_changes_across_calls():
    lik = PhoneticLikelihood()
    lik.log_prob(Instruction.from_text("pass me the milk"), CMDS)
    public = {k: v for k, v in vars(lik).items() if not k.startswith("_")}
    lik.log_prob(Instruction.from_text("the coffee please"), CMDS)
    assert {k: v for k, v in vars(lik).items() if not k.startswith("_")}.keys() == public.keys()
    assert not any(k.startswith("last_") for k in vars(lik))


def test_threads_share_one_likelihood():
    lik = PhoneticLikelihood()
    alone = [lik.log_prob(Instruction.from_text(t), CMDS).log_probs for t in SAID]
    with ThreadPoolExecutor(4) as pool:
        together = list(pool.map(lambda t: lik.log_prob(Instruction.from_text(t), CMDS).log_probs, SAID * 4))
    for k, lp in enumerate(together):
        np.testing.assert_allclose(lp, alone[k % len(SAID)])


# --- pure scorers: no lock, nothing kept on the scorer, bit-identical from many threads ------
import ast  # noqa: E402
import pickle  # noqa: E402
import random  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from siftom.memo import memo, memo_stats  # noqa: E402
from siftom.scenarios.base import get_scenario  # noqa: E402

LIKELIHOODS = Path(__file__).resolve().parents[2] / "src" / "siftom" / "likelihood"
MEMOS = ("phonetic.plans", "phonetic.contents", "phonetic.vocabularies", "phonetic.heard", "phonetic.distances",
         "llm.scores")


def _calls(n: int = 48, seed: int = 3) -> list[tuple[Instruction, tuple[RobotCommand, ...]]]:
    """(N-best, a scene's commands) pairs over several scenes and misheard N-best lists."""
    from helpers import model_for

    rng = random.Random(seed)
    model = model_for("full", "phonetic")
    scenes = []
    for sid in ("kitchen-cereal-v0", "household-table-v0/3", "household-table-v0/6", "kitchen-v0/7"):
        sc = get_scenario(sid)
        scenes.append(tuple(model.online(sc.world, sc.start, sc.goals, sc.verb).candidates()[4]))
    words = ["pass me the silver", "could you get me three forks", "i need the", "some cereal please",
             "bring two plates and", "the oatmeal", "spoons four me", "hand me a bowl", "uh the milk"]
    out = []
    for _ in range(n):
        nbest = [(rng.choice(words), -float(rng.randint(0, 40))) for _ in range(rng.randint(1, 4))]
        out.append((Instruction.from_nbest(nbest), rng.choice(scenes)))
    return out


def test_no_likelihood_module_holds_a_lock():
    """Memoisation lives in siftom.memo; a native decoder guards itself (speech/): a scorer needs no lock."""
    for path in sorted(LIKELIHOODS.glob("*.py")):
        tree = ast.parse(path.read_text())
        names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} | {
            n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
        assert not names & {"guarded", "Lock", "RLock", "Semaphore"}, path.name


def test_eight_threads_in_random_order_give_the_serial_scores_bit_for_bit():
    calls = _calls()
    for name in MEMOS:
        memo(name, 1).clear()
    serial = [np.asarray(PhoneticLikelihood().log_prob(i, c).log_probs) for i, c in calls]
    for name in MEMOS:
        memo(name, 1).clear()  # cold again: the threads race to fill the memos
    lik = PhoneticLikelihood()
    order = list(range(len(calls))) * 3
    random.Random(11).shuffle(order)
    with ThreadPoolExecutor(8) as pool:
        got = list(pool.map(lambda k: (k, np.asarray(lik.log_prob(*calls[k]).log_probs)), order))
    for k, lp in got:
        assert np.array_equal(lp, serial[k]), k
    again = [np.asarray(lik.log_prob(i, c).log_probs) for i, c in calls]  # now from the memos
    assert all(np.array_equal(a, b) for a, b in zip(again, serial, strict=True))
    stats = memo_stats()
    assert stats["phonetic.distances"]["hits"] > 0 and stats["phonetic.plans"]["size"] <= 256


def test_a_scorer_keeps_nothing_between_calls():
    lik = PhoneticLikelihood()
    before = pickle.dumps(vars(lik))
    for i, c in _calls(12):
        lik.log_prob(i, c)
    assert pickle.dumps(vars(lik)) == before


class _SlowScorer:
    """A deterministic LLM stand-in that sleeps, so that threads interleave inside a call."""

    model_id = "stand-in"

    def score(self, prefix: str, items):  # noqa: ANN001, ANN201
        time.sleep(0.001)
        return [-(len(c) % 7) - 0.1 * len(t) - 0.01 * sum(map(ord, c + t)) % 3 for c, t in items]


def test_the_llm_likelihood_is_pure_across_threads():
    from siftom.likelihood.llm import LLMLikelihood

    lik = LLMLikelihood(_SlowScorer())
    calls = _calls(16, seed=5)
    memo("llm.scores", 1).clear()
    serial = [np.asarray(lik.log_prob(i, c[:8]).log_probs) for i, c in calls]
    memo("llm.scores", 1).clear()
    with ThreadPoolExecutor(8) as pool:
        got = list(pool.map(lambda k: np.asarray(lik.log_prob(calls[k][0], calls[k][1][:8]).log_probs),
                            [k for k in range(len(calls)) for _ in range(2)]))
    for j, lp in enumerate(got):
        assert np.array_equal(lp, serial[j // 2])


@pytest.mark.slow
def test_the_acoustic_likelihood_is_pure_across_threads(tmp_path):
    pytest.importorskip("faster_whisper")
    from siftom.likelihood.acoustic import AcousticLikelihood
    from siftom.speech import get_noise, mix_at_snr, synthesize, write_wav
    from siftom.speech.asr.base import get_engine

    sc = get_scenario("kitchen-cereal-v0")
    from helpers import model_for

    cmds = tuple(model_for("full", "phonetic").online(sc.world, sc.start, sc.goals, sc.verb).candidates()[4])
    eng = get_engine("pocketsphinx")
    calls = []
    for k, text in enumerate(["can you pass me the cereal", "i need the sugar", "get me some honey"]):
        wav = write_wav(tmp_path / f"{k}.wav", mix_at_snr(synthesize(text, "flite-slt"), get_noise("pink"), 10, rng=k))
        tr = eng.transcribe(wav, nbest=5)
        calls.append(Instruction(nbest=tuple(tr.nbest) or Instruction.from_text(text).nbest, audio=wav))
    lik = AcousticLikelihood()
    serial = [np.asarray(lik.log_prob(i, cmds).log_probs) for i in calls]
    with ThreadPoolExecutor(8) as pool:
        got = list(pool.map(lambda k: np.asarray(lik.log_prob(calls[k], cmds).log_probs), [0, 1, 2] * 3))
    for j, lp in enumerate(got):
        assert np.array_equal(lp, serial[j % 3])
