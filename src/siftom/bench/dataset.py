"""UnclearInstruct-style datasets: spoken instructions for scenarios, clean and in noise.

A dataset is a folder with ``manifest.jsonl`` (one :class:`Stimulus` a line), ``audio/*.wav``
(16 kHz mono 16-bit PCM), ``dataset.json`` (how it was built) and ``README.md`` (a datasheet).
docs/dataset-format.md documents the format so that real recordings can be brought in.

How a dataset is built (paper, Simulated Experiment, Dataset Construction):

* scenarios: the domain's registered scenarios in order (``household-table-v0/0..25``), then
  generated ones (``domain.generate(i)``) when more are asked for. The human has acted for a
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
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from siftom.errors import DatasetError, SiftomError, UnknownNameError

FORMAT_VERSION = 1
MANIFEST = "manifest.jsonl"
SPEC = "dataset.json"
AUDIO_DIR = "audio"
# Five speakers, mixed like the paper's five non-native participants: two flite voices
# (recognised well), a Klatt US voice and two accented espeak-ng Klatt voices (Hindi, French).
# Measured word error rates with the domain LM (clean): 0 %, 0 %, ~20 %, ~6 %, ~35 %.
DEFAULT_VOICES = ("flite-slt", "flite-awb", "espeak-en-us+klatt4", "espeak-hi+klatt", "espeak-fr+klatt")
SYNTHETIC_NOISES = ("babble", "pink", "hum")
DEFAULT_SNRS = (20.0, 10.0, 5.0)
DEFAULT_SCENARIOS = 26
DEFAULT_SPEAKERS = 5


@dataclass(frozen=True)
class Speaker:
    """A simulated participant: a voice with a personal speaking rate and pitch."""

    id: str
    voice: str
    rate: float = 1.0
    pitch: float = 1.0


@dataclass(frozen=True)
class BuildOptions:
    """What to build. Validated at construction.

    Attributes:
        domain: a registered domain id (``household-table-v0``, ``kitchen-v0``).
        scenarios: how many scenarios (registered ones first, then generated).
        speakers: how many speakers; voices are used in order and repeat when fewer.
        voices: TTS voice names (``siftom voices``).
        noise_dir: a folder of noise WAVs named ``CATEGORY_NN.wav`` (or MS-SNSD style); None
            uses synthetic noise.
        noises: noise types: categories of ``noise_dir`` (default: all of them) or synthetic
            kinds (default: babble, pink, hum), or WAV paths.
        snrs: one noisy condition per SNR in dB; () keeps only clean clips.
        seed: drives phrasings, speakers' rate and pitch, noise types and excerpts.
    """

    domain: str = "household-table-v0"
    scenarios: int = DEFAULT_SCENARIOS
    speakers: int = DEFAULT_SPEAKERS
    voices: tuple[str, ...] = DEFAULT_VOICES
    noise_dir: str | None = None
    noises: tuple[str, ...] = ()
    snrs: tuple[float, ...] = DEFAULT_SNRS
    seed: int = 0

    def __post_init__(self) -> None:
        if self.scenarios < 1:
            raise DatasetError(f"--scenarios must be >= 1, got {self.scenarios}")
        if self.speakers < 1:
            raise DatasetError(f"--speakers must be >= 1, got {self.speakers}")
        if not self.voices:
            raise DatasetError("give at least one voice, e.g. --voices flite-slt,flite-awb")
        if any(not np.isfinite(s) for s in self.snrs):
            raise DatasetError(f"--snr values must be finite numbers of dB, got {self.snrs}")
        if len(set(self.snrs)) != len(self.snrs):
            raise DatasetError(f"--snr lists a value twice: {self.snrs}")
        if self.noise_dir is not None and not Path(self.noise_dir).is_dir():
            raise DatasetError(f"--noise-dir {self.noise_dir!r} is not a folder; give a folder of noise WAVs")

    def to_json(self) -> dict[str, Any]:
        """Plain dict (stored in dataset.json)."""
        return {"domain": self.domain, "scenarios": self.scenarios, "speakers": self.speakers,
                "voices": list(self.voices), "noise_dir": self.noise_dir, "noises": list(self.noises),
                "snrs": list(self.snrs), "seed": self.seed}


@dataclass(frozen=True)
class Stimulus:
    """One line of ``manifest.jsonl``: a spoken instruction in one scenario and condition.

    Attributes:
        id: unique within the dataset, also the WAV's file name (``003-s2-babble-10db``).
        scenario: a registered scenario id (``household-table-v0/3``).
        domain: the domain id.
        scenario_seed: the seed to regenerate an unregistered scenario (``generate(seed)``);
            None for registered scenarios.
        observed_actions: the human's actions before speaking, ``grab(human, fork_1, drawer)``.
        audio: WAV path relative to the dataset folder.
        reference: what the speaker said (the reference transcript).
        gold_goal: ``{"name": ..., "counts": {class: n}}``, the human's goal.
        gold_command: the robot command asked for, ``deliver(fork,3)`` / ``fetch(cereal)``.
        speaker: speaker id (``s1``); voice, rate, pitch: how it was synthesised
            (``human`` and 1.0 for real recordings).
        noise: noise type, None when clean; snr_db: SNR in dB over active speech, None when clean.
        style: phrasing style when known (direct, polite, indirect, category), else ''.
        duration_s: clip length in seconds.
    """

    id: str
    scenario: str
    domain: str
    observed_actions: tuple[str, ...]
    audio: str
    reference: str
    gold_goal: dict[str, Any]
    gold_command: str
    speaker: str
    voice: str
    noise: str | None = None
    snr_db: float | None = None
    scenario_seed: int | None = None
    rate: float = 1.0
    pitch: float = 1.0
    style: str = ""
    duration_s: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict, compare=False)

    @property
    def condition(self) -> str:
        """``clean`` or ``NOISE@SNRdB``."""
        return "clean" if self.noise is None else f"{self.noise}@{self.snr_db:g}dB"

    def to_json(self) -> dict[str, Any]:
        """The manifest line (keys in a fixed order)."""
        d = {
            "id": self.id, "scenario": self.scenario, "domain": self.domain,
            "scenario_seed": self.scenario_seed, "speaker": self.speaker, "voice": self.voice,
            "rate": self.rate, "pitch": self.pitch, "style": self.style, "noise": self.noise,
            "snr_db": self.snr_db, "audio": self.audio, "duration_s": self.duration_s,
            "reference": self.reference, "observed_actions": list(self.observed_actions),
            "gold_goal": self.gold_goal, "gold_command": self.gold_command,
        }
        if self.extra:
            d["extra"] = self.extra
        return d

    @classmethod
    def from_json(cls, d: Any, where: str = "manifest") -> Stimulus:
        """Parse and check one manifest line; raise DatasetError saying what is wrong."""
        if not isinstance(d, dict):
            raise DatasetError(f"{where}: each line must be a JSON object, got {type(d).__name__}")
        missing = [k for k in REQUIRED_KEYS if k not in d]
        if missing:
            raise DatasetError(
                f"{where}: missing key(s) {', '.join(missing)}; every line needs "
                f"{', '.join(REQUIRED_KEYS)} (see docs/dataset-format.md)"
            )
        for k in ("id", "scenario", "domain", "audio", "reference", "gold_command", "speaker"):
            if not isinstance(d[k], str) or not d[k].strip():
                raise DatasetError(f"{where}: {k!r} must be a non-empty string, got {d[k]!r}")
        if not re.fullmatch(r"[A-Za-z0-9_.@+-]+", d["id"]):
            raise DatasetError(f"{where}: id {d['id']!r} may use only letters, digits and _ . @ + -")
        acts = d.get("observed_actions")
        if not isinstance(acts, list) or not all(isinstance(a, str) for a in acts):
            raise DatasetError(f"{where}: 'observed_actions' must be a list of strings like 'walk(human, fridge)'")
        goal = d.get("gold_goal")
        if not isinstance(goal, dict) or not isinstance(goal.get("counts"), dict):
            raise DatasetError(f"{where}: 'gold_goal' must be {{\"name\": ..., \"counts\": {{\"fork\": 3}}}}")
        from siftom.world.commands import RobotCommand

        try:
            RobotCommand.parse(d["gold_command"])
        except SiftomError as exc:
            raise DatasetError(f"{where}: gold_command: {exc}") from None
        noise, snr = d.get("noise"), d.get("snr_db")
        if (noise is None) != (snr is None):
            raise DatasetError(f"{where}: give both 'noise' and 'snr_db' for a noisy clip, or neither for a clean one")
        if snr is not None and (not isinstance(snr, int | float) or not np.isfinite(snr)):
            raise DatasetError(f"{where}: 'snr_db' must be a number of dB or null, got {snr!r}")
        seed = d.get("scenario_seed")
        if seed is not None and not isinstance(seed, int):
            raise DatasetError(f"{where}: 'scenario_seed' must be an integer or null, got {seed!r}")
        return cls(
            id=d["id"], scenario=d["scenario"], domain=d["domain"], observed_actions=tuple(acts),
            audio=d["audio"], reference=d["reference"], gold_goal=goal, gold_command=d["gold_command"],
            speaker=d["speaker"], voice=str(d.get("voice", "human")), noise=noise,
            snr_db=None if snr is None else float(snr), scenario_seed=seed,
            rate=float(d.get("rate", 1.0)), pitch=float(d.get("pitch", 1.0)), style=str(d.get("style", "")),
            duration_s=float(d.get("duration_s", 0.0)), extra=dict(d.get("extra", {}) or {}),
        )


REQUIRED_KEYS = ("id", "scenario", "domain", "observed_actions", "audio", "reference", "gold_goal",
                 "gold_command", "speaker")


@dataclass(frozen=True)
class Dataset:
    """A loaded dataset: its folder, stimuli in manifest order and the build spec (if any)."""

    root: Path
    stimuli: tuple[Stimulus, ...]
    spec: dict[str, Any] = field(default_factory=dict)

    def audio_path(self, s: Stimulus) -> Path:
        """Absolute path of a stimulus' WAV."""
        p = Path(s.audio)
        return p if p.is_absolute() else self.root / p

    @property
    def fingerprint(self) -> str:
        """Hash of the manifest content: a results folder belongs to one dataset."""
        blob = "\n".join(json.dumps(s.to_json(), sort_keys=True) for s in self.stimuli)
        return hashlib.sha1(blob.encode()).hexdigest()[:16]


def load_dataset(folder: str | Path, check_audio: bool = True) -> Dataset:
    """Read and check ``folder/manifest.jsonl``; raise DatasetError with what to fix."""
    root = Path(folder)
    if not root.is_dir():
        raise DatasetError(f"dataset folder {str(root)!r} does not exist; build one with: siftom dataset build --out {root}")
    mpath = root / MANIFEST
    if not mpath.is_file():
        raise DatasetError(
            f"{str(root)!r} has no {MANIFEST}; build a dataset with 'siftom dataset build --out {root}' "
            "or write one as described in docs/dataset-format.md"
        )
    stimuli: list[Stimulus] = []
    seen: set[str] = set()
    for n, line in enumerate(mpath.read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip():
            continue
        where = f"{mpath}:{n}"
        try:
            d = json.loads(line)
        except json.JSONDecodeError as exc:
            raise DatasetError(f"{where}: not valid JSON ({exc.msg}); each line must be one JSON object") from None
        s = Stimulus.from_json(d, where)
        if s.id in seen:
            raise DatasetError(f"{where}: stimulus id {s.id!r} appears twice; ids must be unique")
        seen.add(s.id)
        if check_audio:
            p = Path(s.audio) if Path(s.audio).is_absolute() else root / s.audio
            if not p.is_file():
                raise DatasetError(f"{where}: audio file {str(p)!r} is missing; rebuild the dataset or fix the path")
        stimuli.append(s)
    if not stimuli:
        raise DatasetError(f"{mpath} lists no stimuli; it must have one JSON object per line")
    spec: dict[str, Any] = {}
    if (root / SPEC).is_file():
        try:
            spec = json.loads((root / SPEC).read_text(encoding="utf-8"))
        except json.JSONDecodeError as exc:
            raise DatasetError(f"{root / SPEC}: not valid JSON ({exc.msg})") from None
    return Dataset(root, tuple(stimuli), spec)


# -- scenarios ---------------------------------------------------------------------------------

def select_scenarios(domain: str, n: int) -> list[tuple[str, int | None]]:
    """The first ``n`` scenarios of a domain as (id, seed): registered ones, then generated."""
    from siftom.scenarios.base import get_domain

    fixed = list(get_domain(domain).fixed())
    out: list[tuple[str, int | None]] = [(sid, None) for sid in fixed[:n]]
    taken = set(fixed)
    i = 0
    while len(out) < n:
        sid = f"{domain}/{i}"
        if sid not in taken:
            out.append((sid, i))
        i += 1
    return out


_SCENARIOS: dict[tuple[str, int | None], Any] = {}


def resolve_scenario(sid: str, domain: str, seed: int | None) -> Any:
    """The Scenario for a manifest's (scenario, domain, scenario_seed); cached per process."""
    from siftom.scenarios.base import get_domain, get_scenario

    key = (sid, seed)
    if key not in _SCENARIOS:
        if seed is None:
            try:
                _SCENARIOS[key] = get_scenario(sid)
            except UnknownNameError as exc:
                raise DatasetError(
                    f"scenario {sid!r} is not registered ({exc}); give 'scenario_seed' to generate it "
                    f"with {domain}.generate(seed)"
                ) from None
        else:
            _SCENARIOS[key] = get_domain(domain).generate(seed, sid=sid)
    return _SCENARIOS[key]


def scenario_for(s: Stimulus) -> Any:
    """The scenario of a stimulus, with the manifest's observed actions when they differ."""
    sc = resolve_scenario(s.scenario, s.domain, s.scenario_seed)
    if s.observed_actions == tuple(sc.world.format_action(a) for a in sc.actions):
        return sc
    key = (s.scenario, s.scenario_seed, s.observed_actions)
    if key not in _SCENARIOS:
        from siftom.world.model import apply

        state, acts = sc.start, []
        for k, text in enumerate(s.observed_actions):
            try:
                a = sc.world.parse_action(text, state)
                state = apply(state, a)
            except SiftomError as exc:
                raise DatasetError(f"stimulus {s.id}: observed_actions[{k}] {text!r}: {exc}") from None
            acts.append(a)
        _SCENARIOS[key] = replace(sc, actions=tuple(acts))  # type: ignore[index]
    return _SCENARIOS[key]  # type: ignore[index]


# -- building ----------------------------------------------------------------------------------

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
    root = Path(folder)
    sub = root / "noise_train"
    base = sub if sub.is_dir() else root
    cats = {re.sub(r"[_-]?\d+$", "", p.stem) for p in base.iterdir() if p.suffix.lower() == ".wav"}
    return sorted(c for c in cats if c)


def resolve_noises(opts: BuildOptions) -> list[tuple[str, Any]]:
    """(name, NoiseSource) for each noise type of the build."""
    from siftom.speech.noise import FolderNoise, get_noise

    if opts.noise_dir is not None:
        cats = noise_categories(opts.noise_dir)
        names = list(opts.noises) or cats
        out = []
        for n in names:
            if n in cats:
                out.append((n, FolderNoise(opts.noise_dir, categories=(n,))))
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
    out = []
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
    text = sample_phrasing(sc.command, default_lexicon(), rng)
    style = next((("category" if p.category else p.style) for p in phrasing_details(sc.command) if p.text == text), "")
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
            if noise is None:
                x = clean
            else:
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
        ))
    return rows


def _stable(s: str) -> int:
    return int(hashlib.sha1(s.encode()).hexdigest()[:8], 16)


def _worker_build(unit: _Unit, shared: tuple[BuildOptions, str]) -> list[Stimulus]:
    opts, out = shared
    return _build_unit(unit, opts, Path(out))


def plan_units(opts: BuildOptions) -> list[_Unit]:
    """Every scenario x speaker with its conditions (clean first, then one per SNR)."""
    scenarios = select_scenarios(opts.domain, opts.scenarios)
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

    with RunLock(out), stop_on_signals():
        owned = backend is None or isinstance(backend, str)
        be = make_backend(backend or "local", workers) if owned else backend
        try:
            return _build(opts, Path(out), be, progress)
        finally:
            if owned:
                be.shutdown()


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
           + f" --snr {','.join(f'{x:g}' for x in opts.snrs) or 'none'} --seed {opts.seed}")
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
come from the registered scenario id), the human's observed actions, the WAV, the reference
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
Nothing was recorded from people. Instructions are drawn from siftom's phrasing model
(`siftom.likelihood.phrasing.sample_phrasing`: direct, polite and indirect carriers, with
or without the count, synonyms and category words), spoken by offline TTS (flite, espeak-ng)
with a per-speaker rate and pitch, and mixed with noise at the stated SNR measured over active
speech (`siftom.speech.noise.mix_at_snr`). Noise: {"recordings in " + str(opts.noise_dir) if opts.noise_dir else "synthetic (" + ", ".join(SYNTHETIC_NOISES) + ")"}.

Rebuild bit for bit with:

    {cmd}

## Limitations
* TTS voices stand in for the paper's five non-native speakers; accented espeak-ng voices are
  harder for the recogniser than the flite voices, but no voice hesitates, restarts or mixes
  languages as people do.
* The phrasings come from the same grammar that the model's instruction likelihood and the
  domain-biased recogniser use, so no instruction falls outside the model's vocabulary.
* Noise is added, not recorded in a room (no reverberation, no Lombard effect).
"""
    if seconds is not None:
        text += f"\nBuilt in {seconds:.0f} s.\n"
    p = ds.root / "README.md"
    p.write_text(text, encoding="utf-8")
    return p
