"""The dataset format: stimuli, the manifest, build options, and loading a dataset folder.

docs/dataset-format.md documents the format so that real recordings can be brought in;
:mod:`siftom.bench.dataset` builds datasets in it.
"""

from __future__ import annotations

import hashlib
import json
import re
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


RECORDED = "recorded"


def noise_folder(noise_dir: str | Path) -> Path:
    """The folder a ``--noise-dir`` value names: ``recorded`` is the recordings shipped with siftom."""
    if str(noise_dir) == RECORDED:
        from siftom.speech.noise import RECORDED_NOISE_DIR

        return Path(RECORDED_NOISE_DIR)
    return Path(noise_dir)


def check_seed(seed: object, name: str = "--seed") -> None:
    """Seeds are integers >= 0 (numpy's generators take nothing else)."""
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise DatasetError(f"{name} must be an integer >= 0, got {seed!r}")


@dataclass(frozen=True)
class BuildOptions:
    """What to build. Validated at construction.

    Attributes:
        domain: a registered domain id (``household-table-v0``, ``kitchen-v0``).
        scenarios: how many scenarios (registered ones first, then generated; with
            ``world_seed``, all generated).
        speakers: how many speakers; voices are used in order and repeat when fewer.
        voices: TTS voice names (``siftom voices``).
        noise_dir: a folder of noise WAVs named ``CATEGORY_NN.wav`` (or MS-SNSD style);
            ``"recorded"`` is the real recordings shipped with siftom
            (``siftom.speech.noise.RECORDED_NOISE_DIR``); None uses synthetic noise.
        noises: noise types: categories of ``noise_dir`` (default: all of them) or synthetic
            kinds (default: babble, pink, hum), or WAV paths.
        snrs: one noisy condition per SNR in dB; () keeps only clean clips.
        seed: drives phrasings, speakers' rate and pitch, noise types and excerpts.
        phrasings: a carrier file (one carrier with ``{np}`` per line) or a shipped set name
            (``free-v0``); carriers are drawn uniformly from it instead of the built-in
            grammar, noun phrases as before. None: ``sample_phrasing``.
        room: reverberation time RT60 in seconds: every clip is heard across a reverberant room
            (``siftom.speech.room``, a seeded synthetic impulse response per clip) before the
            noise is added; None: dry speech.
        world_seed: draw the scenarios from this seed instead of taking the registered ones:
            ``scenarios`` worlds generated with ``world_scenario_seed(world_seed, k)``
            (siftom.scenarios.base), which never meet the seeds the registered scenarios and
            every tuned constant came from. None: registered scenarios first, then generated
            ones (``generate(i)``), as before.
        rooms, distances: rooms (``siftom.speech.rooms.ROOMS``) and talker distances in metres: each
            scenario x speaker is heard in one room at one distance (an image-source response), every
            pair equally often; the manifest's ``extra`` says which (``room``: not with these).
    """

    domain: str = "household-table-v0"
    scenarios: int = DEFAULT_SCENARIOS
    speakers: int = DEFAULT_SPEAKERS
    voices: tuple[str, ...] = DEFAULT_VOICES
    noise_dir: str | None = None
    noises: tuple[str, ...] = ()
    snrs: tuple[float, ...] = DEFAULT_SNRS
    seed: int = 0
    phrasings: str | None = None
    room: float | None = None
    world_seed: int | None = None
    rooms: tuple[str, ...] = ()
    distances: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        check_seed(self.seed)
        if self.world_seed is not None:
            check_seed(self.world_seed, "--world-seed")
        from siftom.scenarios.base import get_domain

        get_domain(self.domain)  # unknown domain: UnknownNameError with suggestions, before any work
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
        if self.noise_dir is not None and not noise_folder(self.noise_dir).is_dir():
            raise DatasetError(f"--noise-dir {self.noise_dir!r} is not a folder; give a folder of noise WAVs")
        if self.phrasings is not None:
            from siftom.likelihood.carriers import load_carriers

            load_carriers(self.phrasings)  # DatasetError for a missing file or no {np} line
        if self.room is not None and not (np.isfinite(self.room) and 0.05 <= self.room <= 3.0):
            raise DatasetError(f"--room is a reverberation time RT60 in seconds (0.05-3), got {self.room}")
        if self.rooms or self.distances:  # DatasetError naming the presets or the range
            from siftom.speech.rooms import check_rooms
            check_rooms(self.rooms, self.distances, self.room)

    def to_json(self) -> dict[str, Any]:
        """Plain dict (stored in dataset.json)."""
        return {"domain": self.domain, "scenarios": self.scenarios, "speakers": self.speakers,
                "voices": list(self.voices), "noise_dir": self.noise_dir, "noises": list(self.noises),
                "snrs": list(self.snrs), "seed": self.seed,
                **({"phrasings": self.phrasings} if self.phrasings is not None else {}),
                **({"room": self.room} if self.room is not None else {}),
                **({"world_seed": self.world_seed} if self.world_seed is not None else {}),
                **({"rooms": list(self.rooms), "distances": list(self.distances)} if self.rooms else {})}


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

def select_scenarios(domain: str, n: int, world_seed: int | None = None) -> list[tuple[str, int | None]]:
    """The first ``n`` scenarios of a domain as (id, seed): registered ones, then generated.

    With ``world_seed``, no registered scenario: ``n`` worlds generated from
    ``world_scenario_seed(world_seed, k)`` for k = 0..n-1, with ids ``DOMAIN/wW-k``.
    """
    from siftom.scenarios.base import get_domain, world_scenario_seed

    if world_seed is not None:
        check_seed(world_seed, "--world-seed")
        worlds: list[tuple[str, int | None]] = [
            (world_scenario_id(domain, world_seed, k), world_scenario_seed(world_seed, k)) for k in range(n)]
        if len({seed for _sid, seed in worlds}) != n:  # 52-bit hashes: never seen, but a build must not repeat a world
            raise DatasetError(f"--world-seed {world_seed} draws one generator seed twice; use another world seed")
        return worlds

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


def world_scenario_id(domain: str, world_seed: int, k: int) -> str:
    """The id of scenario ``k`` of a ``--world-seed`` build: ``kitchen-v0/w7-0``."""
    return f"{domain}/w{world_seed}-{k}"


# (scenario, seed) for the registered or generated scenario; (scenario, seed, actions) for a manifest's own
_SCENARIOS: dict[tuple[str, int | None] | tuple[str, int | None, tuple[str, ...]], Any] = {}


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
        _SCENARIOS[key] = replace(sc, actions=tuple(acts))
    return _SCENARIOS[key]


# -- building ----------------------------------------------------------------------------------

