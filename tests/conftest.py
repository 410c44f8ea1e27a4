import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))


import pytest  # noqa: E402


@pytest.fixture()
def fake_openai():
    """A local OpenAI-compatible server (tests/support/fake_openai.py), stopped after the test."""
    from support.fake_openai import FakeOpenAI

    server = FakeOpenAI().start()
    yield server
    server.stop()
