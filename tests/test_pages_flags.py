"""The commands the pages name state the product's defaults, refuse contradictory flags in one line,
create the folder they write to and keep committed results unless --force is given."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import click
import pytest

from siftom.cli import main, root
from siftom.cli.outputs import is_committed


def _run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str]:
    try:
        code = main(list(args))
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    cap = capsys.readouterr()
    return code, cap.out + cap.err


def _one_error_line(out: str) -> str:
    assert "Traceback" not in out, out
    errors = [ln for ln in out.splitlines() if ln.lower().startswith("error:")]
    assert len(errors) == 1, out
    return errors[0]


def _command(path: str) -> click.Command:
    cmd: click.Command = root
    for word in path.split():
        assert isinstance(cmd, click.Group)
        cmd = cmd.commands[word]
    return cmd


def _all_commands(cmd: click.Command, path: str = "siftom") -> list[tuple[str, click.Command]]:
    out = [(path, cmd)]
    if isinstance(cmd, click.Group):
        for name, sub in sorted(cmd.commands.items()):
            out += _all_commands(sub, f"{path} {name}")
    return out


def test_bench_trials_defaults_to_the_products_rule() -> None:
    opt = next(p for p in _command("bench trials").params if p.name == "rules")
    from siftom.settings import Settings

    assert opt.default == Settings.load().infer.decide == "teammate"


def test_no_help_names_two_defaults() -> None:
    """An option's help that marks ``NAME (default)`` agrees with the default it shows."""
    wrong = []
    for path, cmd in _all_commands(root):
        for p in cmd.params:
            if not isinstance(p, click.Option) or not p.help:
                continue
            marked = re.findall(r"([\w.+-]+) \(default\)", p.help)
            shown = p.default if p.show_default and isinstance(p.default, str) else None
            if marked and shown is not None and marked != [shown]:
                wrong.append(f"{path} {p.opts[0]}: help marks {marked} (default), the option's default is {shown}")
    assert not wrong, "\n".join(wrong)


def test_eval_help_states_one_engine_default(capsys: pytest.CaptureFixture[str]) -> None:
    code, out = _run(capsys, "eval", "--help")
    assert code == 0
    text = " ".join(out.split())
    assert "pocketsphinx (default)" not in text
    assert "[default: pocketsphinx-vocab]" in text


@pytest.mark.parametrize("flags", [("--transcript", "pass me the cereal", "--audio", "say.wav"),
                                   ("--transcript", "pass me the cereal", "--nbest", "nbest.json")])
def test_infer_refuses_two_things_heard(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                        flags: tuple[str, ...]) -> None:
    (tmp_path / "nbest.json").write_text(json.dumps([{"text": "pass me the cereal", "score": 0}]))
    args = [a if not a.endswith((".wav", ".json")) else str(tmp_path / a) for a in flags]
    code, out = _run(capsys, "infer", "--scenario", "kitchen-cereal-v0", *args)
    assert code != 0
    line = _one_error_line(out)
    assert flags[0] in line and flags[2] in line, line


def test_bench_trials_creates_the_folder_it_writes(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # the page's command, from a folder that has no results/trials/
    code, out = _run(capsys, "bench", "trials", "--seeds", "1", "--scenario", "kitchen-cereal-v0",
                     "--max-requests", "1", "--no-progress", "--out", "results/trials/kitchen-v0.jsonl")
    assert code == 0, out
    rows = [json.loads(ln) for ln in (tmp_path / "results/trials/kitchen-v0.jsonl").read_text().splitlines()]
    assert rows and {r["rule"] for r in rows} == {"teammate"}


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_bench_trials_keeps_committed_results(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    repo = tmp_path / "clone"
    (repo / "results" / "trials").mkdir(parents=True)
    committed = repo / "results" / "trials" / "kitchen-v0.jsonl"
    committed.write_text('{"committed": true}\n')
    subprocess.run(["git", "init", "-q"], cwd=repo, check=True)
    subprocess.run(["git", "add", "results"], cwd=repo, check=True)
    assert is_committed(committed) and not is_committed(repo / "results" / "other.jsonl")
    monkeypatch.chdir(repo)
    args = ["bench", "trials", "--seeds", "1", "--scenario", "kitchen-cereal-v0", "--max-requests", "1",
            "--no-progress", "--out", "results/trials/kitchen-v0.jsonl"]
    code, out = _run(capsys, *args)
    assert code != 0
    line = _one_error_line(out)
    assert "committed" in line and "--force" in line, line
    assert committed.read_text() == '{"committed": true}\n'
    code, out = _run(capsys, *args, "--force")
    assert code == 0, out
    assert '"committed"' not in committed.read_text()
