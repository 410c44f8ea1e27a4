"""Results as data: a tiny plan runs end to end; pages are a deterministic function of the files."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest

import siftom
from siftom.bench.machine import Machine
from siftom.bench.pages import END, PAGES, REPRODUCE, START, voice_table, write_pages
from siftom.bench.reproduce import SetData, SetResult, load_plan
from siftom.cli import main
from siftom.errors import DatasetError

ROOT = Path(__file__).resolve().parents[2]
TINY = """
[[set]]
name = "tiny"
title = "tiny kitchen"
domain = "kitchen-v0"
seed = 5
scenarios = 2
speakers = 1
snr = []
models = ["literal-asr", "siftom"]
"""


def test_the_shipped_plan_loads() -> None:
    plan = load_plan(ROOT / "results" / "plan.toml")
    assert {s.domain for s in plan.sets} == {"household-table-v0", "kitchen-v0"}
    assert all(s.noise_dir == "recorded" for s in plan.sets)


def test_a_bad_plan_names_the_problem(tmp_path: Path) -> None:
    p = tmp_path / "plan.toml"
    p.write_text('[[set]]\nname = "x"\ndomain = "kitchen-v0"\nmodels = ["siftom"]\nvoice = "flite-slt"\n')
    with pytest.raises(DatasetError, match="unknown key.*voice"):
        load_plan(p)


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
def test_reproduce_a_tiny_plan_then_pages(tmp_path: Path) -> None:
    plan = tmp_path / "plan.toml"
    plan.write_text(TINY, encoding="utf-8")
    readme = tmp_path / "README.md"
    readme.write_text(f"# x\n\n{START}\nold\n{END}\n\nafter\n", encoding="utf-8")
    out, docs = tmp_path / "results", tmp_path / "docs"
    rc = main(["bench", "reproduce", "--plan", str(plan), "--out", str(out), "--workers", "1",
               "--docs", str(docs), "--readme", str(readme)])
    assert rc == 0
    data = json.loads((out / "tiny.json").read_text())
    assert data["siftom"] == siftom.__version__
    assert data["dataset"]["stimuli"] == 2 and len(data["dataset"]["fingerprint"]) == 16
    assert data["machine"]["cpu_count"] >= 1
    assert set(data["summary"]["models"]) == {"literal-asr", "siftom"}
    page = (docs / "tiny.md").read_text()
    assert f"siftom {siftom.__version__}" in page and REPRODUCE in page and PAGES in page
    assert "## Accuracy per voice" in page and data["summary"]["breakdowns"]["voice"]
    for v in data["summary"]["breakdowns"]["voice"]:
        assert f"| {v} | 2 |" in page
    acc = data["summary"]["models"]["siftom"]["accuracy"]
    assert f"| siftom | {100 * acc:.1f} %" in page
    text = readme.read_text()
    assert "old" not in text and "tiny kitchen" in text and text.endswith("after\n")
    # regenerating from the same files gives the same bytes
    before = {p.name: p.read_bytes() for p in docs.iterdir()}
    assert main(["bench", "pages", "--results", str(out), "--docs", str(docs), "--readme", str(readme)]) == 0
    assert {p.name: p.read_bytes() for p in docs.iterdir()} == before
    # other options (or other code) than the rows already there: the set is evaluated again
    plan.write_text(TINY.replace('["literal-asr", "siftom"]', '["siftom"]'), encoding="utf-8")
    assert main(["bench", "reproduce", "--plan", str(plan), "--out", str(out), "--workers", "1", "--docs", ""]) == 0
    assert set(json.loads((out / "tiny.json").read_text())["summary"]["models"]) == {"siftom"}


def test_committed_results_pages_match_the_committed_results(tmp_path: Path) -> None:
    """docs/results/ is what the generator makes from results/*.json (no hand-edited numbers)."""
    docs = tmp_path / "docs"
    readme = tmp_path / "README.md"
    shutil.copy(ROOT / "README.md", readme)
    write_pages(ROOT / "results", docs, readme)
    for p in sorted(docs.iterdir()):
        assert p.read_text() == (ROOT / "docs" / "results" / p.name).read_text(), p.name
    assert readme.read_text() == (ROOT / "README.md").read_text()


def test_the_voice_table_has_a_row_per_voice_and_a_column_per_model() -> None:
    cell = {"accuracy": 0.5, "speedup": 0.1, "n": 4}
    result = _set_result(("siftom eval D --out R --models siftom,literal-asr",),
                         {"models": {"siftom": {}, "literal-asr": {}},
                          "breakdowns": {"voice": {"flite-slt": {"siftom": cell, "literal-asr": {**cell, "accuracy": 0.25}},
                                                   "hibari-heart": {"siftom": {**cell, "accuracy": 1.0}}}},
                          "asr_wer": {"voice": {"flite-slt": 0.2}}})
    lines = voice_table(result).splitlines()
    assert lines[0] == "| voice | n | siftom | literal-asr | ASR WER |"
    assert lines[2] == "| flite-slt | 4 | 50.0 % | 25.0 % | 20.0 % |"
    assert lines[3] == "| hibari-heart | 4 | 100.0 % |  | – |"
    assert voice_table(_set_result((), {"models": {}})) == ""


def _set_result(commands: tuple[str, ...], summary: dict[str, Any]) -> SetResult:
    return SetResult("s", "s", "0", "?", SetData("f", 1, "kitchen-v0", 0), Machine(), commands, (0.0, 0.0), summary)
