"""Whole trials: a person works towards a goal and asks the robot for several items on the way.

One request is scored by :mod:`siftom.agents.team`; a trial chains them (docs/team-simulation.md,
"Whole trials"). From the scenario's start state:

* **The person** acts optimally (A*, the team simulation's planner) towards the true goal, minus
  what the robot is bringing, around the objects the robot's plan takes.
* **Requests.** After ``k`` of their own actions (``k`` drawn by the seeded generator from
  ``request_every``), when the robot is idle and something is still needed, the person asks for
  one item: the needed class their own plan would fetch last (ties: the generator), the whole
  count still needed for ``deliver``; by default only a class the person has not grabbed an
  object of yet (``ask_for``). ``speak(command, rng)`` turns the command into what the
  robot hears (text or an :class:`~siftom.observation.Instruction`).
* **The robot** answers through ``observer.answer(online, instruction, decide=rule)`` on an
  online inference that has observed every action so far, the person's (evidence about the
  goal) and its own (they change the world only). ``act``: it runs its optimal plan of the
  command in parallel with the person; ``ask``: both spend ``decision.ask_cost`` steps and the
  answer clarifies to the command the person asked for, which the robot then runs; ``none``:
  nothing happens (a refusal).
* **Parallel time.** Each agent has a clock; the next action is the one of the agent whose
  clock is earlier (the person first on ties). An action is applied when it starts and costs its
  world cost (docs/world.md). An ``open`` of a container the other agent already opened is
  skipped (free). The person replans when the robot takes on a command.
* **Remedy.** Every object the robot brings that the goal does not need (team.py's rule) costs
  the person ``2 + 2 d(target, nearest other surface)`` steps once the robot has put it down:
  the person's clock moves to ``max(person, robot) + remedy``. The object stays where it is in
  the simulated state (the observer is shown only real actions; the clearing is counted in time).
* **End.** When the goal holds and the robot is done: ``L_team`` = the later clock,
  ``L_single`` = the person's optimal cost alone from the start, ``speedup = L_single / L_team - 1``.
  A robot that never acts leaves the person's first plan untouched: speedup exactly 0.

Deterministic given ``seed`` (the observer and the planner are deterministic).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from siftom.agents.team import _reserve, _solve
from siftom.errors import SiftomError
from siftom.observation import Instruction
from siftom.world.commands import MAX_COUNT, RobotCommand
from siftom.world.model import (
    HELD,
    HUMAN,
    NOTHING,
    ROBOT,
    Action,
    Goal,
    State,
    World,
    apply,
    check,
    cost,
)

Speaker = Callable[[RobotCommand, np.random.Generator], "Instruction | str"]
# how many of their own actions the person takes before each request (inclusive range)
REQUEST_EVERY = (2, 6)
MAX_REQUESTS = 3
# which classes the person asks for: the robot's part of the best joint plan, any they have not
# started, or any still needed
ASK_FOR = ("plan", "unstarted", "any")
_NUMBERS = ("zero", "one", "two", "three", "four", "five", "six")
_MAX_EVENTS = 10_000


def _plural(noun: str) -> str:
    if noun.endswith("fe"):
        return noun[:-2] + "ves"
    if noun.endswith("f"):
        return noun[:-1] + "ves"
    return noun + ("es" if noun.endswith(("s", "sh", "ch", "x")) else "s")


def plain_phrasing(command: RobotCommand) -> str:
    """A carrier phrasing of ``command`` without a lexicon: "pass me the cereal", "bring me three forks"."""
    noun = command.obj_class.replace("_", " ")
    if command.verb == "fetch" and command.count == 1:
        return f"pass me the {noun}"
    n = _NUMBERS[command.count] if command.count < len(_NUMBERS) else str(command.count)
    return f"bring me {n} {noun if command.count == 1 else _plural(noun)}"


def plain_speaker(command: RobotCommand, rng: np.random.Generator) -> str:
    """The default speaker: :func:`plain_phrasing`, heard exactly (oracle text)."""
    return plain_phrasing(command)


def nbest_speaker(nbest: Callable[[RobotCommand, np.random.Generator], Sequence[tuple[str, float]]]) -> Speaker:
    """A speaker from a callable that returns an N-best list ``[(text, log score), ...]``, best first."""

    def speak(command: RobotCommand, rng: np.random.Generator) -> Instruction:
        return Instruction.from_nbest(list(nbest(command, rng)))

    return speak


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

    def metrics(self) -> dict[str, Any]:
        """The numbers of the trial, without the log."""
        return {"scenario": self.scenario, "goal": self.goal, "rule": self.rule, "seed": self.seed,
                "l_single": self.l_single, "l_team": self.l_team, "speedup": self.speedup,
                "requests": self.n_requests, "acted": self.acted, "wrong_fetches": self.wrong_fetches,
                "questions": self.questions, "refusals": self.refusals, "answered": self.answered,
                "ignored": self.ignored, "human_actions": self.human_actions,
                "robot_actions": self.robot_actions, "remedy_steps": self.remedy_steps}

    def to_json(self, events: bool = True) -> dict[str, Any]:
        out = self.metrics()
        out["request_log"] = [r.to_json() for r in self.requests]
        if events:
            out["events"] = [e.to_json() for e in self.events]
        return out


@dataclass
class _Job:
    """The command the robot is carrying out."""

    command: RobotCommand
    plan: list[Action]
    reserved: set[int]
    wrong: int
    remedy: float


def _unpack(scene: Any, goals: Sequence[Goal] | None) -> tuple[str, World, State, Goal, tuple[Goal, ...], str]:
    if isinstance(scene, tuple):
        if len(scene) != 4:
            raise SiftomError("a trial's scene is a scenario or (world, start, goal, verb)")
        world, start, goal, verb = scene
        space = tuple(goals) if goals is not None else (goal,)
        if goal not in space:
            raise SiftomError("the goal space must contain the true goal")
        return "custom", world, start, goal, space, verb
    space = tuple(goals) if goals is not None else tuple(scene.goals)
    return str(scene.id), scene.world, scene.start, scene.goal, space, str(scene.verb)


def _aside_distance(world: World, target: int) -> int:
    """Walking steps from the target to the nearest other open surface (team.py's remedy)."""
    surfaces = [i for i, p in enumerate(world.places) if p.kind != "room" and i != target and not p.closable]
    return min((int(world.dist[target, i]) for i in surfaces), default=1)


def simulate_trial(
    scene: Any,
    observer: Any,
    *,
    seed: int = 0,
    speak: Speaker | None = None,
    rule: Any = None,
    max_requests: int = MAX_REQUESTS,
    request_every: tuple[int, int] = REQUEST_EVERY,
    goals: Sequence[Goal] | None = None,
    likelihood: Any = None,
    ask_for: str = "plan",
) -> TrialResult:
    """Simulate a whole trial (module doc) and score it.

    Args:
        scene: a registered scenario (its world, start state, goal space, true goal and verb)
            or ``(world, start, goal, verb)`` (goal space: ``goals``, default the goal alone).
        observer: a :class:`siftom.Observer` (anything with ``fresh`` and ``answer``).
        seed: seeds the request points and the speaker; the same seed gives the same trial.
        speak: ``speak(command, rng)`` -> text or Instruction (default :func:`plain_speaker`).
        rule: the decision rule (a name or a rule object; None: the observer's setting).
        max_requests: the most requests the person makes.
        request_every: the person's own actions before each request, drawn uniformly in this
            inclusive range.
        likelihood: the instruction likelihood (None: the observer's setting).
        ask_for: ``plan`` (default): the person asks for the robot's part of the best joint
            plan -- among the classes they have not yet grabbed an object of, the one whose
            delivery by the robot (while the person does the rest) ends the task soonest, and
            only when that beats working alone (the paper's model: the person asks for pi_r of
            a good joint plan, pi_h = g minus pi_r); ``unstarted``: any class not yet started
            (the part the person's own plan would fetch last); ``any``: also a class they are
            working on.
    """
    sid, world, start, goal, space, verb = _unpack(scene, goals)
    lo, hi = request_every
    if ask_for not in ASK_FOR:
        raise SiftomError(f"ask_for must be one of {', '.join(ASK_FOR)}, got {ask_for!r}")
    if not 1 <= lo <= hi:
        raise SiftomError(f"request_every must be 1 <= low <= high, got {request_every}")
    rng = np.random.default_rng(seed)
    speak = speak or plain_speaker
    online = observer.fresh(world, start, space, verb)
    T = goal.target
    d_aside = _aside_distance(world, T)
    single, plan0 = _solve(world, start, goal, HUMAN)
    s = start
    human_plan = list(plan0)
    job: _Job | None = None
    t_h = t_r = 0.0
    steps_since, next_k = 0, int(rng.integers(lo, hi + 1))
    requests: list[TrialRequest] = []
    events: list[TrialEvent] = []
    n_h = n_r = 0
    remedy_total = 0.0
    started: set[str] = set()  # the classes the person has grabbed an object of
    rule_name = rule if isinstance(rule, str) else getattr(rule, "name", type(rule).__name__ if rule else "")

    def human_goal(state: State) -> Goal:
        """The true goal minus what the robot will still put on the target."""
        if job is None:
            return goal
        # the robot's objects are alike: the first it puts down are the useful ones
        coming = max(0, len(job.reserved) - job.wrong)
        return goal.minus(job.command.obj_class, coming) if coming else goal

    def replan_human(state: State) -> list[Action]:
        reserved = job.reserved if job is not None else set()
        _c, plan = _solve(world, _reserve(state, reserved) if reserved else state, human_goal(state), HUMAN)
        return list(plan)

    def needed(state: State) -> dict[str, int]:
        held = state.held[HUMAN]
        out = {}
        for c, n in goal.counts:
            k = n - world.count_at(state, T, c) - (1 if held != NOTHING and world.items[held].cls == c else 0)
            if k > 0:
                out[c] = k
        return out

    def choose(state: State) -> RobotCommand | None:
        need = needed(state)
        if ask_for != "any":
            need = {c: n for c, n in need.items() if c not in started}
        if not need:
            return None
        if ask_for == "plan":
            return robot_part(state, need)
        first: dict[str, int] = {}
        for k, a in enumerate(human_plan):
            if a.kind == "grab":
                first.setdefault(world.items[a.obj].cls, k)
        rank = {c: first.get(c, len(human_plan) + 1) for c in need}
        top = max(rank.values())
        tied = sorted(c for c, r in rank.items() if r == top)
        cls = tied[int(rng.integers(len(tied)))] if len(tied) > 1 else tied[0]
        n = 1 if verb == "fetch" else min(need[cls], MAX_COUNT)
        return RobotCommand(verb, cls, n)

    def robot_part(state: State, need: dict[str, int]) -> RobotCommand | None:
        """The robot's part of the best joint plan from ``state``: the class whose delivery by the
        robot, while the person does the rest, ends soonest -- if that beats the person alone."""
        alone, _plan = _solve(world, state, goal, HUMAN)
        best: list[tuple[float, str]] = []
        for cls, k in sorted(need.items()):
            n = 1 if verb == "fetch" else min(k, MAX_COUNT)
            have = world.count_at(state, T, cls)
            r_cost, r_plan = _solve(world, state, Goal("robot", T, ((cls, have + n),)), ROBOT)
            taken = {a.obj for a in r_plan if a.kind == "grab"}
            h_cost, _h = _solve(world, _reserve(state, taken), goal.minus(cls, n), HUMAN)
            best.append((max(float(r_cost), float(h_cost)), cls))
        if not best:
            return None
        top = min(t for t, _c in best)
        if top >= alone - 1e-9:  # no part for the robot makes the team faster: the person works alone
            return None
        tied = [c for t, c in best if t <= top + 1e-9]
        cls = tied[int(rng.integers(len(tied)))] if len(tied) > 1 else tied[0]
        return RobotCommand(verb, cls, 1 if verb == "fetch" else min(need[cls], MAX_COUNT))

    def start_job(cmd: RobotCommand, state: State) -> _Job:
        cls = cmd.obj_class
        have = world.count_at(state, T, cls)
        avail = [i for i, loc in enumerate(state.item_at) if loc not in (HELD, T) and world.items[i].cls == cls]
        n = min(cmd.count, len(avail))
        plan: tuple[Action, ...] = ()
        if n:
            _c, plan = _solve(world, state, Goal("robot", T, ((cls, have + n),)), ROBOT)
        taken = {a.obj for a in plan if a.kind == "grab"}
        held = state.held[HUMAN]
        need_c = max(0, goal.count_map.get(cls, 0) - have
                     - (1 if held != NOTHING and world.items[held].cls == cls else 0))
        useful = min(n, need_c)
        wrong = n - useful
        return _Job(cmd, list(plan), taken, wrong, float(wrong * (2 + 2 * d_aside)))

    for _ in range(_MAX_EVENTS):
        if job is not None and not job.plan:
            if job.remedy:
                t0 = max(t_h, t_r)
                t_h = t0 + job.remedy
                remedy_total += job.remedy
                events.append(TrialEvent(t0, t_h, "remedy", f"human clears {job.wrong} wrong object(s) "
                                                            f"of {job.command}"))
            job = None
        if goal.satisfied(world, s) and job is None:
            break
        # a request point: the person has taken k own actions, the robot is idle and free
        if (human_plan and job is None and steps_since >= next_k and t_r <= t_h
                and len(requests) < max_requests):
            asked = choose(s)
            steps_since, next_k = 0, int(rng.integers(lo, hi + 1))
            if asked is not None:
                said = speak(asked, rng)
                instruction = Instruction.from_text(said) if isinstance(said, str) else said
                ans = observer.answer(online, instruction, decide=rule, likelihood=likelihood)
                rule_name = ans.decision.rule
                action, executed, ask_cost = ans.action, None, float(ans.decision.ask_cost)
                events.append(TrialEvent(t_h, t_h, "request", f"{instruction.text!r} (asked {asked}) -> "
                                                               f"{action} {ans.command or ''}".rstrip()))
                if action == "ask":
                    events.append(TrialEvent(t_h, t_h + ask_cost, "question",
                                             f"{ans.decision.question or 'a question'} -> {asked}"))
                    t_h = t_r = t_h + ask_cost
                    executed = asked
                elif action == "act":
                    executed = ans.command
                brought = useful = wrong = 0
                remedy = 0.0
                if executed is not None:
                    job = start_job(RobotCommand.parse(str(executed)), s)
                    t_r = max(t_r, t_h)
                    brought, wrong, remedy = len(job.reserved), job.wrong, job.remedy
                    useful = brought - wrong
                    human_plan = replan_human(s)
                d = ans.decision
                requests.append(TrialRequest(t_h, str(asked), instruction.text, action,
                                             None if executed is None else str(executed), d.reason,
                                             ask_cost if action == "ask" else 0.0, brought, useful, wrong, remedy,
                                             d.question if action == "ask" else "",
                                             tuple(d.options) if action == "ask" else (), d.declined))
                continue
        robot_ready = job is not None and bool(job.plan)
        if not human_plan and not robot_ready:
            human_plan = replan_human(s)
            if not human_plan:
                raise SiftomError(f"trial stuck: {goal.describe()} not reached and nothing left to do")
            continue
        if human_plan and (not robot_ready or t_h <= t_r):
            a = human_plan[0]
            if a.kind == "open" and s.is_open(a.place):
                human_plan.pop(0)
                continue
            if check(world, s, a) is not None:
                human_plan = replan_human(s)
                continue
            human_plan.pop(0)
            if a.kind == "grab":
                started.add(world.items[a.obj].cls)
            c = cost(world, s, a)
            online.observe(a)
            s = apply(s, a)
            events.append(TrialEvent(t_h, t_h + c, "human", world.format_action(a)))
            t_h += c
            n_h += 1
            steps_since += 1
        else:
            assert job is not None
            a = job.plan[0]
            if a.kind == "open" and s.is_open(a.place):
                job.plan.pop(0)
                continue
            why = check(world, s, a)
            if why is not None:
                raise SiftomError(f"the robot's plan for {job.command} broke: {world.format_action(a)}: {why}")
            job.plan.pop(0)
            c = cost(world, s, a)
            online.observe(a)
            s = apply(s, a)
            if a.kind == "put" and a.place == T:
                job.reserved.discard(a.obj)
            events.append(TrialEvent(t_r, t_r + c, "robot", world.format_action(a)))
            t_r += c
            n_r += 1
    else:
        raise SiftomError(f"trial did not end within {_MAX_EVENTS} events")
    l_team = max(t_h, t_r)
    return TrialResult(sid, goal.name, str(rule_name), seed, float(single), float(l_team),
                       float(single) / l_team - 1.0 if l_team > 0 else 0.0, tuple(requests), n_h, n_r,
                       remedy_total, tuple(events), s)
