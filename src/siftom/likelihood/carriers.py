"""Bring-your-own phrasings: carrier sentences read from a text file.

A carrier file is UTF-8 text with one carrier per line, each containing ``{np}`` where the
noun phrase goes ("um could you get {np} for me"); blank lines and lines starting with ``#``
are skipped. :func:`sample_with_carriers` draws a carrier uniformly and a noun phrase from the
same distribution as :func:`siftom.likelihood.phrasing.sample_phrasing` ("the forks", "three
forks", "an onion", "the cutlery"), so only the words around the object change.

Two sets ship with siftom (``siftom/data/phrasings``), written without looking at the phrasing
grammar: ``free-v0`` (65 carriers, the development set) and ``free-heldout-v0`` (31 carriers,
kept for validation only). Pass their names wherever a carrier file is accepted.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from siftom.errors import DatasetError
from siftom.likelihood.lexicon import Lexicon, default_lexicon
from siftom.likelihood.phrasing import _noun_phrases
from siftom.world.commands import RobotCommand

PLACEHOLDER = "{np}"
SHIPPED_DIR = Path(__file__).resolve().parent.parent / "data" / "phrasings"


def shipped_carrier_sets() -> tuple[str, ...]:
    """Names of the carrier files inside the package (``free-v0``, ``free-heldout-v0``)."""
    return tuple(sorted(p.stem for p in SHIPPED_DIR.glob("*.txt")))


def resolve_carrier_file(spec: str | Path) -> Path:
    """A carrier file path, or the name of a shipped set (``free-v0``) -> its path."""
    p = Path(spec)
    if p.is_file():
        return p
    if str(spec) in shipped_carrier_sets():
        return SHIPPED_DIR / f"{spec}.txt"
    raise DatasetError(
        f"phrasings file {str(spec)!r} does not exist; give a UTF-8 text file with one carrier "
        f"per line containing {{np}}, or a shipped set: {', '.join(shipped_carrier_sets())}"
    )


def parse_carriers(text: str, where: str = "phrasings file") -> tuple[str, ...]:
    """Carriers from file text: one per line, ``#`` comments and blank lines skipped.

    Raises:
        DatasetError: no line contains ``{np}``, a line lacks it, or a line has other braces.
    """
    out: list[str] = []
    for i, raw in enumerate(text.splitlines(), start=1):
        line = " ".join(raw.split())
        if not line or line.startswith("#"):
            continue
        if line.count(PLACEHOLDER) != 1:
            raise DatasetError(
                f"{where}, line {i}: {raw.strip()!r} must contain {PLACEHOLDER} exactly once "
                f"(where the noun phrase goes, e.g. 'could you get {PLACEHOLDER} for me')"
            )
        if "{" in line.replace(PLACEHOLDER, "") or "}" in line.replace(PLACEHOLDER, ""):
            raise DatasetError(f"{where}, line {i}: only {PLACEHOLDER} may be in braces: {raw.strip()!r}")
        out.append(line.lower())
    if not out:
        raise DatasetError(
            f"{where} has no carrier line with {PLACEHOLDER}; write one carrier per line, e.g. "
            f"'could you get {PLACEHOLDER} for me' ('#' starts a comment)"
        )
    return tuple(dict.fromkeys(out))


@lru_cache(maxsize=32)
def _load(path: str) -> tuple[str, ...]:
    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise DatasetError(f"phrasings file {path!r} is not UTF-8 text; save it as UTF-8") from None
    except OSError as e:
        raise DatasetError(f"cannot read phrasings file {path!r}: {e}") from None
    return parse_carriers(text, where=f"phrasings file {path!r}")


def load_carriers(spec: str | Path) -> tuple[str, ...]:
    """Read a carrier file (or a shipped set by name); see :func:`parse_carriers`."""
    return _load(str(resolve_carrier_file(spec)))


def sample_with_carriers(
    command: RobotCommand,
    lexicon: Lexicon | None,
    rng: np.random.Generator,
    carriers: tuple[str, ...],
) -> str:
    """A carrier drawn uniformly around a noun phrase drawn as in ``sample_phrasing``."""
    if not carriers:
        raise DatasetError("no carriers given; load them with load_carriers(FILE)")
    nps = _noun_phrases(command, lexicon or default_lexicon())
    w = np.array([n[2] for n in nps], dtype=float)
    k = int(rng.integers(len(carriers)))
    j = int(rng.choice(len(nps), p=w / w.sum()))
    return " ".join(carriers[k].replace(PLACEHOLDER, nps[j][0]).split())
