"""Bring-your-own phrasings: carrier sentences read from a text file.

A carrier file is UTF-8 text with one carrier per line, each containing ``{np}`` where the
noun phrase goes ("um could you get {np} for me"); blank lines and lines starting with ``#``
are skipped. :func:`sample_with_carriers` draws a carrier uniformly and takes the noun phrase
of the phrasing :func:`siftom.likelihood.phrasing.sample_phrasing` draws ("the forks", "three
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
from siftom.likelihood.phrasing import CARRIERS, _noun_phrases, sample_phrasing
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


def noun_phrase_of(text: str, command: RobotCommand, lexicon: Lexicon | None = None) -> str:
    """The noun phrase inside a grammar phrasing of ``command`` ("bring me three forks" ->
    "three forks"; "get me the rest of the forks" -> "the forks")."""
    lex = lexicon or default_lexicon()
    for template, _w in (c for cs in CARRIERS.values() for c in cs):
        for np_text, bare_plural, _nw, _cat in _noun_phrases(command, lex):
            if "{pl}" in template:
                if bare_plural and template.format(pl=bare_plural) == text:
                    return f"the {bare_plural}"
            elif template.format(np=np_text) == text:
                return np_text
    raise DatasetError(f"{text!r} is not a grammar phrasing of {command}")


def sample_with_carriers(
    command: RobotCommand,
    lexicon: Lexicon | None,
    rng: np.random.Generator,
    carriers: tuple[str, ...],
    carrier_rng: np.random.Generator | None = None,
) -> str:
    """A carrier drawn uniformly around a noun phrase drawn as in ``sample_phrasing``.

    The noun phrase is that of ``sample_phrasing(command, lexicon, rng)``, so a dataset built
    with the same seed says the same noun phrases ("three forks", "the cutlery") with the
    grammar's carriers or with the file's: a paired comparison. The carrier is drawn from
    ``carrier_rng`` (default: ``rng``, after the noun phrase).
    """
    if not carriers:
        raise DatasetError("no carriers given; load them with load_carriers(FILE)")
    lex = lexicon or default_lexicon()
    noun_phrase = noun_phrase_of(sample_phrasing(command, lex, rng), command, lex)
    k = int((carrier_rng or rng).integers(len(carriers)))
    return " ".join(carriers[k].replace(PLACEHOLDER, noun_phrase).split())
