"""The datasheet of a built dataset (``README.md`` in its folder): what is in it, how it was made,
its limits (Gebru et al.'s questions, in short). :mod:`siftom.bench.dataset` writes it after a build.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from siftom.people.stimuli import SYNTHETIC_NOISES, BuildOptions, Dataset


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


def _rooms_note(st: Sequence[Any]) -> str:
    """`` By room and talker distance: ...`` for a set built with ``--rooms``; '' otherwise."""
    pairs = Counter(f"{s.extra['room_name']} at {s.extra['distance_m']:g} m" for s in st if "room_name" in s.extra)
    if not pairs:
        return ""
    return ("\nBy room and talker distance (pyroomacoustics image-source responses, `siftom.speech.rooms`): "
            + ", ".join(f"{k} {v}" for k, v in sorted(pairs.items())) + ".")


def _room_limit(opts: BuildOptions) -> str:
    if opts.rooms:
        return ("Rooms are empty shoeboxes with one absorption for every wall (no furniture to scatter sound);\n"
                "  noise is added at the microphone, not played in the room; no Lombard effect.")
    return "Noise is added, not recorded in a room (no reverberation, no Lombard effect)."


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
           + (f" --rooms {','.join(opts.rooms)} --distances {','.join(f'{d:g}' for d in opts.distances)}"
              if opts.rooms else "")
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
By SNR: {", ".join(f"{k} {v}" for k, v in sorted(by_snr.items()))}.{_rooms_note(st)}
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
* {_room_limit(opts)}
"""
    if seconds is not None:
        text += f"\nBuilt in {seconds:.0f} s.\n"
    p = ds.root / "README.md"
    p.write_text(text, encoding="utf-8")
    return p
