"""Rooms of several sizes: the talker the given distance from the microphone, inside the walls,
the image-source response seeded, the speech's level kept, distances that do not fit refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

from siftom.errors import SiftomError, UnknownNameError
from siftom.speech.rooms import (
    HEIGHTS,
    ROOMS,
    WALL_MARGIN,
    check_distance,
    max_distance,
    place,
    reverberate_in_room,
)


@pytest.mark.parametrize("name", sorted(ROOMS))
@pytest.mark.parametrize("distance", [0.5, 1.0, 3.0])
def test_the_talker_stands_the_distance_from_the_mic_inside_the_margins(name: str, distance: float) -> None:
    room = ROOMS[name]
    if distance > max_distance(room):
        pytest.skip("does not fit")
    for seed in range(20):
        p = place(name, distance, seed)
        assert p.distance == pytest.approx(distance, abs=1e-9)
        for pt in (p.mic, p.talker):
            for k in range(2):
                assert WALL_MARGIN - 1e-9 <= pt[k] <= room.size[k] - WALL_MARGIN + 1e-9
            assert HEIGHTS[0] <= pt[2] <= HEIGHTS[1]
    assert place(name, distance, 3) == place(name, distance, 3) != place(name, distance, 4)


def test_the_longest_distance_of_each_room_still_places() -> None:
    for name in ROOMS:
        d = max_distance(name)
        assert place(name, d, 0).distance == pytest.approx(d)
    assert max_distance("kitchen") == 3.2 and max_distance("open") == 6.0


@pytest.mark.parametrize("distance", [0.2, 6.5, float("nan"), -1.0])
def test_a_distance_out_of_range_is_refused_with_the_range(distance: float) -> None:
    with pytest.raises(SiftomError, match="0.5-6 m"):
        check_distance("living", distance)


def test_a_distance_the_room_cannot_hold_names_the_room_and_its_limit() -> None:
    with pytest.raises(SiftomError, match=r"kitchen .*at most 3.2 m"):
        place("kitchen", 4.0, 0)


def test_an_unknown_room_lists_the_presets() -> None:
    with pytest.raises(UnknownNameError, match="kitchen, living, open"):
        place("garage", 1.0, 0)


def test_reverberant_speech_is_seeded_keeps_its_level_and_grows_by_the_tail() -> None:
    pytest.importorskip("pyroomacoustics", reason='pip install "siftom[rooms]"')
    rng = np.random.default_rng(0)
    x = (0.1 * rng.standard_normal(8000)).astype(np.float32)
    y = reverberate_in_room(x, "kitchen", 1.0, 7)
    assert y.dtype == np.float32 and len(y) == len(x) + int(0.3 * ROOMS["kitchen"].rt60 * 16000)
    assert np.sqrt(np.mean(y ** 2)) == pytest.approx(np.sqrt(np.mean(x ** 2)), rel=1e-3)
    assert np.array_equal(y, reverberate_in_room(x, "kitchen", 1.0, 7))
    assert not np.array_equal(y, reverberate_in_room(x, "kitchen", 1.0, 8))


def test_the_response_starts_with_the_direct_sound_and_decays_more_when_far() -> None:
    pytest.importorskip("pyroomacoustics", reason='pip install "siftom[rooms]"')
    from siftom.speech.rooms import room_rir

    def drr(distance: float) -> float:  # direct (first 2.5 ms) to reverberant energy, dB
        h = room_rir("living", place("living", distance, 1))
        assert np.array_equal(h, room_rir("living", place("living", distance, 1)))
        assert int(np.argmax(np.abs(h[:200]))) < 60  # the propagation delay is cut
        k = 40 + 40
        return 10 * math.log10(float(np.sum(h[:k] ** 2) / np.sum(h[k:] ** 2)))

    assert drr(0.5) > drr(3.0) + 6
