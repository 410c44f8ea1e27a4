"""Audio requests scored in worker processes (ServiceSettings.audio_workers)."""

import pytest

pytest.importorskip("fastapi")

from siftom.service.app import create_app  # noqa: E402
from siftom.service.runtime import ServiceSettings  # noqa: E402
from support.client import local_client  # noqa: E402


@pytest.mark.slow
def test_an_audio_worker_answers_like_the_request_thread(tmp_path):
    from siftom.speech.audio import wav_bytes
    from siftom.speech.tts import synthesize

    wav = wav_bytes(synthesize("can you pass me the cereal"))
    bodies = []
    for workers in (0, 1):
        app = create_app(tmp_path / str(workers), ServiceSettings(audio_workers=workers))
        try:
            client = local_client(app)
            r = client.post("/v1/infer", data={"scenario": "kitchen-cereal-v0"},
                            files={"audio": ("say.wav", wav, "audio/wav")})
            assert r.status_code == 200, r.text
            bodies.append(r.json())
            bad = client.post("/v1/infer", data={"scenario": "kitchen-cereal-v0"},
                              files={"audio": ("say.wav", b"not audio", "audio/wav")})
            assert bad.status_code == 422 and "cannot read the upload" in bad.json()["detail"]
        finally:
            app.state.runtime.close()
    assert bodies[0]["command"] == bodies[1]["command"] == "fetch(cereal)"
    assert bodies[0]["asr"]["text"] == bodies[1]["asr"]["text"]


def test_audio_workers_is_a_validated_setting():
    from siftom.errors import ObservationError

    with pytest.raises(ObservationError, match="audio_workers"):
        ServiceSettings(audio_workers=-1)
