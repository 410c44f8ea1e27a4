"""`siftom serve --data-dir D` refuses a folder another live server holds."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from siftom.cli import main

ROOT = Path(__file__).parents[2]
HOLD = ("import sys, time; from siftom.cli.service import claim_data_dir; claim_data_dir(sys.argv[1]); "
        "print('held', flush=True); time.sleep(60)")


def test_a_second_server_on_one_data_dir_is_refused_and_a_dead_ones_folder_is_not(tmp_path, capsys):
    data = tmp_path / "data"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    first = subprocess.Popen([sys.executable, "-c", HOLD, str(data)], env=env, stdout=subprocess.PIPE, text=True)
    try:
        assert first.stdout.readline().strip() == "held"
        assert main(["serve", "--port", "1", "--data-dir", str(data)]) == 2
        err = capsys.readouterr().err
        assert f"siftom pid {first.pid}" in err and "another --data-dir" in err, err
    finally:
        first.kill()
        first.wait(timeout=10)
    # the holder died without cleaning up: the folder is free again
    from siftom.cli.service import claim_data_dir

    claim_data_dir(str(data)).release()
