"""The product (README, docs/, src/) speaks to users: no work history, issue numbers or machine paths."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HISTORY = re.compile(r"session[ -]?[0-9]|/work/|another engineer|issue #?[0-9]", re.IGNORECASE)
TEXT_SUFFIXES = {".md", ".py", ".toml", ".json", ".txt", ".html", ".js", ".css", ".yml", ".yaml", ".tsv"}


def _product_files() -> list[Path]:
    files = [ROOT / "README.md", ROOT / "mkdocs.yml"]
    for top in ("docs", "src"):
        files += [p for p in sorted((ROOT / top).rglob("*")) if p.is_file() and p.suffix in TEXT_SUFFIXES]
    return [p for p in files if p.is_file()]


def find_history(text: str) -> list[str]:
    """Each line of ``text`` that mentions work history, an issue number or a machine path."""
    return [line.strip() for line in text.splitlines() if HISTORY.search(line)]


def test_the_pattern_catches_history() -> None:
    sample = "Measured in Session 5.\nthe session-4 code\nsee issue #12\nissue 9 changed it\n/work/datasets/x\nanother engineer's run\nfine"
    assert len(find_history(sample)) == 6


def test_no_history_in_readme_docs_or_sources() -> None:
    hits = []
    for path in _product_files():
        for line in find_history(path.read_text(encoding="utf-8", errors="replace")):
            hits.append(f"{path.relative_to(ROOT)}: {line[:120]}")
    assert not hits, "work history in the product (move it to CHANGELOG.md):\n" + "\n".join(hits)


def test_readme_is_short() -> None:
    assert len((ROOT / "README.md").read_text(encoding="utf-8").splitlines()) <= 200
