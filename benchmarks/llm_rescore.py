"""Re-score saved eval results with the LLM likelihood's cached scores: temperature and a
product with the phonetic likelihood, without running the language model again.

Run: SIFTOM_LLM_PROMPT=sounds .venv/bin/python benchmarks/llm_rescore.py DATASET RESULTS [DATASET RESULTS ...]
RESULTS must come from `siftom eval --models ...,siftom-llm` with the same LLM settings, so every
score is in the on-disk cache (``$SIFTOM_CACHE_DIR/llm-scores.sqlite``); a missing score is
computed (slow). Prints the full model's accuracy on those stimuli for

* the LLM likelihood with temperature tau (log-probs divided by tau; tau = 1 is siftom-llm),
* the phonetic likelihood plus w x the LLM log-likelihood (a product of experts, w = 0 is siftom).

This is a diagnostic on the stimuli given, not a fitted choice: pick tau or w on one set (e.g.
a seed-1 development set) and check them on another before changing a default.
"""

from __future__ import annotations

import sys

import numpy as np

from siftom.bench.trials import is_correct, saved_trials
from siftom.inference.model import ModelConfig, Observation, SIFToM
from siftom.likelihood.llm import LLMLikelihood
from siftom.likelihood.phonetic import PhoneticLikelihood

TAUS = (1.0, 2.0, 4.0, 8.0)
WEIGHTS = (0.0, 0.05, 0.1, 0.2, 0.5)


class Product:
    """log P_phonetic + w log P_llm (each command's), a log-linear product of experts."""

    name = "product"
    needs_text = True
    needs_audio = False

    def __init__(self, phonetic: PhoneticLikelihood, llm: LLMLikelihood, w: float) -> None:
        self.phonetic, self.llm, self.w = phonetic, llm, w

    def log_prob(self, instruction, commands):  # noqa: ANN001, ANN201 - the likelihood protocol
        out = self.phonetic.log_prob(instruction, commands)
        return out if self.w == 0 else out + self.w * self.llm.log_prob(instruction, commands)


def main() -> None:
    args = sys.argv[1:]
    scorer = LLMLikelihood().scorer  # the configured model (cache hits for a finished siftom-llm run)
    phon = PhoneticLikelihood()
    variants: dict[str, object] = {f"llm tau={t:g}": LLMLikelihood(scorer, temperature=t) for t in TAUS}
    base = variants["llm tau=1"]
    variants.update({f"phonetic + {w:g} llm": Product(phon, base, w) for w in WEIGHTS})
    models = {k: SIFToM(ModelConfig(mode="full"), v) for k, v in variants.items()}
    hits: dict[str, list[bool]] = {k: [] for k in models}
    n = 0
    for dfolder, rfolder in zip(args[::2], args[1::2], strict=True):
        for s, sc, r, ins in saved_trials(dfolder, rfolder):
            n += 1
            for k, m in models.items():
                if ins is None:
                    hits[k].append(bool(r["models"]["siftom"]["correct"]))
                    continue
                post = m.infer(Observation.from_scenario(sc, ins))
                hits[k].append(is_correct(post.command, s.gold_command, sc.verb))
    print(f"n = {n} stimuli")
    for k, v in hits.items():
        print(f"{k:22s} {100 * np.mean(v):5.1f} %")


if __name__ == "__main__":
    main()
