"""Sweeps: the cross product of options, resumable, one combined table and figure."""

from __future__ import annotations

import json
import os
import shutil
import signal
from pathlib import Path

import pytest

from siftom.bench.sweep import load_config, plan
from siftom.errors import SiftomError

CONFIG = """
[dataset]
scenarios = 1
speakers = 1
voices = ["flite-slt"]
noises = ["pink"]
snrs = [10]

[eval]
models = ["literal-asr", "siftom"]

[axes]
seeds = [0, 1]
nbest = [1, 5]
"""


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "sweep.toml"
    p.write_text(text)
    return p


def test_plan_is_the_cross_product_and_shares_datasets(tmp_path: Path) -> None:
    cells = plan(load_config(_write(tmp_path, CONFIG)), tmp_path / "out")
    assert [c.values for c in cells] == [{"seeds": 0, "nbest": 1}, {"seeds": 0, "nbest": 5},
                                         {"seeds": 1, "nbest": 1}, {"seeds": 1, "nbest": 5}]
    assert [(c.build.seed, c.options.nbest) for c in cells] == [(0, 1), (0, 5), (1, 1), (1, 5)]
    assert cells[0].options.seed == 0 and cells[0].options.models == ("literal-asr", "siftom")
    assert len({c.dataset_dir for c in cells}) == 2  # one dataset per seed, evaluated twice
    assert len({c.run_dir for c in cells}) == 4


@pytest.mark.parametrize(("text", "message"), [
    ("[axes]\nvoltage = [1, 2]\n", "sweep axis 'voltage' is not an option"),
    ("[axes]\nseeds = 3\n", "must be a non-empty list"),
    ("[dataset]\nspeakerz = 2\n[axes]\nseeds = [0]\n", r"\[dataset\] has unknown option\(s\) speakerz"),
    ("[axes]\nmodels = [\"sifton\"]\n", "unknown model 'sifton'"),
    ("[axes\n", "not valid TOML"),
])
def test_bad_configs_say_what_to_fix(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(SiftomError, match=message):
        plan(load_config(_write(tmp_path, text)), tmp_path / "out")


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
def test_sweep_runs_every_cell_and_resumes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from siftom.bench.backends import LocalBackend
    from siftom.bench.runlock import RunInterrupted
    from siftom.bench.sweep import run_sweep
    from siftom.cli import main

    cfg = _write(tmp_path, CONFIG.replace("seeds = [0, 1]", "seeds = [0]"))
    out = tmp_path / "out"

    def terminate_at_second_cell(i: int, total: int, cell: object) -> None:
        if i == 1:
            os.kill(os.getpid(), signal.SIGTERM)

    with pytest.raises(RunInterrupted):
        run_sweep(cfg, out, LocalBackend(1), progress=terminate_at_second_cell)
    assert not (out / "table.md").exists()
    assert main(["sweep", str(cfg), "--out", str(out), "--workers", "1", "--json"]) == 0  # resumes
    result = json.loads(capsys.readouterr().out)
    history = [json.loads((Path(c["results"]) / "run.json").read_text())["history"] for c in result["cells"]]
    assert [[h["evaluated"] for h in hs] for hs in history] == [[2, 0], [2]]  # the first cell was not redone
    assert [c["values"] for c in result["cells"]] == [{"seeds": 0, "nbest": 1}, {"seeds": 0, "nbest": 5}]
    for c in result["cells"]:
        assert set(c["models"]) == {"literal-asr", "siftom"} and c["n_stimuli"] == 2
    for name in ("sweep.json", "table.md", "table.csv", "sweep.png"):
        assert (out / name).is_file(), name
    table = (out / "table.md").read_text()
    assert table.count("| siftom |") == 2 and "accuracy % [95 % CI]" in table
    csv_rows = (out / "table.csv").read_text().splitlines()
    assert csv_rows[0].startswith("seeds,nbest,model,n,accuracy,accuracy_lo,accuracy_hi,speedup")
    assert len(csv_rows) == 1 + 2 * 2

    first = {c["results"]: (Path(c["results"]) / "results.jsonl").read_bytes() for c in result["cells"]}
    assert main(["sweep", str(cfg), "--out", str(out), "--workers", "1", "--json"]) == 0  # resumes: nothing to do
    again = json.loads(capsys.readouterr().out)
    assert again["cells"] == result["cells"]
    for c in again["cells"]:
        assert (Path(c["results"]) / "results.jsonl").read_bytes() == first[c["results"]]
        assert json.loads((Path(c["results"]) / "run.json").read_text())["history"][-1]["evaluated"] == 0
