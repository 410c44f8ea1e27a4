"""MkDocs hook: the command-line reference shows no default for an option that has none.

The reference page (``reference/cli.md``) is written by the ``mkdocs-click`` extension, which puts
``option.default`` in the table's Default column. Since click 8.3 an option declared without a default
holds click's ``UNSET`` sentinel there, so ``--help``, ``--version`` and every plain flag showed
``Sentinel.UNSET``. This hook wraps the extension's row formatter: such an option gets an empty
Default cell (or *required* where it is required); options with a real default are left as they are.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

_WRAPPED = "_siftom_no_unset_default"


def has_no_default(option: click.Option) -> bool:
    """True when the option was declared without a default (click's ``UNSET`` sentinel, or ``None``)."""
    default = option.default
    if default is None:
        return True
    unset = getattr(getattr(click, "_utils", None), "UNSET", None)
    return (unset is not None and default is unset) or type(default).__name__ == "Sentinel"


def _without_unset(format_row: Callable[[click.Option], str]) -> Callable[[click.Option], str]:
    def format_row_no_unset(option: click.Option) -> str:
        if not has_no_default(option):
            return format_row(option)
        row = format_row(option)  # "| names | type | description | default |": replace the last cell
        head, sep, _ = row.rstrip().removesuffix("|").rstrip().rpartition(" | ")
        if not sep:  # not the table layout this hook knows: leave the row as the extension wrote it
            return row
        cell = "*required*" if option.required else ""
        return f"{head} | {cell} |"

    setattr(format_row_no_unset, _WRAPPED, True)
    return format_row_no_unset


def on_config(config: Any) -> Any:
    """Wrap mkdocs-click's table-row formatter once per build (idempotent under ``mkdocs serve``)."""
    from mkdocs_click import _docs

    current = getattr(_docs, "_format_table_option_row", None)
    if current is not None and not getattr(current, _WRAPPED, False):
        setattr(_docs, "_format_table_option_row", _without_unset(current))  # noqa: B010
    return config
