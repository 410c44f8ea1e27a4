"""Noisy copies of a dataset's clean recordings (``siftom dataset mix``).

Each clean stimulus gets one noisy copy per SNR, mixed at that SNR over active speech
(:func:`siftom.speech.noise.mix_at_snr`). The noise type rotates over the noise folder's
categories so that every category meets every SNR about equally often, as ``siftom dataset
build`` does: 130 clean recordings x (1 + 3 SNRs) = the paper's 520 stimuli. The default noise
is the recordings that ship with siftom (:data:`siftom.speech.noise.RECORDED_NOISE_DIR`).

Mixing again replaces the copies an earlier mix made (so a re-recorded clip gets fresh ones) and
gives the same bytes for the same options: each excerpt is drawn from a generator seeded with
``[seed, clean id, SNR, noise type]``.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from siftom.errors import DatasetError
from siftom.people.stimuli import (
    AUDIO_DIR,
    FORMAT_VERSION,
    MANIFEST,
    SPEC,
    Dataset,
    Stimulus,
    load_dataset,
)

MIXED_FROM = "mixed_from"  # the extra key that marks a copy made here


@dataclass(frozen=True)
class MixOptions:
    """How to mix. Validated at construction.

    Attributes:
        noise_dir: a folder of noise WAVs named ``CATEGORY_NN.wav``; None: the shipped recordings.
        noises: the categories to use (default: all of the folder's).
        snrs: one noisy copy per SNR in dB.
        seed: drives the noise excerpts.
    """

    noise_dir: str | None = None
    noises: tuple[str, ...] = ()
    snrs: tuple[float, ...] = (20.0, 10.0, 5.0)
    seed: int = 0

    def __post_init__(self) -> None:
        if not self.snrs:
            raise DatasetError("give at least one SNR, e.g. --snr 20,10,5")
        if any(not np.isfinite(s) for s in self.snrs) or len(set(self.snrs)) != len(self.snrs):
            raise DatasetError(f"--snr values must be distinct finite numbers of dB, got {self.snrs}")
        if self.noise_dir is not None and not Path(self.noise_dir).is_dir():
            raise DatasetError(f"--noise-dir {self.noise_dir!r} is not a folder; give a folder of CATEGORY_NN.wav files")

    @property
    def folder(self) -> str:
        from siftom.speech.noise import RECORDED_NOISE_DIR

        return str(self.noise_dir or RECORDED_NOISE_DIR)


def _tag(noise: str, snr: float) -> str:
    return f"{re.sub(r'[^A-Za-z0-9]+', '_', noise)}-{snr:g}db".replace(".", "p")


def _stable(s: str) -> int:
    return int(hashlib.sha1(s.encode()).hexdigest()[:8], 16)


def mix_dataset(folder: str | Path, options: MixOptions | None = None) -> tuple[Dataset, int]:
    """Add noisy copies of every clean stimulus in ``folder``; return (the dataset, copies written)."""
    from siftom.bench.runlock import RunLock

    if not Path(folder).is_dir():
        load_dataset(folder)  # says how to make one
    with RunLock(folder):  # not while siftom collect records into the folder
        return _mix(folder, options or MixOptions())


def _mix(folder: str | Path, opts: MixOptions) -> tuple[Dataset, int]:
    from siftom.bench.dataset import noise_categories
    from siftom.speech.audio import load_audio, write_wav
    from siftom.speech.noise import FolderNoise, mix_at_snr

    ds = load_dataset(folder)
    cats = noise_categories(opts.folder)
    names = list(opts.noises) or cats
    unknown = [n for n in names if n not in cats]
    if not cats or unknown:
        raise DatasetError(f"noise {', '.join(unknown) or 'folder'}: {opts.folder} has the categories "
                           f"{', '.join(cats) or '(none)'}; name files CATEGORY_NN.wav")
    sources = {n: FolderNoise(opts.folder, categories=(n,)) for n in names}
    kept = [s for s in ds.stimuli if MIXED_FROM not in s.extra]
    clean = [s for s in kept if s.noise is None]
    if not clean:
        raise DatasetError(f"{ds.root} has no clean stimuli to mix (every line has 'noise')")
    taken = {s.id for s in kept}
    out: list[Stimulus] = []
    written = 0
    u = 0
    for s in kept:
        out.append(s)
        if s.noise is not None:
            continue
        base = s.id.removesuffix("-clean")
        x = None
        for i, snr in enumerate(opts.snrs):
            noise = names[(u + i) % len(names)]
            sid = f"{base}-{_tag(noise, float(snr))}"
            if sid in taken:
                raise DatasetError(f"{ds.root}: stimulus {sid!r} exists and was not made by a mix; rename it")
            rel = f"{AUDIO_DIR}/{sid}.wav"
            if x is None:
                x = load_audio(ds.audio_path(s))
            rng = np.random.default_rng([opts.seed, _stable(s.id), int(round(float(snr) * 100)), _stable(noise)])
            y = mix_at_snr(x, sources[noise], float(snr), rng)
            tmp = ds.root / f"{rel}.{os.getpid()}.tmp.wav"
            _folder_like(tmp.parent, ds.root)
            _created_like(tmp, ds.audio_path(s))  # a private recording's copy is private from its first byte
            write_wav(tmp, y)
            os.replace(tmp, ds.root / rel)
            written += 1
            out.append(replace(s, id=sid, audio=rel, noise=noise, snr_db=float(snr),
                               duration_s=round(len(y) / 16000, 3), extra={**s.extra, MIXED_FROM: s.id}))
        u += 1
    dropped = {s.audio for s in ds.stimuli if MIXED_FROM in s.extra} - {s.audio for s in out}
    for rel in dropped:  # copies of an earlier mix with other options
        (ds.root / rel).unlink(missing_ok=True)
    tmp = ds.root / f".{MANIFEST}.{os.getpid()}.tmp"
    _created_like(tmp, ds.root / MANIFEST)
    tmp.write_text("".join(json.dumps(s.to_json()) + "\n" for s in out), encoding="utf-8")
    os.replace(tmp, ds.root / MANIFEST)
    _record(ds.root, opts)
    return load_dataset(ds.root), written


def _record(root: Path, opts: MixOptions) -> None:
    """Note the mix in dataset.json (the noise folder is where the benchmark's spoken answers get their noise)."""
    path = root / SPEC
    spec: dict[str, Any] = {"format_version": FORMAT_VERSION}
    if path.is_file():
        try:
            spec = json.loads(path.read_text(encoding="utf-8"))
        except json.JSONDecodeError:
            raise DatasetError(f"{path}: not valid JSON; fix or delete it") from None
    spec["mix"] = {"noise_dir": opts.folder, "noises": list(opts.noises), "snrs": list(opts.snrs), "seed": opts.seed}
    if "collection" in spec or "options" not in spec:  # a built dataset keeps its build options as they were
        spec.setdefault("options", {})["noise_dir"] = opts.folder
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    _created_like(tmp, path if path.is_file() else root / MANIFEST)
    tmp.write_text(json.dumps(spec, indent=2) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def _created_like(path: Path, like: Path) -> None:
    """Create ``path`` empty with the permission bits of ``like`` (a file the dataset has), so a
    private collection (0600 voices and manifest, ``siftom collect``) stays private; a shared one
    keeps its modes too."""
    import stat

    mode = stat.S_IMODE(like.stat().st_mode)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, mode)
    try:
        os.fchmod(fd, mode)  # the mode above went through the umask
    finally:
        os.close(fd)


def _folder_like(folder: Path, root: Path) -> None:
    """``folder`` and its missing parents made with the dataset folder's permission bits."""
    import stat

    if folder.is_dir():
        return
    mode = stat.S_IMODE(root.stat().st_mode)
    folder.mkdir(parents=True, exist_ok=True)
    for d in (folder, *folder.parents):
        if d == root or root not in d.parents:
            break
        os.chmod(d, mode)
