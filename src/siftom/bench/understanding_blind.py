"""The understanding benchmark's hand-written sets (the ``blind`` set, ``data/understanding/blind.jsonl``):
reading and checking their items against their worlds (:func:`load_items`), and the worlds of
``data/understanding/worlds``. :mod:`siftom.bench.understanding_items` re-exports every public name
here."""

from __future__ import annotations

import json
import re
from collections import Counter
from pathlib import Path
from typing import Any

from siftom.bench.understanding_records import Expect, Item
from siftom.bench.utterances import KINDS
from siftom.errors import DatasetError

# kinds only the hand-written sets have: an object outside the lexicon ("the stapler"), more than the
# world holds ("three pens" where two are), a modifier ("the cereal with a bit of sugar") and a reply
# to the robot's question (an item with ``pending``)
EXTRA_KINDS = ("unknown", "beyond_supply", "modifier", "reply")
BLIND_KINDS = KINDS + EXTRA_KINDS
BLIND = "blind"
_FIELDS = {"id", "kind", "scenario", "world", "text", "expected", "pending"}
_EXPECTED = {"request", "targets", "absent", "optional", "refused", "over_supply"}


def items_dir() -> Path:
    """The folder of the hand-written item files and their worlds (``data/understanding``)."""
    return Path(__file__).resolve().parent.parent / "data" / "understanding"


def world_files(name: str) -> tuple[Path, Path]:
    """(world JSON, actions) of a world of the items' data: ``worlds/NAME.json`` and
    ``worlds/NAME.actions.txt``."""
    folder = items_dir() / "worlds"
    world, actions = folder / f"{name}.json", folder / f"{name}.actions.txt"
    if not world.is_file() or not actions.is_file():
        have = sorted(p.stem for p in folder.glob("*.json"))
        raise DatasetError(f"no world {name!r} in {folder}; worlds: {', '.join(have) or 'none'}")
    return world, actions


_SCENES: dict[tuple[str, str], Any] = {}


def scene_of(item: Item) -> Any:
    """The :class:`~siftom.inputs.SceneInput` of an item's world with the person's actions
    (a scenario's own, or a world file's ``.actions.txt``); cached per process."""
    from siftom.inputs import resolve_scene
    from siftom.people.stimuli import resolve_scenario

    key = (item.world, item.scenario if not item.world else "")
    if key not in _SCENES:
        if item.world:
            world, actions = world_files(item.world)
            _SCENES[key] = resolve_scene(str(world), str(actions))
        else:
            _SCENES[key] = resolve_scene(resolve_scenario(item.scenario, item.domain, item.scenario_seed))
    return _SCENES[key]


def _str_list(v: Any, what: str) -> tuple[str, ...]:
    if v is None:
        return ()
    if not isinstance(v, list) or not all(isinstance(x, str) and x for x in v):
        raise ValueError(f"{what} must be a list of class names, got {v!r}")
    return tuple(v)


def _item_from_json(obj: Any) -> Item:
    """An item of a hand-written file (one JSON object); ValueError naming what is wrong."""
    from siftom.people.stimuli import resolve_scenario

    if not isinstance(obj, dict):
        raise ValueError(f"each line must be a JSON object, got {type(obj).__name__}")
    extra = set(obj) - _FIELDS
    if extra:
        raise ValueError(f"unknown field(s) {', '.join(sorted(extra))}; fields: {', '.join(sorted(_FIELDS))}")
    for key in ("id", "kind", "text"):
        if not isinstance(obj.get(key), str) or not obj[key].strip():
            raise ValueError(f"{key!r} must be a non-empty string")
    if obj["kind"] not in BLIND_KINDS:
        raise ValueError(f"unknown kind {obj['kind']!r}; kinds: {', '.join(BLIND_KINDS)}")
    if bool(obj.get("scenario")) == bool(obj.get("world")):
        raise ValueError("give exactly one of 'scenario' (a registered id) and 'world' (a file of worlds/)")
    e = obj.get("expected")
    if not isinstance(e, dict) or not isinstance(e.get("request"), bool):
        raise ValueError("'expected' must be an object with 'request': true or false")
    if set(e) - _EXPECTED:
        raise ValueError(f"unknown expected field(s) {', '.join(sorted(set(e) - _EXPECTED))}; "
                         f"fields: {', '.join(sorted(_EXPECTED))}")
    targets = []
    for t in e.get("targets") or []:
        if (not isinstance(t, list) or len(t) != 2 or not isinstance(t[0], str)
                or not (t[1] is None or (isinstance(t[1], int) and not isinstance(t[1], bool) and t[1] >= 1))):
            raise ValueError(f"each target must be [class, count or null], got {t!r}")
        targets.append((t[0], t[1]))
    absent = e.get("absent") or ""
    if not isinstance(absent, str):
        raise ValueError(f"'absent' must be a name or null, got {absent!r}")
    expect = Expect(e["request"], tuple(targets), absent, _str_list(e.get("optional"), "optional"),
                    _str_list(e.get("refused"), "refused"), bool(e.get("over_supply", False)))
    if (expect.targets or expect.absent) and not expect.request:
        raise ValueError("targets or an absent object need 'request': true")
    pending = _str_list(obj.get("pending"), "pending")
    if pending and len(pending) != 2:
        raise ValueError(f"'pending' must be the question's two commands, got {len(pending)}")
    world = str(obj.get("world") or "")
    if world:
        world_files(world)
        domain = f"world:{world}"
    else:
        domain = resolve_scenario(obj["scenario"], "", None).domain
    item = Item(obj["id"], obj["kind"], domain, None, obj["text"], expect, str(obj.get("scenario") or ""),
                world=world, pending=pending)
    _check_world(item)
    return item


def _check_world(item: Item) -> None:
    """The item's classes are in its world (an absent one is not); ValueError otherwise."""
    world = scene_of(item).world
    have = Counter(it.cls for it in world.items)
    e = item.expect
    for c in [c for c, _ in e.targets] + list(e.optional) + list(e.refused):
        if c not in have:
            raise ValueError(f"class {c!r} is not in the world; its classes: {', '.join(sorted(have))}")
    for c, n in e.targets:
        if n is not None and (n > have[c]) != e.over_supply:
            raise ValueError(f"{n} {c} said where the world holds {have[c]}: set 'over_supply' "
                             f"{'true' if n > have[c] else 'false'}")
    if e.absent and e.absent in have:
        raise ValueError(f"absent {e.absent!r} is in the world")
    for cmd in item.pending:
        m = re.fullmatch(r"(\w+)\((\w+)(?:,(\d+))?\)", cmd)
        if m is None or m.group(2) not in have:
            raise ValueError(f"pending command {cmd!r} must be VERB(CLASS[,N]) of a class of the world")


def load_items(path: str | Path | None = None) -> list[Item]:
    """The items of a hand-written JSON-lines file (default: the blind set, ``blind.jsonl``),
    interleaved so that any prefix mixes kinds (``--limit``).

    Each line: ``id``, ``kind``, ``scenario`` (a registered id) or ``world`` (a world of
    ``data/understanding/worlds``), ``text``, ``expected`` (``request``, ``targets`` as
    ``[[class, count or null], ...]``, ``absent``, ``optional``, ``refused``, ``over_supply``)
    and, for a reply, ``pending`` (the question's two commands).
    """
    p = Path(path) if path is not None else items_dir() / f"{BLIND}.jsonl"
    try:
        lines = p.read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise DatasetError(f"cannot read the items {p}: {exc.strerror or exc}; give a JSON-lines file") from None
    out: list[Item] = []
    for n, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            out.append(_item_from_json(json.loads(line)))
        except (ValueError, DatasetError) as exc:
            raise DatasetError(f"{p}, line {n}: {exc}; fix the line (docs/understanding.md, the item format)") from None
    ids = [i.id for i in out]
    if len(set(ids)) != len(ids):
        dup = sorted({x for x in ids if ids.count(x) > 1})
        raise DatasetError(f"{p}: item id(s) {', '.join(dup[:3])} appear twice; give each item its own id")
    seen: Counter[str] = Counter()
    keyed = []
    for item in out:
        keyed.append(((seen[item.kind], BLIND_KINDS.index(item.kind)), item))
        seen[item.kind] += 1
    return [item for _, item in sorted(keyed, key=lambda p: p[0])]
