"""What a whole trial (:mod:`siftom.agents.trial`) records: its requests, its log and its result."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, TypedDict

from siftom.world.model import State


@dataclass(frozen=True)
class TrialRequest:
    """One request of a trial and what came of it."""

    t: float
    asked: str
    heard: str
    action: str  # act / ask / none
    executed: str | None  # the command the robot ran (after a question: the one asked for)
    reason: str
    ask_cost: float
    brought: int
    useful: int
    wrong: int
    remedy: float
    question: str = ""  # the question asked (action ask)
    options: tuple[str, ...] = ()  # the commands it names
    declined: str = ""  # what the robot said when it turned the request down (action none)

    @property
    def wrong_fetch(self) -> bool:
        return self.wrong > 0

    @property
    def answered(self) -> bool:
        """Carried out as asked, or answered with a question that names what was asked for."""
        return (self.action == "act" and self.executed == self.asked) or (
            self.action == "ask" and self.asked in self.options)

    @property
    def ignored(self) -> bool:
        """Turned down without a reason the robot can say."""
        return self.action == "none" and not self.declined

    def to_json(self) -> dict[str, Any]:
        return {**self.__dict__, "options": list(self.options)}


@dataclass(frozen=True)
class TrialEvent:
    """A line of the trial's log: an action (start and end time) or a request, question, remedy."""

    start: float
    end: float
    who: str  # human / robot / request / remedy
    text: str

    def to_json(self) -> dict[str, Any]:
        return dict(self.__dict__)


class TrialMetrics(TypedDict):
    """The numbers of a trial (:meth:`TrialResult.metrics`)."""

    scenario: str
    goal: str
    rule: str
    seed: int
    l_single: float
    l_team: float
    speedup: float
    requests: int
    acted: int
    wrong_fetches: int
    questions: int
    refusals: int
    answered: int
    ignored: int
    human_actions: int
    robot_actions: int
    remedy_steps: float


@dataclass(frozen=True)
class TrialResult:
    """The outcome of a whole trial (docs/team-simulation.md, "Whole trials")."""

    scenario: str
    goal: str
    rule: str
    seed: int
    l_single: float
    l_team: float
    speedup: float
    requests: tuple[TrialRequest, ...]
    human_actions: int
    robot_actions: int
    remedy_steps: float
    events: tuple[TrialEvent, ...] = field(default=(), repr=False)
    final: State | None = field(default=None, repr=False, compare=False)  # the state at the end

    @property
    def n_requests(self) -> int:
        return len(self.requests)

    @property
    def wrong_fetches(self) -> int:
        return sum(r.wrong_fetch for r in self.requests)

    @property
    def questions(self) -> int:
        return sum(r.action == "ask" for r in self.requests)

    @property
    def refusals(self) -> int:
        return sum(r.action == "none" for r in self.requests)

    @property
    def acted(self) -> int:
        return sum(r.action == "act" for r in self.requests)

    @property
    def answered(self) -> int:
        return sum(r.answered for r in self.requests)

    @property
    def ignored(self) -> int:
        return sum(r.ignored for r in self.requests)

    def metrics(self) -> TrialMetrics:
        """The numbers of the trial, without the log."""
        return {"scenario": self.scenario, "goal": self.goal, "rule": self.rule, "seed": self.seed,
                "l_single": self.l_single, "l_team": self.l_team, "speedup": self.speedup,
                "requests": self.n_requests, "acted": self.acted, "wrong_fetches": self.wrong_fetches,
                "questions": self.questions, "refusals": self.refusals, "answered": self.answered,
                "ignored": self.ignored, "human_actions": self.human_actions,
                "robot_actions": self.robot_actions, "remedy_steps": self.remedy_steps}

    def to_json(self, events: bool = True) -> dict[str, Any]:
        out: dict[str, Any] = dict(self.metrics())
        out["request_log"] = [r.to_json() for r in self.requests]
        if events:
            out["events"] = [e.to_json() for e in self.events]
        return out
