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
* rooms (``--rooms kitchen,living --distances 1,3``): each scenario x speaker is heard in one
  simulated room at one talker distance (``siftom.speech.rooms``, an image-source response), every
  room x distance pair equally often, before the noise; the manifest's ``extra`` names them.

Everything random is drawn from generators seeded with ``[seed, scenario index, speaker index,
...]``, so a build is reproducible bit for bit and independent of the number of workers.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import time
from collections.abc import Callable
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
    room: tuple[str, float] | None = None  # (room preset, talker distance in m) with --rooms


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
                if unit.room is not None:  # the talker in a simulated room, placed afresh per clip
                    from siftom.speech.rooms import reverberate_in_room

                    clean = reverberate_in_room(clean, *unit.room, np.random.default_rng([opts.seed, unit.k, j, 5]))
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
            extra=_extra(unit, opts),
        ))
    return rows


def _extra(unit: _Unit, opts: BuildOptions) -> dict[str, Any]:
    """The manifest's ``extra``: the generated world (``--world-seed``), the room and distance (``--rooms``)."""
    out: dict[str, Any] = {} if opts.world_seed is None else {"world_seed": opts.world_seed, "world": unit.k}
    if unit.room is not None:
        from siftom.speech.rooms import get_room

        out.update(room_name=unit.room[0], distance_m=unit.room[1], rt60_s=get_room(unit.room[0]).rt60)
    return out


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
    # every room x distance in a seeded order; unit u takes pair (u + u // pairs) % pairs: each block of
    # `pairs` units meets every pair once, and the shift per block lets every speaker meet every pair
    pairs = [(r, float(d)) for r in opts.rooms for d in opts.distances]
    pairs = [pairs[i] for i in np.random.default_rng([opts.seed, 9002]).permutation(len(pairs))]
    units = []
    for k, (sid, seed) in enumerate(scenarios):
        for j, spk in enumerate(speakers):
            conds: list[tuple[str | None, float | None]] = [(None, None)]
            for i, snr in enumerate(opts.snrs):
                conds.append((noise_names[(k * len(speakers) + j + i) % len(noise_names)], float(snr)))
            u = k * len(speakers) + j
            room = pairs[(u + u // len(pairs)) % len(pairs)] if pairs else None
            units.append(_Unit(k, sid, seed, spk, tuple(conds), room))
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
    from siftom.bench.datasheet import write_datasheet

    write_datasheet(ds, opts, seconds=time.perf_counter() - t0)
    return ds
