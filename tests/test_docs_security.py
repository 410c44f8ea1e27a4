"""docs/security.md exists, is linked, and names the options and settings the code has."""

from __future__ import annotations

from pathlib import Path

from siftom.cli.service import serve_cmd

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "security.md"


def test_security_page_is_in_the_nav_and_linked_from_the_service_page() -> None:
    assert DOC.is_file(), "docs/security.md is referenced by the code and docs/service.md"
    assert "security.md" in (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    assert "(security.md)" in (ROOT / "docs" / "service.md").read_text(encoding="utf-8")


def test_security_page_names_what_the_server_checks() -> None:
    text = DOC.read_text(encoding="utf-8")
    flags = {opt for p in serve_cmd.params for opt in p.opts}
    for flag in ("--token", "--token-file", "--allow-host", "--allow-origin"):
        assert flag in flags and f"`{flag}" in text, flag
    for word in ("Threat model", "reverse proxy", "Authorization: Bearer", "X-Forwarded-Proto", "SIFTOM_TOKEN",
                 "service.allowed_hosts", "service.allowed_origins", "0600", "0700", "4401", "DNS rebinding",
                 "compare_digest"):
        assert word in text, word
