"""SIFToM inference (paper, Eq. 1-3): an exact hand-computed case, ablations, online updates, errors."""

import math

import numpy as np
import pytest
from scipy.special import logsumexp

# register both built-in domains whatever was imported first (tests/world/test_domains.py, xfail)
import siftom.world.domains.household  # noqa: F401
import siftom.world.domains.kitchen  # noqa: F401
from siftom.api import infer_scenario, make_instruction
from siftom.errors import ObservationError
from siftom.inference.model import UNKNOWN, ModelConfig, Observation, SIFToM
from siftom.likelihood.base import Instruction
from siftom.planning.astar import plan_for_goal
from siftom.scenarios.base import get_scenario
from siftom.world.model import (
    HUMAN,
    NOTHING,
    ROBOT,
    Action,
    Goal,
    Item,
    Place,
    State,
    World,
    apply,
    cost,
    legal_actions,
)


class FixedLikelihood:
    """A stub P(phi | pi_r): fixed log-probs per command string, whatever was heard."""

    name = "fixed"

    def __init__(self, table: dict[str, float], default: float = -10.0) -> None:
        self.table, self.default = table, default
        self.calls = 0

    def log_prob(self, instruction, commands):
        self.calls += 1
        return np.array([self.table.get(str(c), self.default) for c in commands])


# ----------------------------------------------------------------------------- a tiny world
# One room. The table (target) at the origin; the fork 3 m east, the cup 4 m north, the plate
# 5 m south. Two goals: {cup, fork} and {fork, plate}. The human walks to the fork.
PLACES = (
    Place("table", "surface", "room", (0.0, 0.0)),
    Place("fork_shelf", "surface", "room", (3.0, 0.0)),
    Place("cup_shelf", "surface", "room", (0.0, 4.0)),
    Place("plate_shelf", "surface", "room", (0.0, -5.0)),
)
ITEMS = (Item("fork_1", "fork"), Item("cup_1", "cup"), Item("plate_1", "plate"))
TABLE, F, C, P = range(4)


def tiny():
    world = World(PLACES, ITEMS, World.distances_from_positions(PLACES))
    start = State((TABLE, TABLE), (NOTHING, NOTHING), (F, C, P), 0)
    goals = (Goal("cup+fork", TABLE, (("cup", 1), ("fork", 1))),
             Goal("fork+plate", TABLE, (("fork", 1), ("plate", 1))))
    return world, start, goals


def optimum(world, s, counts):
    """V*(s; g) by uniform-cost search (no heuristic, no pruning): the reference planner."""
    if not counts:
        return 0.0
    res = plan_for_goal(world, s, Goal("g", TABLE, counts), use_heuristic=False, prune=False)
    assert res.solved
    return res.cost


def test_hand_computed_two_goal_one_action_posterior():
    world, start, goals = tiny()
    cfg = ModelConfig(betas=(0.5, 2.0), epsilon=0.1, unknown_prior=0.05, help_kappa=0.3, speech_weight=0.7)
    heard = {"deliver(cup,1)": -1.0, "deliver(fork,1)": -2.5, "deliver(plate,1)": -1.5}
    lk = FixedLikelihood(heard)
    walk_to_fork = Action("walk", HUMAN, place=F)
    obs = Observation(world, start, (walk_to_fork,), goals, "deliver", Instruction.from_text("anything"))
    post = SIFToM(cfg, lk).infer(obs)

    # The distances, by hand: ceil(metres).
    assert world.dist[TABLE].tolist() == [0, 3, 4, 5] and world.dist[F, C] == 5 and world.dist[F, P] == 6
    # Legal actions at the start: walk to each of the three shelves (nothing to grab at the table).
    walks = [Action("walk", HUMAN, place=p) for p in (F, C, P)]
    k = walks.index(walk_to_fork)

    # The human's part under each hypothesis (goal, robot's class): the goal without that class.
    human_part = {("cup+fork", "cup"): (("fork", 1),), ("cup+fork", "fork"): (("cup", 1),),
                  ("fork+plate", "fork"): (("plate", 1),), ("fork+plate", "plate"): (("fork", 1),)}
    # Q(s0, walk X; part) = d(table, X) + V*(at X; part), by hand (walk, grab, walk back, put) ...
    q_hand = {(("fork", 1),): [8, 14, 16], (("cup", 1),): [14, 10, 20], (("plate", 1),): [16, 20, 12]}
    # ... and by the reference planner.
    for part, row in q_hand.items():
        assert [cost(world, start, a) + optimum(world, apply(start, a), part) for a in walks] == row

    def action_loglik(part):
        Q = np.array(q_hand[part], dtype=float)
        per_beta = []
        for beta in cfg.betas:
            soft = np.exp(-beta * Q) / np.exp(-beta * Q).sum()
            per_beta.append(math.log((1 - cfg.epsilon) * soft[k] + cfg.epsilon / len(walks)))
        return logsumexp(per_beta) - math.log(len(cfg.betas))  # beta marginalised, uniform grid

    # Prior P(pi_r | g): softmax within the goal of kappa x steps the robot's part saves the human,
    # measured when the human speaks (at the fork shelf).
    now = apply(start, walk_to_fork)
    v_goal = {g.name: optimum(world, now, g.counts) for g in goals}
    assert v_goal == {"cup+fork": 15, "fork+plate": 17}
    saved = {h: v_goal[h[0]] - optimum(world, now, part) for h, part in human_part.items()}
    assert saved == {("cup+fork", "cup"): 10, ("cup+fork", "fork"): 4,
                     ("fork+plate", "fork"): 4, ("fork+plate", "plate"): 12}
    log_joint = {}
    for (g, cls), part in human_part.items():
        others = [saved[h] for h in human_part if h[0] == g]
        log_prior = (math.log(1 - cfg.unknown_prior) - math.log(len(goals))
                     + cfg.help_kappa * saved[(g, cls)] - logsumexp([cfg.help_kappa * x for x in others]))
        cmd = f"deliver({cls},1)"
        log_joint[(g, cmd)] = log_prior + action_loglik(part) + cfg.speech_weight * heard[cmd]
    # An off-plan request: with probability off_plan any command (uniform), whatever the goal;
    # the walk is explained by the goals as they are: sum over hypotheses of prior x action term.
    plans = logsumexp([v - cfg.speech_weight * heard[c] for (_g, c), v in log_joint.items()])
    for key in list(log_joint):
        log_joint[key] += math.log(1 - cfg.off_plan)
    # "Unknown goal": prior mass unknown_prior, uniform over the domain's commands (one object of
    # each class here), uniform over the legal actions.
    for cls in ("cup", "fork", "plate"):
        cmd = f"deliver({cls},1)"
        log_joint[(UNKNOWN, cmd)] = (math.log(cfg.unknown_prior) - math.log(3) - math.log(len(walks))
                                     + cfg.speech_weight * heard[cmd])
        log_joint[("off-plan", cmd)] = (math.log(cfg.off_plan) - math.log(3) + plans
                                        + cfg.speech_weight * heard[cmd])
    z = logsumexp(list(log_joint.values()))
    p = {h: math.exp(v - z) for h, v in log_joint.items()}
    commands, goal_marg = {}, {}
    for (g, cmd), x in p.items():
        commands[cmd] = commands.get(cmd, 0.0) + x
        g = UNKNOWN if g == "off-plan" else g  # the robot values an off-plan request as the goal it names
        goal_marg[g] = goal_marg.get(g, 0.0) + x

    got_commands = dict(post.commands)
    assert got_commands.keys() == commands.keys()
    for cmd, x in commands.items():
        assert got_commands[cmd] == pytest.approx(x, abs=1e-9), cmd
    got_goals = dict(post.goals)
    assert got_goals.keys() == goal_marg.keys()
    for g, x in goal_marg.items():
        assert got_goals[g] == pytest.approx(x, abs=1e-9), g
    assert post.command == max(commands, key=commands.get)
    # each hypothesis reports its terms
    for h in post.hypotheses:
        assert h.prob == pytest.approx(p[(h.goal, h.command)], abs=1e-9)
        assert h.log_prior + h.log_action + h.log_instruction == pytest.approx(log_joint[(h.goal, h.command)],
                                                                              abs=1e-9)
        assert h.log_instruction == pytest.approx(cfg.speech_weight * heard[h.command], abs=1e-12)
    assert post.n_actions == 1 and post.likelihood == "fixed" and post.transcript == "anything"


# ----------------------------------------------------------------------------- ablations
def _infer(mode, actions, text_scores, goals=None):
    world, start, g = tiny()
    obs = Observation(world, start, tuple(actions), goals or g, "deliver", Instruction.from_text("x"))
    return SIFToM(ModelConfig(mode=mode), FixedLikelihood(text_scores)).infer(obs)


TO_FORK = [Action("walk", HUMAN, place=F)]
TO_PLATE = [Action("walk", HUMAN, place=P)]
SAYS_CUP = {"deliver(cup,1)": -0.5, "deliver(fork,1)": -3.0, "deliver(plate,1)": -3.0}
SAYS_PLATE = {"deliver(cup,1)": -3.0, "deliver(fork,1)": -3.0, "deliver(plate,1)": -0.5}


def test_speech_only_ignores_what_the_human_did():
    a = _infer("speech-only", TO_FORK, SAYS_CUP)
    b = _infer("speech-only", TO_PLATE, SAYS_CUP)
    c = _infer("speech-only", [], SAYS_CUP)
    assert a.commands == b.commands == c.commands
    assert a.command == "deliver(cup,1)"
    # words alone, uniform prior: the posterior is the normalised likelihood
    z = logsumexp(list(SAYS_CUP.values()))
    for cmd, x in a.commands:
        assert x == pytest.approx(math.exp(SAYS_CUP[cmd] - z), abs=1e-12)


def test_action_only_ignores_the_words():
    a = _infer("action-only", TO_FORK, SAYS_CUP)
    b = _infer("action-only", TO_FORK, SAYS_PLATE)
    assert a.commands == b.commands and a.goals == b.goals
    assert a.likelihood == "none"
    # ... but it does use the actions
    assert _infer("action-only", TO_PLATE, SAYS_CUP).commands != a.commands


def test_full_model_combines_both():
    # walking to the plate: the human does the plate, so the robot's part is the fork
    act = _infer("action-only", TO_PLATE, SAYS_CUP)
    assert act.command == "deliver(fork,1)"
    words = _infer("speech-only", TO_PLATE, SAYS_CUP)
    assert words.command == "deliver(cup,1)"
    full = _infer("full", TO_PLATE, SAYS_CUP)
    assert 0 < full.prob("deliver(cup,1)") < 1
    assert full.prob("deliver(cup,1)") != words.prob("deliver(cup,1)")
    assert full.prob("deliver(fork,1)") != act.prob("deliver(fork,1)")


def test_speech_only_needs_an_instruction():
    world, start, goals = tiny()
    obs = Observation(world, start, (), goals, "deliver")
    with pytest.raises(ObservationError, match="needs an instruction"):
        SIFToM(ModelConfig(mode="speech-only"), FixedLikelihood({})).infer(obs)


def test_unknown_goal_lets_the_words_win_outside_the_library():
    """A request for a class no goal needs is still followed, through the unknown-goal hypothesis."""
    world, start, goals = tiny()
    only_cup_fork = goals[:1]
    says_plate = {"deliver(cup,1)": -20.0, "deliver(fork,1)": -20.0, "deliver(plate,1)": 0.0}
    obs = Observation(world, start, (), only_cup_fork, "deliver", Instruction.from_text("x"))
    post = SIFToM(ModelConfig(unknown_prior=0.05), FixedLikelihood(says_plate)).infer(obs)
    assert post.command == "deliver(plate,1)"
    assert dict(post.goals)[UNKNOWN] > 0.5
    # without the unknown goal, an off-plan request still lets the words win
    off = SIFToM(ModelConfig(unknown_prior=0.0), FixedLikelihood(says_plate)).infer(obs)
    assert off.command == "deliver(plate,1)"
    none = SIFToM(ModelConfig(unknown_prior=0.0, off_plan=0.0), FixedLikelihood(says_plate)).infer(obs)
    assert none.prob("deliver(plate,1)") == 0.0


# ----------------------------------------------------------------------------- the paper's story
SILVER = "can you pass me the silver"


def test_kitchen_cereal_pass_me_the_silver_chooses_the_cereal():
    post = infer_scenario("kitchen-cereal-v0", make_instruction(SILVER), mode="full")
    assert post.command == "fetch(cereal)"
    assert dict(post.goals)["breakfast_cereal"] == post.goals[0][1]
    words = infer_scenario("kitchen-cereal-v0", make_instruction(SILVER), mode="speech-only")
    assert "fetch(cereal)" in [c for c, _p in words.commands[:3]]  # top 3 on the words alone
    assert post.prob("fetch(cereal)") > words.prob("fetch(cereal)")


# ----------------------------------------------------------------------------- online updates
def test_online_updates_give_the_batch_posterior_at_every_step():
    sc = get_scenario("kitchen-cereal-v0")
    instr = Instruction.from_text(SILVER)
    model = SIFToM(ModelConfig(), FixedLikelihood({"fetch(cereal)": -1.0, "fetch(sugar)": -1.5}, default=-4.0))
    online = model.online(sc.world, sc.start, sc.goals, sc.verb)
    for k in range(len(sc.actions) + 1):
        if k:
            online.observe(sc.actions[k - 1])
        step = online.posterior(instr)
        batch = model.infer(Observation.from_scenario(sc, instr, n_actions=k))
        assert step.n_actions == batch.n_actions == k
        assert [c for c, _ in step.commands] == [c for c, _ in batch.commands]
        np.testing.assert_allclose([p for _, p in step.commands], [p for _, p in batch.commands],
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose([p for _, p in step.goals], [p for _, p in batch.goals], rtol=0, atol=1e-12)


def test_online_refuses_an_impossible_next_action():
    sc = get_scenario("kitchen-cereal-v0")
    online = SIFToM(ModelConfig(mode="action-only")).online(sc.world, sc.start, sc.goals, sc.verb)
    cereal = sc.world.item("cereal")
    with pytest.raises(ObservationError, match="is impossible here: .*not where human stands"):
        online.observe(Action("grab", HUMAN, obj=cereal, place=sc.start.item_at[cereal]))
    assert online.n_actions == 0


# ----------------------------------------------------------------------------- bad observations
def test_malformed_observations_get_clear_errors():
    world, start, goals = tiny()
    with pytest.raises(ObservationError, match="action 0 grab\\(human, cup_1, cup_shelf\\) is impossible here"):
        Observation(world, start, (Action("grab", HUMAN, obj=1, place=C),), goals)
    with pytest.raises(ObservationError, match="goal space is empty"):
        Observation(world, start, (), ())
    with pytest.raises(ObservationError, match="'spoon', which is not in the scene"):
        Observation(world, start, (), (Goal("soup", TABLE, (("spoon", 1),)),))
    with pytest.raises(ObservationError, match="action 0 put\\(robot, cup_1, .*\\) is impossible here"):
        Observation(world, start, (Action("put", ROBOT, obj=1, place=F),), goals)  # the robot holds nothing
    with pytest.raises(ObservationError, match="share one target"):
        Observation(world, start, (), (goals[0], Goal("x", F, (("cup", 1),))))
    with pytest.raises(ObservationError, match="not an Action"):
        Observation(world, start, ("walk(human, fork_shelf)",), goals)  # type: ignore[arg-type]


def test_the_robots_own_actions_change_the_world_not_the_belief():
    world, start, goals = tiny()
    model = SIFToM(ModelConfig(mode="action-only"))
    alone = model.infer(Observation(world, start, (), goals))
    walked = Observation(world, start, (Action("walk", ROBOT, place=F),), goals)
    assert walked.states[-1].agent_at[ROBOT] == F
    after = model.infer(walked)
    assert dict(after.goals) == pytest.approx(dict(alone.goals))  # a walk of the robot says nothing of the goal


@pytest.mark.parametrize("text", ["", "   "])
def test_an_empty_transcript_is_refused(text):
    with pytest.raises(ObservationError, match="transcript is empty"):
        Instruction.from_text(text)
    with pytest.raises(ObservationError, match="transcript is empty"):
        make_instruction(transcript=text)


@pytest.mark.parametrize("score", [float("nan"), float("inf"), float("-inf")])
def test_a_non_finite_nbest_score_is_refused(score):
    with pytest.raises(ObservationError, match="not finite"):
        Instruction.from_nbest([("pass me the cereal", 0.0), ("pass me the serial", score)])
    with pytest.raises(ObservationError, match="not finite"):
        make_instruction(nbest=[{"text": "pass me the cereal", "score": score}])


def test_other_instruction_errors():
    with pytest.raises(ObservationError, match="N-best list is empty"):
        Instruction.from_nbest([])
    with pytest.raises(ObservationError, match="needs a 'text' field"):
        make_instruction(nbest=[{"score": -1.0}])
    assert make_instruction() is None


def test_a_likelihood_returning_bad_scores_is_caught():
    world, start, goals = tiny()
    obs = Observation(world, start, (), goals, "deliver", Instruction.from_text("x"))
    bad = FixedLikelihood({"deliver(cup,1)": float("nan")})
    with pytest.raises(ObservationError, match="invalid scores"):
        SIFToM(ModelConfig(), bad).infer(obs)


@pytest.mark.parametrize("kwargs", [{"mode": "speech"}, {"betas": ()}, {"betas": (0.0,)}, {"unknown_prior": 1.0},
                                    {"help_kappa": -1.0}])
def test_model_config_is_validated(kwargs):
    with pytest.raises(ObservationError):
        ModelConfig(**kwargs)


# ----------------------------------------------------------------------------- the result
def test_posterior_json_shape_and_normalisation():
    post = infer_scenario("kitchen-cereal-v0", make_instruction(SILVER))
    out = post.to_json()
    assert out["command"] == post.command
    assert all(set(c) == {"command", "prob"} for c in out["commands"])
    assert all(set(g) == {"goal", "prob"} for g in out["goals"])
    assert out["commands"][0]["command"] == out["command"]
    probs = [c["prob"] for c in out["commands"]]
    assert probs == sorted(probs, reverse=True)
    assert sum(p for _c, p in post.commands) == pytest.approx(1.0, abs=1e-9)
    assert sum(p for _g, p in post.goals) == pytest.approx(1.0, abs=1e-9)
    assert all(p > 0 for _c, p in post.commands)
    import json

    json.dumps(out)


# ----------------------------------------------------------------------------- online vs an independent reference
def _reference_posterior(world, start, actions, goals, cfg, heard):
    """Eq. 1-3 by brute force: uniform-cost-search values, a direct Boltzmann per beta, and the
    priors as docs/inference.md states them. Shares no code with the model's inference path."""
    classes = sorted({c for g in goals for c, _ in g.counts} | {it.cls for it in world.items})

    def value(s, counts):  # inf when the human alone cannot finish (e.g. the robot holds it)
        if not counts:
            return 0.0
        res = plan_for_goal(world, s, Goal("g", TABLE, counts), use_heuristic=False, prune=False)
        return res.cost if res.solved else math.inf
    states = [start]
    for a in actions:
        states.append(apply(states[-1], a))
    now = states[-1]

    def done(cls):
        on = sum(1 for i, it in enumerate(world.items) if it.cls == cls and now.item_at[i] == TABLE)
        held = now.held[HUMAN]
        return on + (1 if held != NOTHING and world.items[held].cls == cls else 0)

    def action_loglik(part):
        # beta is one unknown constant of the person: the whole trajectory under each beta,
        # then the uniform mixture over the grid
        per_beta = np.zeros(len(cfg.betas))
        for s, a in zip(states, actions, strict=False):
            acts = list(legal_actions(world, s, HUMAN))
            Q = np.array([cost(world, s, b) + value(apply(s, b), part) for b in acts])
            k = acts.index(a)
            per_beta += [math.log((1 - cfg.epsilon) * math.exp(-beta * Q[k]) / np.exp(-beta * Q).sum()
                                  + cfg.epsilon / len(acts)) for beta in cfg.betas]
        return logsumexp(per_beta) - math.log(len(cfg.betas))

    log_joint = {}
    planned = {}
    for g in goals:
        parts = [(c, n - done(c)) for c, n in g.counts if n - done(c) >= 1]
        human = {c: tuple((c2, n2) for c2, n2 in g.counts if c2 != c) for c, _ in parts}
        saved = {c: value(now, g.counts) - value(now, human[c]) for c, _ in parts}
        z = logsumexp([cfg.help_kappa * saved[c] for c, _ in parts])
        for c, left in parts:
            prior = (math.log(1 - cfg.unknown_prior) - math.log(len(goals))
                     + cfg.help_kappa * saved[c] - z)
            cmd = f"deliver({c},{left})"
            planned[(g.name, cmd)] = (prior, action_loglik(human[c]))
    # a request off the plan: with probability off_plan any command, whatever the goal; the
    # actions are then explained by the goals' marginal likelihood
    evidence = logsumexp([pr + al for pr, al in planned.values()])
    for key, (pr, al) in planned.items():
        log_joint[key] = math.log(1 - cfg.off_plan) + pr + al + heard.get(key[1], -10.0)
    unknown_cmds = [f"deliver({c},1)" for c in classes]
    uniform_actions = sum(-math.log(len(list(legal_actions(world, s, HUMAN))))
                          for s in states[:-1])
    for cmd in unknown_cmds:
        log_joint[(UNKNOWN, cmd)] = (math.log(cfg.unknown_prior) - math.log(len(unknown_cmds))
                                     + uniform_actions + heard.get(cmd, -10.0))
        c = cmd[len("deliver("):-len(",1)")]
        left = sum(1 for it in world.items if it.cls == c) - done(c)
        if left >= 1:  # a person asks only for what is left to bring
            log_joint[("off-plan", cmd)] = (math.log(cfg.off_plan) - math.log(len(unknown_cmds))
                                            + evidence + heard.get(cmd, -10.0))
    z = logsumexp(list(log_joint.values()))
    commands = {}
    for (_g, cmd), v in log_joint.items():
        commands[cmd] = commands.get(cmd, 0.0) + math.exp(v - z)
    return commands


def test_online_updates_match_an_independent_reference_at_every_step():
    world, start, goals = tiny()
    cfg = ModelConfig(betas=(0.5, 1.0, 3.0), epsilon=0.05, unknown_prior=0.05, help_kappa=0.2)
    heard = {"deliver(cup,1)": -2.0, "deliver(fork,1)": -1.0, "deliver(plate,1)": -1.2}
    fork = 0
    path = (Action("walk", HUMAN, place=F), Action("grab", HUMAN, obj=fork, place=F),
            Action("walk", HUMAN, place=TABLE), Action("put", HUMAN, obj=fork, place=TABLE))
    online = SIFToM(cfg, FixedLikelihood(heard)).online(world, start, goals, "deliver")
    for k in range(len(path) + 1):
        if k:
            online.observe(path[k - 1])
        got = dict(online.posterior(Instruction.from_text("x")).commands)
        want = _reference_posterior(world, start, path[:k], goals, cfg, heard)
        assert got.keys() == want.keys(), k
        for cmd, p in want.items():
            assert got[cmd] == pytest.approx(p, abs=1e-9), (k, cmd)


def test_on_step_observes_inference_without_changing_it():
    sc = get_scenario("kitchen-cereal-v0")
    events = []
    plain = SIFToM(ModelConfig())
    watched = SIFToM(ModelConfig(), on_step=lambda ev, online, value: events.append((ev, online.n_actions)))
    obs = Observation.from_scenario(sc, Instruction.from_text(SILVER))
    a, b = plain.infer(obs), watched.infer(obs)
    assert a.commands == b.commands
    assert events == [("observe", k) for k in range(1, len(sc.actions) + 1)] + [("posterior", len(sc.actions))]
