"""The check behind every output a page states (tests/support/page_outputs.py): what it accepts, what
it refuses, and that its failure names the page, the line and what the code printed."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from support.page_outputs import (
    Expected,
    console_expectations,
    mismatch,
    printed_by_line,
    python_expectations,
    run_python_source,
)


@pytest.mark.parametrize(("stated", "printed"), [
    ("act fetch(tomato)", "act fetch(tomato)"),
    ("((fetch(tomato), 0.949), ...)", "((fetch(tomato), 0.9494), (fetch(potato), 0.051))"),
    ("P = 0.95", "P = 0.9449"),                        # one unit of the last digit written
    ('{"command": "fetch(sugar)", "prob": 1.00, ...}', '{"command":"fetch(sugar)","prob":0.9999979,"x":1}'),
    ("first\n...\nlast", "first\nmany\nlines\nlast"),
    ("siftom 0.2.0 kitchen-cereal-v0", "siftom 0.2.0 kitchen-cereal-v0"),  # versions and ids are words
])
def test_what_matches(stated: str, printed: str) -> None:
    assert mismatch(Expected("page.md:1", stated), printed) is None


@pytest.mark.parametrize(("stated", "printed"), [
    ("act fetch(tomato)", "act fetch(potato)"),
    ("act fetch(tomato)", "act fetch(tomato) and more"),   # the whole output, unless ... says so
    ("P = 0.95", "P = 0.93"),
    ("3 requests", "4 requests"),                          # integers exactly
    ("siftom 0.2.0", "siftom 0.3.0"),
])
def test_what_does_not_match(stated: str, printed: str) -> None:
    assert mismatch(Expected("page.md:1", stated), printed) is not None


def test_an_explicit_tolerance_widens_the_numbers_only() -> None:
    assert mismatch(Expected("p.md:1", "P = 0.95", tol=0.05), "P = 0.91") is None
    assert mismatch(Expected("p.md:1", "P = 0.95", tol=0.05), "P = 0.89") is not None
    assert mismatch(Expected("p.md:1", "fetch(cereal) 0.95", tol=0.05), "fetch(honey) 0.95") is not None


def test_the_failure_names_the_page_line_and_what_was_printed() -> None:
    why = mismatch(Expected("docs/understanding.md:14", "{'p_request': 0.98}"), "{'p_request': 0.897}")
    assert why is not None
    assert why.startswith("docs/understanding.md:14") and "0.98" in why and "0.897" in why and "±0.01" in why


def test_python_outputs_are_read_per_line(tmp_path: Path) -> None:
    code = 'x = 2\nprint("a", x)   # -> a 2\nfor k in range(2):\n    print(k)   # -> 0 1\nprint("b")  # a remark\n'
    said, bad = python_expectations(code, "page.md", 10, None)
    assert {k: e.text for k, e in said.items()} == {2: "a 2", 4: "0 1"}
    assert said[2].where == "page.md:11"
    assert len(bad) == 1 and bad[0].startswith("page.md:14") and "# ->" in bad[0]
    trace = tmp_path / "trace.json"
    res = subprocess.run([sys.executable, "-c", run_python_source(code, str(trace)), str(trace)], cwd=tmp_path,
                         capture_output=True, text=True, timeout=60, check=True)
    assert res.stdout == "a 2\n0\n1\nb\n"
    printed = printed_by_line(json.loads(trace.read_text()))
    assert printed == {2: "a 2", 4: "0\n1", 5: "b"}
    assert all(mismatch(said[k], printed[k]) is None for k in said)


def test_console_outputs_follow_their_command() -> None:
    code = "$ siftom one \\\n    --flag\nline one\n...\n$ siftom two\n$ siftom three\nthree\n"
    got = console_expectations(code, "page.md", 5, None)
    assert [c for c, _e in got] == ["siftom one  --flag", "siftom two", "siftom three"]
    assert got[0][1] is not None and got[0][1].text == "line one\n..." and got[0][1].where == "page.md:5"
    assert got[1][1] is None
    assert got[2][1] is not None and got[2][1].text == "three"


def test_a_bare_expression_is_refused() -> None:
    _said, bad = python_expectations("res = 1\nres, res + 1   # (1, 2)\n", "page.md", 3, None)
    assert len(bad) == 1 and bad[0].startswith("page.md:4: a bare expression prints nothing")
