"""What the utterance model understood of what was heard, and the evidence it adds to a posterior."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, TypedDict

import numpy as np

from siftom.language.record import NOBODY_ASKED, Understanding
from siftom.likelihood.base import Instruction
from siftom.world.commands import RobotCommand


class UnderstandingEvidence(TypedDict, total=False):
    """What understanding adds to a posterior's evidence (all keys absent when nothing was heard)."""

    understanding: dict[str, Any]  # Understanding.to_json()
    instruction_check: str  # whose words were read: "whisper" or "nbest"
    no_instruction: bool  # nobody asked the robot for anything
    no_instruction_reason: str


def understanding_of(instruction: Instruction, commands: Sequence[RobotCommand], also_heard: Sequence[str] = (),
                     lexicon: Any = None) -> tuple[Understanding, UnderstandingEvidence]:
    """What was understood (siftom.language) and the evidence it adds: ``understanding``, and
    ``no_instruction`` with its reason when nobody asked the robot for anything.

    ``also_heard``: what an open-vocabulary recogniser heard in the same audio (Whisper's own
    words). When it heard words, they are read: the scene-biased recogniser that made the N-best
    can only write the scene's phrasings, so it writes command words into any speech ("my phone
    battery is dead" comes out as "i some can cereal some lettuce"), and its words say little
    about whether a request was made (docs/speech.md, "Was it a request?"). The N-best is read,
    with its weights, when nothing else heard words.
    """
    from siftom.language.understand import understand
    from siftom.likelihood.nearness import ASR_TEMPERATURE, MIN_WEIGHT

    classes = sorted({c.obj_class for c in commands})
    open_words = [t for t in also_heard if t and t.strip()]
    if open_words:
        texts, weights = open_words[:1], [1.0]
        by, who = "whisper", "Whisper"
    else:
        hyps = [h for h in instruction.nbest if h.text.strip()]
        if not hyps:
            return NOBODY_ASKED, {}
        sc = np.array([float(h.score) for h in hyps]) / ASR_TEMPERATURE
        w = np.exp(sc - sc.max())
        w /= w.sum()
        floor = min(MIN_WEIGHT, float(w.max()))  # many equal hypotheses each weigh under the floor: keep the best
        keep = [k for k in range(len(hyps)) if w[k] >= floor]
        texts, weights = [hyps[k].text for k in keep], list(w[keep] / w[keep].sum())
        by, who = "nbest", "the recogniser"
    u = understand(texts, weights, classes, lexicon)
    evidence: UnderstandingEvidence = {"understanding": u.to_json(), "instruction_check": by}
    if not u.request:
        evidence["no_instruction"] = True
        evidence["no_instruction_reason"] = f"{who} heard {texts[0]!r}: {u.reason}"
    return u, evidence
