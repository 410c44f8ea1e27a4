"""The moving parts of a whole trial (:func:`siftom.agents.trial.simulate_trial`).

A :class:`TrialRun` holds what changes while a trial runs -- the shared world state, each agent's
clock and plan, the robot's current job and the log -- and takes one step at a time: ending a
finished job, making a request, or the next action of the agent whose clock is earlier.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from siftom.agents.team import _reserve, _solve
from siftom.agents.trialrecords import TrialEvent, TrialRequest, TrialResult
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


@dataclass
class _Job:
    """The command the robot is carrying out."""

    command: RobotCommand
    plan: list[Action]
    reserved: set[int]
    wrong: int
    remedy: float


def aside_distance(world: World, target: int) -> int:
    """Walking steps from the target to the nearest other open surface (team.py's remedy)."""
    surfaces = [i for i, p in enumerate(world.places) if p.kind != "room" and i != target and not p.closable]
    return min((int(world.dist[target, i]) for i in surfaces), default=1)


@dataclass
class TrialRun:
    """A trial in progress: its settings, the shared state, both clocks, the plans and the log."""

    world: World
    goal: Goal
    verb: str
    ask_for: str
    request_every: tuple[int, int]
    rng: np.random.Generator
    online: Any  # the observer's online inference
    observer: Any
    speak: Speaker
    rule: Any
    likelihood: Any
    s: State
    human_plan: list[Action]
    next_k: int
    rule_name: Any
    d_aside: int = 0
    job: _Job | None = None
    t_h: float = 0.0
    t_r: float = 0.0
    steps_since: int = 0
    requests: list[TrialRequest] = field(default_factory=list)
    events: list[TrialEvent] = field(default_factory=list)
    n_h: int = 0
    n_r: int = 0
    remedy_total: float = 0.0
    started: set[str] = field(default_factory=set)  # the classes the person has grabbed an object of

    def __post_init__(self) -> None:
        self.d_aside = aside_distance(self.world, self.goal.target)

    # -- the person's goal, plan and requests ------------------------------------------------

    def human_goal(self, state: State) -> Goal:
        """The true goal minus what the robot will still put on the target."""
        job, goal = self.job, self.goal
        if job is None:
            return goal
        # the robot's objects are alike: the first it puts down are the useful ones
        coming = max(0, len(job.reserved) - job.wrong)
        return goal.minus(job.command.obj_class, coming) if coming else goal

    def replan_human(self, state: State) -> list[Action]:
        reserved = self.job.reserved if self.job is not None else set()
        _c, plan = _solve(self.world, _reserve(state, reserved) if reserved else state,
                          self.human_goal(state), HUMAN)
        return list(plan)

    def needed(self, state: State) -> dict[str, int]:
        world, T = self.world, self.goal.target
        held = state.held[HUMAN]
        out = {}
        for c, n in self.goal.counts:
            k = n - world.count_at(state, T, c) - (1 if held != NOTHING and world.items[held].cls == c else 0)
            if k > 0:
                out[c] = k
        return out

    def choose(self, state: State) -> RobotCommand | None:
        """The command the person asks for (the module doc of :mod:`siftom.agents.trial`, ``ask_for``)."""
        need = self.needed(state)
        if self.ask_for != "any":
            need = {c: n for c, n in need.items() if c not in self.started}
        if not need:
            return None
        if self.ask_for == "plan":
            return self.robot_part(state, need)
        first: dict[str, int] = {}
        for k, a in enumerate(self.human_plan):
            if a.kind == "grab":
                first.setdefault(self.world.items[a.obj].cls, k)
        rank = {c: first.get(c, len(self.human_plan) + 1) for c in need}
        top = max(rank.values())
        tied = sorted(c for c, r in rank.items() if r == top)
        cls = tied[int(self.rng.integers(len(tied)))] if len(tied) > 1 else tied[0]
        n = 1 if self.verb == "fetch" else min(need[cls], MAX_COUNT)
        return RobotCommand(self.verb, cls, n)

    def robot_part(self, state: State, need: dict[str, int]) -> RobotCommand | None:
        """The robot's part of the best joint plan from ``state``: the class whose delivery by the
        robot, while the person does the rest, ends soonest -- if that beats the person alone."""
        world, goal, verb, T = self.world, self.goal, self.verb, self.goal.target
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
        cls = tied[int(self.rng.integers(len(tied)))] if len(tied) > 1 else tied[0]
        return RobotCommand(verb, cls, 1 if verb == "fetch" else min(need[cls], MAX_COUNT))

    # -- the robot's job ---------------------------------------------------------------------

    def start_job(self, cmd: RobotCommand, state: State) -> _Job:
        world, goal, T = self.world, self.goal, self.goal.target
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
        return _Job(cmd, list(plan), taken, wrong, float(wrong * (2 + 2 * self.d_aside)))

    def end_finished_job(self) -> None:
        """A job whose plan is done ends; the person clears what it brought that was not needed."""
        job = self.job
        if job is None or job.plan:
            return
        if job.remedy:
            t0 = max(self.t_h, self.t_r)
            self.t_h = t0 + job.remedy
            self.remedy_total += job.remedy
            self.events.append(TrialEvent(t0, self.t_h, "remedy", f"human clears {job.wrong} wrong object(s) "
                                                                   f"of {job.command}"))
        self.job = None

    # -- a request ---------------------------------------------------------------------------

    def request_due(self, max_requests: int) -> bool:
        """A request point: the person has taken k own actions, the robot is idle and free."""
        return bool(self.human_plan and self.job is None and self.steps_since >= self.next_k
                    and self.t_r <= self.t_h and len(self.requests) < max_requests)

    def request(self) -> bool:
        """At a request point: the person asks (if something is left to ask for) and the robot
        answers. False when the person asked for nothing."""
        lo, hi = self.request_every
        asked = self.choose(self.s)
        self.steps_since, self.next_k = 0, int(self.rng.integers(lo, hi + 1))
        if asked is None:
            return False
        said = self.speak(asked, self.rng)
        instruction = Instruction.from_text(said) if isinstance(said, str) else said
        ans = self.observer.answer(self.online, instruction, decide=self.rule, likelihood=self.likelihood)
        self.rule_name = ans.decision.rule
        action, executed, ask_cost = ans.action, None, float(ans.decision.ask_cost)
        t_h = self.t_h
        self.events.append(TrialEvent(t_h, t_h, "request", f"{instruction.text!r} (asked {asked}) -> "
                                                           f"{action} {ans.command or ''}".rstrip()))
        if action == "ask":
            self.events.append(TrialEvent(t_h, t_h + ask_cost, "question",
                                          f"{ans.decision.question or 'a question'} -> {asked}"))
            self.t_h = self.t_r = t_h + ask_cost
            executed = asked
        elif action == "act":
            executed = ans.command
        brought = useful = wrong = 0
        remedy = 0.0
        if executed is not None:
            job = self.job = self.start_job(RobotCommand.parse(str(executed)), self.s)
            self.t_r = max(self.t_r, self.t_h)
            brought, wrong, remedy = len(job.reserved), job.wrong, job.remedy
            useful = brought - wrong
            self.human_plan = self.replan_human(self.s)
        d = ans.decision
        self.requests.append(TrialRequest(self.t_h, str(asked), instruction.text, action,
                                          None if executed is None else str(executed), d.reason,
                                          ask_cost if action == "ask" else 0.0, brought, useful, wrong, remedy,
                                          d.question if action == "ask" else "",
                                          tuple(d.options) if action == "ask" else (), d.declined))
        return True

    # -- the next action ---------------------------------------------------------------------

    def act(self) -> None:
        """The next action: the person's or the robot's, whichever clock is earlier (the person
        on ties); the person replans when their plan ran out or no longer applies."""
        robot_ready = self.job is not None and bool(self.job.plan)
        if not self.human_plan and not robot_ready:
            self.human_plan = self.replan_human(self.s)
            if not self.human_plan:
                raise SiftomError(f"trial stuck: {self.goal.describe()} not reached and nothing left to do")
            return
        if self.human_plan and (not robot_ready or self.t_h <= self.t_r):
            self.human_step()
        else:
            self.robot_step()

    def human_step(self) -> None:
        world, s = self.world, self.s
        a = self.human_plan[0]
        if a.kind == "open" and s.is_open(a.place):
            self.human_plan.pop(0)
            return
        if check(world, s, a) is not None:
            self.human_plan = self.replan_human(s)
            return
        self.human_plan.pop(0)
        if a.kind == "grab":
            self.started.add(world.items[a.obj].cls)
        c = cost(world, s, a)
        self.online.observe(a)
        self.s = apply(s, a)
        self.events.append(TrialEvent(self.t_h, self.t_h + c, "human", world.format_action(a)))
        self.t_h += c
        self.n_h += 1
        self.steps_since += 1

    def robot_step(self) -> None:
        world, s, job = self.world, self.s, self.job
        assert job is not None
        a = job.plan[0]
        if a.kind == "open" and s.is_open(a.place):
            job.plan.pop(0)
            return
        why = check(world, s, a)
        if why is not None:
            raise SiftomError(f"the robot's plan for {job.command} broke: {world.format_action(a)}: {why}")
        job.plan.pop(0)
        c = cost(world, s, a)
        self.online.observe(a)
        self.s = apply(s, a)
        if a.kind == "put" and a.place == self.goal.target:
            job.reserved.discard(a.obj)
        self.events.append(TrialEvent(self.t_r, self.t_r + c, "robot", world.format_action(a)))
        self.t_r += c
        self.n_r += 1

    def result(self, sid: str, seed: int, single: float) -> TrialResult:
        l_team = max(self.t_h, self.t_r)
        return TrialResult(sid, self.goal.name, str(self.rule_name), seed, float(single), float(l_team),
                           float(single) / l_team - 1.0 if l_team > 0 else 0.0, tuple(self.requests),
                           self.n_h, self.n_r, self.remedy_total, tuple(self.events), self.s)
