"""A speaker across a room: seeded synthetic impulse responses, the level kept, the tail decays as RT60 says."""

from __future__ import annotations

import numpy as np
import pytest

from siftom.errors import SiftomError
from siftom.speech.room import reverberate, room_impulse_response


def test_the_response_decays_by_60_db_in_rt60_and_is_seeded():
    h = room_impulse_response(0.6, 53)
    assert np.array_equal(h, room_impulse_response(0.6, 53)) and not np.array_equal(h, room_impulse_response(0.6, 54))
    assert h[0] == 1.0 and len(h) == int(1.2 * 0.6 * 16000)
    energy = np.cumsum(h[::-1] ** 2)[::-1]  # Schroeder's backward integral
    db = 10 * np.log10(energy / energy[0])
    t20 = (np.argmax(db < -25) - np.argmax(db < -5)) / 16000  # the -5 to -25 dB slope, times 3: RT60
    assert 0.4 < 3 * t20 < 0.8


def test_reverberant_speech_keeps_its_level_and_length_plus_a_tail():
    rng = np.random.default_rng(0)
    x = (0.1 * rng.standard_normal(16000)).astype(np.float32)
    y = reverberate(x, 0.6, 1)
    assert y.dtype == np.float32 and len(y) == len(x) + int(0.3 * 0.6 * 16000)
    assert np.sqrt(np.mean(y ** 2)) == pytest.approx(np.sqrt(np.mean(x ** 2)), rel=1e-3)
    assert np.array_equal(y, reverberate(x, 0.6, 1))


def test_bad_room_settings_are_refused():
    with pytest.raises(SiftomError, match="rt60"):
        room_impulse_response(10.0, 0)
    from siftom.errors import DatasetError
    from siftom.people.stimuli import BuildOptions

    with pytest.raises(DatasetError, match="--room"):
        BuildOptions(room=0.0)
    assert BuildOptions(room=0.6).to_json()["room"] == 0.6 and "room" not in BuildOptions().to_json()
