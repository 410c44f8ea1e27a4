"""Do the words back the command the posterior chose? (docs/decisions.md, "What the words say").

The posterior multiplies what the person is doing by what was heard, so a plan that needs the
butter can carry ``fetch(butter)`` to P = 0.99 when noise left the words saying nothing of it
("robot, I want the garlic" heard as "i'm one"), or when they named another object. That is
SIFToM's inference when the plan prior is right; but a person may ask for anything, and a wrong
fetch costs them more than a short question. A teammate who heard something unclear and guesses
from what you are doing says so: "Shall I get the butter?".

The words alone speak through the instruction term (``JointPosterior.log_words``, log P(words |
command) up to a constant). Per object class c, take its best command's term w_c; over the K
classes of the call, the words' *lift* of the chosen class t is

    lift(t) = w_t - log( (1/K) sum_c exp(w_c) )

how much likelier the words make t than a class picked at random (0: no likelier). The words
*back* t when its lift is at least :data:`MIN_LIFT`: a clear request lifts its object by many
nats, a near rhyme the plan resolves ("potato" heard, the salad under way: the tomato) lifts
both rhymes, and flat words lift nothing.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from siftom.inference.model import Posterior
from siftom.world.commands import RobotCommand

if TYPE_CHECKING:
    from siftom.assist.questions import Question

# nats: the words must make the chosen object at least e^MIN_LIFT times likelier than the
# typical class. On the understanding benchmark's dev set at 10 dB (80 items, 22 carried out),
# the commands carried out on the wrong object had lifts 1.6 to 5.2 (and two the words did name),
# the right ones 8.1 and more; typed requests 12.9 and more (docs/decisions.md, "What the words say")
MIN_LIFT = 6.0


@dataclass(frozen=True)
class WordsSay:
    """What the words alone say of the chosen command: its class's ``lift`` (nats; module doc)
    and the class the words favour most (``favoured``, a command of it)."""

    lift: float
    favoured: RobotCommand | None

    @property
    def back(self) -> bool:
        return self.lift >= MIN_LIFT


def words_say(post: Posterior, command: RobotCommand | str) -> WordsSay | None:
    """:class:`WordsSay` of ``command`` in ``post``; None when nothing was heard (no words term)
    or the command is not one of the posterior's."""
    j = post.joint
    if j is None or j.log_words is None or not len(j.commands):
        return None
    cmd = command if isinstance(command, RobotCommand) else RobotCommand.parse(command)
    lw = np.asarray(j.log_words, dtype=float)
    if lw.shape != (len(j.commands),):
        return None
    best: dict[str, int] = {}
    for k, c in enumerate(j.commands):
        if c.obj_class not in best or lw[k] > lw[best[c.obj_class]]:
            best[c.obj_class] = k
    if cmd.obj_class not in best or len(best) < 2:
        return None
    per = np.array([lw[k] for k in best.values()])
    lift = float(lw[best[cmd.obj_class]] - np.median(per))
    top = max(best.values(), key=lambda k: lw[k])
    return WordsSay(lift, j.commands[top])


def unheard_question(post: Posterior, where: Any, command: str, lexicon: Any,
                     decline_reason: Callable[[str, Any], str]) -> tuple[Question, str] | None:
    """The question to ask instead of carrying out ``command`` when the words do not back it: a
    choice with the object the words favour ("Which one: the butter or the garlic?"), else
    "Shall I get the butter?"; with the reason's tail. None when they back it, or the question
    was answered in this exchange (``where.settled``)."""
    from siftom.assist.questions import choose_question, confirm_question

    said = words_say(post, command)
    if said is None or said.back:
        return None
    fav = said.favoured
    if fav is not None and fav.obj_class != RobotCommand.parse(command).obj_class and not decline_reason(
            str(fav), where):
        q = choose_question(command, str(fav), lexicon)
    else:
        q = confirm_question(command, lexicon)
    if where.settled(q):
        return None
    return q, (f"by what the person is doing, but the words do not say it (they lift it {said.lift:.1f} "
               f"nats < {MIN_LIFT:g}): asking")
