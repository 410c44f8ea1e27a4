"""A dataset read by the neural voice (siftom[tts-neural]): built offline, reproducible."""

from __future__ import annotations

import importlib.util
import json
import socket
from pathlib import Path

import pytest

from siftom.bench.dataset import build_dataset
from siftom.people.stimuli import BuildOptions, load_dataset

pytestmark = pytest.mark.skipif(
    not all(importlib.util.find_spec(m) is not None for m in ("hibari", "onnxruntime")),
    reason='hibari-tts is not installed (pip install "siftom[tts-neural]")')

OPTS = BuildOptions(domain="kitchen-v0", scenarios=2, speakers=1, voices=("hibari-heart",), noises=("pink",),
                    snrs=(10.0,), seed=4)


def test_a_dataset_in_the_neural_voice_builds_offline_and_reproducibly(tmp_path: Path,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: object, **kwargs: object) -> None:
        raise OSError("the network is disabled in this test")

    monkeypatch.setattr(socket.socket, "connect", refuse)
    monkeypatch.setattr(socket, "create_connection", refuse)
    monkeypatch.setenv("HIBARI_HOME", str(tmp_path / "hibari-cache"))
    a, b = tmp_path / "a", tmp_path / "b"
    build_dataset(OPTS, a)
    build_dataset(OPTS, b)
    ds = load_dataset(a)
    assert len(ds.stimuli) == 4 and {s.voice for s in ds.stimuli} == {"hibari-heart"}
    assert all(s.duration_s > 0.5 for s in ds.stimuli)
    assert (a / "manifest.jsonl").read_text() == (b / "manifest.jsonl").read_text()
    for s in ds.stimuli:
        assert (a / s.audio).read_bytes() == (b / s.audio).read_bytes()
    assert json.loads((a / "dataset.json").read_text())["options"]["voices"] == ["hibari-heart"]
    assert not (tmp_path / "hibari-cache").exists()
