"""What a caller may hand to :func:`siftom.infer`, turned into the model's inputs.

* ``scene``: a registered scenario id (``kitchen-cereal-v0``), a path to a siftom world JSON or
  a VirtualHome scene graph, or a loaded scene / Scenario.
* ``actions``: siftom action strings (``grab(human, milk, fridge)``), VirtualHome script lines
  (``[Grab] <milk> (195)``), or a path to a file of them (JSON list or one per line; ``#``
  starts a comment). None: the scenario's own actions (none for a world file).
* ``heard``: a transcript, an N-best list (texts, best first, or (text, log score) pairs), a
  path to an audio file, or 16 kHz mono samples.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from siftom.errors import ObservationError
from siftom.observation import Hypothesis, Instruction
from siftom.world.model import Action, Goal, State, World

AUDIO_SUFFIXES = (".wav", ".flac", ".ogg", ".mp3", ".aiff", ".aif")


@dataclass(frozen=True, eq=False)
class SceneInput:
    """A resolved scene: the world, its start, the goal space, the verb, the checked actions.

    ``key`` identifies the scene and actions for caches (the action term is computed once per key).
    """

    world: World
    start: State
    goals: tuple[Goal, ...]
    verb: str
    actions: tuple[Action, ...]
    key: Any

    @property
    def target(self) -> int:
        """The place the goals are about (the human's work place)."""
        return self.goals[0].target


def read_actions(path: str | Path) -> list[str]:
    """Action lines from a file: a JSON list (or ``{"actions": [...]}``) or one per line."""
    from siftom.safejson import loads, read_text

    p = Path(path)
    if not p.is_file():
        raise ObservationError(f"{p}: no such actions file; give a JSON list of actions or one action per line")
    text = read_text(p, "actions file")
    try:
        data = json.loads(text)
    except json.JSONDecodeError:
        return [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.strip().startswith("#")]
    except (RecursionError, ValueError):  # JSON nested too deeply, or an integer too long to read
        data = loads(text, f"actions file {str(p)!r}")
    if isinstance(data, dict):
        data = data.get("actions")
    if not isinstance(data, list) or not all(isinstance(a, str) for a in data):
        raise ObservationError(f"{p}: give a JSON list of action strings (or one action per line)")
    return data


@lru_cache(maxsize=16)
def _load_scene_file(path: str, mtime_ns: int, size: int, goal_space: str | None, target: str | None) -> Any:
    from siftom.world.io import load_scene

    return load_scene(path, goal_space=goal_space, target=target)


def load_scene_input(scene: Any, goal_space: str | None = None, target: str | None = None) -> tuple[Any, Any]:
    """(the scenario or loaded scene, its cache key) for a scenario id, a file path or an object."""
    if isinstance(scene, (str, Path)):
        p = Path(scene)
        if p.is_file():
            st = p.stat()
            key = ("file", str(p.resolve()), st.st_mtime_ns, st.st_size, goal_space, target)
            return _load_scene_file(str(p.resolve()), st.st_mtime_ns, st.st_size, goal_space, target), key
        if isinstance(scene, Path) or str(scene).endswith(".json"):
            raise ObservationError(f"{scene}: no such file; give a world JSON, a VirtualHome graph or a "
                                   "scenario id (siftom scenarios list)")
        from siftom.scenarios.base import get_scenario

        return get_scenario(str(scene)), ("scenario", str(scene))
    if hasattr(scene, "world") and hasattr(scene, "start") and hasattr(scene, "goals"):
        return scene, ("object", scene)
    raise ObservationError(f"scene must be a scenario id, a path to a world JSON or VirtualHome graph, or a "
                           f"loaded scene, got {type(scene).__name__}")


def action_lines(actions: Any) -> list[Any] | None:
    """The action strings (or Actions) of ``actions``: a list, a path to a file, or None."""
    if actions is None:
        return None
    if isinstance(actions, Path):
        return read_actions(actions)
    if isinstance(actions, str):
        if Path(actions).is_file():
            return read_actions(actions)
        if "(" in actions or "[" in actions:  # the actions themselves, one per line
            return [ln.strip() for ln in actions.splitlines() if ln.strip() and not ln.strip().startswith("#")]
        raise ObservationError(f"{actions}: no such actions file; give a path, a list of action strings, or None")
    if isinstance(actions, Sequence):
        return list(actions)
    raise ObservationError(f"actions must be a list of action strings or a path, got {type(actions).__name__}")


def resolve_scene(scene: Any, actions: Any = None, *, goal_space: str | None = None,
                  target: str | None = None) -> SceneInput:
    """Resolve ``scene`` and ``actions`` (see the module doc) and check every action."""
    src, key = load_scene_input(scene, goal_space, target)
    lines = action_lines(actions)
    from_file = isinstance(actions, Path) or (isinstance(actions, str) and Path(actions).is_file())
    if lines is None:
        acts = tuple(getattr(src, "actions", ()))
    elif all(isinstance(a, Action) for a in lines):
        acts = tuple(lines)
    else:
        from siftom.world.vhscript import parse_actions

        texts = [a if isinstance(a, str) else src.world.format_action(a) for a in lines]
        # a file's lines are counted from 1 ("action 2"), a list's from 0 ("actions[1]")
        parsed, _ = (parse_actions(src.world, src.start, texts, first=1, label="action {k}") if from_file
                     else parse_actions(src.world, src.start, texts))
        acts = tuple(parsed)
    verb = getattr(src, "verb", "deliver")
    return SceneInput(src.world, src.start, tuple(src.goals), verb, acts, (key, tuple(map(str, acts))))


def make_scene(world: World, start: State, goals: Sequence[Goal], actions: Sequence[Any] = (),
               verb: str = "deliver") -> SceneInput:
    """A SceneInput from a World, its start state and goal space (no file, no registry)."""
    from siftom.world.model import apply, check

    acts, s = [], start
    for k, a in enumerate(actions):
        act = world.parse_action(a, s) if isinstance(a, str) else a
        why = check(world, s, act)
        if why is not None:
            raise ObservationError(f"actions[{k}] {a!r} is impossible here: {why}")
        acts.append(act)
        s = apply(s, act)
    return SceneInput(world, start, tuple(goals), verb, tuple(acts),
                      (("world", world, start, tuple(goals)), tuple(map(str, acts))))


def _is_audio_path(x: Any) -> bool:
    return isinstance(x, Path) or (isinstance(x, str) and x.strip().lower().endswith(AUDIO_SUFFIXES))


def as_heard(heard: Any) -> Instruction | np.ndarray | None:
    """What was heard as an Instruction (words), 16 kHz mono samples (audio) or None.

    Texts without scores are ranked: the k-th (from 0) gets log score -k.
    """
    if heard is None or isinstance(heard, Instruction):
        return heard
    if isinstance(heard, np.ndarray):
        from siftom.speech.audio import as_audio

        return as_audio(heard)
    if _is_audio_path(heard):
        from siftom.speech.audio import as_audio

        if not Path(heard).is_file():
            raise ObservationError(f"{heard}: no such audio file; give a WAV/FLAC/OGG file, samples or a transcript")
        return as_audio(heard)
    if isinstance(heard, str):
        return Instruction.from_text(heard)
    if hasattr(heard, "nbest") and hasattr(heard, "text"):  # a Transcript from an ASR engine
        hyps = tuple(h for h in heard.nbest if h.text) or ((Hypothesis(heard.text, 0.0),) if heard.text else ())
        if not hyps:
            raise ObservationError("nothing was recognised (the transcript is empty); infer from the actions alone "
                                   "with heard=None")
        words = tuple((w.text, w.start, w.end) for w in getattr(heard, "words", ()))
        return Instruction(nbest=hyps, words=words)
    if isinstance(heard, Sequence) and not isinstance(heard, (bytes, bytearray)):
        if not heard:
            raise ObservationError("the N-best list is empty; give at least one text, or heard=None")
        hyps_l: list[Hypothesis] = []
        for k, h in enumerate(heard):
            if isinstance(h, Hypothesis):
                hyps_l.append(h)
            elif isinstance(h, str):
                hyps_l.append(Hypothesis(h.strip(), -float(k)))
            elif isinstance(h, dict) and "text" in h:
                hyps_l.append(Hypothesis(str(h["text"]), float(h.get("score", 0.0))))
            elif isinstance(h, Sequence) and len(h) == 2 and isinstance(h[0], str):
                hyps_l.append(Hypothesis(h[0], float(h[1])))
            else:
                raise ObservationError(f"heard[{k}] must be a text or a (text, log score) pair, got {h!r}")
        return Instruction(nbest=tuple(hyps_l))
    raise ObservationError(f"heard must be a transcript, an N-best list, an audio path or samples, "
                           f"got {type(heard).__name__}")
