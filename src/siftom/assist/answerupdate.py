"""A posterior updated by the person's answer to a question (a second utterance)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from siftom.assist.decision import joint_of
from siftom.errors import ObservationError
from siftom.inference.model import JointPosterior, Posterior, ScoredCommand, ScoredGoal
from siftom.logspace import logsumexp


def answer_log_likelihood(log_lik: Sequence[float] | np.ndarray, reliability: float = 1.0) -> np.ndarray:
    """The answer's log-likelihood per command when it is heard only with probability ``reliability``.

    With probability ``reliability`` the answer was heard and the instruction likelihood
    ``log_lik`` applies; otherwise what was heard is noise and says nothing about the command:
    ``P(heard | c) ∝ reliability * softmax(log_lik)(c) + (1 - reliability) / K`` over the K
    commands. The same channel the question's EVI assumes (question_values); at 1 the
    likelihood is used as it is.
    """
    ll = np.asarray(log_lik, dtype=np.float64)
    if not 0.0 <= reliability <= 1.0:
        raise ObservationError(f"reliability must be a probability in [0, 1], got {reliability!r}")
    if reliability >= 1.0 or len(ll) == 0:
        return ll
    p = np.exp(ll - logsumexp(ll))
    out: npt.NDArray[np.float64] = np.log(reliability * p + (1.0 - reliability) / len(ll))
    return out


def with_answer(post: Posterior, log_lik: Sequence[float] | np.ndarray, transcript: str = "") -> Posterior:
    """The posterior after a second utterance (the answer): ``log_lik`` per ``post.joint.commands``.

    The answer depends on the command alone, so adding its log-likelihood to every hypothesis
    and renormalising is the exact Bayesian update.
    """
    j = joint_of(post)
    ll = np.asarray(log_lik, dtype=np.float64)
    if ll.shape != (len(j.commands),) or not np.all(np.isfinite(ll)):
        raise ObservationError("the answer's likelihood must give one finite score per command")
    lj = j.log_joint + ll[j.cmd_idx]
    p = np.exp(lj - logsumexp(lj))
    cm = np.bincount(j.cmd_idx, weights=p, minlength=len(j.commands))
    ng = len(j.goals) + 1
    gm = np.bincount(j.goal_idx, weights=p, minlength=ng)
    names = [g.name for g in j.goals] + ["unknown"]
    corder = np.lexsort((np.arange(len(cm)), -cm))
    corder = corder[cm[corder] > 0]
    gorder = np.argsort(-gm, kind="stable")
    gorder = gorder[gm[gorder] > 0]
    commands = tuple(ScoredCommand(j.commands[k], float(cm[k])) for k in corder)
    goals = tuple(ScoredGoal(names[k], float(gm[k])) for k in gorder)
    from dataclasses import replace

    return replace(post, command=commands[0][0], commands=commands, goals=goals, hypotheses=(),
                   transcript=(post.transcript + " | " + transcript).strip(" |"),
                   joint=JointPosterior(j.goals, j.commands, j.goal_idx, j.cmd_idx, lj, j.state, j.log_words))
