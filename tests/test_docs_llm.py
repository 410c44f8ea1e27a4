"""docs/llm.md's Python block runs as written, against a local OpenAI-compatible server in place of
the endpoint it names, and uses public names only (``import siftom``)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from support.fake_openai import echo_logprobs

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "llm.md"
ENDPOINT = "http://127.0.0.1:8000/v1"


def _python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)\n```", PAGE.read_text(encoding="utf-8"), re.DOTALL)


def likes_cereal(text: str, offset: int, token: str) -> float:
    """An LM that finds the heard words likely after the cereal command, unlikely otherwise."""
    command = text.rsplit("Command:", 1)[1].split("\n", 1)[0]
    return -1.0 if offset < text.rfind("Heard:") + len("Heard:") else -0.1 if "cereal" in command else -2.0


def test_the_python_of_the_llm_page_uses_public_names_only() -> None:
    blocks = _python_blocks()
    assert blocks
    for code in blocks:
        imports = re.findall(r"^\s*(?:from|import) (siftom[\w.]*)", code, re.MULTILINE)
        assert imports and all(name == "siftom" for name in imports), imports
        assert not re.search(r"siftom\.[a-z_]+\.", code), "a private module of siftom"


def test_the_python_of_the_llm_page_runs(fake_openai, tmp_path: Path) -> None:
    fake_openai.on("completions", echo_logprobs(likes_cereal))
    (code,) = _python_blocks()
    assert ENDPOINT in code
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT / "src"), "SIFTOM_CACHE_DIR": str(tmp_path / "cache"),
           "HOME": str(tmp_path)}
    res = subprocess.run([sys.executable, "-c", code.replace(ENDPOINT, fake_openai.url)], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.split() == ["llm", "fetch(cereal)", "fetch(sugar)"], res.stdout
    assert fake_openai.bodies("completions"), "the endpoint was never asked"


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__]))
