"""Recording real people: a dataset folder that fills up as participants speak.

A participant sees each scenario (what the person has done so far and the goal in words), says
what they would ask the robot, and the recording is written in the dataset format of
docs/dataset-format.md: ``audio/NNN-PARTICIPANT-clean.wav`` (16 kHz mono 16-bit PCM) and one
``manifest.jsonl`` line with the scenario, the participant (``speaker``), the observed actions,
the gold goal and command and what they said (``reference``, typed by the participant).

Consent comes first: the text shown and the participant id are stored in
``participants.jsonl`` (with a hash of the text), and a recording of a participant who has not
agreed is refused. Agreeing gives the participant a secret key (``secrets.token_urlsafe``; only
its SHA-256 is stored): the page sends it with each recording, so nobody else can record as
them, and coming back under a taken id needs it. Everything stays in the folder; nothing is
sent anywhere.
:mod:`siftom.service.collect_app` serves the page; ``siftom collect`` starts it.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import secrets
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from siftom.errors import AudioError, DatasetError, NotYoursError
from siftom.people.records import Agreement
from siftom.people.stimuli import (
    AUDIO_DIR,
    FORMAT_VERSION,
    MANIFEST,
    SPEC,
    Stimulus,
    resolve_scenario,
    select_scenarios,
)
from siftom.private import append_private, make_private, private_dir, write_private_text

PARTICIPANTS = "participants.jsonl"
PARTICIPANT_ID = re.compile(r"[A-Za-z0-9_-]{1,32}")
MIN_SECONDS = 0.3
SILENT_PEAK = 1e-3  # a recording whose loudest sample is below this is a dead microphone
CONSENT_TEXT = (
    "You are taking part in a study of how robots understand spoken requests. You will see a few "
    "household scenes and say, in your own words, what you would ask a robot to do. Your voice is "
    "recorded on this computer only: the recordings, the words you type and the participant id "
    "below are saved in a local folder and are not sent anywhere. They may be mixed with "
    "background noise and played to other people who transcribe them. Taking part is voluntary; "
    "you can stop at any time, and ask for your recordings to be deleted. Do not say your name or "
    "anything else that identifies you in the recordings."
)


def check_participant(pid: str) -> str:
    """Return ``pid`` if it is a valid participant id, else raise DatasetError saying the rule."""
    if not isinstance(pid, str) or not PARTICIPANT_ID.fullmatch(pid):
        raise DatasetError(f"participant id {pid!r} is not valid: use 1-32 letters, digits, '_' or '-' "
                           "(e.g. p01), not a name")
    return pid


def key_digest(key: str) -> str:
    """What is stored of a person's key: its SHA-256."""
    return hashlib.sha256(key.encode("utf-8", "replace")).hexdigest()


def key_matches(key: str | None, digest: str | None) -> bool:
    """``key`` is the one ``digest`` was made from (constant-time)."""
    return bool(key) and bool(digest) and secrets.compare_digest(key_digest(key or ""), digest or "")


def _plural(obj_class: str, n: int) -> str:
    """The class's everyday name (``wine glass``), in the plural when ``n`` > 1."""
    from siftom.likelihood.lexicon import default_lexicon

    e = default_lexicon().entry(obj_class)
    return e.plural if n > 1 else e.singular


def _join(parts: list[str]) -> str:
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def goal_words(scenario: Any) -> str:
    """The human's goal in words, e.g. ``Set the table with 4 knives and 4 bowls.``"""
    counts = dict(scenario.goal.counts)
    if scenario.verb == "deliver":
        items = [f"{n} {_plural(c, n)}" for c, n in counts.items()]
        return f"Set the table with {_join(items)}."
    items = [_plural(c, 1) for c in counts]
    return f"Make {scenario.goal.name.replace('_', ' ')}: you need {_join(items)}."


def ask_words(scenario: Any) -> str:
    """What the participant needs from the robot, without prescribing the words to say it."""
    cmd = scenario.command
    if scenario.verb == "deliver":
        return f"You want the robot to bring the {_plural(cmd.obj_class, cmd.count)} ({cmd.count})."
    return f"You want the robot to bring you the {_plural(cmd.obj_class, 1)}."


def action_words(world: Any, action: Any, subject: str = "You") -> str:
    """An observed action in plain words: ``You took a bowl from the kitchen cabinet.``"""
    place = world.places[action.place].name.replace("_", " ") if action.place >= 0 else ""
    if action.kind in ("walk", "open", "close"):
        verb = {"walk": "walked to", "open": "opened", "close": "closed"}[action.kind]
        return f"{subject} {verb} the {place}."
    item = world.items[action.obj]
    from siftom.likelihood.lexicon import default_lexicon

    what = default_lexicon().entry(item.cls).singular
    what = f"{'an' if what[0] in 'aeiou' else 'a'} {what}"
    if action.kind == "grab":
        return f"{subject} took {what}" + (f" from the {place}." if place else ".")
    if action.kind == "put":
        prep = "in" if world.places[action.place].closable else "on"
        return f"{subject} put {what} {prep} the {place}."
    return f"{subject} handed over {what}."


@dataclass(frozen=True)
class CollectOptions:
    """What to collect. Validated at construction.

    Attributes:
        domain: a registered domain id (``household-table-v0``, ``kitchen-v0``).
        scenarios: how many scenarios each participant sees (registered ones first, then generated).
        participant: the participant id, or None to ask for it on the page.
        consent: the consent text shown before recording (stored with each participant).
        max_seconds: the longest recording accepted.
    """

    domain: str = "household-table-v0"
    scenarios: int = 26
    participant: str | None = None
    consent: str = CONSENT_TEXT
    max_seconds: float = 30.0

    def __post_init__(self) -> None:
        from siftom.scenarios.base import get_domain

        get_domain(self.domain)  # an unknown domain names the close ones
        if self.scenarios < 1:
            raise DatasetError(f"--scenarios must be >= 1, got {self.scenarios}")
        if self.participant is not None:
            check_participant(self.participant)
        if not self.consent.strip():
            raise DatasetError("the consent text is empty; give a file with the text participants agree to")
        if not self.max_seconds > MIN_SECONDS:
            raise DatasetError(f"max_seconds must be > {MIN_SECONDS}, got {self.max_seconds}")


@dataclass(frozen=True)
class Prompt:
    """One scenario as a participant sees it."""

    index: int
    scenario: str
    scenario_seed: int | None
    actions: tuple[str, ...]
    words: tuple[str, ...]
    goal: str
    ask: str

    def to_json(self) -> dict[str, Any]:
        return {"index": self.index, "scenario": self.scenario, "actions": list(self.words),
                "observed_actions": list(self.actions), "steps": len(self.actions), "goal": self.goal,
                "ask": self.ask}


class Collection:
    """A dataset folder being recorded into (thread-safe: one lock around every write)."""

    def __init__(self, root: str | Path, options: CollectOptions) -> None:
        self.root = Path(root)
        self.options = options
        private_dir(self.root / AUDIO_DIR)  # voices: 0700 folders, 0600 files
        self._lock = threading.Lock()
        spec_path = self.root / SPEC
        if spec_path.is_file():
            spec = json.loads(spec_path.read_text(encoding="utf-8"))
            old = spec.get("collection", {}).get("domain")
            if old is not None and old != options.domain:
                raise DatasetError(f"{self.root} holds recordings of {old}, not {options.domain}; "
                                   "use another --out folder")
            if old is None and "voices" in spec.get("options", {}):
                raise DatasetError(f"{self.root} holds a dataset built by 'siftom dataset build'; record into "
                                   "another --out folder")
        else:
            spec = {"format_version": FORMAT_VERSION, "kind": "recorded"}
        spec["collection"] = {"domain": options.domain, "scenarios": max(options.scenarios,
                              int(spec.get("collection", {}).get("scenarios", 0)))}
        _write_text(spec_path, json.dumps(spec, indent=2) + "\n")
        self.prompts = [self._prompt(k, sid, seed)
                        for k, (sid, seed) in enumerate(select_scenarios(options.domain, options.scenarios))]
        self.consent_sha1 = hashlib.sha1(options.consent.encode()).hexdigest()[:16]

    def _prompt(self, k: int, sid: str, seed: int | None) -> Prompt:
        sc = resolve_scenario(sid, self.options.domain, seed)
        return Prompt(k, sc.id, seed, tuple(sc.world.format_action(a) for a in sc.actions),
                      tuple(action_words(sc.world, a) for a in sc.actions), goal_words(sc), ask_words(sc))

    def prompt(self, index: int) -> Prompt:
        """The prompt at ``index``; DatasetError when out of range."""
        if not 0 <= index < len(self.prompts):
            raise DatasetError(f"scenario index {index} is out of range: this collection has {len(self.prompts)} "
                               f"scenarios (0 to {len(self.prompts) - 1})")
        return self.prompts[index]

    def scenario(self, index: int) -> Any:
        p = self.prompt(index)
        return resolve_scenario(p.scenario, self.options.domain, p.scenario_seed)

    # -- participants ---------------------------------------------------------------------------

    def agree(self, participant: str, key: str | None = None) -> Agreement:
        """Store that ``participant`` agreed to the consent text shown; return the record with
        ``key``, the participant's secret (the only place it is ever given in clear).

        A new participant (or one whose key the experimenter reset, :meth:`reset_key`) gets a
        fresh key. One who agreed before keeps theirs, and only when ``key`` is it: any other
        caller is refused with NotYoursError (nobody can lock a participant out by agreeing again).
        """
        check_participant(participant)
        with self._lock:
            digest = self._key_digest(participant)
            if digest and not key_matches(key, digest):
                raise NotYoursError(f"participant {participant!r} has already started on another page and this "
                                    "page does not have their key; continue on that page (it keeps the key), or "
                                    "ask the experimenter to give them a new key with "
                                    f"'siftom collect --participant {participant} --new-key'")
            given = key if digest and key else secrets.token_urlsafe(24)
            rec = Agreement(participant, time.strftime("%Y-%m-%dT%H:%M:%S%z"), self.consent_sha1,
                            self.options.consent, self.options.domain, key_digest(given), given)
            with append_private(self.root / PARTICIPANTS) as f:
                f.write(json.dumps(rec.to_json()) + "\n")
        return rec

    def reset_key(self, participant: str) -> bool:
        """Make ``participant``'s key stop working: their next agreement gets a fresh one (the
        experimenter's way back for a participant who lost their page). False when they have no
        key to reset (they have not agreed)."""
        check_participant(participant)
        with self._lock:
            if self._key_digest(participant) is None:
                return False
            rec = {"participant": participant, "key_reset": True, "at": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
            with append_private(self.root / PARTICIPANTS) as f:
                f.write(json.dumps(rec) + "\n")
        return True

    def _records(self) -> list[dict[str, Any]]:
        p = self.root / PARTICIPANTS
        if not p.is_file():
            return []
        out = []
        for line in p.read_text(encoding="utf-8").splitlines():
            try:
                r = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(r, dict):
                out.append(r)
        return out

    def _key_digest(self, participant: str) -> str | None:
        """The digest of the participant's current key; None if they have not agreed or their key
        was reset since. One who agreed before keys existed has the digest '' (any first key is
        theirs)."""
        found: str | None = None
        for r in self._records():
            if r.get("participant") != participant:
                continue
            if r.get("key_reset"):
                found = None
            elif r.get("agreed"):
                found = str(r.get("key_sha256") or "")
        return found

    def has_agreed(self, participant: str) -> bool:
        return any(r.get("participant") == participant and r.get("agreed") for r in self._records())

    def check_key(self, participant: str, key: str | None) -> None:
        """NotYoursError unless ``key`` is the participant's (who must have agreed)."""
        if not self.has_agreed(participant):
            raise DatasetError(f"participant {participant!r} has not agreed to the consent text; "
                               "agree on the first page before recording")
        if not key_matches(key, self._key_digest(participant)):
            raise NotYoursError(f"this page cannot record for participant {participant!r}: the participant's key "
                                "is missing or wrong; start again on the first page")

    def done(self, participant: str) -> list[int]:
        """Indexes of the prompts this participant has recorded."""
        ids = {s["id"] for s in self._lines()}
        return [p.index for p in self.prompts if self.stimulus_id(p.index, participant) in ids]

    # -- recordings -----------------------------------------------------------------------------

    @staticmethod
    def stimulus_id(index: int, participant: str) -> str:
        return f"{index:03d}-{participant}-clean"

    def save(self, participant: str, index: int, audio: bytes, reference: str, key: str | None = None) -> Stimulus:
        """Write one recording (replacing an earlier one of the same scenario) and its manifest line.

        ``key``: the participant's key, checked when given (the page always sends it; None is a
        caller in this process).
        """
        check_participant(participant)
        if not self.has_agreed(participant):
            raise DatasetError(f"participant {participant!r} has not agreed to the consent text; "
                               "agree on the first page before recording")
        if key is not None:
            self.check_key(participant, key)
        reference = " ".join(str(reference).split())
        if not reference:
            raise DatasetError("type what you said (the words of the recording) before saving")
        if len(reference) > 500:
            raise DatasetError("what you said is over 500 characters; type only the instruction")
        sc = self.scenario(index)
        x = decode_recording(audio, self.options.max_seconds)
        from siftom.speech.audio import write_wav

        sid = self.stimulus_id(index, participant)
        rel = f"{AUDIO_DIR}/{sid}.wav"
        p = self.prompts[index]
        stim = Stimulus(
            id=sid, scenario=sc.id, domain=self.options.domain, observed_actions=p.actions, audio=rel,
            reference=reference, gold_goal={"name": sc.goal.name, "counts": dict(sc.goal.counts)},
            gold_command=str(sc.command), speaker=participant, voice="human", scenario_seed=p.scenario_seed,
            style="free", duration_s=round(len(x) / 16000, 3),
            extra={"recorded": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "consent_sha1": self.consent_sha1},
        )
        with self._lock:
            tmp = self.root / f"{rel}.{os.getpid()}.{threading.get_ident()}.tmp.wav"
            write_wav(tmp, x)
            make_private(tmp)
            os.replace(tmp, self.root / rel)
            lines = [s for s in self._lines() if s["id"] != sid]
            lines.append(stim.to_json())
            lines.sort(key=lambda d: (d["id"].split("-", 1)[0], d.get("speaker", ""), d["id"]))
            _write_text(self.root / MANIFEST, "".join(json.dumps(d) + "\n" for d in lines))
        return stim

    def _lines(self) -> list[dict[str, Any]]:
        p = self.root / MANIFEST
        if not p.is_file():
            return []
        return [json.loads(line) for line in p.read_text(encoding="utf-8").splitlines() if line.strip()]


def decode_recording(data: bytes, max_seconds: float) -> np.ndarray:
    """An uploaded recording (any format soundfile reads) as 16 kHz mono; AudioError saying what is wrong."""
    import soundfile as sf

    from siftom.speech.audio import to_mono16k

    if not data:
        raise AudioError("the recording is empty; record again")
    try:
        with sf.SoundFile(io.BytesIO(data)) as f:
            seconds = f.frames / f.samplerate if f.samplerate > 0 else 0.0
            if seconds > max_seconds:
                raise AudioError(f"the recording lasts {seconds:.1f} s, more than the {max_seconds:g} s allowed; "
                                 "record only the instruction")
            x, rate = f.read(dtype="float32", always_2d=True), f.samplerate
    except AudioError:
        raise
    except Exception as exc:  # soundfile raises several kinds for unreadable data
        raise AudioError(f"cannot read the recording ({type(exc).__name__}); send a WAV file") from None
    y = to_mono16k(x, rate)
    if len(y) < MIN_SECONDS * 16000:
        raise AudioError(f"the recording is shorter than {MIN_SECONDS:g} s; press Record, speak, then Stop")
    if float(np.max(np.abs(y))) < SILENT_PEAK:
        raise AudioError("the recording is silent: check that the right microphone is selected and not muted, "
                         "then record again")
    return y


def _write_text(path: Path, text: str) -> None:
    write_private_text(path, text)


__all__ = ["CONSENT_TEXT", "Collection", "CollectOptions", "Prompt", "check_participant", "decode_recording",
           "goal_words", "ask_words"]
