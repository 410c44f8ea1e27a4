"""The simulated human: acts with a Boltzmann-noisy policy over Q* and speaks after k actions."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from siftom.planning.costtogo import CostToGo, goal_matrix, successor_values
from siftom.planning.policy import BoltzmannPolicy
from siftom.world.model import HUMAN, Action, Goal, State, World, apply, cost, legal_actions


@dataclass(frozen=True)
class Trajectory:
    """What the human did: the actions, the states visited (one more than actions), total cost."""

    actions: tuple[Action, ...]
    states: tuple[State, ...]
    cost: int


def simulate_human(
    world: World, start: State, goal: Goal, n_actions: int, beta: float = 2.0,
    seed: int | np.random.Generator = 0, agent: int = HUMAN,
) -> Trajectory:
    """Roll out ``n_actions`` actions (fewer if ``goal`` is reached) of a Boltzmann human.

    Args:
        goal: the human's own part of the task (the team goal minus the robot's part).
        beta: rationality per step of cost; higher is closer to optimal.
        seed: seed or numpy Generator; the same seed gives the same trajectory.
    """
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    kmax = max([n for _c, n in goal.counts] + [1])
    ctg = CostToGo(world, goal.target, kmax, agent=agent)
    N = goal_matrix(world, [goal])
    policy = BoltzmannPolicy(beta=beta, epsilon=0.0)
    s, actions, states, total = start, [], [start], 0
    for _ in range(n_actions):
        if goal.satisfied(world, s):
            break
        acts = list(legal_actions(world, s, agent))
        Q = successor_values(ctg, s, ctg.tables(s), acts, N)[:, 0]
        p = np.exp(policy.log_probs(Q[:, None])[:, 0])
        a = acts[int(rng.choice(len(acts), p=p / p.sum()))]
        total += cost(world, s, a)
        s = apply(s, a)
        actions.append(a)
        states.append(s)
    return Trajectory(tuple(actions), tuple(states), total)
