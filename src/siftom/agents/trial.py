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
from typing import Any

import numpy as np

from siftom.agents._trialrun import Speaker as Speaker
from siftom.agents._trialrun import TrialRun
from siftom.agents.team import _solve
from siftom.agents.trialrecords import TrialEvent as TrialEvent
from siftom.agents.trialrecords import TrialRequest as TrialRequest
from siftom.agents.trialrecords import TrialResult
from siftom.errors import SiftomError
from siftom.observation import Instruction
from siftom.world.commands import RobotCommand
from siftom.world.model import HUMAN, Goal, State, World

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
    online = observer.fresh(world, start, space, verb)
    single, plan0 = _solve(world, start, goal, HUMAN)
    rule_name = rule if isinstance(rule, str) else getattr(rule, "name", type(rule).__name__ if rule else "")
    run = TrialRun(world, goal, verb, ask_for, (lo, hi), rng, online, observer, speak or plain_speaker, rule,
                   likelihood, start, list(plan0), next_k=int(rng.integers(lo, hi + 1)), rule_name=rule_name)
    for _ in range(_MAX_EVENTS):
        run.end_finished_job()
        if goal.satisfied(world, run.s) and run.job is None:
            break
        if run.request_due(max_requests) and run.request():
            continue
        run.act()
    else:
        raise SiftomError(f"trial did not end within {_MAX_EVENTS} events")
    return run.result(sid, seed, single)
