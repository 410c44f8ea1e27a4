"""An N-best list of many equal-score hypotheses (each weighs less than the floor of what counts
as heard) is read as heard, not dropped: it used to crash ``siftom.infer`` with an IndexError."""

from __future__ import annotations

import json

from click.testing import CliRunner

import siftom
from siftom.cli import root
from siftom.likelihood.base import Hypothesis
from siftom.likelihood.nearness import heard_texts

EQUAL = [{"text": "bring me the milk", "score": -1.0}] * 21
DISTINCT = [{"text": f"bring me the milk {w}", "score": -1.0} for w in
            ("now", "please", "soon", "here", "there", "today", "quickly", "again", "first", "then", "too",
             "later", "slowly", "back", "over", "up", "down", "in", "out", "off", "on")]


def test_equal_hypotheses_are_all_heard():
    hyps = [Hypothesis(h["text"], h["score"]) for h in DISTINCT]
    assert heard_texts(hyps) == [h["text"] for h in DISTINCT]


def test_infer_reads_twenty_one_equal_hypotheses():
    for nbest in (EQUAL, DISTINCT):
        ans = siftom.infer("kitchen-v0/0", heard=[(h["text"], h["score"]) for h in nbest], likelihood="phonetic")
        assert str(ans.command) == "fetch(milk)"


def test_cli_infer_reads_twenty_one_equal_hypotheses(tmp_path):
    path = tmp_path / "nbest.json"
    path.write_text(json.dumps(EQUAL))
    out = CliRunner().invoke(root, ["infer", "--scenario", "kitchen-v0/0", "--nbest", str(path), "--json"])
    assert out.exit_code == 0, out.output
    assert json.loads(out.output)["command"] == "fetch(milk)"
