"""Bad seeds, types and encodings in dataset builds and sweeps are clear errors, found before any work."""

from __future__ import annotations

from pathlib import Path

import pytest

from siftom.bench.sweep import load_config, plan
from siftom.cli import main
from siftom.errors import DatasetError, SiftomError
from siftom.people.stimuli import BuildOptions


def _toml(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "sweep.toml"
    p.write_text("[dataset]\nspeakers = 1\nscenarios = 1\n[axes]\n" + text + "\n", encoding="utf-8")
    return p


@pytest.mark.parametrize("seed", [-1, 0.5, True])
def test_bad_seeds_are_refused_at_construction(seed):
    with pytest.raises(DatasetError, match="seed must be an integer >= 0"):
        BuildOptions(seed=seed)


def test_dataset_build_with_a_negative_seed_leaves_no_folder(tmp_path, capsys):
    out = tmp_path / "ds"
    assert main(["dataset", "build", "--seed", "-1", "--out", str(out)]) == 2
    assert not out.exists()
    # a failure inside the build (an unknown voice) leaves nothing behind either
    assert main(["dataset", "build", "--voices", "no-such-voice", "--scenarios", "1", "--speakers", "1",
                 "--snr", "none", "--workers", "1", "--out", str(out)]) == 2
    assert "unknown voice" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(("axis", "words"), [
    ("seeds = [0.5]", "[axes] seeds: seed must be an integer, got 0.5"),
    ('scenarios = ["4"]', "[axes] scenarios: scenarios must be an integer, got '4'"),
    ('snrs = [[20, "x"]]', "[axes] snrs: snrs must be a list of numbers"),
])
def test_wrong_types_in_a_sweep_name_the_key(tmp_path, axis, words):
    with pytest.raises(DatasetError) as e:
        load_config(_toml(tmp_path, axis))
    assert words in str(e.value)


def test_a_bad_second_cell_is_found_before_the_first_runs(tmp_path, capsys):
    cfg = _toml(tmp_path, 'domains = ["household-table-v0", "kitchn"]')
    with pytest.raises(SiftomError, match="Did you mean 'kitchen-v0'"):
        plan(load_config(cfg), tmp_path / "out")
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "out")]) == 2
    assert not (tmp_path / "out" / "datasets").exists()


def test_non_utf8_sweep_config_and_actions_file_are_clear_errors(tmp_path, capsys):
    toml = tmp_path / "sweep.toml"
    toml.write_bytes(b'[axes]\nseeds = [0]\n# caf\xe9\n')
    with pytest.raises(DatasetError, match="not UTF-8"):
        load_config(toml)
    actions = tmp_path / "actions.txt"
    actions.write_bytes(b"grab(human, \xff\xfe)\n")
    assert main(["infer", "--scenario", "kitchen-cereal-v0", "--actions", str(actions), "--transcript", "hi"]) == 2
    assert "not UTF-8" in capsys.readouterr().err
