"""`recorded` names the household noise recordings shipped with siftom, wherever it is installed."""

from __future__ import annotations

import numpy as np
import pytest

from siftom.bench.dataset import noise_categories, resolve_noises
from siftom.errors import DatasetError, SiftomError
from siftom.people.stimuli import BuildOptions, noise_folder
from siftom.speech.noise import RECORDED_NOISE_DIR, FolderNoise, get_noise


def test_recorded_is_the_packaged_folder() -> None:
    assert noise_folder("recorded") == RECORDED_NOISE_DIR
    cats = noise_categories("recorded")
    assert {"babble", "dishes", "running_water"} <= set(cats)


def test_build_options_take_recorded_and_resolve_its_categories() -> None:
    opts = BuildOptions(noise_dir="recorded", noises=("babble", "dishes"))
    names = [n for n, _ in resolve_noises(opts)]
    assert names == ["babble", "dishes"]
    assert opts.to_json()["noise_dir"] == "recorded"  # the stored command stays portable
    with pytest.raises(DatasetError, match="neither a category"):
        resolve_noises(BuildOptions(noise_dir="recorded", noises=("thunder",)))


def test_get_noise_recorded_category() -> None:
    src = get_noise("recorded:babble")
    assert isinstance(src, FolderNoise) and all(p.name.startswith("babble") for p in src.files)
    x = src.sample(1600, np.random.default_rng(3))
    assert x.shape == (1600,) and np.abs(x).max() > 0
    with pytest.raises(SiftomError, match="no .wav files matching"):
        get_noise("recorded:thunder")
