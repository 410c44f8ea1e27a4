"""How one session answer is computed instead of the session's own way."""

from __future__ import annotations

from typing import TypedDict

from siftom.assist.decision import DecisionRule


class AnswerWith(TypedDict, total=False):
    """One answer's decision rule (``decide``) and instruction likelihood (``likelihood``) instead of
    the session's: a server under load scores an answer with a cheaper likelihood (admission.py).
    A key left out, or None, keeps the session's."""

    decide: str | DecisionRule | None
    likelihood: str | None
