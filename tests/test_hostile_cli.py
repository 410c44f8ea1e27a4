"""Command-line inputs a hostile or careless caller gives: each is a one-line error naming the
problem and the fix (no traceback, nothing written elsewhere than asked), and a signal while the
server starts stops it."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner

from siftom.cli import root

MILK = ["infer", "--scenario", "kitchen-v0/0", "--transcript", "bring me the milk"]


def _lines(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if ln.strip()]


def test_png_is_written_exactly_where_asked(tmp_path: Path) -> None:
    out = CliRunner().invoke(root, [*MILK, "--png", str(tmp_path / "picture")])
    assert out.exit_code == 0, out.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["picture"]  # no ".png" added
    assert (tmp_path / "picture").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_png_in_a_missing_folder_is_refused_before_any_work(tmp_path: Path) -> None:
    target = tmp_path / "not" / "here" / "pic.png"
    out = CliRunner().invoke(root, [*MILK, "--png", str(target)])
    assert out.exit_code == 2
    assert "does not exist" in out.output and "--png" in out.output and "Traceback" not in out.output
    assert not (tmp_path / "not").exists()  # no folder made silently


@pytest.mark.parametrize("target", ["/dev/null", "folder"])
def test_png_over_a_device_or_a_folder_is_refused(tmp_path: Path, target: str) -> None:
    path = Path(target) if target.startswith("/") else tmp_path
    out = CliRunner().invoke(root, [*MILK, "--png", str(path)])
    assert out.exit_code == 2, out.output
    assert "not a regular file" in out.output or "is a folder" in out.output
    assert list(tmp_path.iterdir()) == [] and not Path("/dev/null.png").exists()


def test_png_with_a_scene_file_is_refused_not_ignored(tmp_path: Path) -> None:
    scene = Path(__file__).parent / "fixtures" / "scene_three_rooms.json"
    out = CliRunner().invoke(root, ["infer", "--scene", str(scene), "--transcript", "x", "--png",
                                    str(tmp_path / "p.png")])
    assert out.exit_code == 2 and "--scenario" in out.output


def test_say_to_a_full_device_is_one_line() -> None:
    if not Path("/dev/full").exists():
        pytest.skip("no /dev/full on this system")
    p = subprocess.run([sys.executable, "-m", "siftom.cli", "say", "hello", "-o", "/dev/full"],
                       capture_output=True, text=True, timeout=120)
    lines = _lines(p.stdout + p.stderr)
    assert p.returncode == 1 and len(lines) == 1, lines
    assert "/dev/full" in lines[0] and "not a regular file" in lines[0] and "give -o" in lines[0]


@pytest.mark.parametrize("host", ["999.1.1.1", "no-such-host.invalid", "192.0.2.1"])
def test_serve_on_a_host_that_is_not_here_is_refused_before_a_token(host: str) -> None:
    p = subprocess.run([sys.executable, "-m", "siftom.cli", "serve", "--host", host, "--port", "8765"],
                       capture_output=True, text=True, timeout=60)
    lines = _lines(p.stdout + p.stderr)
    assert p.returncode == 2 and len(lines) == 1, (p.returncode, lines)
    assert f"--host {host!r}" in lines[0] and "127.0.0.1" in lines[0] and "0.0.0.0" in lines[0]
    assert "Bearer" not in p.stderr and "token" not in p.stderr  # no fresh token printed for nothing


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_sigint_while_the_server_starts_stops_it_even_when_started_ignoring_it(tmp_path: Path) -> None:
    """A background job of a shell script starts with SIGINT ignored; a SIGINT that arrives while
    ``siftom serve`` loads its modules (here: sent by the process itself at that point) stops it,
    as one does once it serves; it used to be dropped and the server ran on."""
    code = textwrap.dedent(f"""
        import os, signal, sys
        import siftom.cli.service as service
        need = service._need_serve_extra
        def need_then_interrupted():
            os.kill(os.getpid(), signal.SIGINT)
            need()
        service._need_serve_extra = need_then_interrupted
        from siftom.cli import main
        sys.exit(main(["serve", "--port", "{_free_port()}", "--data-dir", {str(tmp_path / "data")!r}]))
    """)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                       preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))  # noqa: PLW1509
    assert p.returncode == 130, p.stderr[-2000:]
    assert "Uvicorn running" not in p.stderr and "Traceback" not in p.stderr
    assert not (tmp_path / "data" / ".siftom.lock").exists() or os.name != "posix"
