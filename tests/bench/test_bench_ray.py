"""The Ray backend gives the local backend's results, byte for byte (slow: Ray takes seconds to start).

Skipped when ray is not installed (``pip install "siftom[ray]"``; ``make test-slow`` installs it).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from siftom.bench.dataset import build_dataset
from siftom.bench.evaluate import RESULTS
from siftom.people.stimuli import BuildOptions

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed"),
]

SMALL = BuildOptions(scenarios=2, speakers=2, voices=("flite-slt", "flite-awb"), noises=("pink",),
                     snrs=(10.0,), seed=11)
MODELS = "literal-asr,speech-only,siftom"


def test_ray_backend_builds_and_evaluates_exactly_like_the_local_one(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("ray", reason="ray is not installed: pip install \"siftom[ray]\"")
    from siftom.bench.backends import RayBackend
    from siftom.cli import main

    build_dataset(SMALL, tmp_path / "ds-local", workers=1)
    be = RayBackend(workers=2)  # a local 2-CPU Ray instance, started here
    try:
        assert be.started and be.workers == 2
        build_dataset(SMALL, tmp_path / "ds-ray", backend=be)
    finally:
        be.shutdown()
    for name in ("manifest.jsonl", "dataset.json"):
        assert (tmp_path / "ds-ray" / name).read_bytes() == (tmp_path / "ds-local" / name).read_bytes(), name
    wavs = sorted(p.name for p in (tmp_path / "ds-local" / "audio").iterdir())
    assert wavs == sorted(p.name for p in (tmp_path / "ds-ray" / "audio").iterdir())
    for w in wavs:
        assert (tmp_path / "ds-ray" / "audio" / w).read_bytes() == (tmp_path / "ds-local" / "audio" / w).read_bytes()

    ds = str(tmp_path / "ds-local")
    assert main(["eval", "--dataset", ds, "--out", str(tmp_path / "local"), "--models", MODELS,
                 "--workers", "1", "--json"]) == 0
    assert main(["eval", "--dataset", ds, "--out", str(tmp_path / "ray"), "--models", MODELS,
                 "--backend", "ray", "--workers", "2", "--json"]) == 0
    capsys.readouterr()
    local, ray_ = tmp_path / "local", tmp_path / "ray"
    assert (ray_ / RESULTS).read_bytes() == (local / RESULTS).read_bytes()
    assert (ray_ / "summary.json").read_bytes() == (local / "summary.json").read_bytes()
    assert json.loads((ray_ / "run.json").read_text())["history"][-1]["backend"] == "ray"
    assert len((ray_ / RESULTS).read_text().splitlines()) == 8
