"""The package root: the one-call API on first use, and a light import."""

import subprocess
import sys

import pytest


def test_the_root_exposes_the_one_call_api():
    import siftom
    import siftom.api

    assert siftom.listen is siftom.api.listen
    assert siftom.infer_scenario is siftom.api.infer_scenario
    with pytest.raises(AttributeError, match="no attribute 'lisen'"):
        siftom.lisen  # noqa: B018


def test_import_siftom_loads_no_model_code():
    code = "import sys, siftom; print('siftom.api' in sys.modules, 'numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False"]
