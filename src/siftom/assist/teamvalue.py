"""What each robot action is worth to the team, under every hypothesis, from cost-to-go tables.

The team simulation (agents/team.py, docs/team-simulation.md) scores a robot command ``a``
for a true goal ``g`` as ``L_team = prefix + max(H, R) + remedy``; the human alone takes
``L_single = prefix + V_h(now; g)``. Here the same terms come from the cost-to-go tables
(planning/costtogo.py) instead of A*, vectorised over hypotheses and actions, so a decision
costs about as much as the inference that produced the posterior:

* ``R(a)``: the robot's cost-to-go for "``n`` objects of class ``c`` more on the target"
  (``n`` = the command's count, at most what is available), from where the robot stands;
* ``useful(g, a) = min(n, what g still needs of c)`` (objects in the human's hands count as
  handled), ``wrong = n - useful``;
* ``H(g, a)``: the human's cost-to-go for ``g`` minus the useful part, with the objects the
  robot takes out of play (the robot takes the ``n`` with the cheapest round trips, the
  choice the cost-to-go makes; the simulation takes those on its A* plan);
* ``remedy = wrong * (2 + 2 d(target, nearest other open surface))``, exactly as simulated.

The benefit of ``a`` under ``g`` is ``L_single - L_team = V_h(now; g) - max(H, R) - remedy``
(steps saved; negative when the robot slows the team down); doing nothing is worth 0.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from siftom.inference.model import JointPosterior
from siftom.memo import Memo
from siftom.planning.choice import chosen
from siftom.planning.costtogo import ClassTables, CostToGo, SparseGoals
from siftom.world.commands import RobotCommand
from siftom.world.model import HELD, HUMAN, NOTHING, ROBOT, Goal, State, World

NONE = "none"
V = TypeVar("V")
# hypotheses kept for the decision: the most probable ones up to this mass (at most MAX_ROWS)
KEEP_MASS = 0.9999
MAX_ROWS = 256

_CTG: weakref.WeakKeyDictionary[World, dict[tuple[int, int, int], CostToGo]] = weakref.WeakKeyDictionary()


def _ctg(world: World, target: int, kmax: int, agent: int) -> CostToGo:
    per = _CTG.setdefault(world, {})
    key = (target, kmax, agent)
    if key not in per:
        per[key] = CostToGo(world, target, kmax, agent=agent)
    return per[key]


def aside_distance(world: World, target: int) -> int:
    """d(target, nearest other open surface): the walk to clear a wrong object (as simulated)."""
    surfaces = [i for i, p in enumerate(world.places) if p.kind != "room" and i != target and not p.closable]
    return min((int(world.dist[target, i]) for i in surfaces), default=1)


@dataclass(frozen=True, eq=False)
class TeamValues:
    """Benefits (steps saved) of every action under every kept hypothesis.

    Attributes:
        actions: the actions, commands of the domain then ``none`` (last).
        prob: probability of each kept hypothesis row (renormalised to sum to 1).
        row_cmd: the command index (into ``actions``) each row says the human asked for.
        benefit: shape (rows, actions): ``L_single - L_team`` in steps.
        kept_mass: posterior mass of the kept rows before renormalising.
        single: shape (rows,): the human's time alone from now, ``V_h(now; g)`` (steps).
        prefix: steps the human had already spent when it spoke (in both L_single and L_team).
    """

    actions: tuple[str, ...]
    prob: np.ndarray
    row_cmd: np.ndarray
    benefit: np.ndarray
    kept_mass: float
    single: np.ndarray | None = None
    prefix: float = 0.0

    def speedup(self, cost: float = 0.0) -> np.ndarray:
        """Per-row speedup ``L_single / L_team - 1`` of each action (the benchmark's metric).

        ``L_single = prefix + single``, ``L_team = L_single - benefit + cost``; doing nothing
        (without a cost) is 0.
        """
        if self.single is None:
            raise ValueError("these team values carry no L_single; build them with team_values")
        l_single = self.prefix + self.single[:, None]
        l_team = l_single - self.benefit + cost
        return np.where(l_team > 0, l_single / np.maximum(l_team, 1e-9) - 1.0, 0.0)

    def expected(self) -> np.ndarray:
        """Expected benefit of each action."""
        out: np.ndarray = self.prob @ self.benefit
        return out

    def gain(self, unit: str = "steps", cost: float = 0.0) -> np.ndarray:
        """Per-row gain of each action: steps saved (``benefit - cost``) or the speedup ratio."""
        if unit == "speedup":
            return self.speedup(cost)
        if unit != "steps":
            raise ValueError(f"unit must be 'steps' or 'speedup', got {unit!r}")
        return self.benefit - cost if cost else self.benefit

    def utility(self, loss_aversion: float = 0.0, cost: float = 0.0, unit: str = "steps") -> np.ndarray:
        """Per-row utility ``b - loss_aversion * max(0, -b)`` of the gain ``b`` (:meth:`gain`).

        Losses weigh ``1 + loss_aversion``; ``cost`` is time spent before acting (a question).
        """
        b = self.gain(unit, cost)
        if loss_aversion == 0.0:
            return b
        out: np.ndarray = b - loss_aversion * np.maximum(0.0, -b)
        return out

    def expected_utility(self, loss_aversion: float = 0.0, unit: str = "steps") -> np.ndarray:
        """``E[b] - loss_aversion * E[max(0, -b)]`` of each action (the risk-neutral one at 0)."""
        out: np.ndarray = self.prob @ self.utility(loss_aversion, unit=unit)
        return out

    def loss_probability(self) -> np.ndarray:
        """``P(b < 0)`` of each action: how likely it makes the team slower."""
        out: np.ndarray = self.prob @ (self.benefit < -1e-9)
        return out


def _keep_rows(joint: JointPosterior) -> tuple[np.ndarray, np.ndarray, float]:
    lj = joint.log_joint
    p = np.exp(lj - lj.max())
    p /= p.sum()
    order = np.argsort(-p, kind="stable")
    cum = np.cumsum(p[order])
    n = min(int(np.searchsorted(cum, KEEP_MASS)) + 1, MAX_ROWS, len(order))
    rows = order[:n]
    kept = float(cum[n - 1])
    return rows, p[rows] / p[rows].sum(), kept


def team_values(joint: JointPosterior, world: World, target: int, state: State | None = None,
                prefix: float = 0.0) -> TeamValues:
    """Benefit of every command of the domain (and of doing nothing) under each hypothesis.

    Args:
        joint: the posterior's hypotheses (``Posterior.joint``).
        world: the world the posterior is about.
        target: the place goal objects go to.
        state: the state when the human spoke (default: the posterior's).
        prefix: steps the human had spent before it spoke (only the speedup ratio uses it).
    """
    s = state if state is not None else joint.state
    if s is None:
        raise ValueError("team_values needs the state when the human spoke")
    col = {c: k for k, c in enumerate(world.classes)}
    rows, prob, kept = _keep_rows(joint)
    on_t, avail, held_h = _counts(world, s, target)
    cmds = joint.commands
    cmd_cls, cmd_n, actions = _command_arrays(world, cmds)
    c_of = joint.cmd_idx[rows]
    N = _row_goals(joint, col, rows, cmd_cls, cmd_n, on_t + held_h, _goal_matrix(world, joint.goals))
    uniq, u_of = _unique_rows(N)
    kmax = max(4, int(uniq.max()) if uniq.size else 4, int(cmd_n.max()) if len(cmd_n) else 4)
    ctg_h = _ctg(world, target, kmax, HUMAN)
    tabs = ctg_h.tables(s)
    sp = SparseGoals.from_dense(uniq)
    v_single = ctg_h.values(tabs, sp, s.agent_at[HUMAN], s.held[HUMAN])
    # distinct robot deliveries (class, effective count)
    n_eff = np.minimum(cmd_n, avail[cmd_cls])
    deliveries, act_col = _distinct_deliveries(cmd_cls, n_eff)
    D = list(deliveries)
    ben = np.zeros((len(uniq), len(D)))
    live = [j for j, (_c, n) in enumerate(D) if n > 0]
    if live:
        need = np.maximum(uniq - on_t[None, :] - held_h[None, :], 0)  # (U, C)
        l_team = _team_times(world, s, target, kmax, [D[j] for j in live], sp, need, on_t, tabs)
        ben[:, live] = (v_single[None, :] - l_team).T
    benefit = np.concatenate([ben[u_of][:, act_col], np.zeros((len(rows), 1))], axis=1)
    return TeamValues(actions, prob, c_of, benefit, kept,
                      np.asarray(v_single, dtype=np.float64)[u_of], float(prefix))


# per world: the goal-count matrix of a goal space (kept with the tuple it was made from, looked
# up by identity and checked on the way out: hashing a few hundred goals costs what it saves),
# and the class and count of each command of a command list
_GOALS: weakref.WeakKeyDictionary[World, Memo[tuple[object, np.ndarray]]] = weakref.WeakKeyDictionary()
_COMMANDS: weakref.WeakKeyDictionary[World, Memo[tuple[np.ndarray, np.ndarray, tuple[str, ...]]]] = weakref.WeakKeyDictionary()


def _per_world(table: weakref.WeakKeyDictionary[World, Memo[V]], world: World, name: str) -> Memo[V]:
    got = table.get(world)
    return got if got is not None else table.setdefault(world, Memo[V](name, 64))


def _goal_matrix(world: World, goals: tuple[Goal, ...]) -> np.ndarray:
    """Counts of each goal by class, shape (len(goals) + 1, C): the last row (the unknown goal) zero."""
    memo = _per_world(_GOALS, world, "teamvalue.goals")
    got = memo.peek(id(goals))
    if got is not None and got[0] is goals:
        return got[1]
    col = {c: k for k, c in enumerate(world.classes)}
    gmat = np.zeros((len(goals) + 1, len(col)), dtype=np.int64)
    for g, goal in enumerate(goals):
        for name, count in goal.counts:
            gmat[g, col[name]] = count
    gmat.flags.writeable = False
    memo.put(id(goals), (goals, gmat))
    return gmat


def _command_arrays(world: World, cmds: tuple[RobotCommand, ...]) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """The class index and the count of each command, and the actions (the commands as text, then none)."""
    memo = _per_world(_COMMANDS, world, "teamvalue.commands")
    got = memo.peek(cmds)
    if got is not None:
        return got
    col = {c: k for k, c in enumerate(world.classes)}
    cls = np.array([col[c.obj_class] for c in cmds], dtype=np.int64)
    n = np.array([c.count for c in cmds], dtype=np.int64)
    cls.flags.writeable = n.flags.writeable = False
    return memo.put(cmds, (cls, n, tuple(str(c) for c in cmds) + (NONE,)))


def _distinct_deliveries(cmd_cls: np.ndarray, n_eff: np.ndarray) -> tuple[dict[tuple[int, int], int], np.ndarray]:
    """The distinct (class, effective count) pairs in first-seen order, and each command's."""
    deliveries: dict[tuple[int, int], int] = {}
    act_col = np.empty(len(cmd_cls), dtype=np.int64)
    for a, key in enumerate(zip(cmd_cls.tolist(), n_eff.tolist(), strict=True)):
        act_col[a] = deliveries.setdefault(key, len(deliveries))
    return deliveries, act_col


def _counts(world: World, s: State, target: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per class: objects on the target, objects elsewhere and not held, and in the human's hands."""
    C = len(world.classes)
    on_t = np.zeros(C, dtype=np.int64)
    avail = np.zeros(C, dtype=np.int64)
    for i, loc in enumerate(s.item_at):
        k = int(world.item_class_idx[i])
        if loc == target:
            on_t[k] += 1
        elif loc != HELD:
            avail[k] += 1
    held_h = np.zeros(C, dtype=np.int64)
    if s.held[HUMAN] != NOTHING:
        held_h[int(world.item_class_idx[s.held[HUMAN]])] = 1
    return on_t, avail, held_h


def _unique_rows(N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct rows of ``N`` and the index of each row among them (in some fixed order:
    every value is computed row by row). Rows compared as raw bytes: several times faster than
    ``np.unique(axis=0)``, which compares them field by field."""
    a = np.ascontiguousarray(N)
    if a.shape[0] == 0:
        return a, np.zeros(0, dtype=np.intp)
    rows = a.view(np.dtype((np.void, a.dtype.itemsize * a.shape[1]))).reshape(-1)
    _, first, inv = np.unique(rows, return_index=True, return_inverse=True)
    return a[first], inv.reshape(-1)


def _row_goals(joint: JointPosterior, col: dict[str, int], rows: np.ndarray, cmd_cls: np.ndarray,
               cmd_n: np.ndarray, handled: np.ndarray, gmat: np.ndarray) -> np.ndarray:
    """A goal vector per kept row: a known goal's counts (``gmat``), or (unknown goal) exactly
    the command asked for on top of what is handled (on the target or in the human's hands)."""
    G = len(joint.goals)
    g_of, c_of = joint.goal_idx[rows], joint.cmd_idx[rows]
    N: np.ndarray = gmat[g_of]
    unk = np.flatnonzero(g_of == G)
    if len(unk):
        k = cmd_cls[c_of[unk]]
        N[unk] = 0
        N[unk, k] = handled[k] + cmd_n[c_of[unk]]
    return N


# per world: what a state's robot deliveries cost and leave behind, by (state, target, kmax,
# deliveries); a function of the world and the state alone, so shared by every request on them
_DELIVERIES: weakref.WeakKeyDictionary[World, Memo[_Deliveries]] = weakref.WeakKeyDictionary()
_DELIVERIES_PER_WORLD = 128


@dataclass(frozen=True, eq=False)
class _Deliveries:
    """The robot's side of a state's deliveries (class, count > 0), and the human's tables with
    each delivery's objects out of play appended (row ``C + r`` for delivery ``r``)."""

    cls: np.ndarray  # (L,) class of each delivery
    n: np.ndarray  # (L,) objects it brings
    robot: np.ndarray  # (L,) R: the robot's cost-to-go of each
    tables: ClassTables  # the human's tables, the reserved rows of each delivery appended
    remedy: int  # steps to clear one wrong object: 2 + 2 d(target, nearest other open surface)


def clear_state_caches(world: World) -> None:
    """Forget what was kept for ``world``'s states (benchmarks call this to time work from scratch)."""
    for per in _CTG.get(world, {}).values():
        per.clear_state_cache()
    got = _DELIVERIES.get(world)
    if got is not None:
        got.clear()


def _deliveries(world: World, s: State, target: int, kmax: int, live: tuple[tuple[int, int], ...],
                on_t: np.ndarray, tabs: ClassTables) -> _Deliveries:
    """The deliveries ``live`` in state ``s`` (``on_t`` and ``tabs``: the state's, so not in the key)."""
    per = _DELIVERIES.get(world)
    if per is None:
        per = _DELIVERIES.setdefault(world, Memo[_Deliveries]("teamvalue.deliveries", _DELIVERIES_PER_WORLD))
    return per.get((s, target, kmax, live), lambda: _make_deliveries(world, s, target, kmax, live, on_t, tabs))


def _make_deliveries(world: World, s: State, target: int, kmax: int, live: tuple[tuple[int, int], ...],
                     on_t: np.ndarray, tabs: ClassTables) -> _Deliveries:
    C = len(world.classes)
    ctg_h, ctg_r = _ctg(world, target, kmax, HUMAN), _ctg(world, target, kmax, ROBOT)
    # robot: one batched call over the distinct deliveries
    R_goals = np.zeros((len(live), C), dtype=np.int64)
    for r, (c, n) in enumerate(live):
        R_goals[r, c] = on_t[c] + n
    R = ctg_r.values(ctg_r.tables(s), R_goals, s.agent_at[ROBOT], s.held[ROBOT])
    # human: the reserved rows of the changed class are appended to the tables (as
    # successor_values does)
    extra = []
    for c, n in live:
        taken = _taken(world, s, ctg_h, target, c, n, s.agent_at[ROBOT])
        item_at = tuple(HELD if i in taken else loc for i, loc in enumerate(s.item_at))
        extra.append(ctg_h._class_rows(c, item_at, s.open_mask))
    return _Deliveries(np.array([c for c, _n in live], dtype=np.int64), np.array([n for _c, n in live], dtype=np.int64),
                       np.asarray(R), tabs.extend(extra), 2 + 2 * aside_distance(world, target))


def _team_times(world: World, s: State, target: int, kmax: int, live: list[tuple[int, int]], sp: SparseGoals,
                need: np.ndarray, on_t: np.ndarray, tabs: ClassTables) -> np.ndarray:
    """``max(H, R) + remedy`` per robot delivery (class, count > 0) and distinct goal row."""
    C, U, L = len(world.classes), len(sp), len(live)
    dv = _deliveries(world, s, target, kmax, tuple(live), on_t, tabs)
    ctg_h = _ctg(world, target, kmax, HUMAN)
    # human: the goal minus the useful part, with the robot's objects out of play (all deliveries
    # at once: row r * U + u is delivery r under goal row u)
    hold_h = s.held[HUMAN]
    hc = int(world.item_class_idx[hold_h]) if hold_h != NOTHING else -1
    useful_all = np.minimum(dv.n[:, None], need[:, dv.cls].T)  # (L, U)
    is_c = sp.idx[None, :, :] == dv.cls[:, None, None]  # (L, U, m)
    hit = is_c & (sp.cnt > 0)[None, :, :]
    ext = (C + np.arange(L, dtype=np.int64))[:, None, None]
    idx = np.where(is_c, ext, sp.idx[None, :, :]).reshape(L * U, -1)
    cnt = (sp.cnt[None, :, :] - hit * useful_all[:, :, None]).reshape(L * U, -1)
    held = np.repeat(np.where(dv.cls == hc, C + np.arange(L, dtype=np.int64), hc), U)
    H = ctg_h._values(dv.tables, idx, cnt, np.array([s.agent_at[HUMAN]]), held)[0].reshape(L, U)
    wrong = dv.n[:, None] - useful_all
    out: np.ndarray = np.maximum(H, dv.robot[:, None]) + wrong * dv.remedy
    return out


def _taken(world: World, s: State, ctg: CostToGo, target: int, c: int, n: int, start: int | None = None) -> set[int]:
    """The ``n`` objects of class ``c`` the robot fetches, as its cost-to-go plan chooses them.

    The ``n`` cheapest round trips, except that the first trip starts where the robot stands
    (``start``): the first object comes from the place that minimises the walk plus the
    containers opened, the rest are the cheapest round trips of the others
    (``planning.choice.chosen``). The team simulation's robot (A*) takes the objects on its optimal
    plan, which this reproduces; the human plans around them.
    """
    return set(chosen(ctg, s, c, n, start))


def command_of(action: str) -> RobotCommand | None:
    """The RobotCommand of an action string (``none``: None)."""
    return None if action == NONE else RobotCommand.parse(action)
