"""Silence has a price: words read as no request that may still have asked get a question
(docs/decisions.md, "Silence has a price")."""

from __future__ import annotations

from collections.abc import Sequence

from siftom.assist.decision import DEFAULT_ASK_COST, Decision
from siftom.assist.questions import Question
from siftom.assist.teamvalue import NONE

OPEN_QUESTION = "Sorry, what do you need?"
# P(somebody asked) above which words read as no request still get "Sorry, what do you need?"
# from the teammate. Silence after a request costs the person the wait and a second request
# (about two exchanges on top of the one a question takes, C_ignored = 3 C_q); the question costs
# a person who asked one exchange (C_q) and one who did not the same interruption (C_q). Asking
# is worth it when P C_ignored > P C_q + (1 - P) C_q, i.e. P > 1/3 (docs/decisions.md, "Silence
# has a price", gives both sides measured).
ASK_WHEN_UNSURE = 1.0 / 3.0


def ask_if_unsure(silent: Decision, p_request: float, answered: Sequence[Question] = ()) -> Decision:
    """``silent`` (no action: the words read as no request), or "Sorry, what do you need?" when
    they may still have asked (``p_request`` >= :data:`ASK_WHEN_UNSURE`) and it was not asked
    already in this exchange."""
    q = Question("open", OPEN_QUESTION, (), ((),), ((),))
    if p_request < ASK_WHEN_UNSURE or any(a.text == q.text for a in answered):
        return silent
    return Decision(silent.rule, "ask", NONE, 0.0, float("nan"), q.text, (), 0.0, DEFAULT_ASK_COST,
                    f"{silent.reason}; but P(somebody asked) = {p_request:.2f} >= {ASK_WHEN_UNSURE:.2f}: silence "
                    "would cost a person who asked more than a question costs one who did not", (), q.kind, q)
