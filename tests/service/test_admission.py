"""The server's CPU budget: past it, an utterance is answered with the cheaper likelihood and the
answer says so; nothing is refused."""

from __future__ import annotations

import threading

from siftom.service.admission import DEGRADED_LIKELIHOOD, Admission, cpu_budget


def test_within_the_budget_the_sessions_own_likelihood_answers():
    adm = Admission(budget=2)
    with adm.slot() as a, adm.slot() as b:
        assert (a.likelihood, b.likelihood, a.reason) == (None, None, "")
        assert adm.stats()["in_flight"] == 2
    assert adm.stats() == {"budget": 2, "in_flight": 0, "answered": 2, "degraded": 0}


def test_past_the_budget_the_next_utterance_is_degraded_and_says_why():
    adm = Admission(budget=2)
    with adm.slot(), adm.slot(), adm.slot() as third:
        assert third.likelihood == DEGRADED_LIKELIHOOD
        assert "2 utterances were being answered on 2 CPUs" in third.reason
    with adm.slot() as after:  # the crowd has gone
        assert after.likelihood is None
    assert adm.stats()["degraded"] == 1


def test_a_budget_of_zero_never_degrades_and_the_default_is_the_cpus_we_may_use():
    adm = Admission(budget=0)
    with adm.slot(), adm.slot(), adm.slot() as s:
        assert s.likelihood is None
    assert Admission().budget == cpu_budget() >= 1


def test_slots_are_released_when_an_answer_fails_and_counted_across_threads():
    adm = Admission(budget=4)
    try:
        with adm.slot():
            raise ValueError("a bug in one answer")
    except ValueError:
        pass
    assert adm.stats()["in_flight"] == 0
    go = threading.Barrier(8)

    def answer() -> None:
        go.wait()
        with adm.slot():
            pass

    threads = [threading.Thread(target=answer) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert adm.stats()["in_flight"] == 0 and adm.stats()["answered"] == 9


def test_a_likelihood_someone_chose_is_kept_even_past_the_budget():
    adm = Admission(budget=1)
    with adm.slot(), adm.slot("llm") as chosen, adm.slot("auto") as default:
        assert chosen.likelihood is None and chosen.reason == ""
        assert default.likelihood == DEGRADED_LIKELIHOOD
    assert adm.stats()["degraded"] == 1
