"""``siftom config env``: every variable siftom reads, with keys shown only as set."""

from __future__ import annotations

import json

from click.testing import CliRunner

from siftom.cli import root as main
from siftom.settings import environment


def test_config_env_lists_every_variable_and_hides_keys(monkeypatch):
    monkeypatch.setenv("SIFTOM_LLM_API_KEY", "sk-very-secret-value")
    monkeypatch.setenv("SIFTOM_ASR_WORKERS", "0")
    out = CliRunner().invoke(main, ["config", "env", "--json"])
    assert out.exit_code == 0, out.output
    rows = {r["name"]: r for r in json.loads(out.output)}
    assert set(rows) == set(environment.VARIABLES)
    assert rows["SIFTOM_LLM_API_KEY"] == {**rows["SIFTOM_LLM_API_KEY"], "set": True, "value": None}
    assert rows["SIFTOM_ASR_WORKERS"]["value"] == "0"
    assert "sk-very-secret-value" not in CliRunner().invoke(main, ["config", "env"]).output


def test_an_unlisted_variable_is_refused():
    import pytest

    from siftom.errors import SettingsError

    with pytest.raises(SettingsError, match="VARIABLES"):
        environment.read("SIFTOM_NOT_A_THING")
