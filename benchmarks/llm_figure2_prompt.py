"""The paper's Figure 2 story with the LLM likelihood: before and after decontaminating the prompt.

Run: .venv/bin/python benchmarks/llm_figure2_prompt.py [--model smollm2-135m|gemma3-270m|PATH]
(needs the llm extra; or point SIFTOM_LLM_BASE_URL/SIFTOM_LLM_MODEL at an endpoint and pass
--backend openai). For each prompt it prints, for kitchen-cereal-v0 heard as "can you pass me the
silver": the full model's P(fetch(cereal)) and its choice, the speech-only choice and
P(fetch(cereal)), and the rank of cereal under the likelihood alone.

"before" is the prompt siftom used until the LLM prompt was decontaminated: its first example was
the paper's own Figure 2 pair (pass(robot, human, cereal) / "pass me the silver"), so the model
could copy the answer. "plain" is :data:`siftom.likelihood.llm.FEW_SHOT` with words only;
"sounds" (the default) is the same examples with each command's and transcript's pronunciation.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from siftom.api import get_model, make_instruction
from siftom.backends.config import LLMConfig
from siftom.inference.model import Observation
from siftom.likelihood.llm import FEW_SHOT, LLMLikelihood, build_prefix, make_backend
from siftom.scenarios.base import get_scenario
from siftom.world.commands import RobotCommand

BEFORE = (  # the contaminated examples (kept here only to measure the difference)
    ("pass(robot, human, cereal)", "pass me the silver"),
    ("deliver(robot, table, forks, 3)", "bring me tree forks"),
    ("pass(robot, human, milk)", "can you pass me the mail"),
    ("deliver(robot, table, wine glasses, 2)", "we still need two wine classes"),
    ("pass(robot, human, flour)", "could you grab the flower please"),
    ("deliver(robot, table, plates, 4)", "get me the rest of the plates"),
    ("pass(robot, human, bacon)", "pass me the beta"),
    ("deliver(robot, table, knives, 1)", "i need a knife"),
)
OLD_HEADER = (
    "A person asks a household robot for help. A speech recogniser transcribed each request, "
    "so some words are misheard. Each example gives the robot command the person meant and "
    "the noisy transcript that was heard.\n\n"
)
HEARD = "can you pass me the silver"


def run(config: LLMConfig) -> None:
    scorer = make_backend(config)
    sc = get_scenario("kitchen-cereal-v0")
    ins = make_instruction(HEARD)
    print(f"model: {scorer.model_id}; heard: {HEARD!r}")
    for label, examples, prompt in (("before", BEFORE, "plain"), ("plain", FEW_SHOT, "plain"),
                                    ("sounds", FEW_SHOT, "sounds")):
        lik = LLMLikelihood(scorer, examples=examples, prompt=prompt)
        if label == "before":
            lik.prefix = build_prefix(examples, OLD_HEADER)
        t0 = time.perf_counter()
        full = get_model("full", lik).infer(Observation.from_scenario(sc, ins))
        speech = get_model("speech-only", lik).infer(Observation.from_scenario(sc, ins))
        seconds = time.perf_counter() - t0
        cmds = sorted({c for c, _ in speech.commands})
        lp = lik.log_prob(ins, [RobotCommand.parse(c) for c in cmds])
        rank = 1 + int(np.sum(lp > lp[cmds.index("fetch(cereal)")]))
        print(f"{label:6s} full: P(cereal)={full.prob('fetch(cereal)'):.3f} choice={full.command}; "
              f"speech-only: P(cereal)={speech.prob('fetch(cereal)'):.3f} choice={speech.command}; "
              f"likelihood rank of cereal {rank}/{len(cmds)}; top3 {[c for c, _ in speech.commands[:3]]} "
              f"({seconds:.1f} s)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--backend", default="llama", choices=("llama", "openai"))
    ap.add_argument("--model", default=None, help="packaged model name or .gguf path (llama) / served model")
    args = ap.parse_args()
    run(LLMConfig.from_env(backend=args.backend, model=args.model))


if __name__ == "__main__":
    main()
