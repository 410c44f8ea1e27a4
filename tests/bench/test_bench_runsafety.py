"""Results that cannot be corrupted: one writer per folder, signals, duplicates, provenance.

Fast tests (default suite) drive the library in this process; the CLI-level interruption tests
(a real ``siftom eval`` process stopped with SIGINT / SIGTERM) are marked slow.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from siftom.bench.dataset import build_dataset
from siftom.bench.evaluate import RESULTS, EvalOptions, evaluate, load_results
from siftom.bench.report import write_report
from siftom.bench.runlock import LOCK, RunInterrupted, RunLock, RunLockedError
from siftom.errors import DatasetError, UnknownNameError
from siftom.people.stimuli import BuildOptions, load_dataset

pytestmark = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")

TINY = BuildOptions(scenarios=2, speakers=1, voices=("flite-slt",), noises=("pink",), snrs=(10.0,), seed=5)
FAST = EvalOptions(models=("literal-asr", "siftom"))
SRC = str(Path(__file__).resolve().parents[2] / "src")


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("tiny") / "ds"
    build_dataset(TINY, out)
    return out


@pytest.fixture(scope="module")
def reference(tiny: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An uninterrupted run in this process."""
    out = tmp_path_factory.mktemp("ref") / "r"
    evaluate(tiny, out, FAST)
    write_report(out, figures=False)
    return out


def _holder(folder: Path) -> subprocess.Popen[str]:
    """Another process that takes the folder's lock and keeps it until killed."""
    code = ("import sys, time; from siftom.bench.runlock import RunLock; "
            f"RunLock({str(folder)!r}).acquire(); print('held', flush=True); time.sleep(60)")
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, env=_env())
    assert p.stdout is not None and p.stdout.readline().strip() == "held"
    return p


def test_second_writer_is_refused_and_a_dead_owners_lock_is_taken_over(tiny: Path, tmp_path: Path) -> None:
    out = tmp_path / "r"
    p = _holder(out)
    try:
        with pytest.raises(RunLockedError, match=rf"being written by siftom pid {p.pid} on host '{socket.gethostname()}'"):
            evaluate(tiny, out, FAST)
        assert not (out / RESULTS).exists()
    finally:
        p.kill()  # SIGKILL: no cleanup, the lock file stays behind
        p.wait()
    assert json.loads((out / LOCK).read_text())["pid"] == p.pid
    with RunLock(out) as lock:
        assert lock.took_over is not None and lock.took_over.pid == p.pid
        assert json.loads((out / LOCK).read_text())["pid"] == os.getpid()
    assert not (out / LOCK).exists()


def test_sigterm_stops_the_run_and_the_resumed_run_matches_an_uninterrupted_one(
        tiny: Path, reference: Path, tmp_path: Path) -> None:
    out = tmp_path / "r"

    def terminate_after_two(done: int, total: int) -> None:
        if done >= 2:
            os.kill(os.getpid(), signal.SIGTERM)

    with pytest.raises(RunInterrupted) as info:
        evaluate(tiny, out, FAST, progress=terminate_after_two)
    assert info.value.signum == signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # handlers restored
    assert len((out / RESULTS).read_text().splitlines()) == 2
    assert not (out / LOCK).exists()
    run = evaluate(tiny, out, FAST, workers=2)  # resumed on a process pool
    assert (run.resumed, run.evaluated) == (2, 2)
    write_report(out, figures=False)
    assert (out / RESULTS).read_bytes() == (reference / RESULTS).read_bytes()
    assert (out / "summary.json").read_bytes() == (reference / "summary.json").read_bytes()


def test_results_record_code_and_options_and_keep_timings_apart(reference: Path) -> None:
    rows = load_results(reference)
    prov = rows[0]["provenance"]
    assert prov["options"]["models"] == list(FAST.models)
    assert set(prov["code"]) == {"siftom", "source_sha1"}
    assert all("seconds" not in m for r in rows for m in r["models"].values())
    timings = [json.loads(x) for x in (reference / "timings.jsonl").read_text().splitlines()]
    assert sorted(t["id"] for t in timings) == sorted(r["id"] for r in rows)


def test_a_duplicated_stimulus_is_an_error_naming_it(tiny: Path, reference: Path, tmp_path: Path) -> None:
    out = tmp_path / "r"
    shutil.copytree(reference, out)
    lines = (out / RESULTS).read_text().splitlines(keepends=True)
    (out / RESULTS).write_text("".join(lines) + lines[1])
    dup = json.loads(lines[1])["id"]
    with pytest.raises(DatasetError, match=rf"stimulus '{dup}' appears twice \(lines 2 and {len(lines) + 1}\)"):
        write_report(out, figures=False)
    with pytest.raises(DatasetError, match=f"'{dup}' appears twice"):
        evaluate(tiny, out, FAST)


@pytest.mark.parametrize("change", ["options", "code"])
def test_resuming_with_other_options_or_code_refuses(tiny: Path, reference: Path, tmp_path: Path, change: str) -> None:
    out = tmp_path / "r"
    shutil.copytree(reference, out)
    (out / "run.json").unlink()  # the rows alone must tell
    rows = [json.loads(x) for x in (out / RESULTS).read_text().splitlines()[:2]]
    if change == "options":
        for r in rows:
            r["provenance"]["options"]["nbest"] = 3
        expect = rf"option nbest \(3 then, {FAST.nbest} now\)"
    else:
        for r in rows:
            r["provenance"]["code"]["source_sha1"] = "0000000000000000"
        expect = "the code"
    (out / RESULTS).write_text("".join(json.dumps(r) + "\n" for r in rows))
    with pytest.raises(DatasetError, match=expect):
        evaluate(tiny, out, FAST)
    assert len((out / RESULTS).read_text().splitlines()) == 2  # nothing was added


# -- a real `siftom eval` process, stopped by a signal (slow) ----------------------------------

MEDIUM = BuildOptions(scenarios=4, speakers=2, voices=("flite-slt", "flite-awb"), noises=("pink",),
                      snrs=(10.0,), seed=7)
CLI_MODELS = "literal-asr,siftom"


def _eval_cmd(ds: Path, out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "siftom.cli", "eval", "--dataset", str(ds), "--out", str(out),
            "--models", CLI_MODELS, "--json", *extra]


@pytest.fixture(scope="module")
def medium(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A 16-stimulus dataset and its uninterrupted results (CLI, 2 workers)."""
    root = tmp_path_factory.mktemp("medium")
    build_dataset(MEDIUM, root / "ds", workers=2)
    subprocess.run(_eval_cmd(root / "ds", root / "ref", "--workers", "2"), check=True, env=_env(),
                   capture_output=True)
    return root / "ds", root / "ref"


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["local", "ray"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_stops_siftom_eval_within_5_s_and_the_folder_resumes(
        medium: tuple[Path, Path], tmp_path: Path, sig: int, backend: str) -> None:
    from siftom.cli import main

    if backend == "ray":
        pytest.importorskip("ray", reason="ray is not installed: pip install \"siftom[ray]\"")
    ds, ref = medium
    out = tmp_path / "r"
    total = len(load_dataset(ds).stimuli)
    p = subprocess.Popen(_eval_cmd(ds, out, "--workers", "2", "--backend", backend), env=_env(),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    t_end = time.time() + 120
    while time.time() < t_end and p.poll() is None:
        if (out / RESULTS).is_file() and (out / RESULTS).read_text().count("\n") >= 1:
            break
        time.sleep(0.05)
    assert main(["eval", "--dataset", str(ds), "--out", str(out), "--models", CLI_MODELS]) == 2  # refused
    t0 = time.time()
    os.kill(p.pid, sig)
    _, err = p.communicate(timeout=30)
    assert time.time() - t0 < 5.0
    assert p.returncode == 128 + sig, err
    assert "run the same command again to resume" in err
    while True:  # every worker (and a Ray instance started for the run) is gone within 5 s
        left = subprocess.run(["pgrep", "-s", str(p.pid)], capture_output=True, text=True).stdout.split()
        if not left or time.time() - t0 > 5.0:
            break
        time.sleep(0.1)
    assert left == [], f"processes left running: {left}"
    n = (out / RESULTS).read_text().count("\n")
    assert 1 <= n < total, f"not interrupted midway ({n} of {total} done)"
    subprocess.run(_eval_cmd(ds, out, "--workers", "2"), check=True, env=_env(), capture_output=True)
    assert (out / RESULTS).read_text().count("\n") == total
    assert (out / RESULTS).read_bytes() == (ref / RESULTS).read_bytes()
    assert (out / "summary.json").read_bytes() == (ref / "summary.json").read_bytes()


def test_backend_flags_are_checked_before_anything_starts(tiny: Path, tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    from siftom.bench.backends import make_backend
    from siftom.cli import main

    out = tmp_path / "r"
    assert main(["eval", "--dataset", str(tiny), "--out", str(out), "--ray-address", "auto"]) == 2
    assert "--ray-address needs --backend ray" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(UnknownNameError, match="unknown backend .dask."):
        make_backend("dask")
