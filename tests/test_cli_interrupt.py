"""Ctrl-C while the command line is still loading ends it quietly (no traceback), exit status 130."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time


def test_ctrl_c_in_the_first_tenths_of_a_second_prints_no_traceback():
    interrupted = 0
    for delay in (0.05, 0.1, 0.15, 0.2):
        proc = subprocess.Popen([sys.executable, "-m", "siftom.cli", "--help"], stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE)
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        frames = re.findall(r'File "([^"]+)"', err.decode())
        if "Could not import runpy module" in err.decode() or (
                frames and not any("siftom/cli" in f.replace("\\", "/") for f in frames)):
            continue  # on a loaded machine the signal landed before the command line began to load
            # (Python's start-up, or the package's first import): nothing of siftom's can catch it
        assert "Traceback" not in err.decode(), err.decode()[-600:]
        assert proc.returncode in (0, 130), (delay, proc.returncode)
        interrupted += proc.returncode == 130
    assert interrupted  # at least one signal landed while the commands loaded
