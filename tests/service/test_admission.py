"""The server's CPU budget: past it, an utterance is answered with the cheaper likelihood and the
answer says so; nothing is refused."""

from __future__ import annotations

import threading
import time

from siftom.service.admission import DEGRADED_LIKELIHOOD, Admission, cpu_budget


def test_within_the_budget_the_sessions_own_likelihood_answers():
    adm = Admission(budget=2)
    with adm.slot() as a, adm.slot() as b:
        assert (a.likelihood, b.likelihood, a.reason) == (None, None, "")
        assert adm.stats()["in_flight"] == 2
    assert adm.stats() == {"budget": 2, "in_flight": 0, "recognising": 0, "answered": 2, "degraded": 0}


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


def test_utterances_waiting_for_the_recogniser_count_as_the_queue():
    """A burst: speech ends in several streams at once; while the others wait for the recogniser,
    the first to reach its answer is already past the budget and says so."""
    adm = Admission(budget=2)
    with adm.recognising(), adm.recognising():  # two more utterances still being recognised
        assert adm.stats()["recognising"] == 2
        with adm.slot() as first:
            assert first.likelihood == DEGRADED_LIKELIHOOD
            assert "0 utterances were being answered and 2 more being recognised on 2 CPUs" in first.reason
    with adm.recognising(), adm.slot() as alone:  # one other in the queue: within a budget of 2
        assert alone.likelihood is None
    assert adm.stats()["recognising"] == 0 and adm.stats()["degraded"] == 1


def test_at_most_the_budget_of_degraded_answers_compute_at_once_and_a_share_never_stalls():
    adm = Admission(budget=2, share_wait_s=5.0)
    running, most = 0, 0
    lock = threading.Lock()
    go = threading.Barrier(6)

    def answer() -> None:
        nonlocal running, most
        go.wait()
        with adm.slot() as s:
            assert s.likelihood == DEGRADED_LIKELIHOOD
            with lock:
                running += 1
                most = max(most, running)
            time.sleep(0.05)
            with lock:
                running -= 1

    with adm.slot() as a, adm.slot() as b:  # two answers on the full path: they take no share
        assert (a.likelihood, b.likelihood) == (None, None)
        threads = [threading.Thread(target=answer) for _ in range(6)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    assert most == 2 and adm.stats()["answered"] == 8
    short = Admission(budget=1, share_wait_s=0.05)
    with short.slot(), short.slot() as held:  # the full path, then a degraded answer holding the share
        assert held.likelihood == DEGRADED_LIKELIHOOD
        t0 = time.monotonic()
        with short.slot() as late:  # the share is held: after share_wait_s it runs anyway
            assert time.monotonic() - t0 < 1.0 and late.likelihood == DEGRADED_LIKELIHOOD


def test_the_last_of_a_burst_counts_the_queue_it_waited_behind():
    adm = Admission(budget=2)
    ahead = [adm.recognising() for _ in range(2)]
    for cm in ahead:
        cm.__enter__()
    with adm.recognising():  # joins behind two: by its turn the queue may be empty
        for cm in ahead:
            cm.__exit__(None, None, None)
    assert adm.stats()["recognising"] == 0
    with adm.slot() as last:
        assert last.likelihood == DEGRADED_LIKELIHOOD and "2 utterances were ahead of it" in last.reason
    with adm.slot() as next_one:  # what the queue was counts once, for that utterance's answer
        assert next_one.likelihood is None
