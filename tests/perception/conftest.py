"""Rendered kitchen-cereal-v0 frames (once per session) and the environment of a local fake VLM."""

from __future__ import annotations

import pytest

from perception.ideal import render_frames


@pytest.fixture(scope="session")
def frames(tmp_path_factory):
    return render_frames(tmp_path_factory.mktemp("frames"))


@pytest.fixture()
def vlm_env(fake_openai, monkeypatch, tmp_path):
    """Point siftom at the fake server: model fake-vlm, no retries, a short timeout, a fresh cache."""
    for k, v in {"SIFTOM_LLM_BASE_URL": fake_openai.url, "SIFTOM_LLM_MODEL": "text-model",
                 "SIFTOM_VLM_MODEL": "fake-vlm", "SIFTOM_LLM_MAX_RETRIES": "0", "SIFTOM_LLM_TIMEOUT": "5",
                 "SIFTOM_CACHE_DIR": str(tmp_path / "cache")}.items():
        monkeypatch.setenv(k, v)
    monkeypatch.delenv("SIFTOM_LLM_API_KEY", raising=False)
    return fake_openai
