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

# The targets the benchmark is read against: (set or None for any, condition, measure, kind or None
# for every kind, most or least share, "max"/"min").  ``understood`` is the share understood,
# ``nothing``, ``other_object`` and ``acted_unasked`` the shares of :func:`outcome` among the items
# where they can happen.
GATES: tuple[tuple[str | None, str, str, bool, float, str], ...] = (
    ("dev", "text", "understood", False, 0.95, "min"),
    (BLIND, "text", "understood", True, 0.90, "min"),
    (None, "10dB", "nothing", True, 0.05, "max"),
    (None, "10dB", "other_object", True, 0.03, "max"),
    (None, "10dB", "acted_unasked", True, 0.02, "max"),
    (None, "5dB", "nothing", True, 0.10, "max"),
)


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


MEASURES = ("nothing", "other_object", "acted_unasked", "asked_unasked")


def _count(rows: Sequence[dict[str, Any]], measure: str) -> dict[str, Any]:
    """How many rows ``measure`` (of :func:`outcome`) happened to, among those it can happen to."""
    can = [r for r in rows if r.get(measure) is not None]
    k = sum(1 for r in can if r[measure])
    return {"n": len(can), "count": k, "share": round(k / len(can), 4) if can else None}


def _share(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    n = len(rows)
    ok = sum(1 for r in rows if r["understood"])
    return {"n": n, "understood": ok, "share": round(ok / n, 4) if n else None,
            **{m: _count(rows, m) for m in MEASURES}}


def _order(values: Sequence[str], known: Sequence[str]) -> list[str]:
    """``values`` once each: those of ``known`` in its order, then the others sorted."""
    got = set(values)
    return [v for v in known if v in got] + sorted(got - set(known))


def gates(summary: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The :data:`GATES` this run's summary can be read against, each with its value and whether
    it holds (per kind: the worst kind, and every kind that misses)."""
    out: list[dict[str, Any]] = []
    for set_name, cond, measure, per_kind, limit, side in GATES:
        if (set_name is not None and summary.get("set") != set_name) or cond not in summary.get("overall", {}):
            continue
        cells = dict(summary["by_kind"][cond]) if per_kind else {"all": summary["overall"][cond]}

        def value(cell: Mapping[str, Any], measure: str = measure) -> float | None:
            v = cell["share"] if measure == "understood" else cell[measure]["share"]
            return None if v is None else float(v)

        vals = {k: v for k, cell in cells.items() if (v := value(cell)) is not None}
        if not vals:
            continue
        worst_kind = (min if side == "min" else max)(vals, key=lambda k: vals[k])
        missed = sorted(k for k, v in vals.items() if (v < limit if side == "min" else v > limit))
        out.append({"set": set_name, "condition": cond, "measure": measure, "per_kind": per_kind,
                    "limit": limit, "side": side, "worst": vals[worst_kind], "worst_kind": worst_kind,
                    "missed": missed, "holds": not missed})
    return out


def _summarize(rows: Sequence[dict[str, Any]], meta: Mapping[str, object] | None = None) -> dict[str, Any]:
    """Per condition, overall, per kind, per domain and per kind and domain: the share understood
    and the counts of :data:`MEASURES`; then the :func:`gates`."""
    conds = [c for c in CONDITIONS if any(r["condition"] == c for r in rows)]
    kinds = _order([r["kind"] for r in rows], BLIND_KINDS)
    domains = _order([r["domain"] for r in rows], DOMAINS)
    out: dict[str, Any] = {**(meta or {}), "rows": len(rows), "overall": {}, "by_kind": {}, "by_domain": {},
                           "by_kind_domain": {}, "seconds_per_item": {}}
    for c in conds:
        rc = [r for r in rows if r["condition"] == c]
        out["overall"][c] = _share(rc)
        out["by_kind"][c] = {k: _share([r for r in rc if r["kind"] == k]) for k in kinds
                             if any(r["kind"] == k for r in rc)}
        out["by_domain"][c] = {d: _share([r for r in rc if r["domain"] == d]) for d in domains
                               if any(r["domain"] == d for r in rc)}
        out["by_kind_domain"][c] = {f"{k}/{d}": _share([r for r in rc if r["kind"] == k and r["domain"] == d])
                                    for k in kinds for d in domains
                                    if any(r["kind"] == k and r["domain"] == d for r in rc)}
        out["seconds_per_item"][c] = round(float(np.mean([r["seconds"] for r in rc])), 4) if rc else None
    out["gates"] = gates(out)
    return out


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
    summary = _summarize(rows, info)
    files: list[str] = []
    if out_path is not None:
        sp = summary_path(out_path)
        sp.write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
        files = [str(out_path), str(sp)]
    return Run(rows, summary, secs, files)


def _pct(s: Mapping[str, Any] | None) -> str:
    if not s or not s["n"]:
        return "-"
    return f"{s['count']}/{s['n']} {100 * s['share']:.0f} %"


def table(run: Run) -> Any:
    """Rich tables of the run, one per condition, a row per kind: the share understood, then
    requests answered with nothing, carried out on another object, and nobody-asked words acted
    on (each among the items where it can happen)."""
    from rich.console import Group
    from rich.table import Table

    summary = run.summary
    version = (summary.get("machine") or {}).get("version", "?")
    where = f"world seed {summary.get('world_seed')}, " if summary.get("world_seed") is not None else ""
    kinds_of = _order([k for c in summary["overall"] for k in summary["by_kind"][c]], BLIND_KINDS)
    domains_of = _order([d for c in summary["overall"] for d in summary["by_domain"][c]], DOMAINS)

    def _cell(s: Mapping[str, Any] | None) -> str:
        if not s or not s["n"]:
            return "-"
        return f"{s['understood']}/{s['n']} {100 * s['share']:.0f} %"

    tables = []
    for c in summary["overall"]:
        t = Table(title=f"{summary.get('set', '?')} set, {c}",
                  caption=f"{where}{summary.get('items', '?')} items, siftom {version}")
        for head in ("kind", "understood", "nothing", "other object", "unasked acted"):
            t.add_column(head, justify="left" if head == "kind" else "right")

        def _row(x: Mapping[str, Any] | None) -> list[str]:
            return [_cell(x), *(_pct(x[m]) if x else "-" for m in ("nothing", "other_object", "acted_unasked"))]

        for k in kinds_of:
            if k in summary["by_kind"][c]:
                t.add_row(k, *_row(summary["by_kind"][c][k]))
        t.add_section()
        for d in domains_of:
            if d in summary["by_domain"][c]:
                t.add_row(d, *_row(summary["by_domain"][c][d]))
        t.add_row("all", *_row(summary["overall"][c]), style="bold")
        tables.append(t)
    return Group(*tables)


def gate_lines(summary: Mapping[str, Any]) -> list[str]:
    """One line per gate of the summary: what it asks, the worst value and whether it holds."""
    out = []
    for g in summary.get("gates", []):
        what = {"understood": "understood", "nothing": "requests answered with nothing",
                "other_object": "carried out on another object",
                "acted_unasked": "nobody asked, acted on"}[g["measure"]]
        op = ">=" if g["side"] == "min" else "<="
        scope = "per kind" if g["per_kind"] else "overall"
        worst = f"{100 * g['worst']:.1f} %" + (f" ({g['worst_kind']})" if g["per_kind"] else "")
        miss = f"; missed by {', '.join(g['missed'])}" if g["missed"] and g["per_kind"] else ""
        out.append(f"{'holds' if g['holds'] else 'MISSES'}: {g['condition']} {what} {scope} {op} "
                   f"{100 * g['limit']:.0f} %: worst {worst}{miss}")
    return out


def markdown(summaries: Sequence[tuple[str, Mapping[str, Any]]], measure: str = "understood") -> str:
    """A Markdown table from result summaries: a row per kind, a column per (label, condition);
    ``measure`` ``understood`` (the share understood) or one of :data:`MEASURES` (its count among
    the items where it can happen)."""
    if measure != "understood" and measure not in MEASURES:
        raise DatasetError(f"unknown measure {measure!r}; choose understood or one of {', '.join(MEASURES)}")
    cols = [(label, c, s) for label, s in summaries for c in s.get("overall", {})]
    kinds = _order([k for _, c, s in cols for k in s["by_kind"][c]], BLIND_KINDS)

    def cell(x: Mapping[str, Any] | None) -> str:
        if measure == "understood":
            return "-" if not x or not x["n"] else f"{100 * x['share']:.0f} % ({x['understood']}/{x['n']})"
        y = x.get(measure) if x else None
        return "-" if not y or not y["n"] else f"{100 * y['share']:.0f} % ({y['count']}/{y['n']})"

    lines = ["| kind | " + " | ".join(f"{label}, {c}" for label, c, _ in cols) + " |",
             "|---|" + "---|" * len(cols)]
    for k in kinds:
        cells = [cell(s["by_kind"][c].get(k)) for _, c, s in cols]
        if any(x != "-" for x in cells):
            lines.append(f"| {k} | " + " | ".join(cells) + " |")
    lines.append("| **all** | " + " | ".join(cell(s["overall"][c]) for _, c, s in cols) + " |")
    return "\n".join(lines)
