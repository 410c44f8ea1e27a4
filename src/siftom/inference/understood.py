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


def hearings_of(instruction: Instruction, also_heard: Sequence[str] = (),
                also_logprob: float | None = None) -> list[Any]:
    """Every recogniser's words of one utterance as evidence (``siftom.language.understand.Hearing``):
    the N-best with its weights, through the scene channel when its recogniser writes only the
    scene's phrasings; and an open-vocabulary recogniser's transcript (Whisper's) with its
    :func:`transcript_reliability` as its reliability."""
    from siftom.language.understand import OPEN, SCENE, Hearing
    from siftom.likelihood.nearness import heard_weights

    out: list[Any] = []
    heard = heard_weights(instruction.nbest)
    if heard:
        out.append(Hearing(tuple(t for t, _ in heard), tuple(w for _, w in heard),
                           SCENE if instruction.scene_words else OPEN,
                           SCENE_RELIABILITY if instruction.scene_words else 1.0, "the recogniser"))
    for t in also_heard:
        if t and t.strip():
            out.append(Hearing((t,), (1.0,), OPEN, transcript_reliability(also_logprob), "Whisper"))
    return out


# How far an open-vocabulary transcript's reading of "was it a request?" is trusted, from its
# mean token log-probability lp: 1 / (1 + exp(-SLOPE (lp - MIDPOINT))). Whisper's greedy guess at
# lp -0.25 is nearly always the words said; at -0.8 it is as often made-up words as not
# ("kill you past me let's goog" for "could you pass me the spoon"). Fitted by log loss on the
# dev set's recordings with the scene recogniser's weight (docs/understanding.md, "Channels").
TRANSCRIPT_SLOPE = 4.0
TRANSCRIPT_MIDPOINT = -0.8
# the scene recogniser's reading speaks with this weight (the same fit)
SCENE_RELIABILITY = 0.7


def transcript_reliability(logprob: float | None) -> float:
    """The weight of an open-vocabulary transcript's reading (module constants); 1 when the
    recogniser gives no log-probability (a transcript typed or from elsewhere)."""
    if logprob is None:
        return 1.0
    if not np.isfinite(logprob):
        return 0.0
    return float(1.0 / (1.0 + np.exp(-TRANSCRIPT_SLOPE * (float(logprob) - TRANSCRIPT_MIDPOINT))))


def understanding_of(instruction: Instruction, commands: Sequence[RobotCommand], also_heard: Sequence[str] = (),
                     lexicon: Any = None, also_logprob: float | None = None) -> tuple[Understanding, UnderstandingEvidence]:
    """What was understood (siftom.language) and the evidence it adds: ``understanding``, and
    ``no_instruction`` with its reason when nobody asked the robot for anything.

    ``also_heard``: what an open-vocabulary recogniser heard in the same audio (Whisper's own
    words), with ``also_logprob`` its mean token log-probability. Every recogniser's words are
    evidence weighed by its reliability (:func:`hearings_of`,
    ``siftom.language.understand.understand_heard``): no one transcript decides whether a
    request was made.
    """
    from siftom.language.understand import understand_heard

    classes = sorted({c.obj_class for c in commands})
    hearings = hearings_of(instruction, also_heard, also_logprob)
    if not hearings:
        return NOBODY_ASKED, {}
    u = understand_heard(hearings, classes, lexicon)
    by = next((h for h in hearings if " ".join(read_words(h.texts[0])) == u.heard), hearings[0])
    evidence: UnderstandingEvidence = {"understanding": u.to_json(),
                                       "instruction_check": "whisper" if by.who == "Whisper" else "nbest"}
    if not u.request:
        evidence["no_instruction"] = True
        evidence["no_instruction_reason"] = f"{by.who} heard {by.texts[0]!r}: {u.reason}"
    return u, evidence


def typed(instruction: Instruction) -> bool:
    """Whether the words are one transcript with no recording and no recogniser's scores behind
    them (typed text, or a transcript given as the words said)."""
    return (not instruction.has_audio and len(instruction.nbest) == 1 and not instruction.scene_words
            and instruction.nbest[0].score == 0.0)


def read_words(text: str) -> tuple[str, ...]:
    """The words the utterance model reads in ``text``."""
    from siftom.language.parse import read

    return tuple(read(text).words)
