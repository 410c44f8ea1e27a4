"""What a session looks like from outside: its state, belief and view, the observer's answer to
an instruction and the robot's plan, each as the JSON the session endpoints send (and the store
keeps)."""

from __future__ import annotations

import json
from typing import Any

from siftom.assist.clarify import Clarification, ClarifyPolicy, clarify
from siftom.assist.decision import DecisionRule
from siftom.assist.reply import Pending
from siftom.errors import ObservationError, SiftomError
from siftom.inference.model import OnlineInference
from siftom.observation import Instruction
from siftom.observer import Heard, Observer
from siftom.service.session_records import SessionReply
from siftom.service.session_scene import Session
from siftom.world.model import AGENT_NAMES, HELD, NOTHING, apply

BELIEF_TOP = 5


def _pending_of(last: SessionReply | None) -> Pending | None:
    """The question the session's last answer left waiting (None: none, or a record this version
    cannot read, which is then forgotten rather than failing the instruction)."""
    got = last.body.get("awaiting") if last is not None else None
    if not isinstance(got, dict):
        return None
    try:
        return Pending.from_json(got)
    except ObservationError:
        return None


def _state_json(w: Any, s: Any) -> dict[str, Any]:
    """Where the agents are, what they hold, what is open and where every object is."""
    items: dict[str, list[str]] = {}
    for i, loc in enumerate(s.item_at):
        if loc != HELD:
            items.setdefault(w.places[loc].name, []).append(w.items[i].name)
    return {
        "agents": {AGENT_NAMES[k]: w.places[p].name for k, p in enumerate(s.agent_at)},
        "held": {AGENT_NAMES[k]: (w.items[h].name if h != NOTHING else None) for k, h in enumerate(s.held)},
        "open": [p.name for i, p in enumerate(w.places) if p.closable and s.is_open(i)],
        "items": items,
    }


class Planned:
    """A session's scene as the robot's planner reads it (world, target, command parsing)."""

    def __init__(self, scene: Any) -> None:
        self.world, self.target = scene.world, scene.goals[0].target

    def parse_command(self, text: str) -> Any:
        from siftom.world.commands import RobotCommand

        return RobotCommand.parse(text)


def executed_plan(sess: Session, commands: list[str]) -> list[str]:
    """The robot's actions for each command in turn, each planned from the state the one before
    left (the session's lock held); a command with nothing left to do is an ObservationError."""
    from siftom.assist.route import robot_plan
    from siftom.world.commands import RobotCommand

    out: list[str] = []
    world, state = sess.scene.world, sess.online.state
    for text in commands:
        try:
            cmd = RobotCommand.parse(text)
        except SiftomError as exc:
            raise ObservationError(f"executed: {exc}") from None
        if cmd.obj_class not in world.classes:
            raise ObservationError(f"executed: no object of class {cmd.obj_class!r} in this world; "
                                   f"classes: {', '.join(world.classes)}")
        plan = robot_plan(Planned(sess.scene), state, cmd)
        if not plan.actions:
            raise ObservationError(f"executed: the robot has nothing to do for {text} here ({plan.status}); "
                                   "send the robot's actions instead")
        for line in plan.actions:
            state = apply(state, world.parse_action(line, state))
        out.extend(plan.actions)
    return out


def _plan_json(sess: Session, command: str) -> dict[str, Any] | None:
    from siftom.assist.route import robot_plan

    try:
        return robot_plan(Planned(sess.scene), sess.online.state, command, max_time=0.1).to_json()
    except SiftomError:
        return None


def _belief_json(sess: Session, online: OnlineInference | None = None) -> dict[str, Any]:
    """The top goals and commands from the actions alone (none before words in speech-only mode);
    the session's own belief is kept until its next action."""
    if sess.options.mode == "speech-only":
        return {"goals": [], "commands": []}
    if online is None or online is sess.online:
        n = len(sess.actions)
        if sess.belief is not None and sess.belief[0] == n:
            return sess.belief[1]
        online = sess.online
    post = online.posterior(None, top=BELIEF_TOP)
    belief = {"goals": [{"goal": g, "prob": p} for g, p in post.goals[:BELIEF_TOP]],
              "commands": [{"command": c, "prob": p} for c, p in post.commands[:BELIEF_TOP]]}
    if online is sess.online:
        sess.belief = (len(sess.actions), belief)
    return belief


def actions_reply(sess: Session, online: OnlineInference, n: int, added: list[str], replayed: bool
                  ) -> SessionReply:
    """The answer to an actions request: what it added and the state after them (``online``)."""
    return SessionReply({"id": sess.id, "added": list(added), "n_actions": n,
                         "state": _state_json(sess.scene.world, online.state),
                         "belief": _belief_json(sess, online), "replayed": replayed})


def answer_reply(observer: Observer, sess: Session, instruction: Instruction | None, top: int | None,
                 policy: ClarifyPolicy, heard: Heard | None, decide: str | DecisionRule | None,
                 likelihood: str | None) -> SessionReply:
    """The observer's answer as the session's JSON (its lock held)."""
    top = top or observer.settings.infer.top
    ans = observer.answer(sess.online, instruction, likelihood=likelihood or sess.options.likelihood,
                          decide=decide or sess.options.decide, top=top, heard=heard,
                          mode=sess.options.mode, pending=_pending_of(sess.last))
    body: dict[str, Any] = {"session": sess.id, **ans.to_json(top=top)}
    # the question the robot waits on an answer to, kept with the session (assist/reply.py)
    body["awaiting"] = ans.pending.to_json() if ans.pending is not None else None
    body["nbest"] = [{"text": h.text, "score": h.score} for h in (instruction.nbest if instruction else ())]
    body["clarification"] = clarify(ans.commands, policy).to_json()
    if ans.action == "none" and not ans.instruction_heard:  # nothing to act on, nothing to ask about
        body["clarification"] = Clarification(False, "none", "", (), 0.0, 0.0, policy.threshold, policy.cost,
                                              ans.message).to_json()
    body["plan"] = _plan_json(sess, str(ans.command)) if ans.command is not None else None
    return SessionReply(json.loads(json.dumps(body)))  # exactly what the store gives back after a restart


def view_reply(sess: Session) -> SessionReply:
    """The session's state (the same before and after a restart; its lock held)."""
    w = sess.scene.world
    return SessionReply({
        "id": sess.id,
        "created": sess.created,
        "mode": sess.options.mode,
        "likelihood": sess.options.likelihood,
        "verb": sess.scene.verb,
        "target": w.places[sess.scene.goals[0].target].name,
        "num_goals": len(sess.scene.goals),
        "classes": list(w.classes),
        "places": [p.name for p in w.places],
        "n_actions": len(sess.actions),
        "actions": list(sess.actions),
        "state": _state_json(w, sess.online.state),
        "belief": _belief_json(sess),
        "last_instruction": sess.last.to_json() if sess.last is not None else None,
        "warnings": list(sess.warnings),
    })
