"""A fixed set of ``POST /v1/infer`` requests answers exactly what the stored golden file says:
the same action, the same question text and the same posterior numbers (to 1e-9), so work made
cheaper (caches, vectorised loops) cannot change an answer.

Regenerate the golden file only when an answer is meant to change:
``python tests/service/test_answers_identical.py --write``.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

import pytest

GOLDEN = Path(__file__).with_name("golden") / "infer_answers.json"
VOLATILE = {"seconds", "timings", "request_id", "id", "created", "time"}  # differ on every call
TOL = 1e-9

_SCENES = ("kitchen-cereal-v0", "kitchen-v0/2", "household-table-v0/0", "household-table-v0/3",
           "household-table-v0/7")
_TEXTS = ("can you pass me the cereal", "pass me the sugar", "bring me the forks", "could you get the bowls",
          "get me the milk", "get me that", "bring me three spoons", "the bowl no the plate",
          "put the mug on the table", "I need two knives please")
REQUESTS: tuple[dict[str, Any], ...] = (
    *({"scenario": s, "transcript": t} for s in _SCENES for t in _TEXTS),
    {"scenario": "kitchen-cereal-v0", "nbest": [{"text": "pass me the see real", "score": -3.0},
                                                 {"text": "pass me the sugar", "score": -4.0}]},
    {"scenario": "household-table-v0/3", "nbest": [{"text": "bring me the spoons", "score": -2.0},
                                                    {"text": "bring me the forks", "score": -2.5},
                                                    {"text": "bring me the fork", "score": -6.0}]},
    *({"scenario": "kitchen-cereal-v0", "transcript": "pass me the cereal", "decide": d}
      for d in ("map", "expected-benefit", "ask-or-act", "teammate")),
    *({"scenario": "household-table-v0/0", "transcript": "get me those", "decide": d}
      for d in ("map", "expected-benefit", "ask-or-act", "teammate")),
    *({"scenario": "household-table-v0/3", "transcript": "bring me the spoons", "mode": m}
      for m in ("full", "speech-only", "action-only")),
    *({"scenario": "household-table-v0/0", "transcript": "could you get the bowls", "n_actions": n}
      for n in (0, 1, 3, 6)),
    {"scenario": "household-table-v0/7", "n_actions": 4},
    {"scenario": "kitchen-cereal-v0", "transcript": "pass me the cereal", "clarify": {"threshold": 0.99, "cost": 0.01}},
    {"scenario": "household-table-v0/0", "transcript": "bring me the plates", "top": 20},
)


def _stable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _stable(v) for k, v in obj.items() if k not in VOLATILE}
    if isinstance(obj, list):
        return [_stable(v) for v in obj]
    return obj


def answers() -> list[Any]:
    """Every request's answer over HTTP (the app in this process), the volatile fields left out."""
    from fastapi.testclient import TestClient

    from siftom.service.app import create_app

    out: list[Any] = []
    with TestClient(create_app(), base_url="http://localhost") as client:
        for body in REQUESTS:
            r = client.post("/v1/infer", json=body)
            out.append({"request": body, "status": r.status_code, "answer": _stable(r.json())})
    return out


def _diff(got: Any, want: Any, where: str, found: list[str]) -> None:
    if isinstance(want, dict) and isinstance(got, dict):
        if set(got) != set(want):
            found.append(f"{where}: keys {sorted(set(got) ^ set(want))} differ")
        for k in want.keys() & got.keys():
            _diff(got[k], want[k], f"{where}.{k}", found)
    elif isinstance(want, list) and isinstance(got, list):
        if len(got) != len(want):
            found.append(f"{where}: {len(got)} items, golden {len(want)}")
        for i, (g, w) in enumerate(zip(got, want, strict=False)):
            _diff(g, w, f"{where}[{i}]", found)
    elif isinstance(want, float) and isinstance(got, int | float) and not isinstance(got, bool):
        if not math.isclose(got, want, rel_tol=TOL, abs_tol=TOL):
            found.append(f"{where}: {got!r}, golden {want!r}")
    elif got != want:
        found.append(f"{where}: {got!r}, golden {want!r}")


def test_the_answers_are_the_golden_ones():
    want = json.loads(GOLDEN.read_text(encoding="utf-8"))
    got = answers()
    assert len(want) == len(REQUESTS)
    found: list[str] = []
    for g, w in zip(got, want, strict=True):
        assert g["request"] == w["request"]
        _diff(g, w, json.dumps(w["request"]), found)
    assert not found, "\n".join(found[:40])


def test_answering_again_gives_the_same_answers():
    """What a cache keeps from one request does not change the next one's answer."""
    first = answers()
    again = answers()
    found: list[str] = []
    for g, w in zip(again, first, strict=True):
        _diff(g, w, json.dumps(w["request"]), found)
    assert not found, "\n".join(found[:40])


def test_the_golden_answers_act_and_ask():
    """The golden set covers both kinds of answer and more than one action."""
    want = json.loads(GOLDEN.read_text(encoding="utf-8"))
    assert all(w["status"] == 200 for w in want)
    text = json.dumps(want)
    assert '"ask": true' in text and '"ask": false' in text


if __name__ == "__main__":
    if "--write" not in sys.argv:
        pytest.main([__file__, "-q"])
    else:
        GOLDEN.parent.mkdir(exist_ok=True)
        GOLDEN.write_text(json.dumps(answers(), indent=1, sort_keys=True) + "\n", encoding="utf-8")
