"""Generated blocks in the docs: the constants table matches the code, results numbers the files."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from siftom.bench.blocks import (
    BLOCK,
    FILL,
    fill_page,
    fill_pages,
    load_service,
    load_trials,
    render,
)
from siftom.bench.constants import (
    CONSTANTS,
    NOT_RECORDED,
    ORIGINS,
    Constant,
    constants_table,
    fmt,
    value_of,
)
from siftom.bench.pages import load_results
from siftom.cli import main
from siftom.errors import DatasetError, SiftomError

ROOT = Path(__file__).resolve().parents[2]
CONSTANTS_PAGE = ROOT / "docs" / "explanation" / "constants.md"


def _pages_with_blocks() -> list[Path]:
    return sorted(p for p in (ROOT / "docs").rglob("*.md") if BLOCK.search(p.read_text(encoding="utf-8")))


def test_every_registered_constant_exists_and_is_documented() -> None:
    refs = [c.ref for c in CONSTANTS]
    assert len(refs) == len(set(refs)), "a constant is registered twice"
    for c in CONSTANTS:
        value_of(c.ref)  # raises when the constant was renamed or removed
        assert c.origin in ORIGINS and c.does and c.chosen_on and c.refit, c.ref
        if c.doc:
            assert (ROOT / "docs" / c.doc.split("#")[0]).is_file(), c.ref


def test_values_are_read_from_the_code() -> None:
    from siftom.assist.decide import DEFAULT_LOSS_AVERSION
    from siftom.inference.model import ModelConfig
    from siftom.likelihood.acoustic import DEFAULT_WHISPER_TEMPERATURE

    assert value_of("siftom.assist.decide.DEFAULT_LOSS_AVERSION") == DEFAULT_LOSS_AVERSION
    assert value_of("siftom.inference.model.ModelConfig.betas") == ModelConfig().betas
    assert value_of("siftom.likelihood.acoustic.DEFAULT_WHISPER_TEMPERATURE") == DEFAULT_WHISPER_TEMPERATURE
    assert fmt((0.5, 1.0)) == "(0.5, 1)" and fmt({2: 0.076}) == "{2: 0.076}"


@pytest.mark.parametrize("ref", ["siftom.likelihood.acoustic.NO_SUCH_CONSTANT", "siftom.no_such_module.X",
                                 "siftom.likelihood.phonetic.PhoneticLikelihood(no_such_param)",
                                 "siftom.inference.model.ModelConfig.no_such_field"])
def test_a_constant_that_no_longer_exists_fails(ref: str) -> None:
    with pytest.raises(SiftomError):
        value_of(ref)
    with pytest.raises(SiftomError):
        constants_table([Constant(ref, "does", NOT_RECORDED, "—")])


def test_the_constants_page_shows_the_codes_values() -> None:
    text = CONSTANTS_PAGE.read_text(encoding="utf-8")
    assert "<!-- gen:constants -->" in text
    for c in CONSTANTS:
        assert f"| `{c.ref}` | `{fmt(value_of(c.ref)).replace('|', chr(92) + '|')}` |" in text, (
            f"{c.ref} differs from the code; run: {FILL}")
    assert "explanation/constants.md" in (ROOT / "mkdocs.yml").read_text(encoding="utf-8")


def test_generated_docs_match_the_committed_results_and_code() -> None:
    """Every <!-- gen: --> block of docs/ is what the generator writes from results/*.json and the code."""
    results = load_results(ROOT / "results")
    trials = load_trials(ROOT / "results" / "trials")
    service = load_service(ROOT / "results" / "service")
    pages = _pages_with_blocks()
    assert CONSTANTS_PAGE in pages and ROOT / "docs" / "benchmark.md" in pages and ROOT / "docs" / "decisions.md" in pages
    assert ROOT / "docs" / "streaming.md" in pages
    for p in pages:
        text = p.read_text(encoding="utf-8")
        assert fill_page(text, results, trials, service) == text, f"{p.relative_to(ROOT)} is stale; run: {FILL}"


def test_the_trials_block_renders_the_rules_and_says_where_it_came_from() -> None:
    trials = load_trials(ROOT / "results" / "trials")
    got = render("trials kitchen-v0", {}, trials)
    assert "| kitchen-v0 | oracle | plan | teammate |" in got and "results/trials/kitchen-v0.jsonl" in got
    assert "siftom " in got and "CPUs" in got
    with pytest.raises(DatasetError, match="no results/trials/nope.jsonl"):
        render("trials nope", {}, trials)


def test_blocks_render_from_a_results_file(tmp_path: Path) -> None:
    results = {r.set: r for r in load_results(ROOT / "results")}
    name = "kitchen-s0"
    acc = results[name].summary["models"]["siftom"]["accuracy"]
    assert render(f"value {name} models/siftom/accuracy pct", results) == f"{100 * acc:.1f} %"
    assert render(f'value {name} "breakdowns/snr/10 dB/siftom/accuracy" pct0', results).endswith(" %")
    table = render(f"table {name} models=literal-asr,siftom", results)
    assert "| siftom | " in table and "speech-only" not in table
    assert "| clean | " in render(f"snr {name} models=siftom wer", results)
    with pytest.raises(DatasetError, match="no results/nope.json"):
        render("table nope", results)
    with pytest.raises(DatasetError, match="no summary/models/nope"):
        render(f"value {name} models/nope/accuracy pct", results)
    # the command rewrites a page in place and leaves the rest alone
    page = tmp_path / "p.md"
    page.write_text(f"before <!-- gen:value {name} models/siftom/accuracy pct -->9 %<!-- /gen --> after\n")
    shutil.copytree(ROOT / "results", tmp_path / "results")
    assert main(["bench", "pages", "--results", str(tmp_path / "results"), "--docs", str(tmp_path / "d"),
                 "--readme", "", "--fill", str(page)]) == 0
    assert page.read_text() == f"before <!-- gen:value {name} models/siftom/accuracy pct -->{100 * acc:.1f} %<!-- /gen --> after\n"
    (tmp_path / "none.md").write_text("no blocks\n")
    with pytest.raises(DatasetError, match="no <!-- gen"):
        fill_pages(tmp_path / "results", [tmp_path / "none.md"])
