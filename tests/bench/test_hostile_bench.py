"""``siftom bench hostile`` beyond oversized worlds: the stream-slot, stream-line, header and ROS
cases each say what they must get, and a case this machine cannot run is marked so rather than
counted as met or failed."""

from __future__ import annotations

import pytest

from siftom.bench.blocks import ServiceResults, _service_block
from siftom.bench.hostile import NOT_RUN, HostileResult, HostileRow, run_hostile_bench
from siftom.bench.machine import Machine


def _row(status: int, expect: int = 0, seconds: float = 0.1, within_s: float = 1.0,
         health: float | None = 5.0) -> HostileRow:
    return HostileRow("x", "WS /v1/sessions/{id}/listen", status, seconds, "said", health, 3, expect, within_s)


def test_a_row_meets_its_own_expectation() -> None:
    assert _row(422).meets() and not _row(200).meets()  # default: any 4xx
    assert _row(4408, expect=4408, seconds=10.0, within_s=12.0).meets()
    assert not _row(1013, expect=4408, seconds=10.0, within_s=12.0).meets()
    assert not _row(4408, expect=4408, seconds=13.0, within_s=12.0).meets()
    assert not _row(422, health=150.0).meets() and _row(200, expect=200, health=None).meets()
    assert not _row(NOT_RUN).ran and _row(0).ran


def test_rows_round_trip_and_old_files_still_read() -> None:
    row = _row(4408, expect=4408, within_s=12.0)
    assert HostileRow.from_json(row.to_json()) == row
    old = {"input": "3,000-place world", "path": "/v1/sessions", "status": 422, "seconds": 0.01, "detail": "d",
           "healthz_max_ms": 3.0, "healthz_n": 2}
    assert HostileRow.from_json(old).expect == 0 and HostileRow.from_json(old).meets()


def test_the_page_table_says_what_each_must_get() -> None:
    rows = (_row(4408, expect=4408, seconds=10.0, within_s=12.0), _row(NOT_RUN), _row(200, expect=200, health=None))
    table = _service_block("hostile", ServiceResults((), HostileResult(Machine.here(), rows, True)))
    assert "| x | 4408 within 12 s | 4408 | 10.0 | 5.0 |" in table
    assert "| x | 4xx within 1 s | not run |" in table and "| x | 200 within 1 s | 200 | 0.1 | – |" in table


@pytest.mark.slow
def test_the_slot_stream_header_and_ros_cases_against_a_real_server() -> None:
    res = run_hostile_bench()
    by = {r.input: r for r in res.rows}
    assert by["8 streams trickling 2 bytes every 2 s"].status == 4408
    assert by["8 streams trickling 2 bytes every 2 s"].seconds < 12
    assert by["a robot's stream once they are closed"].status == 1000
    assert by["a stream action line of 5,000 characters"].status == 422
    assert by["a 1 MB stream text message"].status == 1009
    assert by["30 wrong tokens, a fresh X-Forwarded-For each"].status == 429
    assert by["the right token, a fresh X-Forwarded-For, while throttled"].status == 429
    ros = [r for r in res.rows if r.path.startswith("ROS")]
    assert all(r.status == r.expect for r in ros if r.ran), ros
