"""UnclearInstruct-style datasets: spoken instructions for scenarios, clean and in noise.

A dataset is a folder with ``manifest.jsonl`` (one :class:`Stimulus` a line), ``audio/*.wav``
(16 kHz mono 16-bit PCM), ``dataset.json`` (how it was built) and ``README.md`` (a datasheet).
docs/dataset-format.md documents the format so that real recordings can be brought in.

How a dataset is built (paper, Simulated Experiment, Dataset Construction):

* scenarios: the domain's registered scenarios in order (``household-table-v0/0..25``), then
  generated ones (``domain.generate(i)``) when more are asked for. With ``world_seed`` (``--world-seed``)
  none is registered: scenario k is ``domain.generate(world_scenario_seed(world_seed, k))``, a world
  no constant was tuned on (siftom.scenarios.base explains the seeds). The human has acted for a
  while (``Scenario.actions``) and asks the robot for its part (``Scenario.command``).
* speakers: each speaker is a TTS voice with its own speaking rate and pitch. Per scenario,
  each speaker phrases the command as people do (``sample_phrasing``: direct, polite,
  indirect, with or without the count, category words) and says it.
* conditions: every clip is kept clean and mixed with background noise once per SNR in
  ``snrs``. The noise type rotates over ``noises`` so that every type meets every SNR equally
  often: the default is 1 clean + 3 noisy = 4 conditions, 26 x 5 x 4 = 520 stimuli.

Everything random is drawn from generators seeded with ``[seed, scenario index, speaker index,
...]``, so a build is reproducible bit for bit and independent of the number of workers.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from siftom.errors import DatasetError, SiftomError
from siftom.people.stimuli import (
    AUDIO_DIR,
    FORMAT_VERSION,
    MANIFEST,
    SPEC,
    SYNTHETIC_NOISES,
    BuildOptions,
    Dataset,
    Speaker,
    Stimulus,
    noise_folder,
    resolve_scenario,
    select_scenarios,
)


def make_speakers(opts: BuildOptions) -> list[Speaker]:
    """Speakers s1..sN: voices in order (repeating), rate and pitch drawn from the seed."""
    from siftom.speech.tts import get_voice

    out = []
    for j in range(opts.speakers):
        voice = get_voice(opts.voices[j % len(opts.voices)]).name
        rng = np.random.default_rng([opts.seed, 9001, j])
        out.append(Speaker(f"s{j + 1}", voice, round(float(rng.uniform(0.9, 1.1)), 3),
                           round(float(rng.uniform(0.92, 1.08)), 3)))
    return out


def noise_categories(folder: str | Path) -> list[str]:
    """Categories of a noise folder: file names ``CATEGORY_NN.wav`` without the number."""
    root = noise_folder(folder)
    sub = root / "noise_train"
    base = sub if sub.is_dir() else root
    cats = {re.sub(r"[_-]?\d+$", "", p.stem) for p in base.iterdir() if p.suffix.lower() == ".wav"}
    return sorted(c for c in cats if c)


def resolve_noises(opts: BuildOptions) -> list[tuple[str, Any]]:
    """(name, NoiseSource) for each noise type of the build."""
    from siftom.speech.noise import FolderNoise, NoiseSource, get_noise

    out: list[tuple[str, NoiseSource]] = []
    if opts.noise_dir is not None:
        cats = noise_categories(opts.noise_dir)
        names = list(opts.noises) or cats
        for n in names:
            if n in cats:
                out.append((n, FolderNoise(noise_folder(opts.noise_dir), categories=(n,))))
            else:
                try:
                    out.append((Path(n).stem if n.endswith(".wav") else n, get_noise(n)))
                except SiftomError:
                    raise DatasetError(
                        f"noise {n!r} is neither a category of {opts.noise_dir} ({', '.join(cats)}) "
                        "nor a synthetic kind or WAV file"
                    ) from None
        if not out:
            raise DatasetError(f"no noise WAVs in {opts.noise_dir}; add CATEGORY_NN.wav files")
        return out
    names = list(opts.noises) or list(SYNTHETIC_NOISES)
    for n in names:
        try:
            out.append((Path(n).stem if n.endswith(".wav") else n, get_noise(n)))
        except SiftomError as exc:
            raise DatasetError(f"noise {n!r}: {exc}") from None
    return out


@dataclass(frozen=True)
class _Unit:
    """One scenario x speaker: a clean clip and its noisy versions."""

    k: int
    sid: str
    scenario_seed: int | None
    speaker: Speaker
    conditions: tuple[tuple[str | None, float | None], ...]


def _cond_tag(noise: str | None, snr: float | None) -> str:
    if noise is None:
        return "clean"
    return f"{re.sub(r'[^A-Za-z0-9]+', '_', noise)}-{snr:g}db".replace(".", "p")


_NOISE_SOURCES: dict[tuple[str | None, tuple[str, ...]], dict[str, Any]] = {}


def _build_unit(unit: _Unit, opts: BuildOptions, out: Path) -> list[Stimulus]:
    """Phrase, synthesise and mix one unit; skip WAVs already written (resume)."""
    from siftom.likelihood.lexicon import default_lexicon
    from siftom.likelihood.phrasing import phrasing_details, sample_phrasing
    from siftom.speech.audio import load_audio, write_wav
    from siftom.speech.noise import mix_at_snr
    from siftom.speech.tts import synthesize

    sc = resolve_scenario(unit.sid, opts.domain, unit.scenario_seed)
    j = int(unit.speaker.id[1:]) - 1
    rng = np.random.default_rng([opts.seed, unit.k, j, 1])
    if opts.phrasings is None:
        text = sample_phrasing(sc.command, default_lexicon(), rng)
        style = next((("category" if p.category else p.style) for p in phrasing_details(sc.command) if p.text == text), "")
    else:
        from siftom.likelihood.carriers import load_carriers, sample_with_carriers

        text = sample_with_carriers(sc.command, default_lexicon(), rng, load_carriers(opts.phrasings),
                                    carrier_rng=np.random.default_rng([opts.seed, unit.k, j, 3]))
        style = "free"
    nkey = (opts.noise_dir, opts.noises)
    if nkey not in _NOISE_SOURCES:
        _NOISE_SOURCES[nkey] = dict(resolve_noises(opts)) if opts.snrs else {}
    sources = _NOISE_SOURCES[nkey]
    base = f"{unit.k:03d}-{unit.speaker.id}"
    clean: np.ndarray | None = None
    rows = []
    for noise, snr in unit.conditions:
        sid = f"{base}-{_cond_tag(noise, snr)}"
        rel = f"{AUDIO_DIR}/{sid}.wav"
        path = out / rel
        if path.is_file():
            x = load_audio(path)
        else:
            if clean is None:
                clean = synthesize(text, unit.speaker.voice, rate=unit.speaker.rate, pitch=unit.speaker.pitch)
                if opts.room is not None:  # the talker across a reverberant room, one response per clip
                    from siftom.speech.room import reverberate

                    clean = reverberate(clean, opts.room, np.random.default_rng([opts.seed, unit.k, j, 4]))
            if noise is None:
                x = clean
            else:
                assert snr is not None  # a noisy condition has its SNR (plan_units)
                mix_rng = np.random.default_rng([opts.seed, unit.k, j, 2, int(round(snr * 100)), _stable(noise)])
                x = mix_at_snr(clean, sources[noise], snr, mix_rng)
            tmp = path.with_name(path.stem + f".{os.getpid()}.tmp.wav")
            write_wav(tmp, x)
            os.replace(tmp, path)
        rows.append(Stimulus(
            id=sid, scenario=sc.id, domain=opts.domain,
            observed_actions=tuple(sc.world.format_action(a) for a in sc.actions),
            audio=rel, reference=text,
            gold_goal={"name": sc.goal.name, "counts": dict(sc.goal.counts)},
            gold_command=str(sc.command), speaker=unit.speaker.id, voice=unit.speaker.voice,
            noise=noise, snr_db=snr, scenario_seed=unit.scenario_seed, rate=unit.speaker.rate,
            pitch=unit.speaker.pitch, style=style, duration_s=round(len(x) / 16000, 3),
            extra={} if opts.world_seed is None else {"world_seed": opts.world_seed, "world": unit.k},
        ))
    return rows


def _stable(s: str) -> int:
    return int(hashlib.sha1(s.encode()).hexdigest()[:8], 16)


def _worker_build(unit: _Unit, shared: tuple[BuildOptions, str]) -> list[Stimulus]:
    opts, out = shared
    return _build_unit(unit, opts, Path(out))


def plan_units(opts: BuildOptions) -> list[_Unit]:
    """Every scenario x speaker with its conditions (clean first, then one per SNR)."""
    scenarios = select_scenarios(opts.domain, opts.scenarios, opts.world_seed)
    speakers = make_speakers(opts)
    noise_names = [n for n, _ in resolve_noises(opts)] if opts.snrs else []
    units = []
    for k, (sid, seed) in enumerate(scenarios):
        for j, spk in enumerate(speakers):
            conds: list[tuple[str | None, float | None]] = [(None, None)]
            for i, snr in enumerate(opts.snrs):
                conds.append((noise_names[(k * len(speakers) + j + i) % len(noise_names)], float(snr)))
            units.append(_Unit(k, sid, seed, spk, tuple(conds)))
    return units


def build_dataset(
    opts: BuildOptions,
    out: str | Path,
    workers: int = 1,
    progress: Callable[[int, int], None] | None = None,
    backend: Any = None,
) -> Dataset:
    """Build (or finish building) a dataset in ``out``; return it loaded.

    WAVs already in ``out/audio`` are reused, so an interrupted build resumes where it stopped.
    The manifest is written at the end, in a fixed order, whatever the number of workers.

    Args:
        opts: what to build.
        out: the dataset folder (created).
        workers: processes for synthesis and mixing (1 = in this process).
        progress: called with (units done, units total) after each scenario x speaker.
        backend: ``"local"`` (default), ``"ray"`` or a backend object (bench/backends.py).
    """
    from siftom.bench.backends import make_backend
    from siftom.bench.runlock import RunLock, stop_on_signals

    fresh = not Path(out).exists()
    try:
        with RunLock(out), stop_on_signals():
            owned = backend is None or isinstance(backend, str)
            be = make_backend(backend or "local", workers) if owned else backend
            try:
                return _build(opts, Path(out), be, progress)
            finally:
                if owned:
                    be.shutdown()
    except Exception:
        if fresh:
            _remove_if_empty(Path(out))
        raise


def _remove_if_empty(root: Path) -> None:
    """Remove a folder this build created when it failed before writing any audio (nothing to resume)."""
    audio = root / AUDIO_DIR
    if audio.is_dir() and not any(audio.iterdir()):
        audio.rmdir()
    left = {p.name for p in root.iterdir()} if root.is_dir() else {"?"}
    if left <= {SPEC}:
        (root / SPEC).unlink(missing_ok=True)
        root.rmdir()


def _build(opts: BuildOptions, root: Path, be: Any, progress: Callable[[int, int], None] | None) -> Dataset:
    from siftom.scenarios.base import get_domain

    get_domain(opts.domain)  # unknown domain: UnknownNameError with suggestions
    spec_path = root / SPEC
    if spec_path.is_file():
        old = json.loads(spec_path.read_text(encoding="utf-8")).get("options")
        if old is not None and old != opts.to_json():
            raise DatasetError(
                f"{root} already holds a dataset built with other options ({old}); "
                "use another --out folder or delete this one"
            )
    (root / AUDIO_DIR).mkdir(parents=True, exist_ok=True)
    for tmp in (root / AUDIO_DIR).glob("*.tmp.wav"):  # left by a stopped worker; we hold the lock
        tmp.unlink()
    t0 = time.perf_counter()
    units = plan_units(opts)
    spec = {"format_version": FORMAT_VERSION, "options": opts.to_json(),
            "speakers": [s.__dict__ for s in make_speakers(opts)]}
    spec_path.write_text(json.dumps(spec, indent=2) + "\n", encoding="utf-8")
    results: list[list[Stimulus]] = [[] for _ in units]
    # units go out in order and come back in any order; the manifest keeps the order
    for n, (i, rows) in enumerate(be.map_unordered(_worker_build, units, shared=(opts, str(root))), 1):
        results[i] = rows
        if progress:
            progress(n, len(units))
    stimuli = [s for rows in results for s in rows]
    tmp = root / (MANIFEST + ".tmp")
    tmp.write_text("".join(json.dumps(s.to_json()) + "\n" for s in stimuli), encoding="utf-8")
    os.replace(tmp, root / MANIFEST)
    ds = Dataset(root, tuple(stimuli), spec)
    write_datasheet(ds, opts, seconds=time.perf_counter() - t0)
    return ds


# -- the datasheet -----------------------------------------------------------------------------

def _table(rows: Iterable[Sequence[Any]], header: Sequence[str]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def _phrasing_note(opts: BuildOptions) -> str:
    if opts.phrasings is None:
        return ("Instructions are drawn from siftom's phrasing model "
                "(`siftom.likelihood.phrasing.sample_phrasing`: direct, polite and indirect carriers, with\n"
                "or without the count, synonyms and category words)")
    return (f"Instructions put a carrier drawn uniformly from `{opts.phrasings}` around a noun phrase drawn "
            "as in\n`sample_phrasing` (with or without the count, synonyms and category words)")


def _world_note(opts: BuildOptions) -> str:
    if opts.world_seed is None:
        return "the registered scenario id"
    return (f"`generate(scenario_seed)`: every world was drawn from world seed {opts.world_seed}, none is a\n"
            "registered scenario, so no constant of siftom was tuned on them")


def _grammar_limit(opts: BuildOptions) -> str:
    if opts.phrasings is None:
        return ("* The phrasings come from the same grammar that the model's instruction likelihood and the\n"
                "  domain-biased recogniser use, so no instruction falls outside the model's vocabulary.")
    return ("* The carriers come from a file, but the noun phrases (counts, names, category words) still\n"
            "  come from siftom's lexicon, so no object is named in a way the model does not know.")


def write_datasheet(ds: Dataset, opts: BuildOptions, seconds: float | None = None) -> Path:
    """Write ``README.md`` in the dataset folder: what is in it, how it was made, its limits."""
    st = ds.stimuli
    speakers = {s.speaker: s for s in st}
    by_cond = Counter(s.condition if s.noise is None else s.noise for s in st)
    by_snr = Counter("clean" if s.snr_db is None else f"{s.snr_db:g} dB" for s in st)
    by_style = Counter(s.style or "?" for s in st if s.noise is None)
    dur = [s.duration_s for s in st if s.noise is None]
    cmd = (f"siftom dataset build --domain {opts.domain} --out DIR --scenarios {opts.scenarios} "
           f"--speakers {opts.speakers} --voices {','.join(opts.voices)}"
           + (f" --noise-dir {opts.noise_dir}" if opts.noise_dir else "")
           + (f" --noises {','.join(opts.noises)}" if opts.noises else "")
           + f" --snr {','.join(f'{x:g}' for x in opts.snrs) or 'none'} --seed {opts.seed}"
           + (f" --phrasings {opts.phrasings}" if opts.phrasings else "")
           + (f" --room {opts.room:g}" if opts.room is not None else "")
           + (f" --world-seed {opts.world_seed}" if opts.world_seed is not None else ""))
    examples = [s for s in st if s.noise is None][:6]
    text = f"""# Datasheet: {ds.root.name}

A synthetic UnclearInstruct-style dataset of spoken robot instructions, built by siftom
(paper, Simulated Experiment). {len(st)} stimuli: {len({s.scenario for s in st})} scenarios of
`{opts.domain}` x {len(speakers)} speakers x {len(st) // max(1, len({(s.scenario, s.speaker) for s in st}))} conditions
(clean + one noisy version per SNR).

## Motivation
To measure how well a robot infers what a person asks for from a noisy spoken instruction
and what the person was doing, with the paper's metrics (accuracy, speedup, helpful errors).

## Composition
Each line of `manifest.jsonl` is one stimulus: the scenario (world, start state, goal space
come from {_world_note(opts)}), the human's observed actions, the WAV, the reference
transcript, the gold goal and the gold robot command, the speaker and voice, noise type and SNR.
The format is documented in docs/dataset-format.md of the siftom repository.

Speakers:

{_table([(k, v.voice, v.rate, v.pitch) for k, v in sorted(speakers.items())], ["speaker", "voice", "rate", "pitch"])}

Stimuli by noise type: {", ".join(f"{k} {v}" for k, v in sorted(by_cond.items()))}.
By SNR: {", ".join(f"{k} {v}" for k, v in sorted(by_snr.items()))}.
Phrasing styles (clean clips): {", ".join(f"{k} {v}" for k, v in sorted(by_style.items()))}.
Clip length: {min(dur):.1f}-{max(dur):.1f} s (mean {np.mean(dur):.1f} s).

Examples:

{_table([(s.id, s.scenario, f'"{s.reference}"', s.gold_command) for s in examples], ["id", "scenario", "said", "gold command"])}

## Collection process
Nothing was recorded from people. {_phrasing_note(opts)}, spoken by offline TTS (flite, espeak-ng)
with a per-speaker rate and pitch, and mixed with noise at the stated SNR measured over active
speech (`siftom.speech.noise.mix_at_snr`). Noise: {"recordings in " + str(opts.noise_dir) if opts.noise_dir else "synthetic (" + ", ".join(SYNTHETIC_NOISES) + ")"}.

Rebuild bit for bit with:

    {cmd}

## Limitations
* TTS voices stand in for the paper's five non-native speakers; accented espeak-ng voices are
  harder for the recogniser than the flite voices, but no voice hesitates, restarts or mixes
  languages as people do.
{_grammar_limit(opts)}
* Noise is added, not recorded in a room (no reverberation, no Lombard effect).
"""
    if seconds is not None:
        text += f"\nBuilt in {seconds:.0f} s.\n"
    p = ds.root / "README.md"
    p.write_text(text, encoding="utf-8")
    return p
