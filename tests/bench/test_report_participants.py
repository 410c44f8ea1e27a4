"""A study's report breaks collected recordings down by participant (accuracy, questions and speedup
with CIs), beside the per-voice table where every participant is ``human``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from siftom.bench.report import participants, write_report
from siftom.cli import main


def _row(sid: str, speaker: str, voice: str, correct: bool, asked: bool, speedup: float) -> dict[str, Any]:
    trial = {"command": "fetch(cereal)" if correct else "fetch(honey)", "correct": correct, "helpful": False,
             "speedup": speedup, "prob": 0.9, "asked": asked}
    return {"id": sid, "scenario": "kitchen-cereal-v0", "speaker": speaker, "voice": voice, "noise": None,
            "snr_db": None, "models": {"siftom": trial}}


ROWS = [_row("a1", "p1", "human", True, False, 0.4), _row("a2", "p1", "human", True, True, 0.2),
        _row("b1", "p2", "human", False, False, -0.3), _row("b2", "p2", "human", True, False, 0.1),
        _row("s1", "s1", "flite-slt", True, False, 0.5)]


def test_each_participant_has_accuracy_questions_and_speedup_with_cis() -> None:
    parts = participants(ROWS, seed=0, n_boot=200)
    assert list(parts) == ["p1", "p2"]  # the synthetic voice's speaker is not a participant
    p1, p2 = parts["p1"]["siftom"], parts["p2"]["siftom"]
    assert (p1["n"], p1["accuracy"], p1["questions_per_trial"], p1["speedup"]) == (2, 1.0, 0.5, 0.3)
    assert (p2["accuracy"], p2["questions_per_trial"], p2["speedup"]) == (0.5, 0.0, -0.1)
    assert p2["accuracy_ci"][0] <= 0.5 <= p2["accuracy_ci"][1] and p2["accuracy_ci"][0] < p2["accuracy_ci"][1]
    assert p1["questions_ci"][0] <= 0.5 <= p1["questions_ci"][1]
    assert p2["speedup_ci"][0] <= -0.1 <= p2["speedup_ci"][1]


def test_the_report_has_the_participant_table_beside_the_voice_table(tmp_path: Path) -> None:
    out = tmp_path / "results"
    out.mkdir()
    (out / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in ROWS))
    summary = write_report(out, figures=False)
    assert set(summary["participants"]) == {"p1", "p2"}
    assert set(summary["breakdowns"]["voice"]) == {"human", "flite-slt"}
    report = (out / "report.md").read_text()
    assert report.index("## By voice") < report.index("## By participant")
    section = report.split("## By participant", 1)[1]
    assert "| p1 | siftom | 100.0 %" in section and "| p2 | siftom | 50.0 %" in section
    assert "| 0.50 [" in section  # p1's questions per trial, with its CI


def test_a_synthetic_set_has_no_participant_section(tmp_path: Path) -> None:
    out = tmp_path / "results"
    out.mkdir()
    (out / "results.jsonl").write_text(json.dumps(ROWS[-1]) + "\n")
    assert write_report(out, figures=False)["participants"] == {}
    assert "## By participant" not in (out / "report.md").read_text()


def test_siftom_report_prints_the_participant_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "results"
    out.mkdir()
    (out / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in ROWS))
    assert main(["report", str(out), "--no-figures"]) in (0, None)
    printed = capsys.readouterr().out
    assert "by participant:" in printed and "| p1 | siftom | 100.0 %" in printed
