"""A stream's answer is prepared without side effects and committed under the session's lock:
never twice, never after an action that makes it stale, never for a stream that closed."""

from __future__ import annotations

import pytest

from siftom.observation import Hypothesis, Instruction


def test_a_session_commit_checks_under_its_lock_and_stores_nothing_for_a_closed_stream(tmp_path):
    from siftom.assist.clarify import ClarifyPolicy
    from siftom.options import SessionLimits
    from siftom.scenarios.base import get_scenario
    from siftom.service.session_records import SessionOptions
    from siftom.service.sessions import SessionManager
    from siftom.service.store import SessionStore
    from siftom.service.stream_api import scenario_spec

    class Closed(Exception):
        pass

    def closed():
        raise Closed

    mgr = SessionManager(SessionStore(tmp_path / "sessions.sqlite3"), SessionLimits())
    sc = get_scenario("kitchen-cereal-v0")
    sess = mgr.create(scenario_spec(sc), SessionOptions(likelihood="phonetic"), None, actions=list(sc.actions[:3]))
    said = Instruction(nbest=(Hypothesis("pass me the cereal", 0.0),))
    body = mgr.prepare(sess.id, said, None, ClarifyPolicy())
    assert mgr.get(sess.id).last is None  # preparing stores nothing
    with pytest.raises(Closed):
        mgr.commit(sess.id, body, closed)
    assert mgr.get(sess.id).last is None
    mgr.append(sess.id, [sc.world.format_action(sc.actions[3])])
    assert mgr.commit(sess.id, body) is None  # an action came after it was prepared
    body = mgr.prepare(sess.id, said, None, ClarifyPolicy())
    stored = mgr.commit(sess.id, body)
    assert stored is not None and stored == body.reply and mgr.get(sess.id).last == stored
    assert mgr.commit(sess.id, body) is None  # written once: the session moved on
