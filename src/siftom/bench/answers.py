"""Spoken answers to the robot's questions in the benchmark, and how reliably they are heard.

When an asking model (``siftom-ask``) asks (assist/questions.py), the simulated human answers truthfully: it
says a phrase of the cell its command is in ("yes", "three please", "the oatmeal", "neither"),
in the stimulus's voice (TTS with the speaker's rate and pitch), mixed with the stimulus's
noise type at its SNR. The recogniser listens with the question's answer grammar (a
``pocketsphinx-vocab`` LM over the grammar's phrases, as a dialogue system constrains its
recogniser after a question), and the heard text names a cell by its key words, or none.

``siftom bench answer-grammar DATASET`` measures, per question kind and SNR, how often the
answer is heard as the cell it names, on a development set (another seed than the evaluation
sets): for a seeded sample of stimuli it asks every kind with the gold command (a "yes"
confirmation, a "no" one, a choice with the gold option, a choice without it, the gold class's
count and another class's count, answered "nothing") through exactly this path. The table is :data:`ANSWER_RELIABILITY`.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import click
import numpy as np

from siftom.assist.questions import (
    KINDS,
    Question,
    answer_reliability,
    choose_question,
    confirm_question,
    count_question,
)
from siftom.errors import DatasetError, SiftomError

FALLBACK_VOICE = "flite-slt"  # for recordings of real people: no TTS voice to answer with
def answer_reliabilities(snr_db: float | None) -> dict[str, float]:
    """:func:`answer_reliability` for every question kind."""
    return {k: answer_reliability(snr_db, k) for k in KINDS}


def seed_of(stimulus_id: str, *extra: int) -> list[int]:
    return [int(hashlib.sha1(stimulus_id.encode()).hexdigest()[:8], 16), *extra]


def answer_phrase(question: Question, cell: int, stimulus_id: str) -> str:
    """What the human says for ``cell`` (one of the cell's phrases, seeded by the stimulus)."""
    phrases = question.answers[cell]
    rng = np.random.default_rng(seed_of(stimulus_id, 11, cell, len(question.text)))
    return phrases[int(rng.integers(len(phrases)))]


@lru_cache(maxsize=16)
def _noise_dir(dataset_root: str) -> str | None:
    spec = Path(dataset_root) / "dataset.json"
    if not spec.is_file():
        return None
    nd = json.loads(spec.read_text(encoding="utf-8")).get("options", {}).get("noise_dir")
    if not nd:
        return None
    from siftom.people.stimuli import RECORDED, noise_folder

    if nd == RECORDED:
        return str(noise_folder(nd))
    for base in (Path.cwd(), Path(dataset_root)):
        p = Path(nd) if Path(nd).is_absolute() else base / nd
        if p.is_dir():
            return str(p)
    return None


def answer_audio(stimulus: Any, text: str, dataset_root: str, salt: int = 0) -> np.ndarray:
    """The answer as the stimulus's speaker would say it, in the stimulus's noise at its SNR."""
    from siftom.speech.noise import FolderNoise, get_noise, mix_at_snr
    from siftom.speech.tts import VOICES, synthesize

    voice = stimulus.voice if stimulus.voice in VOICES else FALLBACK_VOICE
    x = synthesize(text, voice, rate=stimulus.rate, pitch=stimulus.pitch)
    if stimulus.noise is None or stimulus.snr_db is None:
        return x
    nd = _noise_dir(dataset_root)
    source = FolderNoise(nd, categories=(stimulus.noise,)) if nd else get_noise(stimulus.noise)
    return mix_at_snr(x, source, float(stimulus.snr_db), np.random.default_rng(seed_of(stimulus.id, 12, salt)))


Listen = Callable[[np.ndarray, tuple[str, ...]], Any]  # (audio, grammar) -> Transcript


class AnswerUnavailableError(DatasetError):
    """The human's answer cannot be synthesised: its voice or its noise is not available here."""


@dataclass(frozen=True)
class HeardAnswer:
    """The simulated person's spoken answer and what the robot heard of it.

    Attributes:
        answer: what the person said.
        answer_heard: the transcript the robot heard.
        heard_cell: the question's cell the heard text names (None: none, or an open question).
        cell: the cell the person meant (None for an open question).
    """

    answer: str
    answer_heard: str
    heard_cell: int | None
    cell: int | None


def ask_and_hear(question: Question, cell: int, stimulus: Any, dataset_root: str, listen: Listen,
                 salt: int = 0) -> HeardAnswer:
    """Say the answer of ``cell`` to ``question`` and hear it with the question's grammar.

    Raises:
        AnswerUnavailableError: the stimulus's voice or noise is not available (e.g. a dataset
            of recordings, or a noise folder that is not here); the trial cannot be evaluated.
    """
    text = answer_phrase(question, cell, stimulus.id)
    try:
        audio = answer_audio(stimulus, text, dataset_root, salt)
    except (SiftomError, OSError) as exc:
        raise AnswerUnavailableError(f"cannot say the answer in voice {stimulus.voice!r} with noise "
                                     f"{stimulus.noise!r}: {exc}") from None
    tr = listen(audio, question.grammar())
    texts = [h.text for h in tr.nbest] or [tr.text]
    # the 1-best names the cell; when it names none ("of of those"), the first N-best that does
    heard, hc = texts[0], None
    for t in texts:
        hc = question.heard_cell(t)
        if hc is not None:
            heard = t
            break
    return HeardAnswer(text, heard, hc, cell)


def repeat_and_hear(stimulus: Any, dataset_root: str, listen: Callable[..., Any], salt: int = 0) -> HeardAnswer:
    """The person's answer to an open question ("Sorry, what do you need?"): the request said
    again in the stimulus's voice and noise, heard with the evaluator's own vocabulary.

    Raises:
        AnswerUnavailableError: as :func:`ask_and_hear`.
    """
    text = stimulus.reference
    try:
        audio = answer_audio(stimulus, text, dataset_root, salt)
    except (SiftomError, OSError) as exc:
        raise AnswerUnavailableError(f"cannot say the answer in voice {stimulus.voice!r} with noise "
                                     f"{stimulus.noise!r}: {exc}") from None
    tr = listen(audio)
    return HeardAnswer(text, tr.text, None, None)


def probe_questions(scenario: Any, gold: str, stimulus_id: str) -> list[tuple[Question, int]]:
    """The questions :func:`reliability_by_kind` asks about one stimulus, with the true cell."""
    from siftom.bench.llm_baselines import command_space
    from siftom.bench.scoring import is_correct

    cmds = [str(c) for c in command_space(scenario)]
    gold_s = next((c for c in cmds if is_correct(c, gold, scenario.verb)), None)
    others = [c for c in cmds if c != gold_s]
    if gold_s is None or len(others) < 2:
        return []
    rng = np.random.default_rng(seed_of(stimulus_id, 13))
    d1, d2 = (others[i] for i in rng.choice(len(others), 2, replace=False))
    out = [(confirm_question(gold_s), 0), (confirm_question(d1), 1)]
    pair = (gold_s, d1) if rng.random() < 0.5 else (d1, gold_s)
    out += [(choose_question(*pair), pair.index(gold_s)), (choose_question(d1, d2), 2)]
    if scenario.verb == "deliver":
        from siftom.world.commands import RobotCommand

        gold_cls = RobotCommand.parse(gold_s).obj_class
        q = count_question(gold_cls, cmds)
        out.append((q, q.cell(gold_s)))
        # and the count of another class: the truthful answer is the "anything else" cell
        other = next((RobotCommand.parse(c).obj_class for c in (d1, d2)
                      if RobotCommand.parse(c).obj_class != gold_cls), None)
        if other is not None:
            q = count_question(other, cmds)
            out.append((q, q.n_cells - 1))
    return out


def reliability_by_kind(dataset: str, engine: str = "pocketsphinx-vocab", limit: int | None = None,
                        seed: int = 0) -> dict[str, dict[float, list[bool]]]:
    """{kind: {snr: [heard as its own cell, ...]}} over a seeded sample of the dataset's stimuli."""
    from siftom.bench.engines import engine as get_engine
    from siftom.people.stimuli import load_dataset, scenario_for

    ds = load_dataset(dataset)
    stims = list(ds.stimuli)
    if limit is not None and limit < len(stims):
        idx = np.random.default_rng(seed).choice(len(stims), limit, replace=False)
        stims = [stims[i] for i in sorted(idx)]

    def listen(x: np.ndarray, grammar: tuple[str, ...]) -> Any:
        return get_engine(engine, grammar).transcribe(x, nbest=5)

    out: dict[str, dict[float, list[bool]]] = {k: {} for k in KINDS}
    for s in stims:
        sc = scenario_for(s)
        snr = float("inf") if s.snr_db is None else float(s.snr_db)
        for k, (q, cell) in enumerate(probe_questions(sc, s.gold_command, s.id)):
            h = ask_and_hear(q, cell, s, str(ds.root), listen, salt=k)
            out[q.kind].setdefault(snr, []).append(h.heard_cell == cell)
    return out


@click.command("answer-grammar")
@click.argument("datasets", nargs=-1, required=True, type=click.Path(exists=True, file_okay=False))
@click.option("--limit", type=int, default=200, show_default=True, help="stimuli sampled per dataset (seeded)")
@click.option("--engine", default="pocketsphinx-vocab", show_default=True, help="ASR engine")
@click.option("--json", "as_json", is_flag=True, help="print JSON")
def answer_grammar_cmd(datasets: tuple[str, ...], limit: int, engine: str, as_json: bool) -> None:
    """How reliably answers to each kind of question are heard, by SNR, pooled over DATASETS.

    Measure on development sets (another seed than the evaluation sets); the printed table is
    ANSWER_RELIABILITY in assist/questions.py.
    """
    pooled: dict[str, dict[float, list[bool]]] = {k: {} for k in KINDS}
    for d in datasets:
        for kind, by in reliability_by_kind(d, engine, limit).items():
            for snr, v in by.items():
                pooled[kind].setdefault(snr, []).extend(v)
    table = {k: [(snr, len(v), float(np.mean(v))) for snr, v in sorted(by.items())] for k, by in pooled.items()}
    if as_json:
        click.echo(json.dumps({k: [{"snr_db": None if not np.isfinite(s) else s, "n": n, "heard": h}
                                   for s, n, h in rows] for k, rows in table.items()}, indent=2))
        return
    for kind, rows in table.items():
        cells = ", ".join(f"{'clean' if not np.isfinite(s) else f'{s:g} dB'} {100 * h:.1f} % (n={n})" for s, n, h in rows)
        click.echo(f"{kind:>8}: {cells}")
    click.echo("ANSWER_RELIABILITY = {")
    inf = 'float("inf")'
    for kind, rows in table.items():
        pts = ", ".join(f"({s if np.isfinite(s) else inf}, {h:.2f})" for s, _n, h in rows)
        click.echo(f'    "{kind}": ({pts}),')
    click.echo("}")
