"""A results folder whose lock file is not one siftom wrote, or is a directory, is a one-line
error naming the path and the fix, not a traceback (siftom.bench.runlock)."""

from __future__ import annotations

import json

import pytest

from siftom.bench.runlock import LOCK, LockFileError, RunLock, read_owner
from siftom.errors import SiftomError


def test_a_lock_file_that_is_not_utf8_is_a_one_line_error(tmp_path):
    (tmp_path / LOCK).write_bytes(b'\xff\xfe{"pid": 1}\x80')
    assert read_owner(tmp_path) is None  # unreadable: no owner to name
    with pytest.raises(LockFileError) as exc, RunLock(tmp_path):
        pass
    msg = str(exc.value)
    assert isinstance(exc.value, SiftomError)
    assert str(tmp_path / LOCK) in msg and "not UTF-8" in msg and "delete" in msg and "\n" not in msg
    assert (tmp_path / LOCK).read_bytes().startswith(b"\xff\xfe")  # left as it was
    (tmp_path / LOCK).unlink()
    with RunLock(tmp_path):  # once deleted, the folder locks again
        assert json.loads((tmp_path / LOCK).read_text())["pid"]


def test_a_lock_path_that_is_a_directory_is_a_one_line_error(tmp_path):
    (tmp_path / LOCK).mkdir()
    with pytest.raises(LockFileError) as exc, RunLock(tmp_path):
        pass
    msg = str(exc.value)
    assert str(tmp_path / LOCK) in msg and "is a directory" in msg and "remove it" in msg and "\n" not in msg


def test_a_folder_that_is_a_file_is_a_one_line_error(tmp_path):
    (tmp_path / "results").write_text("not a folder")
    with pytest.raises(LockFileError, match="is a file, not a folder"), RunLock(tmp_path / "results"):
        pass


def test_a_truncated_lock_file_of_a_dead_run_is_still_taken_over(tmp_path):
    (tmp_path / LOCK).write_text('{"pid": 12')
    with RunLock(tmp_path):
        assert json.loads((tmp_path / LOCK).read_text())["pid"]


def test_the_cli_says_it_in_one_line(tmp_path, capsys):
    from siftom.cli import main

    (tmp_path / LOCK).mkdir()
    code = main(["dataset", "mix", str(tmp_path)])
    err = capsys.readouterr().err
    assert code != 0 and "Traceback" not in err
    assert err.count("\n") == 1 and str(tmp_path / LOCK) in err and "is a directory" in err
