"""siftom bench robots: how answers are matched to instructions, its options, and (slow) a run
against a real server."""

from __future__ import annotations

import pytest

from siftom.bench.machine import Machine
from siftom.bench.robots import ServeBenchOptions, ServeBenchResult, match_delays, run_serve_bench
from siftom.errors import OptionsError


def test_each_answer_goes_to_the_earliest_instruction_ended_before_it():
    assert match_delays([2.0, 5.0, 9.0], [2.5, 5.25]) == [0.5, 0.25, None]  # the third one was missed
    assert match_delays([2.0, 5.0], [1.0, 6.0, 6.5]) == [4.0, 1.5]  # an answer before any end answers nothing
    assert match_delays([2.0, 5.0], []) == [None, None]


@pytest.mark.parametrize("bad", [{"streams": 0}, {"streams": 65}, {"instructions": 9}, {"http_rps": -1},
                                 {"idle_requests": 0}, {"grace_s": 0}])
def test_options_out_of_range_say_which(bad):
    with pytest.raises(OptionsError):
        ServeBenchOptions(**bad)


def _result(answered, p90, idle, load):
    return ServeBenchResult({}, Machine(), {"p90": idle}, {"p90": load}, 0, [], 4, answered, 0.5, p90, (0, 0, 0), 0, 1)


def test_the_floors_need_every_decision_p90_within_a_second_and_http_within_three_times_idle():
    assert _result(4, 0.9, 10, 29).meets()
    assert not _result(3, 0.9, 10, 29).meets()
    assert not _result(4, 1.1, 10, 29).meets()
    assert not _result(4, 0.9, 10, 31).meets()


@pytest.mark.slow
def test_two_robots_stream_into_a_real_server_and_every_instruction_is_answered():
    res = run_serve_bench(ServeBenchOptions(streams=2, instructions=2, http_rps=1, idle_requests=3))
    assert res.expected == 4 and res.answered == 4
    assert all(st["closed"] == "1000" for st in res.streams)
    assert res.machine.cpus and res.idle_infer_ms["n"] == 3


@pytest.mark.slow
def test_every_hostile_request_is_a_4xx_naming_its_limit_against_a_real_server():
    from siftom.bench.hostile import run_hostile_bench

    res = run_hostile_bench()
    requests = [r for r in res.rows if r.path.startswith("/")]  # the other cases: tests/bench/test_hostile_bench.py
    assert requests and all(400 <= r.status < 500 and "allowed" in r.detail for r in requests), res.rows


def test_the_streaming_page_is_generated_from_the_service_results(tmp_path):
    from siftom.bench.blocks import ServiceResults, fill_page, load_service
    from siftom.errors import DatasetError

    res = _result(4, 0.9, 10, 29).to_json()
    res.update(options={"streams": 2, "instructions": 2}, machine={"version": "9.9", "cpus": 2, "processor": "cpu",
                                                                 "load_avg_before": [0.5, 0.5, 0.5]})
    res["idle_infer_ms"], res["load_infer_ms"] = {"n": 3, "p90": 10.0}, {"n": 9, "p90": 29.0}
    (tmp_path / "robots-2.json").write_text(__import__("json").dumps(res))
    page = fill_page("x <!-- gen:service robots --><!-- /gen --> y", [], None, load_service(tmp_path))
    assert "| robots-2 | 2 × 2 | 4/4 |" in page and "2.9×" in page and "siftom 9.9" in page
    with pytest.raises(DatasetError, match="siftom bench hostile --out"):
        fill_page("<!-- gen:service hostile --><!-- /gen -->", [], None, ServiceResults())


@pytest.mark.slow
def test_a_burst_sends_one_recording_to_every_stream_at_once_and_each_is_answered():
    res = run_serve_bench(ServeBenchOptions(streams=3, instructions=1, http_rps=0, idle_requests=1, burst=True))
    assert res.options["burst"] is True and res.expected == 3 and res.answered == 3
    assert all(len(st["delays_s"]) == 1 and st["delays_s"][0] is not None for st in res.streams)
