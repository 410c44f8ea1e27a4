"""`make demo`'s main job (README, quick start): the Figure 2 story from synthetic speech in noise."""

import json
import shutil

import pytest

from siftom.cli import main

pytestmark = pytest.mark.skipif(shutil.which("flite") is None, reason="needs flite (make sysdeps)")


def test_demo_recovers_the_cereal_from_noisy_speech(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    post = json.loads((tmp_path / "posterior.json").read_text())
    # seed 0: the README quotes this run (the words alone point elsewhere; with the actions, cereal)
    assert post["command"] == "fetch(cereal)"
    assert post["commands"][0]["prob"] > post["commands"][1]["prob"]
    assert "SIFToM chooses fetch(cereal)" in out
    assert (tmp_path / "demo.png").stat().st_size > 10_000
