"""SIFToM inference: the joint posterior over goals and robot commands (paper, Eq. 1-3).

    P(g, pi_r | s_1:T, a_1:T, phi)  ∝  P(g) P(pi_r | g) · prod_t P(a_t | s_t, pi_h) · P(phi | pi_r)

where the human's part of the joint plan is pi_h = g minus pi_r (what the human must still do
when the robot does pi_r). Enumeration is exact, in log space, over every (g, pi_r) pair plus an
"unknown goal" hypothesis (docs/inference.md explains each choice):

* P(g): uniform over the goal space, with ``unknown_prior`` mass on "unknown goal".
* P(pi_r | g): softmax over the goal's possible robot parts of ``help_kappa`` times the steps
  the part saves the human (useful, non-redundant help); under "unknown goal", uniform over
  every command of the domain.
* P(a_t | s_t, pi_h): Boltzmann over Q* (planning/costtogo.py), marginalised over a grid of
  ``betas``; under "unknown goal", uniform over the legal actions.
* P(phi | pi_r): any InstructionLikelihood (phonetic by default).

The ablations are configurations: ``speech-only`` drops the action term and uses a uniform
prior over commands; ``action-only`` drops the instruction term.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache, partial
from typing import Any

import numpy as np

from siftom.errors import ObservationError
from siftom.inference.goalspace import changed_classes
from siftom.inference.goalspace import goal_space as _goal_space
from siftom.inference.joint import JointHypothesis as JointHypothesis
from siftom.inference.joint import JointPosterior as JointPosterior
from siftom.inference.joint import ScoredCommand as ScoredCommand
from siftom.inference.joint import ScoredGoal as ScoredGoal
from siftom.inference.parts import BoltzmannActions, GoalPrior, HelpfulPartPrior, UniformActions
from siftom.inference.understood import understanding_of as understanding_of
from siftom.language.record import Understanding
from siftom.likelihood.base import Instruction, InstructionLikelihood, as_scores
from siftom.likelihood.registry import LIKELIHOODS, check_instruction
from siftom.logspace import group_logsumexp, logsumexp
from siftom.options import MODES as MODES
from siftom.options import (
    ModelConfig as ModelConfig,  # re-exported: the option classes live in siftom.options
)
from siftom.planning.costtogo import successor_values
from siftom.world.commands import RobotCommand
from siftom.world.model import HUMAN, Action, Goal, State, World, apply, check, legal_actions

OnStep = Callable[[str, "OnlineInference", Any], None]
UNKNOWN = "unknown"
OFF_PLAN = "off-plan"  # a request for something outside the person's plan (hypotheses only)
_changed_classes = changed_classes  # the name the speed benchmark imports
_SCORED_COMMAND: Callable[[tuple[RobotCommand, float]], ScoredCommand] = partial(tuple.__new__, ScoredCommand)
_SCORED_GOAL: Callable[[tuple[str, float]], ScoredGoal] = partial(tuple.__new__, ScoredGoal)


@dataclass(frozen=True, eq=False)
class Observation:
    """What the robot saw and heard. Validated on construction (every action must be legal)."""

    world: World
    start: State
    actions: tuple[Action, ...]
    goals: tuple[Goal, ...]
    verb: str = "deliver"
    instruction: Instruction | None = None
    states: tuple[State, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not self.goals:
            raise ObservationError("the goal space is empty; give at least one goal")
        targets = {g.target for g in self.goals}
        if len(targets) != 1:
            raise ObservationError("all goals must share one target place")
        classes = set(self.world.classes)
        for g in self.goals:
            for c, n in g.counts:
                if c not in classes:
                    raise ObservationError(f"goal {g.name!r} needs {c!r}, which is not in the scene")
                if n < 1:
                    raise ObservationError(f"goal {g.name!r}: count of {c!r} must be >= 1")
        states = [self.start]
        for t, a in enumerate(self.actions):
            if not isinstance(a, Action):
                raise ObservationError(f"action {t} is not an Action: {a!r}")
            why = check(self.world, states[-1], a)
            if why is not None:
                raise ObservationError(f"action {t} {self.world.format_action(a)} is impossible here: {why}")
            states.append(apply(states[-1], a))
        object.__setattr__(self, "states", tuple(states))

    @classmethod
    def from_scenario(cls, scenario: Any, instruction: Instruction | None = None,
                      n_actions: int | None = None) -> Observation:
        acts = scenario.actions if n_actions is None else scenario.actions[:n_actions]
        return cls(scenario.world, scenario.start, tuple(acts), scenario.goals, scenario.verb, instruction)


@dataclass(frozen=True)
class Posterior:
    """The result of inference. ``to_json`` gives the documented JSON shape."""

    command: RobotCommand
    commands: tuple[tuple[RobotCommand, float], ...]
    goals: tuple[tuple[str, float], ...]
    hypotheses: tuple[JointHypothesis, ...]
    mode: str
    likelihood: str
    n_actions: int
    seconds: float
    transcript: str = ""
    joint: JointPosterior | None = field(default=None, repr=False, compare=False)
    # what the instruction likelihood used besides the N-best (``evidence()``), e.g. Whisper's own words
    evidence: dict[str, Any] = field(default_factory=dict, compare=False)
    # what a decision rule made of it (``siftom.infer(..., decide=RULE)``): a ``Decision``
    decision: Any = field(default=None, compare=False)
    # what the utterance model understood of the words (siftom.language); None without words
    understanding: Understanding | None = field(default=None, compare=False)

    def prob(self, command: str) -> float:
        """The posterior probability of ``command`` (a RobotCommand or its text)."""
        for c, p in self.commands:
            if c == command:
                return p
        return 0.0

    def to_json(self, top: int = 10) -> dict[str, Any]:
        return {
            "command": str(self.command),
            "commands": [{"command": str(c), "prob": p} for c, p in self.commands[:top]],
            "goals": [{"goal": g, "prob": p} for g, p in self.goals[:top]],
            "hypotheses": [{**h.__dict__, "command": str(h.command)} for h in self.hypotheses[:top]],
            "mode": self.mode,
            "likelihood": self.likelihood,
            "n_actions": self.n_actions,
            "transcript": self.transcript,
            "seconds": self.seconds,
            "evidence": dict(self.evidence),
            **({"decision": self.decision.to_json()} if self.decision is not None else {}),
        }



class SIFToM:
    """The model: build once per observation stream; ``infer`` or use ``online`` updates."""

    def __init__(self, config: ModelConfig | None = None, likelihood: InstructionLikelihood | None = None,
                 on_step: OnStep | None = None) -> None:
        """``on_step(event, online, value)`` observes inference without touching the math:
        ``("observe", online, action)`` after each action, ``("posterior", online, posterior)``
        after each posterior (logging, plots, progress)."""
        self.config = config or ModelConfig()
        self.on_step = on_step
        if likelihood is None and self.config.uses_speech:
            from siftom.likelihood.phonetic import PhoneticLikelihood

            likelihood = PhoneticLikelihood()
        self.likelihood = likelihood

    def infer(self, obs: Observation, instruction: Instruction | None = None) -> Posterior:
        """Posterior for the whole observation."""
        online = self.online(obs.world, obs.start, obs.goals, obs.verb)
        for a in obs.actions:
            online.observe(a)
        return online.posterior(instruction or obs.instruction)

    def online(self, world: World, start: State, goals: Sequence[Goal], verb: str = "deliver") -> OnlineInference:
        """An incremental inference: ``observe(action)`` per step, ``posterior(instruction)`` any time."""
        return OnlineInference(self, world, start, tuple(goals), verb)


class OnlineInference:
    """Keeps per-hypothesis action log-likelihoods so one more action costs one Q-table row."""

    def __init__(self, model: SIFToM, world: World, start: State, goals: tuple[Goal, ...], verb: str) -> None:
        self.model, self.world, self.goals, self.verb = model, world, goals, verb
        cfg = model.config
        self.state = start
        self.n_actions = 0
        self.target = goals[0].target
        gs = _goal_space(world, goals, cfg.max_count)
        self._N_goal, self._sp_goal, self._sp = gs.N, gs.sp_goal, gs.sp
        self._pair_goal, self._pair_cls, self._pair_row = gs.pair_goal, gs.pair_cls, gs.pair_row
        self._class_total = gs.class_total
        self.ctg = gs.ctg
        self._tabs = self.ctg.tables(start)
        # the unknown goal's commands, coded class * K + count (fixed for the domain)
        self._code_base = K = max(cfg.max_count, int(self._N_goal.max())) + 1
        tops = (np.minimum(self._class_total, cfg.max_count) if verb == "deliver"
                else np.ones_like(self._class_total))
        self._unknown_codes = np.concatenate([c * K + np.arange(1, t + 1) for c, t in enumerate(tops) if t > 0])
        self._goal_names = [g.name for g in goals] + [UNKNOWN]
        # the model's parts (parts.py): priors and action models; the posterior only sums them
        self.goal_prior = GoalPrior(cfg.unknown_prior)
        self.part_prior = HelpfulPartPrior(cfg.help_kappa)
        self.actions = BoltzmannActions(cfg.betas, cfg.epsilon, len(gs.sp))  # one row per human subgoal
        self.unknown_actions = UniformActions()
        # values of this state (a new dict with every action, so a copy that is advanced, e.g.
        # a view with another model, never shares it with the original): :meth:`_kept`
        self._memo: dict[str, Any] = {}

    # ----- actions ---------------------------------------------------------------------------
    def observe(self, action: Action) -> None:
        """Add one observed action (checked against the current state).

        The human's actions are evidence about the goal (the action term). The robot's own
        actions (``action.agent == ROBOT``: what it carried out) change the world the next
        actions and requests are read in, and say nothing about the human's goal: an object the
        robot brought is no longer left to bring.
        """
        why = check(self.world, self.state, action)
        if why is not None:
            raise ObservationError(f"{self.world.format_action(action)} is impossible here: {why}")
        if action.agent != HUMAN or not self.model.config.uses_actions:
            self._advance(action)
            if self.model.on_step is not None:
                self.model.on_step("observe", self, action)
            return
        acts = list(legal_actions(self.world, self.state, HUMAN))
        # legal_actions writes grabs with their place and handovers to the other agent
        key = (action.kind, action.obj, action.place if action.kind != "grab" else self.state.item_at[action.obj])
        k = next(i for i, a in enumerate(acts) if (a.kind, a.obj, a.place) == key)
        Q = successor_values(self.ctg, self.state, self._tabs, acts, self._sp)  # (A, R)
        self.actions.observe(Q, k)
        self.unknown_actions.observe(len(acts))
        self._advance(action)
        if self.model.on_step is not None:
            self.model.on_step("observe", self, action)

    def _advance(self, action: Action) -> None:
        s2 = apply(self.state, action)
        self._tabs = self.ctg.retable(self._tabs, s2, changed_classes(self.world, self.state, action))
        self.state = s2
        self.n_actions += 1
        self._memo = {}

    def _kept(self, name: str, make: Callable[[], Any]) -> Any:
        """``make()``, a function of the actions observed so far alone, made once per state."""
        got = self._memo.get(name)
        if got is None:
            got = self._memo[name] = make()
        return got

    # ----- hypotheses ------------------------------------------------------------------------
    def candidates(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[RobotCommand]]:
        """Hypotheses as arrays: (goal index, command index, human-subgoal row) per (g, pi_r)
        pair, the command indices of the unknown-goal hypothesis, and the command list.

        The robot's part for goal g and class c is every object of c the goal still needs: not
        yet on the target and not in the human's hands. Made once per state (the arrays are
        read-only).
        """
        goal_idx, cmd_of, rows, unk, cmds = self._kept("candidates", self._candidates)
        return goal_idx, cmd_of, rows, unk, list(cmds)

    def _candidates(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[RobotCommand, ...]]:
        done = self._done()
        left = self._N_goal[self._pair_goal, self._pair_cls] - done[self._pair_cls]
        keep = np.flatnonzero(left >= 1)
        K = self._code_base
        known = self._pair_cls[keep] * K + left[keep]
        codes, inv = np.unique(np.concatenate([known, self._unknown_codes]), return_inverse=True)
        classes = self.world.classes
        cmds = [_command(self.verb, classes[int(code) // K], int(code) % K) for code in codes]
        inv = inv.reshape(-1)
        out = (self._pair_goal[keep], inv[: len(known)], self._pair_row[keep], inv[len(known):])
        for a in out:
            a.flags.writeable = False
        return (*out, tuple(cmds))

    def _done(self) -> np.ndarray:
        """Objects of each class on the target or in the person's hands."""
        s = self.state
        done: np.ndarray = self._tabs.at_target.copy()
        if s.held[HUMAN] >= 0:
            done[self.world.item_class_idx[s.held[HUMAN]]] += 1
        return done

    def posterior(self, instruction: Instruction | None = None, top: int = 10, heard_nothing: bool = False) -> Posterior:
        """The joint posterior now, given what was heard (None: the action term alone).

        ``heard_nothing``: a recording was heard and held no words; speech-only inference then
        gives its prior (uniform over the domain's commands) instead of an error."""
        t0 = time.perf_counter()
        cfg = self.model.config
        if cfg.mode == "action-only":
            instruction = None
        if cfg.mode == "speech-only" and instruction is None and not heard_nothing:
            raise ObservationError("speech-only inference needs an instruction (a transcript, N-best or audio)")
        goal_idx, cmd_of, rows, unk_cmds, cmds = self.candidates()
        # instruction term per unique command
        if instruction is not None and self.model.likelihood is not None:
            lk = self.model.likelihood
            if getattr(lk, "name", None) in LIKELIHOODS:  # explain a missing input before scoring
                check_instruction(lk.name, instruction)
            if getattr(lk, "uses_context", False):
                # e.g. the acoustic likelihood prunes commands with little prior x action mass
                ctx = self._context(goal_idx, cmd_of, rows, unk_cmds, cmds) if cfg.uses_actions else None
                scored = as_scores(lk.log_prob(instruction, cmds, context=ctx))  # type: ignore[call-arg]
            else:
                scored = as_scores(lk.log_prob(instruction, cmds))
            understood, checked = _understood(instruction, cmds, scored.evidence, getattr(lk, "lexicon", None))
            evidence = {**scored.evidence, **checked}
            instr = scored.log_probs * cfg.speech_weight
            if instr.shape != (len(cmds),) or not np.all(np.isfinite(instr)):
                raise ObservationError("the instruction likelihood returned invalid scores")
        else:
            instr, evidence, understood = np.zeros(len(cmds)), {}, None
        if cfg.mode == "speech-only":
            # uniform over the domain's commands, words alone
            lj = instr[unk_cmds] - np.log(len(unk_cmds))
            terms = np.stack([np.full(len(unk_cmds), -np.log(len(unk_cmds))), np.zeros(len(unk_cmds)), instr[unk_cmds]], 1)
        else:
            prior, act, unk_prior, unk_act = self._prior_and_actions(goal_idx, rows, len(unk_cmds))
            off_prior, off_act = self._off_plan(prior, act, len(unk_cmds))
            prior = prior + np.log1p(-cfg.off_plan)
            terms = np.concatenate([
                np.stack([prior, act, instr[cmd_of]], 1),
                np.stack([np.full(len(unk_cmds), unk_prior), np.full(len(unk_cmds), unk_act), instr[unk_cmds]], 1),
                np.stack([off_prior + self._bringable(unk_cmds, cmds), np.full(len(unk_cmds), off_act),
                          instr[unk_cmds]], 1),
            ])
            lj = terms.sum(axis=1)
        logZ = logsumexp(lj)
        p = np.exp(lj - logZ)
        cmd_all = unk_cmds if cfg.mode == "speech-only" else np.concatenate([cmd_of, unk_cmds, unk_cmds])
        goal_all = (np.zeros(len(unk_cmds), dtype=np.int64) if cfg.mode == "speech-only"
                    else np.concatenate([goal_idx, np.full(2 * len(unk_cmds), len(self.goals))]))
        goal_names = ["(any)"] if cfg.mode == "speech-only" else self._goal_names
        cm = np.bincount(cmd_all, weights=p, minlength=len(cmds))
        gm = np.bincount(goal_all, weights=p, minlength=len(goal_names))
        corder = np.lexsort((np.arange(len(cmds)), -cm))
        corder = corder[cm[corder] > 0] if (cm > 0).any() else corder
        # tuple.__new__ is what a NamedTuple's constructor calls, without its Python frame
        commands = tuple(map(_SCORED_COMMAND, zip(map(cmds.__getitem__, corder.tolist()), cm[corder].tolist(),
                                                  strict=True)))
        gorder = np.argsort(-gm, kind="stable")
        gorder = gorder[gm[gorder] > 0]
        goals = tuple(map(_SCORED_GOAL, zip(map(goal_names.__getitem__, gorder.tolist()), gm[gorder].tolist(),
                                            strict=True)))
        order = np.argsort(-lj, kind="stable")[:top]
        # the off-plan rows (the last len(unk_cmds)) are labelled apart, valued as the unknown goal
        off_from = len(goal_all) - len(unk_cmds) if cfg.mode != "speech-only" and len(unk_cmds) else len(goal_all)
        hyps = tuple(JointHypothesis(OFF_PLAN if i >= off_from else goal_names[goal_all[i]], cmds[cmd_all[i]],
                                     float(p[i]), float(terms[i, 0]), float(terms[i, 1]), float(terms[i, 2]))
                     for i in order.tolist())
        post = Posterior(
            command=commands[0][0], commands=commands, goals=goals, hypotheses=hyps, mode=cfg.mode,
            likelihood=getattr(self.model.likelihood, "name", "none") if instruction is not None else "none",
            n_actions=self.n_actions, seconds=time.perf_counter() - t0,
            transcript=instruction.text if instruction is not None else "",
            joint=JointPosterior(() if cfg.mode == "speech-only" else self.goals, tuple(cmds), goal_all, cmd_all, lj,
                                 self.state, None if understood is None else instr),
            evidence=evidence, understanding=understood,
        )
        if self.model.on_step is not None:
            self.model.on_step("posterior", self, post)
        return post

    def _prior_and_actions(self, goal_idx: np.ndarray, rows: np.ndarray,
                           n_unknown: int) -> tuple[np.ndarray, np.ndarray, float, float]:
        """log P(g) P(pi_r | g) and the action term per known hypothesis; the same for each
        unknown-goal command (a constant each). Made once per state for its own candidates."""
        own = self._memo.get("candidates")
        if own is not None and goal_idx is own[0] and rows is own[2] and n_unknown == len(own[3]):
            got: tuple[np.ndarray, np.ndarray, float, float] = self._kept(
                "prior_and_actions", lambda: _read_only(self._make_prior_and_actions(goal_idx, rows, n_unknown)))
            return got
        return self._make_prior_and_actions(goal_idx, rows, n_unknown)

    def _make_prior_and_actions(self, goal_idx: np.ndarray, rows: np.ndarray,
                                n_unknown: int) -> tuple[np.ndarray, np.ndarray, float, float]:
        n_goals = len(self.goals)
        prior = (self.goal_prior.log_known(goal_idx, n_goals)
                 + self.part_prior.log_prob(self._steps_saved(goal_idx, rows), goal_idx, n_goals))
        return (prior, self.actions.log_lik(rows), self.goal_prior.log_unknown(n_unknown),
                self.unknown_actions.cumulative)

    def _off_plan(self, prior: np.ndarray, act: np.ndarray, n_unknown: int) -> tuple[float, float]:
        """log prior and action term of an off-plan request: with probability ``off_plan`` the
        person asks for any object of the world (uniform over the domain's commands), whatever
        their goal; the actions are explained by the goals as they are (their marginal
        likelihood), so a clear request for something no likely goal needs keeps this prior
        however many actions were seen."""
        rho = self.model.config.off_plan
        if rho <= 0 or n_unknown == 0 or len(prior) == 0:
            return -np.inf, 0.0
        own = self._memo.get("prior_and_actions")
        if own is not None and prior is own[0] and act is own[1]:  # this state's own terms: kept
            mass, marginal = self._kept("off_plan_mass", lambda: self._masses(prior, act))
        else:
            mass, marginal = self._masses(prior, act)
        return float(np.log(rho) - np.log(n_unknown) + mass), marginal

    @staticmethod
    def _masses(prior: np.ndarray, act: np.ndarray) -> tuple[float, float]:
        """log sum of the prior, and the actions' log marginal likelihood under it."""
        mass = float(logsumexp(prior))
        return mass, float(logsumexp(prior + act)) - mass

    def _bringable(self, unk_cmds: np.ndarray, cmds: Sequence[RobotCommand]) -> np.ndarray:
        """0 for a command the robot could carry out now, -inf for one asking for more objects
        of a class than are left to bring (a person does not ask for what is already in front of
        them): the off-plan request's support. Kept per state for its own candidates."""
        own = self._memo.get("candidates")
        if own is not None and unk_cmds is own[3]:
            got: np.ndarray = self._kept("bringable", lambda: self._make_bringable(unk_cmds, cmds))
            return got
        return self._make_bringable(unk_cmds, cmds)

    def _make_bringable(self, unk_cmds: np.ndarray, cmds: Sequence[RobotCommand]) -> np.ndarray:
        left = self._class_total - self._done()
        classes = {c: k for k, c in enumerate(self.world.classes)}
        ok = np.array([cmds[int(i)].count <= left[classes[cmds[int(i)].obj_class]] for i in unk_cmds], dtype=bool)
        out: np.ndarray = np.where(ok, 0.0, -np.inf)
        out.flags.writeable = False
        return out

    def _context(self, goal_idx: np.ndarray, cmd_of: np.ndarray, rows: np.ndarray, unk_cmds: np.ndarray,
                 cmds: Sequence[RobotCommand]) -> np.ndarray:
        """log P(command | actions) up to a constant: the posterior without the instruction term."""
        prior, act, unk_prior, unk_act = self._prior_and_actions(goal_idx, rows, len(unk_cmds))
        off_prior, off_act = self._off_plan(prior, act, len(unk_cmds))
        n_cmds = len(cmds)
        known = group_logsumexp(prior + np.log1p(-self.model.config.off_plan) + act, cmd_of, n_cmds)
        unk = np.full(n_cmds, -np.inf)
        unk[unk_cmds] = np.logaddexp(unk_prior + unk_act, off_prior + self._bringable(unk_cmds, cmds) + off_act)
        out: np.ndarray = np.logaddexp(known, unk)
        return out

    def _steps_saved(self, goal_idx: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """V(now; g) - V(now; g minus the robot's part): how much each part helps the human."""
        s = self.state
        v_rows = self.ctg.values(self._tabs, self._sp, s.agent_at[HUMAN], s.held[HUMAN])
        v_goal = self.ctg.values(self._tabs, self._sp_goal, s.agent_at[HUMAN], s.held[HUMAN])
        saved: np.ndarray = np.minimum(v_goal[goal_idx] - v_rows[rows], 1e3)
        return saved



def _read_only(terms: tuple[np.ndarray, np.ndarray, float, float]) -> tuple[np.ndarray, np.ndarray, float, float]:
    terms[0].flags.writeable = terms[1].flags.writeable = False
    return terms


@lru_cache(maxsize=65536)
def _command(verb: str, cls: str, n: int) -> RobotCommand:
    return RobotCommand(verb, cls, n)


def _understood(instruction: Instruction, cmds: Sequence[RobotCommand], evidence: Mapping[str, Any],
                lexicon: Any) -> tuple[Any, Any]:
    """The utterance model's reading of what was heard, with Whisper's words (and their
    confidence) where the likelihood heard them (inference/understood.py)."""
    whisper, wlp = evidence.get("whisper_heard"), evidence.get("whisper_logprob")
    return understanding_of(instruction, cmds, (whisper,) if isinstance(whisper, str) else (), lexicon,
                            float(wlp) if isinstance(wlp, (int, float)) else None)
