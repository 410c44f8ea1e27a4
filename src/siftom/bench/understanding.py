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
world seed 201 for dev, 202 for held-out, 203 for unseen). Conditions: ``text`` (the words
themselves), ``clean`` (spoken by a TTS voice) and ``10dB`` (the same clip in recorded household
noise at 10 dB SNR).

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

from siftom.bench.understanding_items import Expect, Item, generate_items, understood
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
    "CONDITIONS", "CONFUSIONS", "COUNTED", "DEFAULT_WORLDS", "DOMAINS", "HOUSEHOLD", "KINDS", "KITCHEN",
    "MAX_COUNT", "NOISE", "NUMBER_WORDS", "PER_KIND", "SETS", "SNR_DB", "TEMPLATES", "VOICES", "WORLD_SEEDS",
    "Expect", "Item", "Run", "add_noise", "as_recorded", "generate_items", "record", "run_benchmark",
    "scene_for", "speak", "summary_path", "table", "understood", "voices_available",
]

CONDITIONS = ("text", "clean", "10dB")
VOICES = ("flite-slt", "flite-awb", "espeak-en-us+klatt", "hibari-heart")
NOISE = "recorded"
SNR_DB = 10.0


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
    """The :class:`~siftom.inputs.SceneInput` of an item's world, with the scenario's own actions."""
    from siftom.inputs import resolve_scene
    from siftom.people.stimuli import resolve_scenario

    return resolve_scene(resolve_scenario(item.scenario, item.domain, item.scenario_seed))


def _run_item(observer: Any, item: Item, scene: Any, heard: str | np.ndarray, *,
             condition: str = "text", voice: str | None = None) -> dict[str, Any]:
    """Ask ``observer`` about what was ``heard`` (a transcript or 16 kHz samples) of ``item`` in
    ``scene``; the result row (``understood`` by :func:`understood`)."""
    from siftom.errors import SiftomError

    t0 = time.perf_counter()
    row: dict[str, Any] = {"id": item.id, "kind": item.kind, "domain": item.domain, "scenario": item.scenario,
                           "condition": condition, "voice": voice, "text": item.text,
                           "expected": item.expect.to_json()}
    try:
        answer = observer.infer(scene, None, heard)
    except SiftomError as exc:
        return {**row, "heard": None, "understanding": None, "parts": [], "action": None, "command": None,
                "reason": None, "error": str(exc), "seconds": round(time.perf_counter() - t0, 4),
                "understood": False}
    u = getattr(answer, "understanding", None)
    cmd = answer.command
    row.update({
        "heard": answer.transcript,
        "understanding": _plain(u.to_json()) if u is not None else None,
        "parts": [str(p) for p in tuple(getattr(answer, "parts", None) or ())],
        "action": answer.action,
        "command": str(cmd) if cmd is not None else None,
        "reason": answer.decision.reason,
        "seconds": round(time.perf_counter() - t0, 4),
        "understood": understood(item, answer),
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


def add_noise(clean: np.ndarray, item: Item, seed: int = 0) -> np.ndarray:
    """``clean`` in the recorded household noise at 10 dB SNR, an excerpt seeded per item."""
    from siftom.speech.noise import get_noise, mix_at_snr

    return mix_at_snr(clean, get_noise(NOISE), SNR_DB, np.random.default_rng([seed, _stable(item.id)]))


def record(item: Item, condition: str, voice: str, seed: int = 0) -> np.ndarray:
    """The item spoken by ``voice`` in a recorded condition: ``clean`` or ``10dB``."""
    if condition not in CONDITIONS[1:]:
        raise DatasetError(f"no recording for condition {condition!r}; recorded conditions: clean, 10dB")
    clean = speak(item, voice)
    return clean if condition == "clean" else add_noise(clean, item, seed)


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
        if condition not in CONDITIONS[1:]:
            raise DatasetError(f"no recording for condition {condition!r}; recorded conditions: clean, 10dB")
        tag = f"{item.id}|{voice}|{item.text}"
        if self._clean is None or self._clean[0] != tag:
            self._clean = (tag, speak(item, voice))
        x = as_recorded(self._clean[1] if condition == "clean" else add_noise(self._clean[1], item, self.seed))
        if path is not None:
            write_wav(path, x)
        return x


def _stem(out: Path) -> str:
    return out.name[: -len(".jsonl")] if out.name.endswith(".jsonl") else out.name


def summary_path(out: str | Path) -> Path:
    """``FILE.summary.json`` beside ``FILE.jsonl``."""
    p = Path(out)
    return p.with_name(_stem(p) + ".summary.json")


def _share(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    n = len(rows)
    ok = sum(1 for r in rows if r["understood"])
    return {"n": n, "understood": ok, "share": round(ok / n, 4) if n else None}


def _summarize(rows: Sequence[dict[str, Any]], meta: Mapping[str, object] | None = None) -> dict[str, Any]:
    """Share understood per condition: overall, per kind, per domain and per kind and domain."""
    conds = [c for c in CONDITIONS if any(r["condition"] == c for r in rows)]
    out: dict[str, Any] = {**(meta or {}), "rows": len(rows), "overall": {}, "by_kind": {}, "by_domain": {},
                           "by_kind_domain": {}, "seconds_per_item": {}}
    for c in conds:
        rc = [r for r in rows if r["condition"] == c]
        out["overall"][c] = _share(rc)
        out["by_kind"][c] = {k: _share([r for r in rc if r["kind"] == k]) for k in KINDS
                             if any(r["kind"] == k for r in rc)}
        out["by_domain"][c] = {d: _share([r for r in rc if r["domain"] == d]) for d in DOMAINS
                               if any(r["domain"] == d for r in rc)}
        out["by_kind_domain"][c] = {f"{k}/{d}": _share([r for r in rc if r["kind"] == k and r["domain"] == d])
                                    for k in KINDS for d in DOMAINS
                                    if any(r["kind"] == k and r["domain"] == d for r in rc)}
        out["seconds_per_item"][c] = round(float(np.mean([r["seconds"] for r in rc])), 4) if rc else None
    return out


@dataclass
class Run:
    """A benchmark run: the rows (one per item and condition) and their summary."""

    rows: list[dict[str, Any]]
    summary: dict[str, Any]
    seconds: float = 0.0
    files: list[str] = field(default_factory=list)


def run_benchmark(items: Sequence[Item], conditions: Sequence[str] = ("text",), *, observer: Any = None,
                  seed: int = 0, out: str | Path | None = None, meta: Mapping[str, str | int | None] | None = None,
                  progress: Callable[[int, int], None] | None = None) -> Run:
    """Run every item in every condition; write ``out`` (JSON lines) and its summary when given.

    Args:
        items: the items (:func:`generate_items`).
        conditions: of :data:`CONDITIONS`; ``clean`` and ``10dB`` speak each item with a voice of
            :func:`voices_available` (rotating).
        observer: the observer to ask (default: one from the settings).
        seed: seed of the noise excerpts.
        out: a ``.jsonl`` file for the rows; ``FILE.summary.json`` beside it, and the recordings
            under ``FILE.audio/`` (reused when the same run is repeated).
        meta: what the run was (set, seeds), copied into the summary.
        progress: called with (done, total) after each row.
    """
    from siftom.observer import Observer

    bad = [c for c in conditions if c not in CONDITIONS]
    if bad:
        raise DatasetError(f"unknown condition {bad[0]!r}; choose from {', '.join(CONDITIONS)}")
    voices: tuple[str, ...] = ()
    if any(c != "text" for c in conditions):
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
    info = {**(meta or {}), "items": len(items), "conditions": list(conditions), "voices": list(voices),
            "noise": NOISE if "10dB" in conditions else None, "seconds": round(secs, 1)}
    summary = _summarize(rows, info)
    files: list[str] = []
    if out_path is not None:
        sp = summary_path(out_path)
        sp.write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
        files = [str(out_path), str(sp)]
    return Run(rows, summary, secs, files)


def table(run: Run) -> Any:
    """A rich table of the run's share understood per kind (rows) and condition (columns)."""
    from rich.table import Table

    summary = run.summary
    conds = list(summary["overall"])
    t = Table(title=f"understood, {summary.get('set', '?')} set",
              caption=f"world seed {summary.get('world_seed', '?')}, {summary.get('items', '?')} items")
    t.add_column("kind")
    for c in conds:
        t.add_column(c, justify="right")

    def _cell(s: dict[str, Any] | None) -> str:
        if not s or not s["n"]:
            return "-"
        return f"{s['understood']}/{s['n']} {100 * s['share']:.0f} %"

    for k in KINDS:
        if any(k in summary["by_kind"][c] for c in conds):
            t.add_row(k, *(_cell(summary["by_kind"][c].get(k)) for c in conds))
    t.add_section()
    for d in DOMAINS:
        if any(d in summary["by_domain"][c] for c in conds):
            t.add_row(d, *(_cell(summary["by_domain"][c].get(d)) for c in conds))
    t.add_row("all", *(_cell(summary["overall"][c]) for c in conds), style="bold")
    return t
