"""One typed call through the service: the router's record reaches the runtime, the audio
workers and the observer, and the answer over HTTP is the observer's own."""

from __future__ import annotations

import ast
import pickle
from pathlib import Path
from typing import Any

import pytest

import siftom
from siftom.assist.clarify import ClarifyPolicy
from siftom.bench.loadtest import DEFAULT_BODIES
from siftom.observation import Instruction
from siftom.service.infer_reply import InferCall

SERVICE = Path(siftom.__file__).parent / "service"
VOLATILE = {"seconds", "timings"}  # wall-clock times, different on every call


def _stable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _stable(v) for k, v in obj.items() if k not in VOLATILE}
    if isinstance(obj, list):
        return [_stable(v) for v in obj]
    return obj


def _params(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    a = fn.args
    n = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + bool(a.vararg) + bool(a.kwarg)
    return n - bool(a.args and a.args[0].arg in ("self", "cls"))


def test_no_function_of_the_service_takes_more_than_eight_parameters():
    long = [f"{p.name}:{fn.name} ({_params(fn)})" for p in sorted(SERVICE.glob("*.py"))
            for fn in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
            if isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef) and _params(fn) > 8]
    assert not long, long


def test_one_class_is_named_infer_options():
    src = Path(siftom.__file__).parent
    named = [str(p.relative_to(src)) for p in src.rglob("*.py")
             if any(isinstance(n, ast.ClassDef) and n.name == "InferOptions" for n in ast.walk(ast.parse(p.read_text())))]
    assert named == ["options.py"], named


def test_the_call_record_is_frozen_and_travels_to_a_worker_process():
    call = InferCall("kitchen-cereal-v0", audio=b"RIFF", likelihood="phonetic", asr_nbest=3,
                     policy=ClarifyPolicy(0.8, 0.1))
    with pytest.raises(AttributeError):
        call.scenario = "kitchen-v0/2"  # type: ignore[misc]
    assert pickle.loads(pickle.dumps(call)) == call
    heard = call.with_(audio=None, instruction=Instruction.from_text("pass me the cereal"))
    assert heard.audio is None and heard.asr_nbest == 3 and call.audio == b"RIFF"


@pytest.mark.parametrize("body", DEFAULT_BODIES, ids=lambda b: f"{b['scenario']}:{b.get('transcript', 'nbest')}")
def test_the_load_tests_answers_over_http_are_the_observers_own(client, body):
    """The service adds what was heard, the question and the plan, and changes nothing of the answer."""
    r = client.post("/v1/infer", json=body)
    assert r.status_code == 200, r.text
    got = r.json()
    heard = body.get("transcript") or [(h["text"], h["score"]) for h in body["nbest"]]
    want = siftom.infer(body["scenario"], heard=heard).to_json(top=10)
    assert _stable({k: got[k] for k in want}) == _stable(want)
    assert got["scenario"] == body["scenario"] and set(got) - set(want) == {"scenario", "nbest", "clarification", "plan"}
