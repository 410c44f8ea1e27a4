"""``siftom listen`` as a user runs it: a file played as a microphone (two instructions, actions
from a file or from stdin while listening), and the errors for a missing microphone or file."""

from __future__ import annotations

import io
import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from support.streaming import say, silence

ROOT = Path(__file__).resolve().parents[1]
WORLD = ROOT / "docs" / "examples" / "salad" / "world.json"


def siftom(*args: str, stdin: str | None = None, capsys=None, monkeypatch=None) -> tuple[int, str, str]:
    """``siftom ARGS`` in this process (the recogniser cache is shared between tests)."""
    from siftom.cli import main

    if stdin is not None:
        monkeypatch.setattr(sys, "stdin", io.StringIO(stdin))
    capsys.readouterr()
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def two_instructions(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("listen")
    a = say("can you get me the tomato", d / "a.wav")
    b = say("pass me the cheese", d / "b.wav")
    path = d / "two.wav"
    sf.write(path, np.concatenate([silence(0.4), a, silence(1.0), b]), 16000, subtype="PCM_16")
    return path


def test_a_file_played_as_a_microphone_gives_one_line_per_utterance(two_instructions, tmp_path, capsys):
    acts = tmp_path / "actions.txt"
    acts.write_text("# seen before listening\n[Walk] <fridge> (1)\n[Open] <fridge> (1)\n")
    code, out, err = siftom("listen", "--wav", str(two_instructions), "--scene", str(WORLD), "--actions", str(acts),
                            "--events", "--json", capsys=capsys)
    assert code == 0, err
    lines = [json.loads(ln) for ln in out.splitlines()]
    assert [ln["event"] for ln in lines if ln["event"] != "decision"] == ["speech_started", "speech_ended"] * 2
    decisions = [ln for ln in lines if ln["event"] == "decision"]
    assert [d["heard"] for d in decisions] == ["can you get me the tomato", "pass me the cheese"]
    assert [d["command"] for d in decisions] == ["fetch(tomato)", "fetch(cheese)"]
    for d in decisions:
        assert d["action"] == "act" and d["n_actions"] == 2 and 0 < d["prob"] <= 1
        assert set(d["timings"]) >= {"asr", "answer", "wait"} and "after_speech_s" not in d["timings"]
        assert len(d["nbest"]) <= 3 and d["start_s"] < d["end_s"]
        assert d["recogniser"] == "pocketsphinx-vocab" and d["rule"] == "teammate" and d["likelihood"]


def test_actions_read_from_stdin_while_listening(two_instructions, capsys, monkeypatch):
    code, out, err = siftom("listen", "--wav", str(two_instructions), "--scene", str(WORLD), "--actions", "-",
                            "--json", stdin="[Walk] <fridge> (1)\nnot an action\n[Open] <fridge> (1)\n",
                            capsys=capsys, monkeypatch=monkeypatch)
    assert code == 0, err
    notes = [json.loads(ln) for ln in err.splitlines() if ln.startswith("{")]
    assert [n["event"] for n in notes] == ["actions", "error", "actions"]
    assert "cannot parse action 'not an action'" in notes[1]["detail"]
    assert len([ln for ln in out.splitlines() if '"decision"' in ln]) == 2


def test_listen_prints_one_readable_line_per_utterance_by_default(two_instructions, capsys, monkeypatch):
    code, out, err = siftom("listen", "--wav", str(two_instructions), "--scene", str(WORLD), "--actions", "-",
                            stdin="[Walk] <fridge> (1)\nnot an action\n[Open] <fridge> (1)\n",
                            capsys=capsys, monkeypatch=monkeypatch)
    assert code == 0, err
    lines = out.splitlines()
    assert len(lines) == 2 and not any(ln.lstrip().startswith("{") for ln in out.splitlines())
    for line, heard, command in zip(lines, ("can you get me the tomato", "pass me the cheese"),
                                    ("fetch(tomato)", "fetch(cheese)"), strict=True):
        # when, what was heard and by whom, what decided, what the robot does
        assert re.match(r"^ *\d+\.\d\d-\d+\.\d\d s  ", line), line
        assert f'heard "{heard}" (pocketsphinx-vocab, likelihood ' in line, line
        assert ", rule teammate)" in line and f"->  the robot carries out {command} (P = " in line, line
    notes = err.splitlines()
    assert notes[0] == "observed walk(human, fridge) (1 action so far)", notes
    assert notes[1].startswith("error: line 'not an action': cannot parse action 'not an action'"), notes
    assert notes[2].startswith("observed ") and not any(n.startswith("{") for n in notes)


def test_missing_microphone_or_file_is_a_clear_error(capsys):
    code, _, err = siftom("listen", "--mic", "--device", "999", "--scene", str(WORLD), capsys=capsys)
    assert code == 2 and err.startswith("error: ")
    assert "PortAudio" in err or "no usable input device 999" in err, err
    code, _, err = siftom("listen", "--wav", "nope.wav", "--scenario", "kitchen-cereal-v0", capsys=capsys)
    assert code == 2 and "does not exist" in err
    code, _, err = siftom("listen", "--scenario", "kitchen-cereal-v0", capsys=capsys)
    assert code == 2 and "--mic or --wav" in err
