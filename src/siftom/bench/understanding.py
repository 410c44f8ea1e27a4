"""The understanding benchmark: does the robot get what people say to it right?

Items are short utterances to the robot, generated from templates over worlds of both domains
(``kitchen-v0``, ``household-table-v0``) drawn with ``--world-seed`` (``select_scenarios``), each
with what a listener should understand (:class:`Expect`): whether anybody asked the robot for
something, the objects asked for with the count said, or the object named that is not here.

Kinds (:data:`KINDS`): ``plain`` requests, ``misheard`` (a word that sounds like an object of the
world but is not its name: "the serial"), ``correction`` ("not the X, the Y": Y), ``negation``
("don't bring the X": no request), ``context`` ("the X for the Y": X), ``compound`` ("the X and
the Y": both), ``count`` ("four bowls", household), ``any_object`` (an object the person's goal
does not need), ``absent`` (a known object that is not in the world: nothing done, the reason
names it) and ``nonrequest`` (thanks, room talk, questions to nobody).

Three sets of wordings, written apart: ``dev``, ``heldout`` and ``unseen`` share no template, so
a model built on the dev wordings can be checked on wordings it never saw (and on other worlds:
world seed 201 for dev, 202 for held-out, 203 for unseen). A fourth set, ``blind``, is written by
hand (``data/understanding/blind.jsonl``, :func:`load_items`) by someone who never ran the model:
repairs with no edit term ("the jam the honey"), objects outside the lexicon ("the stapler"),
counts beyond supply ("three pens" where two are), modifiers ("the cereal with a bit of sugar")
and replies to an open question (:data:`EXTRA_KINDS`), in registered scenarios and in the worlds of
``data/understanding/worlds``. Conditions: ``text`` (the words themselves), ``clean`` (spoken by a
TTS voice), ``10dB`` and ``5dB`` (the same clip in recorded household noise at that SNR).

Beside "understood", every row says what went wrong the way a person meets it (:func:`outcome`):
a request answered with nothing (no action, no question), a request carried out on another
object, and words nobody addressed to the robot acted on (or asked back about); the summary
counts them per kind and condition and checks them against :data:`GATES`.

Everything random is drawn from generators seeded with ``[seed, set, domain, world, kind]``, so
the same arguments give the same items. The templates are benchmark data only: nothing in the
product reads them. The wordings live in :mod:`siftom.bench.utterances`, the items and their
scoring in :mod:`siftom.bench.understanding_items`; this module runs them.
"""

from __future__ import annotations

import hashlib
import json
import re
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from siftom.bench.understanding_items import (
    BLIND,
    BLIND_KINDS,
    EXTRA_KINDS,
    Expect,
    Item,
    carried_out,
    generate_items,
    load_items,
    outcome,
    scene_of,
    understood,
)
from siftom.bench.understanding_report import (
    GATES,
    MEASURES,
    _summarize,
    gate_lines,
    gates,
    markdown,
    table,
)
from siftom.bench.utterances import (
    CONFUSIONS,
    COUNTED,
    DEFAULT_WORLDS,
    DOMAINS,
    HOUSEHOLD,
    KINDS,
    KITCHEN,
    MAX_COUNT,
    NUMBER_WORDS,
    PER_KIND,
    SETS,
    TEMPLATES,
    WORLD_SEEDS,
)
from siftom.errors import DatasetError

__all__ = [
    "ALL_SETS", "BLIND", "BLIND_KINDS", "CONDITIONS", "CONFUSIONS", "COUNTED", "DEFAULT_WORLDS", "DOMAINS",
    "EXTRA_KINDS", "GATES", "HOUSEHOLD", "KINDS", "KITCHEN", "MAX_COUNT", "MEASURES", "NOISE", "NUMBER_WORDS",
    "PER_KIND", "REPLY_EVIDENCE", "SETS", "SNRS", "SNR_DB", "TEMPLATES", "VOICES", "WORLD_SEEDS", "Expect", "Item",
    "Run", "add_noise", "as_recorded", "gate_lines", "gates", "generate_items", "items_of", "load_items", "markdown",
    "outcome", "pending_for", "record", "run_benchmark", "scene_for", "speak", "summary_path", "table", "understood",
    "voices_available",
]

CONDITIONS = ("text", "clean", "10dB", "5dB")
ALL_SETS = (*SETS, BLIND)
VOICES = ("flite-slt", "flite-awb", "espeak-en-us+klatt", "hibari-heart")
NOISE = "recorded"
SNR_DB = 10.0
SNRS = {"10dB": 10.0, "5dB": 5.0}  # the noisy conditions' SNR
# how much more the words that led to an open question (an item's ``pending``) favoured its two
# options than any other command, as a log-likelihood ratio: 3.0 is about 20 to 1
REPLY_EVIDENCE = 3.0


# -- running -------------------------------------------------------------------------------------


def _plain(v: Any) -> Any:
    """``v`` with numpy scalars as Python ones (for JSON)."""
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def scene_for(item: Item) -> Any:
    """The :class:`~siftom.inputs.SceneInput` of an item's world, with the person's actions (the
    scenario's own, or the world file's)."""
    return scene_of(item)


def items_of(set_name: str, world_seed: int | None = None, worlds: int = DEFAULT_WORLDS, seed: int = 0,
             path: str | Path | None = None) -> list[Item]:
    """The items of a set: generated (``dev``, ``heldout``, ``unseen``) or the hand-written ``blind``
    set (``path``: another file of the same format)."""
    if set_name == BLIND or path is not None:
        return load_items(path)
    return generate_items(set_name, world_seed, worlds, seed)


_ALL_COMMANDS: dict[int, tuple[str, ...]] = {}


def pending_for(item: Item, scene: Any, observer: Any) -> Any:
    """The open question of a reply item (None for others): "Which one: A or B?" over its two
    ``pending`` commands, the words before it favouring those two by :data:`REPLY_EVIDENCE` over
    every other command of the scene."""
    if not item.pending:
        return None
    from siftom.assist.questions import choose_question
    from siftom.assist.reply import Pending
    from siftom.likelihood.lexicon import lexicon_for

    a, b = item.pending
    key = id(scene)
    if key not in _ALL_COMMANDS:
        _ALL_COMMANDS[key] = tuple(str(c) for c, _ in observer.infer(scene, None, None).commands)
    rest = tuple((c, -REPLY_EVIDENCE) for c in _ALL_COMMANDS[key] if c not in (a, b))
    return Pending(choose_question(a, b, lexicon_for(scene.world)), ((a, 0.0), (b, 0.0), *rest), a)


def _run_item(observer: Any, item: Item, scene: Any, heard: str | np.ndarray, *,
             condition: str = "text", voice: str | None = None) -> dict[str, Any]:
    """Ask ``observer`` about what was ``heard`` (a transcript or 16 kHz samples) of ``item`` in
    ``scene`` (after its open question, if any); the result row (``understood`` by
    :func:`understood`, what went wrong by :func:`outcome`)."""
    from siftom.errors import SiftomError

    t0 = time.perf_counter()
    row: dict[str, Any] = {"id": item.id, "kind": item.kind, "domain": item.domain, "scenario": item.scenario,
                           "world": item.world or None, "condition": condition, "voice": voice, "text": item.text,
                           "pending": list(item.pending) or None, "expected": item.expect.to_json()}
    try:
        pending = pending_for(item, scene, observer)
        answer = observer.infer(scene, None, heard, pending=pending)
    except SiftomError as exc:
        return {**row, "heard": None, "understanding": None, "parts": [], "action": None, "command": None,
                "carried_out": [], "question": None, "options": [], "reason": None, "declined": None,
                "error": str(exc), "seconds": round(time.perf_counter() - t0, 4), "understood": False,
                **outcome(item, None)}
    u = getattr(answer, "understanding", None)
    cmd = answer.command
    d = answer.decision
    row.update({
        "heard": answer.transcript,
        "understanding": _plain(u.to_json()) if u is not None else None,
        "parts": [str(p) for p in tuple(getattr(answer, "parts", None) or ())],
        "action": answer.action,
        "command": str(cmd) if cmd is not None else None,
        "carried_out": [str(c) for c in carried_out(answer)],
        "question": d.question or None,
        "options": [str(o) for o in d.options] if answer.action == "ask" else [],
        "reason": d.reason,
        "declined": getattr(d, "declined", "") or None,
        "seconds": round(time.perf_counter() - t0, 4),
        "understood": understood(item, answer),
        **outcome(item, answer),
    })
    return row


def voices_available() -> tuple[str, ...]:
    """The benchmark's voices (:data:`VOICES`) whose TTS engine is installed here."""
    from siftom.speech.tts import VOICES as REGISTRY

    return tuple(v for v in VOICES if REGISTRY.spec(v).missing() is None)


def _stable(text: str) -> int:
    return int(hashlib.sha1(text.encode()).hexdigest()[:8], 16)


def speak(item: Item, voice: str) -> np.ndarray:
    """The item said by ``voice`` (16 kHz samples)."""
    from siftom.speech.tts import synthesize

    return synthesize(item.text, voice)


def add_noise(clean: np.ndarray, item: Item, seed: int = 0, snr_db: float = SNR_DB) -> np.ndarray:
    """``clean`` in the recorded household noise at ``snr_db`` (10 dB), an excerpt seeded per item
    (the same excerpt at every SNR)."""
    from siftom.speech.noise import get_noise, mix_at_snr

    return mix_at_snr(clean, get_noise(NOISE), snr_db, np.random.default_rng([seed, _stable(item.id)]))


def _recorded(condition: str) -> None:
    if condition not in CONDITIONS[1:]:
        raise DatasetError(f"no recording for condition {condition!r}; recorded conditions: "
                           f"{', '.join(CONDITIONS[1:])}")


def record(item: Item, condition: str, voice: str, seed: int = 0) -> np.ndarray:
    """The item spoken by ``voice`` in a recorded condition: ``clean``, ``10dB`` or ``5dB``."""
    _recorded(condition)
    clean = speak(item, voice)
    return clean if condition == "clean" else add_noise(clean, item, seed, SNRS[condition])


def as_recorded(x: np.ndarray) -> np.ndarray:
    """``x`` as a 16-bit PCM recording holds it: the same samples whether a clip was just made or
    read back from ``FILE.audio/``."""
    import io

    import soundfile as sf

    from siftom.speech.audio import wav_bytes

    got: np.ndarray = sf.read(io.BytesIO(wav_bytes(x)), dtype="float32")[0]
    return got


class _Recorder:
    """Recordings of the items, said once per item and voice; on disk only under ``folder``."""

    def __init__(self, seed: int, folder: Path | None) -> None:
        self.seed = seed
        self.folder = folder
        self._clean: tuple[str, np.ndarray] | None = None

    def __call__(self, item: Item, condition: str, voice: str) -> np.ndarray:
        from siftom.speech.audio import load_audio, write_wav

        path = None
        if self.folder is not None:
            key = hashlib.sha1(json.dumps([item.text, voice, condition, self.seed]).encode()).hexdigest()[:10]
            path = self.folder / f"{re.sub(r'[^A-Za-z0-9-]+', '_', item.id)}-{condition}-{key}.wav"
            if path.is_file():
                return load_audio(path)
        _recorded(condition)
        tag = f"{item.id}|{voice}|{item.text}"
        if self._clean is None or self._clean[0] != tag:
            self._clean = (tag, speak(item, voice))
        x = as_recorded(self._clean[1] if condition == "clean"
                        else add_noise(self._clean[1], item, self.seed, SNRS[condition]))
        if path is not None:
            write_wav(path, x)
        return x


def _stem(out: Path) -> str:
    return out.name[: -len(".jsonl")] if out.name.endswith(".jsonl") else out.name


def summary_path(out: str | Path) -> Path:
    """``FILE.summary.json`` beside ``FILE.jsonl``."""
    p = Path(out)
    return p.with_name(_stem(p) + ".summary.json")


def _machine() -> dict[str, Any]:
    """The machine, siftom's version and, in a git checkout, the commit the run measured."""
    import subprocess

    from siftom.bench.machine import Machine

    info = Machine.here().to_json("service")
    try:
        got = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=5,
                             cwd=Path(__file__).resolve().parent, check=False)
        info["commit"] = got.stdout.strip() or None if got.returncode == 0 else None
    except (OSError, subprocess.SubprocessError):
        info["commit"] = None
    return info


@dataclass
class Run:
    """A benchmark run: the rows (one per item and condition) and their summary."""

    rows: list[dict[str, Any]]
    summary: dict[str, Any]
    seconds: float = 0.0
    files: list[str] = field(default_factory=list)


def run_benchmark(items: Sequence[Item], conditions: Sequence[str] = ("text",), *, observer: Any = None,
                  seed: int = 0, out: str | Path | None = None, meta: Mapping[str, object] | None = None,
                  progress: Callable[[int, int], None] | None = None, voices: Sequence[str] | None = None) -> Run:
    """Run every item in every condition; write ``out`` (JSON lines) and its summary when given.

    Args:
        items: the items (:func:`items_of`).
        conditions: of :data:`CONDITIONS`; ``clean``, ``10dB`` and ``5dB`` speak each item with a
            voice of ``voices`` (rotating; the same voice for an item in every condition).
        observer: the observer to ask (default: one from the settings).
        seed: seed of the noise excerpts.
        out: a ``.jsonl`` file for the rows; ``FILE.summary.json`` beside it, and the recordings
            under ``FILE.audio/`` (reused when the same run is repeated).
        meta: what the run was (set, seeds), copied into the summary.
        progress: called with (done, total) after each row.
        voices: the voices (default: :func:`voices_available`).

    The summary records the machine, siftom's version and the commit (``machine``).
    """
    from siftom.observer import Observer

    bad = [c for c in conditions if c not in CONDITIONS]
    if bad:
        raise DatasetError(f"unknown condition {bad[0]!r}; choose from {', '.join(CONDITIONS)}")
    if voices is not None:
        unknown = [v for v in voices if v not in VOICES]
        if unknown or not voices:
            raise DatasetError(f"unknown voice {unknown[0] if unknown else ''!r}; the benchmark's voices: "
                               f"{', '.join(VOICES)}")
        missing = [v for v in voices if v not in voices_available()]
        if missing and any(c != "text" for c in conditions):
            raise DatasetError(f"voice {missing[0]!r} is not installed here; installed: "
                               f"{', '.join(voices_available()) or 'none'} (make sysdeps)")
    voices = tuple(voices) if voices is not None else ()
    if any(c != "text" for c in conditions) and not voices:
        voices = voices_available()
        if not voices:
            raise DatasetError(f"no voice of {', '.join(VOICES)} is installed for the recorded conditions; "
                               "install flite or espeak-ng (make sysdeps), or run --conditions text")
    ob = observer if observer is not None else Observer()
    out_path = Path(out) if out is not None else None
    rec = _Recorder(seed, out_path.with_name(_stem(out_path) + ".audio") if out_path is not None else None)
    t0 = time.perf_counter()
    rows: list[dict[str, Any]] = []
    total = len(items) * len(conditions)
    sink = None
    if out_path is not None:
        out_path.parent.mkdir(parents=True, exist_ok=True)
        sink = out_path.open("w", encoding="utf-8")
    try:
        for i, item in enumerate(items):
            scene = scene_for(item)
            for c in conditions:
                voice = voices[i % len(voices)] if c != "text" else None
                heard: str | np.ndarray = item.text if voice is None else rec(item, c, voice)
                row = _run_item(ob, item, scene, heard, condition=c, voice=voice)
                rows.append(row)
                if sink is not None:
                    sink.write(json.dumps(row) + "\n")
                    sink.flush()
                if progress is not None:
                    progress(len(rows), total)
    finally:
        if sink is not None:
            sink.close()
    secs = time.perf_counter() - t0
    info = {**(meta or {}), "items": len(items), "conditions": list(conditions),
            "voices": list(voices) if any(c != "text" for c in conditions) else [],
            "noise": NOISE if any(c in SNRS for c in conditions) else None,
            "snr_db": {c: SNRS[c] for c in conditions if c in SNRS}, "seconds": round(secs, 1),
            "machine": _machine()}
    summary = _summarize(rows, CONDITIONS, info)
    files: list[str] = []
    if out_path is not None:
        sp = summary_path(out_path)
        sp.write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
        files = [str(out_path), str(sp)]
    return Run(rows, summary, secs, files)
