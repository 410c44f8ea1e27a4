"""The package stays readable: few long files and functions, typed records instead of loose
dictionaries in public signatures (``python tests/code_sizes.py -v`` lists each one)."""

from __future__ import annotations

from code_sizes import FILE_LINES, FUNCTION_LINES, measure

SIZES = measure()
SERIALISERS = ("to_json", "from_json", "to_dict", "from_dict")


def test_few_files_are_long():
    assert len(SIZES.long_files) <= 4, f"files over {FILE_LINES} lines: {SIZES.long_files}"


def test_few_functions_are_long():
    assert len(SIZES.long_functions) <= 5, f"functions over {FUNCTION_LINES} lines: {SIZES.long_functions}"


def test_public_signatures_pass_typed_records_not_loose_dictionaries():
    """``dict[str, Any]`` belongs at the JSON boundary: a record's ``to_json``/``from_json``."""
    loose = [w for w in SIZES.loose_signatures if w.rsplit(".", 1)[-1].rsplit(":", 1)[-1] not in SERIALISERS]
    assert len(loose) <= 40, f"{len(loose)} public signatures with dict[str, Any]: {loose}"
