"""Sessions: a robot's own world, the human's actions as they happen, instructions when heard.

A session holds a scene (world JSON or VirtualHome scene graph, see docs/world.md), an
:class:`~siftom.inference.model.OnlineInference` that has observed every action so far (one
more action costs one Q-table row), and the answer to the last instruction. The SQLite store
(:mod:`siftom.service.store`) is the truth: every change is written there before the caller
returns, memory only caches live sessions (rebuilt by replaying the stored actions when a
restarted service, or an evicted cache entry, meets the id again).

Actions come in through :meth:`SessionManager.append`: lines in siftom's or VirtualHome's
script format (:mod:`siftom.world.vhscript`), checked against the session's current state,
all or none, tagged with a ``source``. Another producer of actions (e.g. perception of
camera frames) calls :meth:`SessionManager.append_actions` with checked
:class:`~siftom.world.model.Action` objects and its own source name.
"""

from __future__ import annotations

import secrets
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from typing import Unpack

from pydantic import ValidationError

from siftom.assist.clarify import ClarifyPolicy
from siftom.assist.decision import DecisionRule
from siftom.errors import ObservationError, SiftomError
from siftom.inference.model import OnlineInference
from siftom.observation import Instruction
from siftom.observer import Heard, Observer
from siftom.options import SessionLimits
from siftom.service.answer_with import AnswerWith
from siftom.service.idempotency import Idem, check_same
from siftom.service.problems import ProblemError
from siftom.service.session_records import Prepared, SessionOptions, SessionReply, SessionSpec
from siftom.service.session_scene import Session, build_scene, check_speakable, unreadable
from siftom.service.session_views import (
    BELIEF_TOP,
    actions_reply,
    answer_reply,
    executed_plan,
    view_reply,
)
from siftom.service.store import DiskFullError, KeyTaken, SessionStore
from siftom.world.io import LoadedScene
from siftom.world.model import HUMAN, Action, apply, check

# "auto": spoken instructions (audio) get the acoustic likelihood when the whisper extra is installed,
# transcripts the phonetic one (siftom.likelihood.registry.resolve_likelihood)
SESSION_LIKELIHOODS = ("auto", "phonetic", "llm")


class SessionManager:
    """Create, advance, query and end sessions; thread-safe (see module doc)."""

    def __init__(self, store: SessionStore, limits: SessionLimits, observer: Observer | None = None) -> None:
        self.store, self.limits = store, limits
        self.observer = observer if observer is not None else Observer()
        self._live: OrderedDict[str, Session] = OrderedDict()
        self._lock = threading.Lock()
        self._loading: dict[str, threading.Lock] = {}
        self._last_sweep = 0.0
        self._held: dict[str, int] = {}  # sessions in use by an open stream (how many)

    def _online(self, scene: LoadedScene, options: SessionOptions) -> OnlineInference:
        """A new online inference of the session's world (the observer's model for its mode)."""
        return self.observer.fresh(scene.world, scene.start, scene.goals, scene.verb, options.mode)

    # ----- lifecycle ---------------------------------------------------------------------------
    def sweep(self, force: bool = False) -> None:
        """Delete sessions idle for longer than the limit (at most once a minute unless forced)."""
        now = time.time()
        if not force and now - self._last_sweep < 60:
            return
        self._last_sweep = now
        with self._lock:
            held = list(self._held)
        for sid in held:  # in use: a stream's audio is use even when nothing is said
            self.store.touch(sid)
        try:
            expired = self.store.expire(now - self.limits.idle_s)
        except DiskFullError:  # no room even to delete: the next sweep tries again
            return
        for sid in expired:
            with self._lock:
                self._live.pop(sid, None)

    def create(self, spec: SessionSpec, options: SessionOptions, idem: Idem | None = None,
               actions: list[Action] | None = None, source: str = "actions") -> Session:
        """A new session over ``spec.world``, having seen ``actions`` (from ``source``); written
        to the store before returning. ``idem``: the request's Idempotency-Key, claimed with the
        session (a request that lost the race for the key gets the session the winner made, its
        actions not added again; :meth:`created_reply` answers the retries)."""
        self.sweep(force=True)
        n = self.store.count()
        if n >= self.limits.max_sessions:
            raise ProblemError(429, "too-many-sessions",
                               f"{n} sessions are open, the most this server allows (--max-sessions); DELETE "
                               f"finished sessions, or wait for idle ones to expire after {self.limits.idle_s:g} s",
                               headers={"Retry-After": "60"})
        st = self.observer.settings
        options = options.model_copy(update={"mode": options.mode or st.model.mode,
                                             "likelihood": options.likelihood or st.infer.likelihood})
        if options.likelihood not in SESSION_LIKELIHOODS:
            raise ObservationError(f"sessions infer with the {' or '.join(SESSION_LIKELIHOODS)} likelihood, not "
                                   f"{options.likelihood!r}; for the acoustic likelihood use POST /v1/infer")
        self.observer.check_likelihood(options.likelihood)
        scene, warnings = build_scene(spec, self.limits.max_world_items)
        check_speakable(scene.world)  # now, not at the first instruction
        online = self._online(scene, options)
        sid = secrets.token_urlsafe(12)
        options = options.model_copy(update={"warnings": tuple(warnings)})
        try:
            created = self.store.create(sid, spec, options, None if idem is None else (idem.key, idem.request))
        except KeyTaken:
            assert idem is not None
            first = self.store.creation(idem.key)
            if first is None:  # claimed and expired meanwhile: practically never
                raise ProblemError(409, "conflict", "another request with this Idempotency-Key created a session "
                                   "at the same time; retry with the same key") from None
            check_same(idem, first.request)
            return self.get(first.session)
        sess = Session(sid, created, spec, options, scene, online, [], warnings)
        self._remember(sess)
        if actions:
            self.append_actions(sid, actions, source)
        return sess

    def hold(self, sid: str) -> None:
        """Mark ``sid`` in use (an open stream) until :meth:`release`: it does not expire meanwhile."""
        with self._lock:
            self._held[sid] = self._held.get(sid, 0) + 1

    def release(self, sid: str) -> None:
        """The end of a :meth:`hold`; the session's idle time starts now."""
        with self._lock:
            left = self._held.get(sid, 0) - 1
            if left > 0:
                self._held[sid] = left
            else:
                self._held.pop(sid, None)
        self.store.touch(sid)

    def created_reply(self, idem: Idem | None) -> SessionReply | None:
        """The first answer of the session-creating request with ``idem``'s key, or None (422
        when the key asked otherwise; the session's state now while the first has not finished)."""
        if idem is None:
            return None
        first = self.store.creation(idem.key)
        if first is None:
            return None
        check_same(idem, first.request)
        return first.reply if first.reply is not None else self.view(self.get(first.session))

    def created(self, idem: Idem | None, view: SessionReply) -> SessionReply:
        """Record ``view`` as the first answer to a session-creating request; returns it."""
        if idem is not None:
            self.store.set_creation_reply(idem.key, view)
        return view

    def _remember(self, sess: Session) -> None:
        with self._lock:
            self._live[sess.id] = sess
            self._live.move_to_end(sess.id)
            while len(self._live) > self.limits.cache:
                self._live.popitem(last=False)

    def get(self, sid: str) -> Session:
        """The live session, rebuilt from the store if needed; 404 when there is none."""
        self.sweep()
        with self._lock:
            sess = self._live.get(sid)
            if sess is not None:
                self._live.move_to_end(sid)
                return sess
            gate = self._loading.setdefault(sid, threading.Lock())
        try:
            with gate:  # one thread rebuilds a given session; the others wait for it
                with self._lock:
                    sess = self._live.get(sid)
                if sess is None:
                    sess = self._rebuild(sid)
                    self._remember(sess)
        finally:
            with self._lock:
                self._loading.pop(sid, None)
        return sess

    def _rebuild(self, sid: str) -> Session:
        try:
            if (row := self.store.load(sid)) is None:
                raise ProblemError(404, "unknown-session",
                                   f"no session {sid!r} (it was deleted, or expired after {self.limits.idle_s:g} s "
                                   "idle); create one with POST /v1/sessions")
            scene, _warnings = build_scene(row.spec, self.limits.max_world_items)
            online = self._online(scene, row.options)
            for text in row.actions:
                online.observe(scene.world.parse_action(text, online.state))
        except (ValidationError, ValueError, SiftomError) as exc:  # the stored rows, not the request
            raise unreadable(sid, exc) from None
        return Session(row.id, row.created, row.spec, row.options, scene, online, list(row.actions),
                       list(row.options.warnings), row.last)

    def delete(self, sid: str, key: str | None = None) -> None:
        """End a session; a retry with the ``key`` that ended it succeeds again."""
        with self._lock:
            self._live.pop(sid, None)
        if not self.store.delete(sid, key) and not (key is not None and self.store.closed_by(sid, key)):
            raise ProblemError(404, "unknown-session", f"no session {sid!r}; nothing to delete")

    # ----- actions -----------------------------------------------------------------------------
    def append(self, sid: str, lines: list[str], source: str = "actions") -> list[str]:
        """Parse, check and add action lines (siftom or VirtualHome format), all or none; returns
        the actions added, in siftom's form (a script line may stand for none, one or two)."""
        added: list[str] = self.append_reply(sid, lines, None, None, source).body["added"]
        return added

    def append_once(self, sid: str, lines: list[str], after: int | None) -> tuple[list[str], bool]:
        """:meth:`append`, safe to retry with ``after`` (see :meth:`append_reply`)."""
        body = self.append_reply(sid, lines, after).body
        return body["added"], body["replayed"]

    def replayed(self, sid: str, idem: Idem | None) -> SessionReply | None:
        """The first answer to ``idem``'s key in this session, or None (422 if the key asked otherwise)."""
        if idem is None:
            return None
        sess = self.get(sid)
        with sess.lock:
            return self._replayed(sess, idem)

    def _replayed(self, sess: Session, idem: Idem | None) -> SessionReply | None:
        if idem is None:
            return None
        got = self.store.reply(sess.id, idem.key)
        if got is None:
            return None
        check_same(idem, got.request)
        reply = got.reply
        pending = reply.pending_actions
        if pending is not None:  # the service stopped between storing the actions and their answer
            reply = self._actions_reply(sess, *pending, False)
            self.store.put_reply(sess.id, idem.key, idem.request, reply)
        return reply

    def append_reply(self, sid: str, lines: list[str], after: int | None, idem: Idem | None = None,
                     source: str = "actions") -> SessionReply:
        """Append action lines and answer with the session's state right after them.

        ``after`` is the action count the client saw before it first sent ``lines``: if those
        lines were already applied at that point (a retry after a lost reply or a 503) they are
        returned again with ``replayed`` True and nothing is added; any other mismatch is a 409
        naming the session's count. ``idem``: an Idempotency-Key; a key seen before returns its
        first answer unchanged. The answer is built under the session's lock, so concurrent
        requests each get their own state.
        """
        from siftom.world.vhscript import parse_actions

        sess = self.get(sid)
        with sess.lock:
            first = self._replayed(sess, idem)
            if first is not None:
                return first
            n = len(sess.actions)
            if after is None or n == after:
                acts, _ = parse_actions(sess.scene.world, sess.online.state, lines, first=0)
                return self._add(sess, acts, source, idem)
            if after < n:
                w, s = sess.scene.world, sess.scene.start
                for text in sess.actions[:after]:
                    s = apply(s, w.parse_action(text, s))
                late: list[Action] | None
                try:
                    late, _ = parse_actions(w, s, lines, first=0)
                except ObservationError:
                    late = None
                texts = None if late is None else [w.format_action(a) for a in late]
                if texts is not None and after + len(texts) == n and sess.actions[after:] == texts:
                    return self._actions_reply(sess, n, texts, True)
        raise ProblemError(409, "conflict", f"the session holds {n} actions, not the {after} this request was "
                           "sent after; GET the session to see them and send only what is new")

    def executed_actions(self, sid: str, command: str | list[str]) -> list[str]:
        """The robot's actions for a command it carried out, or the parts of a request of several
        carried out in order: each part's plan from the state the one before left
        (assist/route.py), in siftom's form; a part with nothing left to bring is a 422."""
        commands = [command] if isinstance(command, str) else list(command)
        sess = self.get(sid)
        with sess.lock:
            return executed_plan(sess, commands)

    def append_actions(self, sid: str, actions: list[Action], source: str) -> list[str]:
        """Add already-built human actions (another producer, e.g. perception), all or none;
        returns them in siftom's form."""
        sess = self.get(sid)
        with sess.lock:
            s = sess.online.state
            for k, a in enumerate(actions):
                why = check(sess.scene.world, s, a) if a.agent == HUMAN else "only the human's actions are observed"
                if why is not None:
                    raise ObservationError(f"{source} action {k} is impossible here: {why}")
                s = apply(s, a)
            added: list[str] = self._add(sess, actions, source).body["added"]
            return added

    def _add(self, sess: Session, acts: list[Action], source: str, idem: Idem | None = None) -> SessionReply:
        """Store and observe ``acts`` (the session's lock held); the answer to the request."""
        if len(sess.actions) + len(acts) > self.limits.max_actions:
            raise ObservationError(f"a session may observe at most {self.limits.max_actions} actions "
                                   "(--max-session-actions); start a new session for a new task")
        texts = [sess.scene.world.format_action(a) for a in acts]
        n = len(sess.actions) + len(texts)
        # the key is stored with the actions (one transaction); its full answer once it is known
        pending = None if idem is None else (idem.key, idem.request, SessionReply.pending(n, texts))
        if texts:
            try:
                self.store.append(sess.id, len(sess.actions), texts, source, pending)  # durable before the reply
            except ProblemError as exc:
                if exc.status == 404:  # deleted or expired meanwhile: forget the live copy too
                    with self._lock:
                        self._live.pop(sess.id, None)
                raise
        for a in acts:
            sess.online.observe(a)
        sess.actions.extend(texts)
        reply = self._actions_reply(sess, n, texts, False)
        if idem is not None:
            self.store.put_reply(sess.id, idem.key, idem.request, reply)
        return reply

    def _actions_reply(self, sess: Session, n: int, added: list[str], replayed: bool) -> SessionReply:
        """The answer to an actions request: what it added and the state after its ``n``-th action."""
        online = sess.online
        if n != len(sess.actions):  # an older request: replay the actions up to it
            online = self._online(sess.scene, sess.options)
            for text in sess.actions[:n]:
                online.observe(sess.scene.world.parse_action(text, online.state))
        return actions_reply(sess, online, n, added, replayed)

    # ----- instruction -------------------------------------------------------------------------
    def instruct(self, sid: str, instruction: Instruction | None, top: int | None, policy: ClarifyPolicy,
                 heard: Heard | None = None, idem: Idem | None = None, **how: Unpack[AnswerWith]) -> SessionReply:
        """What the robot does about what was heard, given everything so far (the observer's answer);
        ``heard``: the clip it was recognised from; ``idem``: see :meth:`append_reply`; ``how``: :class:`AnswerWith`."""
        sess = self.get(sid)
        with sess.lock:
            first = self._replayed(sess, idem)
            if first is not None:
                return first
            body = self._answer(sess, instruction, top, policy, heard, how.get("decide"), how.get("likelihood"))
            return self._store_last(sess, body, idem)

    def prepare(self, sid: str, instruction: Instruction | None, top: int | None, policy: ClarifyPolicy,
                heard: Heard | None = None, likelihood: str | None = None,
                decide: str | DecisionRule | None = None) -> Prepared:
        """:meth:`instruct`'s answer, not stored: :meth:`commit` stores it unless the session changed
        meanwhile (a stream answers while the end of speech is still being confirmed)."""
        sess = self.get(sid)
        with sess.lock:
            return Prepared(self._answer(sess, instruction, top, policy, heard, decide, likelihood), self.revision(sid))

    def commit(self, sid: str, prepared: Prepared, check: Callable[[], None] | None = None) -> SessionReply | None:
        """Store a :meth:`prepare`'d answer as the session's last; None when an action or another
        answer came after it was prepared (prepare it again). ``check`` runs under the session's
        lock first and may raise to store nothing (a stream that closed meanwhile)."""
        sess = self.get(sid)
        with sess.lock:
            if check is not None:
                check()
            if prepared.revision != self.revision(sid):
                return None
            return self._store_last(sess, prepared.reply, None)

    def revision(self, sid: str) -> tuple[int, int, int]:
        """A token that changes whenever the session's next answer could: its actions, its last answer."""
        sess = self.get(sid)
        return id(sess), len(sess.actions), sess.revision

    def _answer(self, sess: Session, instruction: Instruction | None, top: int | None, policy: ClarifyPolicy,
                heard: Heard | None, decide: str | DecisionRule | None, likelihood: str | None) -> SessionReply:
        """The observer's answer as the session's JSON (its lock held)."""
        return answer_reply(self.observer, sess, instruction, top, policy, heard, decide, likelihood)

    def _store_last(self, sess: Session, body: SessionReply, idem: Idem | None) -> SessionReply:
        """Keep ``body`` as the session's last answer (its lock held)."""
        self.store.set_last(sess.id, body, None if idem is None else (idem.key, idem.request))
        sess.last = body
        sess.revision += 1
        return body

    def view(self, sess: Session) -> SessionReply:
        """The session's state (the same before and after a restart)."""
        with sess.lock:
            return view_reply(sess)


__all__ = ["BELIEF_TOP", "SESSION_LIKELIHOODS", "Prepared", "Session", "SessionLimits", "SessionManager",
           "SessionOptions", "SessionReply", "SessionSpec", "build_scene", "check_speakable"]
