"""Decision rules: what the robot does with a posterior (docs/decisions.md gives the reasons).

* ``map``: execute the command with the highest posterior marginal (the Bayes choice for
  the accuracy metric, which scores the command).
* ``expected-benefit``: execute the action, the command that was asked for (the most probable
  one; ``scope="any"``: any command of the domain) or doing nothing, with
  the highest expected loss-averse utility of the steps it saves the team,
  ``argmax_a E[u(b)]`` with ``b = L_single(g) - L_team(g, a)`` and
  ``u(b) = b - loss_aversion * max(0, -b)``, the team terms counted as the team simulation
  counts them (assist/teamvalue.py).
* ``ask-or-act``: ask the question (confirm "Shall I bring two plates?", choose "Which one:
  the cereal or the oatmeal?", count "How many plates?"; assist/questions.py) whose expected
  value of information (EVI, in steps) exceeds its cost by the most, when one does: the cost
  is the time of the spoken exchange (assist/askcost.py); otherwise act by ``expected-benefit``. The answer names a cell of the question's partition,
  heard right with the kind's probability ``Situation.reliability(kind)``:

      EVI = sum_heard max_a E[u(b(a) - ask_cost) ; heard] - max_a E[u(b(a))] + ask_cost.

Rules are registered by name in :data:`RULES`; :func:`get_rule` builds one.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from siftom.assist.answerupdate import answer_log_likelihood as answer_log_likelihood
from siftom.assist.answerupdate import with_answer as with_answer
from siftom.assist.askcost import QuestionCost
from siftom.assist.asking import QUESTION_POOL as QUESTION_POOL
from siftom.assist.asking import best_questions as best_questions
from siftom.assist.asking import lexicon_of as _lexicon
from siftom.assist.asking import question_cost as question_cost
from siftom.assist.asking import question_values as question_values
from siftom.assist.decision import DEFAULT_ASK_COST as DEFAULT_ASK_COST
from siftom.assist.decision import Decision as Decision
from siftom.assist.decision import DecisionRule as DecisionRule
from siftom.assist.decision import Situation as Situation
from siftom.assist.decision import joint_of as _joint
from siftom.assist.phrasing_en import already_with_you, be
from siftom.assist.questions import KINDS, Question
from siftom.assist.teamvalue import NONE, TeamValues, team_values
from siftom.assist.unsure import OPEN_QUESTION as OPEN_QUESTION
from siftom.errors import ObservationError, unknown_name
from siftom.inference.model import Posterior
from siftom.registry import Registry
from siftom.world.commands import RobotCommand

# An interruption cost in steps on top of the exchange's time: none by default (a question is
# worth asking when its value beats its time); a deployment whose people should be asked less
# may set one.
DEFAULT_QUESTION_PENALTY = 0.0
# A step lost weighs 1 + DEFAULT_LOSS_AVERSION steps saved (a teammate who slows the team down
# is worse than one who does nothing); chosen on a development set of another seed
# (docs/decisions.md; `python recipes/loss_aversion.py`).
DEFAULT_LOSS_AVERSION = 3.0
# what the deciding rules measure a gain in: "steps" saved (L_single - L_team) or "speedup"
# (L_single / L_team - 1, the benchmark's metric); docs/decisions.md
UTILITIES = ("steps", "speedup")
# which commands expected-benefit weighs against doing nothing: the one asked for, or any
SCOPES = ("asked", "any")
DEFAULT_UTILITY = "steps"


def _values(post: Posterior, where: Situation) -> TeamValues:
    return team_values(_joint(post), where.world, where.target, where.state, where.prefix)


def _top(actions: Sequence[str], eb: np.ndarray, k: int = 5) -> tuple[tuple[str, float], ...]:
    order = np.argsort(-eb, kind="stable")[:k]
    return tuple((actions[i], float(eb[i])) for i in order)


def _best(tv: TeamValues, loss_aversion: float = 0.0, unit: str = "steps",
          spent: float = 0.0, only: Sequence[str] | None = None) -> tuple[int, np.ndarray]:
    """The action of highest expected utility (ties go to doing nothing) and every action's E[b].

    ``spent``: steps the team has already lost (a question asked), counted in every outcome.
    ``only``: the commands that may be chosen (doing nothing always may); None: every one.
    """
    eu = tv.prob @ tv.utility(loss_aversion, spent, unit)
    if only is not None:
        keep = np.zeros(len(eu), dtype=bool)
        keep[-1] = True
        keep[[tv.actions.index(c) for c in only if c in tv.actions]] = True
        eu = np.where(keep, eu, -np.inf)
    # ties (e.g. several commands worth exactly nothing) go to doing nothing, then to the list order
    best = int(np.argmax(eu))
    if eu[-1] >= eu[best] - 1e-9:
        best = len(eu) - 1
    return best, tv.expected()


def _check_steps(obj: Any, *names: str) -> None:
    for k in names:
        v = getattr(obj, k)
        if isinstance(v, bool) or not (isinstance(v, (int, float)) and v >= 0 and np.isfinite(v)):
            raise ObservationError(f"{k} must be a non-negative finite number, got {v!r}")


def _check_utility(unit: Any) -> None:
    if unit not in UTILITIES:
        raise ObservationError(f"utility must be one of {', '.join(UTILITIES)}, got {unit!r}")


class MapRule:
    """Execute the command with the highest posterior marginal."""

    name = "map"

    def __call__(self, post: Posterior, where: Situation | None = None) -> Decision:
        eb = float("nan")
        benefits: tuple[tuple[str, float], ...] = ()
        if where is not None and post.joint is not None:
            tv = _values(post, where)
            e = tv.expected()
            if post.command in tv.actions:
                eb = float(e[tv.actions.index(post.command)])
            benefits = _top(tv.actions, e)
        p = float(post.commands[0][1]) if post.commands else 0.0
        return Decision(self.name, post.command, post.command, p, eb,
                        reason=f"most probable command: P = {p:.2f}", benefits=benefits)


@dataclass(frozen=True)
class ExpectedBenefitRule:
    """Execute the action (a command or nothing) of highest expected loss-averse utility.

    The utility of saving ``b`` steps is ``b - loss_aversion * max(0, -b)``: a step lost
    weighs ``1 + loss_aversion`` steps saved (0: risk-neutral, the expected steps saved).

    ``scope``: ``asked`` (default) weighs only the command the person most probably asked for
    against doing nothing, so the robot never carries out a command nobody asked for; ``any``
    weighs every command of the domain (it may bring what helps most instead of what was asked).
    """

    loss_aversion: float = DEFAULT_LOSS_AVERSION
    # what a gain is measured in: steps saved, or the speedup L_single / L_team - 1
    utility: str = DEFAULT_UTILITY
    # steps the team has already spent on this request (a question asked and answered): they
    # count in every outcome, doing nothing included, so a loss-averse robot weighs them as the
    # question's value assumed it would (ask-or-act's EVI)
    spent: float = 0.0
    scope: str = "asked"
    name: str = "expected-benefit"

    def __post_init__(self) -> None:
        _check_steps(self, "loss_aversion", "spent")
        _check_utility(self.utility)
        if self.scope not in SCOPES:
            raise ObservationError(f"scope must be one of {', '.join(SCOPES)}, got {self.scope!r}")

    def __call__(self, post: Posterior, where: Situation) -> Decision:
        tv = _values(post, where)
        only = (post.command,) if self.scope == "asked" and post.command in tv.actions else None
        best, eb = _best(tv, self.loss_aversion, self.utility, self.spent, only)
        a = tv.actions[best]
        p = 0.0 if a == NONE else post.prob(a)
        why = (f"no command is worth its risk (best {tv.actions[int(np.argmax(eb[:-1]))]}: "
               f"{eb[:-1].max():+.1f} steps expected)" if a == NONE and len(eb) > 1 else
               f"expected to save {eb[best]:.1f} steps (P = {p:.2f})")
        return Decision(self.name, a, a, p, float(eb[best]), reason=why, benefits=_top(tv.actions, eb))


@dataclass(frozen=True)
class AskOrActRule:
    """Ask the best question when its EVI exceeds its cost; otherwise act by expected utility.

    The candidates are confirmations, choices between two and count questions about the most
    probable commands (``kinds``); each EVI is weighted by how reliably that kind's answer is
    heard here (``Situation.reliability``). A question costs the time of its spoken exchange
    (``cost_model``, assist/askcost.py), or ``ask_cost`` steps when that is given, plus
    ``penalty`` steps of interruption (none by default).
    """

    ask_cost: float | None = None
    penalty: float = DEFAULT_QUESTION_PENALTY
    loss_aversion: float = DEFAULT_LOSS_AVERSION
    kinds: tuple[str, ...] = KINDS
    cost_model: QuestionCost = field(default_factory=QuestionCost)
    # the question's time as a loss inside the loss-averse utility, or a sure price at face value
    # (best_questions; docs/decisions.md)
    time_as_loss: bool = True
    # what a gain is measured in, as for expected-benefit: steps saved or the speedup ratio
    utility: str = DEFAULT_UTILITY
    # steps already spent on earlier questions about this request (a follow-up question weighs
    # its outcomes from there, as expected-benefit's ``spent`` does)
    spent: float = 0.0
    name: str = "ask-or-act"

    def __post_init__(self) -> None:
        _check_steps(self, "penalty", "loss_aversion", "spent")
        if self.ask_cost is not None:
            _check_steps(self, "ask_cost")
        bad = [k for k in self.kinds if k not in KINDS]
        if bad or not self.kinds:
            raise ObservationError(f"unknown question kinds {bad or list(self.kinds)!r}; choose from {', '.join(KINDS)}")
        _check_utility(self.utility)
        if not isinstance(self.cost_model, QuestionCost):
            raise ObservationError(f"cost_model must be a QuestionCost, got {type(self.cost_model).__name__}")

    def cost(self, q: Question) -> float:
        """Steps question ``q`` costs: its time plus the interruption penalty."""
        return question_cost(q, self.ask_cost, self.cost_model) + self.penalty

    def __call__(self, post: Posterior, where: Situation) -> Decision:
        return self._ask_or_act(post, where)

    def _ask_or_act(self, post: Posterior, where: Situation, naming: str | None = None) -> Decision:
        """Ask the best question when it pays, else act as expected-benefit does; ``naming``: only
        questions that name this command (a person who asked for the cereal is asked about the
        cereal, not about the flour alone)."""
        tv = _values(post, where)
        # without a question it acts as expected-benefit does: the command asked for, or nothing
        only = (post.command,) if post.command in tv.actions else None
        best, eb = _best(tv, self.loss_aversion, self.utility, self.spent, only)
        a = tv.actions[best]
        p = 0.0 if a == NONE else post.prob(a)
        qs = [(v, q) for v, q in best_questions(tv, post, where, self.loss_aversion, self.ask_cost, self.kinds,
                                                unit=self.utility, cost_model=self.cost_model,
                                                time_as_loss=self.time_as_loss, spent=self.spent)
              if naming is None or naming in q.options]
        top = _top(tv.actions, eb)
        if qs and qs[0][0] > self.cost(qs[0][1]) + 1e-9:  # a question worth exactly its cost is not asked
            value, q = qs[0]
            t = question_cost(q, self.ask_cost, self.cost_model)
            return Decision(self.name, "ask", a, p, float(eb[best]), q.text, q.options, value, t,
                            f"asking is worth {value:.1f} steps > its cost {self.cost(q):.1f}", top, q.kind, q)
        value = qs[0][0] if qs else 0.0
        cost = self.cost(qs[0][1]) if qs else 0.0
        return Decision(self.name, a, a, p, float(eb[best]), "", (), value, cost,
                        f"acting: the best question is worth {value:.1f} steps <= its cost {cost:.1f}; "
                        + (f"{a} saves {eb[best]:.1f} steps" if a != NONE else "no command saves time"), top)


# P(most probable command) at which a request counts as understood: the robot carries it out
# (docs/decisions.md, "The teammate rule")
DEFAULT_CONFIDENT = 0.75


def left_to_bring(command: str, where: Situation) -> tuple[int, int]:
    """(objects of the command's class the robot could still bring, objects already at the
    target or in the person's hands) in the situation's state."""
    from siftom.world.model import HUMAN

    cmd = RobotCommand.parse(command)
    w, st = where.world, where.state
    if cmd.obj_class not in w.classes:
        return 0, 0
    k = w.classes.index(cmd.obj_class)
    items = [i for i, c in enumerate(w.item_class_idx) if int(c) == k]
    held = {int(st.held[HUMAN])}
    there = [i for i in items if int(st.item_at[i]) == where.target or i in held]
    return len(items) - len(there), len(there)


def _sentence(text: str) -> str:
    """``text`` as a sentence the robot says: "Sorry, the honey is already with you."."""
    return f"Sorry, {text.rstrip('.')}."


def decline_reason(command: str, where: Situation) -> str:
    """A reason the robot can say for not carrying out ``command``, or '' when it can."""
    cmd = RobotCommand.parse(command)
    left, there = left_to_bring(command, where)
    if left >= 1:
        return ""
    name = _lexicon(where.world).entry(cmd.obj_class).singular
    if there:
        return already_with_you(name)  # "the scissors are already with you"
    return f"there {be(name)} no {name} left to bring"


@dataclass(frozen=True)
class TeammateRule(AskOrActRule):
    """Answer every request: carry it out when understood, ask when unsure, decline with a reason.

    Team value speaks first: when ask-or-act finds a question worth more than its cost, the
    robot asks it; when it finds a command worth carrying out, the robot carries it out. Where
    ask-or-act would do nothing, a request is still never ignored: the robot declines only for a
    reason it can say ("the honey is already with you"); it carries out the command asked for
    when that holds at least ``confident`` of the posterior (a request understood is not
    overruled by the robot's guess of its worth); otherwise it asks a choice naming the two
    likeliest objects ("Which one: the cereal or the sugar?"), or "Sorry, what do you need?".
    A request nobody made never reaches a rule (the observer answers ``none``).

    The other options are ask-or-act's (loss aversion, question cost, kinds).
    """

    confident: float = DEFAULT_CONFIDENT
    name: str = "teammate"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (isinstance(self.confident, (int, float)) and 0.0 < self.confident <= 1.0):
            raise ObservationError(f"confident must be a probability in (0, 1], got {self.confident!r}")

    def __call__(self, post: Posterior, where: Situation) -> Decision:
        top = str(post.command)
        p = post.prob(top)
        made = self._ask_or_act(post, where, naming=top)  # a question naming it when one pays, else expected benefit
        if made.action == "ask":
            alt = ", ".join(o for o in made.options if o != top) or next(
                (f"{c} (P = {q:.2f})" for c, q in post.commands if str(c) != top), "something else")
            return dataclasses.replace(made, reason=f"asked for {top} (P = {p:.2f}), or {alt}: {made.reason}")
        if made.action != NONE:
            unsure = self._unheard(post, where, made.action, post.prob(made.action))
            if unsure is not None:
                return unsure
            return dataclasses.replace(made, reason=f"asked for {top} (P = {p:.2f}): {made.reason}")
        # expected benefit would do nothing; a request is never ignored
        why_not = decline_reason(top, where)
        if why_not:
            return Decision(self.name, NONE, NONE, 0.0, 0.0, reason=f"asked for {top}, but {why_not}",
                            declined=_sentence(why_not))
        if p >= self.confident:  # understood: carried out, whatever the robot guesses of its worth
            unsure = self._unheard(post, where, top, p)
            if unsure is not None:
                return unsure
            valued = dict(made.benefits).get(top, float("nan"))  # loss-averse, as expected benefit weighed it
            tv = _values(post, where)
            raw = float(tv.expected()[tv.actions.index(top)]) if top in tv.actions else float("nan")
            worth = (f"expected to save {raw:+.1f} steps, {valued:+.1f} weighed for risk; "
                     if np.isfinite(raw) and np.isfinite(valued) else "")
            return Decision(self.name, top, top, p, raw,
                            reason=f"asked for {top} (P = {p:.2f}): understood, so carried out ({worth}"
                                   f"the best question is worth {made.evi:.1f} steps <= its cost {made.ask_cost:.1f})",
                            benefits=made.benefits)
        return self._choose(post, where, top, p)

    def _unheard(self, post: Posterior, where: Situation, command: str, p: float) -> Decision | None:
        """A question instead of ``command`` when the words do not back it (assist/wordsback.py)."""
        from siftom.assist.wordsback import unheard_question

        if (q := unheard_question(post, where, command, _lexicon(where.world), decline_reason)) is None:
            return None
        question, why = q
        return Decision(self.name, "ask", command, p, float("nan"), question.text, question.options, 0.0,
                        question_cost(question, self.ask_cost, self.cost_model),
                        f"asked for {command} (P = {p:.2f}) {why}", (), question.kind, question)

    def _choose(self, post: Posterior, where: Situation, top: str, p: float) -> Decision:
        """Ask which of the two likeliest objects it was (or what was needed, with one)."""
        from siftom.assist.questions import Question, choose_question

        others = [str(c) for c, _ in post.commands[1:] if str(c) != top and not decline_reason(str(c), where)]
        q_choice = choose_question(top, others[0], _lexicon(where.world)) if others else None
        if not decline_reason(top, where) and q_choice is not None and not where.settled(q_choice):
            q = q_choice
            return Decision(self.name, "ask", top, p, float("nan"), q.text, q.options, 0.0,
                            question_cost(q, self.ask_cost, self.cost_model),
                            f"asked for {top} (P = {p:.2f}) or {others[0]}: not sure which", (), q.kind, q)
        q = Question("open", OPEN_QUESTION, (), ((),), ((),))
        if where.settled(q):  # asked already, and still not made out: say so rather than ask again
            return Decision(self.name, NONE, NONE, 0.0, 0.0, reason=f"asked for {top} (P = {p:.2f}): still not sure "
                            "what was asked for after asking", declined="Sorry, I could not make out what you need.")
        return Decision(self.name, "ask", top, p, float("nan"), q.text, (), 0.0, self.ask_cost or DEFAULT_ASK_COST,
                        "not sure what was asked for", (), q.kind, q)


RULES = Registry("decision rule", default="map")
RULES.register("map", "siftom.assist.decide:MapRule", summary="execute the most probable command")
RULES.register("expected-benefit", "siftom.assist.decide:ExpectedBenefitRule",
               summary="carry out the command asked for when it saves the team steps in expectation, else nothing",
               attrs={"options": ("loss_aversion", "utility", "spent", "scope")})
RULES.register("teammate", "siftom.assist.decide:TeammateRule",
               summary="carry out a request understood, ask about one unsure (naming the candidates), "
                       "decline only with a reason",
               attrs={"options": ("confident", "ask_cost", "penalty", "loss_aversion", "kinds", "cost_model",
                                   "time_as_loss", "utility", "spent")})
RULES.register("ask-or-act", "siftom.assist.decide:AskOrActRule",
               summary="ask the best question when it is worth more than its cost, else expected-benefit",
               attrs={"options": ("ask_cost", "penalty", "loss_aversion", "kinds", "cost_model",
                                   "time_as_loss", "utility", "spent")})


def get_rule(name: str, **options: Any) -> DecisionRule:
    """Build the decision rule registered as ``name``; an option it does not take is an error naming it."""
    entry = RULES.spec(name)
    takes = tuple(entry.attrs.get("options", ()))
    for key in options:
        if key not in takes:
            raise unknown_name(f"option of decision rule {name!r}", key, takes)
    rule: DecisionRule = entry.make(**options)  # the registry imports its rules by name: untyped
    return rule


def decide(post: Posterior, where: Situation, rule: str = "map", **options: Any) -> Decision:
    """Apply the named decision rule; words that hold no instruction (``evidence['no_instruction']``,
    likelihood/nearness.py) are not acted on: the robot does nothing."""
    chosen = get_rule(rule, **options)
    if post.evidence.get("no_instruction"):
        return Decision(rule, NONE, NONE, 0.0, 0.0,
                        reason=f"no instruction heard ({post.evidence.get('no_instruction_reason', '')})")
    return chosen(post, where)
