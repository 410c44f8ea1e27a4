"""A talker a given distance from the robot's microphone in a real-sized room: image-source RIRs.

``speech/room.py`` draws a statistical impulse response for one reverberation time; this module
builds the room itself. A named preset is a shoebox room with a target reverberation time; for a
room, a talker-to-microphone distance and a seeded generator, :func:`place` puts the microphone
and the talker that far apart inside it, and :func:`room_rir` computes the image-source impulse
response between them with pyroomacoustics (``ShoeBox``, 16 kHz; ``pip install "siftom[rooms]"``).
:func:`reverberate_in_room` convolves dry speech with it and keeps the speech's RMS level, as
``speech.room.reverberate`` does, so noise is then mixed at the same SNR as for dry speech.

The presets (``ROOMS``), furnished homes:

========  =================  ==========  ===================================================
name      size (m)           target RT60  what it stands for
========  =================  ==========  ===================================================
kitchen   3 x 4 x 2.5        0.40 s      a small kitchen: tiles, cupboards, worktops
living    5 x 6 x 2.7        0.45 s      a living room: sofa, curtains and rug soften a larger room
open      8 x 10 x 3         0.60 s      an open-plan kitchen-diner: large, hard floor, few soft surfaces
========  =================  ==========  ===================================================

The target RT60s are typical of furnished homes (0.3-0.7 s). The walls' energy absorption
coefficient and the image-source order come from ``pyroomacoustics.inverse_sabine(rt60, size)``:
Sabine's formula ``RT60 = 0.161 V / (S a)`` solved for one absorption ``a`` shared by every
surface, and the reflection order that reaches RT60 seconds. The image-source response decays
more slowly than Sabine's diffuse-field estimate (a shoebox with uniform walls keeps its axial
modes): measured on the responses (``pyroomacoustics.experimental.measure_rt60``, Schroeder
integration) their RT60 is 1.25-1.75 x the target: kitchen ~0.50 s, living room ~0.63 s, open
plan ~1.05 s (a large bare room). The manifest records the target (``rt60_s``).

Placement: the microphone and the talker are at least ``WALL_MARGIN`` (0.5 m) from every wall, at
heights drawn from ``HEIGHTS`` (1.1-1.7 m: a robot's head, a seated or standing mouth), the
direction between them drawn uniformly; the two are exactly ``distance`` metres apart. A
distance fits a room when it is at most ``max_distance(room)`` (90 % of the diagonal of the floor
area the margin leaves; capped at ``DISTANCES[1]`` = 6 m). The propagation delay is cut from the
response, so the reverberant speech starts when the dry speech does. Everything is deterministic
for a seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from siftom.errors import DatasetError, SiftomError, missing_extra, unknown_name
from siftom.speech.audio import SAMPLE_RATE

WALL_MARGIN = 0.5
HEIGHTS = (1.1, 1.7)
DISTANCES = (0.5, 6.0)  # the talker-to-microphone distances a dataset may ask for (m)
SOUND_SPEED = 343.0  # m/s, as pyroomacoustics' default


@dataclass(frozen=True)
class RoomPreset:
    """A shoebox room: its size in metres (length, width, height) and target RT60 in seconds."""

    name: str
    size: tuple[float, float, float]
    rt60: float
    about: str


ROOMS: dict[str, RoomPreset] = {r.name: r for r in (
    RoomPreset("kitchen", (3.0, 4.0, 2.5), 0.40, "a small kitchen"),
    RoomPreset("living", (5.0, 6.0, 2.7), 0.45, "a living room"),
    RoomPreset("open", (8.0, 10.0, 3.0), 0.60, "an open-plan kitchen-diner"),
)}


def get_room(name: str) -> RoomPreset:
    """The preset called ``name``; UnknownNameError listing the presets otherwise."""
    if name not in ROOMS:
        raise unknown_name("room", name, ROOMS)
    return ROOMS[name]


def max_distance(room: RoomPreset | str) -> float:
    """The longest talker-to-microphone distance the room fits (module doc), in metres, 0.1 m steps."""
    r = get_room(room) if isinstance(room, str) else room
    a, b = r.size[0] - 2 * WALL_MARGIN, r.size[1] - 2 * WALL_MARGIN
    return min(DISTANCES[1], math.floor(9 * math.hypot(a, b)) / 10)


def check_distance(room: RoomPreset | str, distance: float) -> None:
    """SiftomError unless ``distance`` is in ``DISTANCES`` and fits the room."""
    r = get_room(room) if isinstance(room, str) else room
    if not (isinstance(distance, int | float) and math.isfinite(distance)
            and DISTANCES[0] <= distance <= DISTANCES[1]):
        raise SiftomError(f"the talker-to-microphone distance must be {DISTANCES[0]:g}-{DISTANCES[1]:g} m, "
                          f"got {distance!r}")
    if distance > max_distance(r):
        raise SiftomError(f"a talker {distance:g} m from the microphone does not fit the {r.name} "
                          f"({' x '.join(f'{x:g}' for x in r.size)} m): at most {max_distance(r):g} m there")


def check_rooms(rooms: tuple[str, ...], distances: tuple[float, ...], rt60: float | None = None) -> None:
    """DatasetError (``--rooms/--distances: ...``) unless ``rooms`` are distinct presets and every
    distance fits every one of them (a dataset crosses them: each clip gets one room and one
    distance); ``rt60``, the synthetic reverberation of ``--room``, must be None with them."""
    try:
        if rt60 is not None:
            raise SiftomError("give --room RT60 (one synthetic reverberation) or --rooms, not both")
        if not rooms or not distances:
            raise SiftomError(f"give both, e.g. --rooms kitchen,living --distances 1,3 (rooms: "
                              f"{', '.join(ROOMS)}; distances {DISTANCES[0]:g}-{DISTANCES[1]:g} m)")
        if len(set(rooms)) != len(rooms):
            raise SiftomError(f"a room is listed twice: {', '.join(rooms)}")
        if len(set(distances)) != len(distances):
            raise SiftomError(f"a distance is listed twice: {', '.join(f'{d:g}' for d in distances)}")
        for name in rooms:
            for d in distances:
                check_distance(get_room(name), d)
    except SiftomError as exc:
        raise DatasetError(f"--rooms/--distances: {exc}") from None


@dataclass(frozen=True)
class Placement:
    """Where the microphone and the talker stand in a room (metres, x y z from a corner)."""

    mic: tuple[float, float, float]
    talker: tuple[float, float, float]

    @property
    def distance(self) -> float:
        """The talker-to-microphone distance."""
        return math.dist(self.mic, self.talker)


def place(room: RoomPreset | str, distance: float, rng: np.random.Generator | int | None) -> Placement:
    """Microphone and talker ``distance`` m apart inside ``room`` (module doc), drawn from ``rng``."""
    r = get_room(room) if isinstance(room, str) else room
    check_distance(r, distance)
    g = np.random.default_rng(rng)
    a, b = r.size[0] - 2 * WALL_MARGIN, r.size[1] - 2 * WALL_MARGIN
    for _ in range(100):  # batches of candidate heights and directions; the first that fits is kept
        hm, ht = g.uniform(*HEIGHTS, size=(2, 512))
        theta = g.uniform(0.0, 2 * math.pi, size=512)
        horiz = np.sqrt(np.maximum(distance ** 2 - (ht - hm) ** 2, 0.0))
        dx, dy = horiz * np.cos(theta), horiz * np.sin(theta)
        ok = np.flatnonzero((np.abs(ht - hm) <= distance) & (np.abs(dx) <= a) & (np.abs(dy) <= b))
        if len(ok):
            i = int(ok[0])
            # the microphone anywhere that leaves room for the talker inside the margins
            x0 = WALL_MARGIN + g.uniform(0.0, a - abs(dx[i])) + max(0.0, -dx[i])
            y0 = WALL_MARGIN + g.uniform(0.0, b - abs(dy[i])) + max(0.0, -dy[i])
            mic = (float(x0), float(y0), float(hm[i]))
            return Placement(mic, (float(x0 + dx[i]), float(y0 + dy[i]), float(ht[i])))
    raise SiftomError(f"could not place a talker {distance:g} m from the microphone in the {r.name}")


def _pyroomacoustics() -> Any:
    try:
        import pyroomacoustics
    except ImportError:
        raise missing_extra("rooms", "pyroomacoustics") from None
    return pyroomacoustics


def absorption(room: RoomPreset | str) -> tuple[float, int]:
    """(wall energy absorption, image-source order) from ``inverse_sabine`` for the preset's RT60."""
    r = get_room(room) if isinstance(room, str) else room
    e, order = _pyroomacoustics().inverse_sabine(r.rt60, list(r.size))
    return float(e), int(order)


def room_rir(room: RoomPreset | str, placement: Placement, sr: int = SAMPLE_RATE) -> np.ndarray:
    """The image-source impulse response from the talker to the microphone, propagation delay cut."""
    pra = _pyroomacoustics()
    r = get_room(room) if isinstance(room, str) else room
    e, order = absorption(r)
    shoebox = pra.ShoeBox(list(r.size), fs=sr, materials=pra.Material(e), max_order=order)
    shoebox.add_source(list(placement.talker))
    shoebox.add_microphone(list(placement.mic))
    shoebox.compute_rir()
    h = np.asarray(shoebox.rir[0][0], dtype=np.float64)
    return h[int(placement.distance / SOUND_SPEED * sr):]


def reverberate_in_room(x: np.ndarray, room: RoomPreset | str, distance: float,
                        rng: np.random.Generator | int | None) -> np.ndarray:
    """``x`` as heard ``distance`` m away in ``room`` (module doc), float32, same RMS level; the
    length grows by 0.3 x RT60 of tail, as ``speech.room.reverberate``."""
    r = get_room(room) if isinstance(room, str) else room
    from siftom.speech.room import convolve_at_level

    return convolve_at_level(x, room_rir(r, place(r, distance, rng)), r.rt60)
