"""``siftom dataset mix`` on a private collection (``siftom collect``: 0600 voices and manifest in
0700 folders) keeps it private under any umask: the noisy copies of a voice, the rewritten
manifest and dataset.json are 0600, never 0644; a shared dataset keeps its own modes."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np
import pytest

from siftom.bench.mix import MixOptions, mix_dataset
from siftom.people.collect import Collection, CollectOptions
from siftom.speech.audio import wav_bytes


def _modes(root: Path) -> dict[str, int]:
    return {str(p.relative_to(root)): stat.S_IMODE(p.stat().st_mode) for p in sorted(root.rglob("*"))}


@pytest.fixture()
def open_umask():
    old = os.umask(0o022)
    yield
    os.umask(old)


def _voice() -> np.ndarray:
    t = np.arange(16000) / 16000
    return (0.3 * np.sin(2 * np.pi * 220 * t) * (0.6 + 0.4 * np.sin(2 * np.pi * 3 * t))).astype(np.float32)


@pytest.mark.skipif(os.name != "posix", reason="file modes are POSIX")
def test_mix_keeps_a_private_collection_private(tmp_path: Path, open_umask: None) -> None:
    root = tmp_path / "collected"
    c = Collection(root, CollectOptions(domain="kitchen-v0", scenarios=1))
    c.agree("p1")
    c.save("p1", 0, wav_bytes(_voice()), "bring me the milk")
    assert _modes(root)["manifest.jsonl"] == 0o600
    mix_dataset(root, MixOptions(snrs=(10.0, 5.0)))
    modes = _modes(root)
    copies = [k for k in modes if k.startswith("audio/") and "clean" not in k]
    assert len(copies) == 2
    for name, mode in modes.items():
        assert mode == (0o700 if (root / name).is_dir() else 0o600), (name, oct(mode))


@pytest.mark.skipif(os.name != "posix", reason="file modes are POSIX")
def test_mix_keeps_a_shared_dataset_shared(tmp_path: Path, open_umask: None) -> None:
    root = tmp_path / "shared"
    c = Collection(root, CollectOptions(domain="kitchen-v0", scenarios=1))
    c.agree("p1")
    c.save("p1", 0, wav_bytes(_voice()), "bring me the milk")
    for p in root.rglob("*"):
        os.chmod(p, 0o755 if p.is_dir() else 0o644)
    os.chmod(root, 0o755)
    mix_dataset(root, MixOptions(snrs=(10.0,)))
    assert set(_modes(root).values()) <= {0o644, 0o755}
