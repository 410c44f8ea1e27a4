"""The decision rules the pages name exist, and the outputs they quote carry the rule that runs
by default (the ``decide`` setting)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from siftom.assist.decide import RULES
from siftom.options import InferOptions

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", ROOT / "docs" / "streaming.md", ROOT / "docs" / "llm.md",
         *sorted((ROOT / "docs" / "tutorials").glob("*.md"))]
QUOTED = re.compile(r'(?:\(rule |, rule |"rule": ")([a-z][a-z-]+)')


@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
def test_the_decision_rules_a_page_names_exist(page: Path) -> None:
    text = page.read_text(encoding="utf-8")
    for m in re.finditer(r'(?:\brule |"rule": "|decide="|--decide )([a-z][a-z-]+)', text):
        name = m.group(1)
        if name in {"that", "the", "is", "ran", "and", "of", "for", "a", "says", "its"}:
            continue
        assert name in RULES, f"{page.name}: {m.group(0)!r} names no decision rule ({', '.join(RULES)})"


def test_the_listen_outputs_of_the_streaming_page_carry_the_default_rule() -> None:
    text = (ROOT / "docs" / "streaming.md").read_text(encoding="utf-8")
    quoted = QUOTED.findall(text)
    assert quoted, "docs/streaming.md quotes siftom listen's output"
    assert set(quoted) == {InferOptions().decide}, quoted
    assert not re.search(r"--scenario[^.\n]*ignor", text), "siftom listen --scenario observes the actions"
