"""Results as data: run a plan of dataset builds and evaluations, stamp each summary.

A plan (TOML) lists evaluation sets::

    [defaults]
    models = ["literal-asr", "speech-only", "action-only", "siftom", "siftom-oracle-text"]

    [[set]]
    name = "household-s0"
    title = "household, seed 0, recorded noise"
    domain = "household-table-v0"
    seed = 0
    noise_dir = "recorded"          # the recordings shipped with siftom; omit for synthetic noise
    # voices, noises, phrasings, scenarios, speakers, snr, world_seed: as `siftom dataset build`

For each set :func:`reproduce` builds the dataset (``OUT/runs/NAME/dataset``), evaluates it
(``OUT/runs/NAME/results``, resumable) and writes ``OUT/NAME.json``: the evaluator's summary
stamped with the package version, the dataset's fingerprint (a hash of its manifest), the
machine (CPU count, platform) and the commands that made it. ``siftom.bench.pages`` turns
those files into the documentation's results pages and the README's table.
"""

from __future__ import annotations

import json
import time
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from siftom.bench.machine import Machine
from siftom.errors import DatasetError

if TYPE_CHECKING:
    from siftom.bench.results_io import Provenance

RESULT_FORMAT = 1
SET_KEYS = {"name", "title", "domain", "seed", "noise_dir", "noises", "voices", "phrasings", "scenarios",
            "speakers", "snr", "models", "engine", "world_seed"}


@dataclass(frozen=True)
class EvalSet:
    """One evaluation set of a plan: how its dataset is built and which models are scored."""

    name: str
    title: str
    domain: str
    seed: int
    models: tuple[str, ...]
    noise_dir: str | None = None
    noises: tuple[str, ...] = ()
    voices: tuple[str, ...] = ()
    phrasings: str | None = None
    scenarios: int = 26
    speakers: int = 5
    snr: tuple[float, ...] = (20.0, 10.0, 5.0)
    engine: str = "pocketsphinx-vocab"
    world_seed: int | None = None  # generated worlds nobody tuned on (`--world-seed`); None: registered scenarios

    def build_command(self, out: str) -> str:
        """The ``siftom dataset build`` command line for this set."""
        parts = [f"siftom dataset build --domain {self.domain} --out {out} --seed {self.seed}",
                 f"--scenarios {self.scenarios} --speakers {self.speakers}",
                 f"--snr {','.join(f'{x:g}' for x in self.snr) or 'none'}"]
        if self.voices:
            parts.append(f"--voices {','.join(self.voices)}")
        if self.noise_dir:
            parts.append(f"--noise-dir {self.noise_dir}")
        if self.noises:
            parts.append(f"--noises {','.join(self.noises)}")
        if self.phrasings:
            parts.append(f"--phrasings {self.phrasings}")
        if self.world_seed is not None:
            parts.append(f"--world-seed {self.world_seed}")
        return " ".join(parts)

    def eval_command(self, dataset: str, out: str) -> str:
        """The ``siftom eval`` command line for this set."""
        return (f"siftom eval --dataset {dataset} --out {out} --models {','.join(self.models)} "
                f"--engine {self.engine}")


@dataclass(frozen=True)
class Plan:
    """The sets of a plan file, in file order."""

    path: str
    sets: tuple[EvalSet, ...] = field(default_factory=tuple)


def load_plan(path: str | Path) -> Plan:
    """Read and check a plan TOML; raise DatasetError naming what to fix."""
    p = Path(path)
    if not p.is_file():
        raise DatasetError(f"plan {str(p)!r} does not exist; give a TOML file with [[set]] tables")
    try:
        raw = tomllib.loads(p.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise DatasetError(f"plan {str(p)!r} is not valid TOML: {exc}") from None
    defaults = dict(raw.get("defaults", {}))
    sets = []
    for i, s in enumerate(raw.get("set", [])):
        merged = {**defaults, **s}
        unknown = sorted(set(merged) - SET_KEYS)
        if unknown:
            raise DatasetError(f"plan set {i + 1}: unknown key(s) {', '.join(unknown)}; known: {', '.join(sorted(SET_KEYS))}")
        for key in ("name", "domain", "models"):
            if key not in merged:
                raise DatasetError(f"plan set {i + 1}: missing {key!r}")
        sets.append(EvalSet(
            name=str(merged["name"]), title=str(merged.get("title", merged["name"])), domain=str(merged["domain"]),
            seed=int(merged.get("seed", 0)), models=tuple(merged["models"]),
            noise_dir=merged.get("noise_dir"), noises=tuple(merged.get("noises", ())),
            voices=tuple(merged.get("voices", ())), phrasings=merged.get("phrasings"),
            scenarios=int(merged.get("scenarios", 26)), speakers=int(merged.get("speakers", 5)),
            snr=tuple(float(x) for x in merged.get("snr", (20, 10, 5))),
            engine=str(merged.get("engine", "pocketsphinx-vocab")),
            world_seed=_world_seed(merged.get("world_seed"), i)))
    if not sets:
        raise DatasetError(f"plan {str(p)!r} lists no [[set]]")
    names = [s.name for s in sets]
    if len(set(names)) != len(names):
        raise DatasetError(f"plan {str(p)!r} names a set twice: {names}")
    return Plan(str(p), tuple(sets))


def _world_seed(value: object, i: int) -> int | None:
    if value is None:
        return None
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        raise DatasetError(f"plan set {i + 1}: world_seed must be an integer >= 0, got {value!r}")
    return value


@dataclass(frozen=True)
class SetData:
    """The dataset a set was evaluated on: its fingerprint, stimuli, domain, seed and world seed."""

    fingerprint: str
    stimuli: int
    domain: str
    seed: int
    world_seed: int | None = None

    def to_json(self) -> dict[str, Any]:
        """The ``dataset`` entry of ``NAME.json``."""
        return {"fingerprint": self.fingerprint, "stimuli": self.stimuli, "domain": self.domain, "seed": self.seed,
                **({"world_seed": self.world_seed} if self.world_seed is not None else {})}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> SetData:
        """Read :meth:`to_json`'s form."""
        return cls(str(data["fingerprint"]), int(data["stimuli"]), str(data["domain"]), int(data["seed"]),
                   data.get("world_seed"))


@dataclass(frozen=True)
class SetResult:
    """One set's stamped result, ``OUT/NAME.json`` (module doc): the evaluator's summary with the
    version and source hash that made it, its dataset, the machine, the commands and how long it took.

    Attributes:
        set: the set's name.
        title: its title in the pages.
        siftom: siftom's version.
        source_sha1: the hash of siftom's source code.
        dataset: the dataset evaluated.
        machine: where it ran.
        commands: the build and eval command lines.
        seconds: (build, total) seconds.
        summary: the evaluator's summary, as ``summary.json`` holds it (:mod:`siftom.bench.report`).
        format: the file's format version.
    """

    set: str
    title: str
    siftom: str
    source_sha1: str
    dataset: SetData
    machine: Machine
    commands: tuple[str, ...]
    seconds: tuple[float, float]
    summary: dict[str, Any]
    format: int = RESULT_FORMAT

    def to_json(self) -> dict[str, Any]:
        """The ``NAME.json`` form."""
        return {"format": self.format, "set": self.set, "title": self.title, "siftom": self.siftom,
                "source_sha1": self.source_sha1, "dataset": self.dataset.to_json(),
                "machine": self.machine.to_json("results"), "commands": list(self.commands),
                "seconds": {"build": self.seconds[0], "total": self.seconds[1]}, "summary": self.summary}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> SetResult:
        """Read :meth:`to_json`'s form."""
        secs = data.get("seconds") or {}
        return cls(set=str(data["set"]), title=str(data["title"]), siftom=str(data["siftom"]),
                   source_sha1=str(data.get("source_sha1", "?")), dataset=SetData.from_json(data["dataset"]),
                   machine=Machine.from_json(data.get("machine")), commands=tuple(data.get("commands", ())),
                   seconds=(float(secs.get("build", 0.0)), float(secs.get("total", 0.0))),
                   summary=dict(data["summary"]), format=int(data.get("format", RESULT_FORMAT)))


def _run_set(s: EvalSet, out: Path, backend: Any, progress: Callable[[str], None] | None = None) -> SetResult:
    """Build and evaluate one set; return the stamped result (also written to ``out/NAME.json``)."""
    from siftom import __version__
    from siftom.bench.dataset import build_dataset
    from siftom.bench.evaluate import EvalOptions, evaluate
    from siftom.bench.report import write_report
    from siftom.bench.results_io import code_version, provenance
    from siftom.people.stimuli import DEFAULT_VOICES, BuildOptions, load_dataset

    say = progress or (lambda _m: None)
    work = out / "runs" / s.name
    ds_dir, res_dir = work / "dataset", work / "results"
    opts = BuildOptions(domain=s.domain, scenarios=s.scenarios, speakers=s.speakers, voices=s.voices or DEFAULT_VOICES,
                        noise_dir=s.noise_dir, noises=s.noises, snrs=s.snr, seed=s.seed, phrasings=s.phrasings,
                        world_seed=s.world_seed)
    t0 = time.perf_counter()
    if (ds_dir / "manifest.jsonl").is_file() and json.loads((ds_dir / "dataset.json").read_text()).get("options") == opts.to_json():
        say(f"{s.name}: dataset already built")
        ds = load_dataset(ds_dir)
    else:
        say(f"{s.name}: building the dataset")
        ds = build_dataset(opts, ds_dir, backend=backend)
    t_build = time.perf_counter() - t0
    eval_opts = EvalOptions(models=s.models, engine=s.engine)
    stale = _stale(res_dir, provenance(eval_opts, ds.fingerprint))
    if stale:
        say(f"{s.name}: earlier results differ in {stale}; evaluating again from scratch")
    say(f"{s.name}: evaluating {len(ds.stimuli)} stimuli")
    evaluate(ds, res_dir, eval_opts, backend=backend, overwrite=bool(stale))
    summary = write_report(res_dir, figures=False)
    result = SetResult(
        set=s.name, title=s.title, siftom=__version__, source_sha1=code_version()["source_sha1"],
        dataset=SetData(ds.fingerprint, len(ds.stimuli), s.domain, s.seed, s.world_seed),
        machine=Machine.here(), commands=(s.build_command("DATASET"), s.eval_command("DATASET", "RESULTS")),
        seconds=(round(t_build, 1), round(time.perf_counter() - t0, 1)), summary=summary)
    (out / f"{s.name}.json").write_text(json.dumps(result.to_json(), indent=1, sort_keys=True) + "\n",
                                        encoding="utf-8")
    return result


def _stale(res_dir: Path, prov: Provenance) -> str:
    """What differs between the rows already in ``res_dir`` and this run ('' when none or the same)."""
    from siftom.bench.results_io import Provenance, provenance_mismatch

    path = res_dir / "results.jsonl"
    if not path.is_file():
        return ""
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        return "; ".join(provenance_mismatch(Provenance.from_json(row.get("provenance")), prov))
    return ""


def reproduce(plan: Plan, out: str | Path, backend: Any, only: tuple[str, ...] = (),
              progress: Callable[[str], None] | None = None) -> list[SetResult]:
    """Run every set of ``plan`` (or those named in ``only``) into ``out``."""
    root = Path(out)
    root.mkdir(parents=True, exist_ok=True)
    chosen = [s for s in plan.sets if not only or s.name in only]
    missing = sorted(set(only) - {s.name for s in plan.sets})
    if missing:
        raise DatasetError(f"no set named {', '.join(missing)} in {plan.path}; sets: "
                           + ", ".join(s.name for s in plan.sets))
    return [_run_set(s, root, backend, progress) for s in chosen]
