"""One default N-best size: the service asks the recogniser for as many hypotheses as the library
and the evaluator, so an uploaded clip is heard as ``siftom.listen`` hears it."""

from __future__ import annotations

import inspect

from siftom.api import listen, transcribe_for
from siftom.bench.evaluate import EvalOptions
from siftom.cli import root
from siftom.inference.listen import hear
from siftom.options import InferOptions
from siftom.service.schemas import AudioFields
from siftom.service.session_schemas import AudioInstructionFields
from siftom.speech.asr import DEFAULT_NBEST


def _default(fn, name: str = "nbest"):
    return inspect.signature(fn).parameters[name].default


def test_library_evaluator_and_service_share_one_default():
    assert DEFAULT_NBEST == 10  # the library's size since session 1; docs/speech.md "N-best size"
    # the doors leave it out (None): the setting infer.nbest, whose default is the library's
    assert _default(listen) is None and AudioFields(scenario="kitchen-cereal-v0").asr_nbest is None
    assert AudioInstructionFields().asr_nbest is None and InferOptions().nbest == DEFAULT_NBEST
    assert _default(transcribe_for) == _default(hear) == DEFAULT_NBEST
    assert EvalOptions().nbest == DEFAULT_NBEST  # recipes/calibrate.py too: tests/test_recipes.py


def test_documented_defaults_match(client):
    spec = client.get("/openapi.json").json()
    schemas = spec["components"]["schemas"]
    for form in ("AudioInferForm", "AudioInstructionForm"):  # left out: the server's setting infer.nbest
        assert "default" not in schemas[form]["properties"]["asr_nbest"]
    assert client.get("/healthz").json()["settings"]["infer.nbest"] == DEFAULT_NBEST
    nbest = next(p for p in root.commands["eval"].params if p.name == "nbest")
    assert nbest.default == DEFAULT_NBEST and nbest.show_default  # `siftom eval --help` says 10
