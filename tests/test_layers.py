"""No module imports from a layer above its own (docs/architecture.md draws the layers).

Imports inside functions count too: a lazy import is still a dependency.
"""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "siftom"

# Lowest first. A package may import from its own layer and any layer below.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("errors", "registry", "observation", "logspace", "concurrency", "safejson", "private"),
    ("world",),
    ("planning",),
    ("agents",),
    ("scenarios",),
    ("backends", "speech", "options"),  # options: the option classes of every stage and door
    ("likelihood",),
    ("inference",),
    ("assist", "perception"),
    ("inputs", "settings", "answer"),  # the resolved settings and the one answer shape
    ("observer",),  # the one path behind every door
    ("api", "bench", "service", "__init__"),  # the package root is the public facade
    ("cli",),
)
LAYER_OF = {name: k for k, names in enumerate(LAYERS) for name in names}


def _part(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _imports(path: Path):
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names] if node.module == "siftom" else [node.module]
            for m in names:
                if m.startswith("siftom."):
                    yield node.lineno, m
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("siftom."):
                    yield node.lineno, a.name


def _modules():
    return sorted(p for p in SRC.rglob("*.py"))


def test_every_package_has_a_layer():
    tops = {p.relative_to(SRC).parts[0].removesuffix(".py") for p in _modules()}
    assert tops <= set(LAYER_OF), f"give these a layer in LAYERS: {sorted(tops - set(LAYER_OF))}"


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(SRC)))
def test_no_module_imports_from_a_layer_above(path):
    own = LAYER_OF[path.relative_to(SRC).parts[0].removesuffix(".py")]
    up = [f"line {n}: {m} (layer {LAYER_OF[_part(m)]} > {own})"
          for n, m in _imports(path) if LAYER_OF.get(_part(m), -1) > own]
    assert not up, "imports from a higher layer: " + "; ".join(up)


def _entry_points(path: Path):
    """Registration strings: ``"siftom.module:attr"`` constants (lazy entry points) and f-strings
    that start with one (``f"siftom.cli.{name}:register"``)."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        text = None
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            text = node.value
        elif isinstance(node, ast.JoinedStr) and node.values and isinstance(node.values[0], ast.Constant):
            text = str(node.values[0].value)
        if text and text.startswith("siftom.") and ":" in text and " " not in text:
            yield node.lineno, text.partition(":")[0]


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(SRC)))
def test_no_registration_names_a_layer_above(path):
    own = LAYER_OF[path.relative_to(SRC).parts[0].removesuffix(".py")]
    up = [f"line {n}: {m} (layer {LAYER_OF[_part(m)]} > {own})"
          for n, m in _entry_points(path) if LAYER_OF.get(_part(m), -1) > own]
    assert not up, "registers an entry point from a higher layer: " + "; ".join(up)


def test_the_layer_test_sees_registration_strings(tmp_path):
    bad = tmp_path / "mod.py"
    bad.write_text('REG.register("x", "siftom.likelihood.asr:open_engine")\n')
    assert list(_entry_points(bad)) == [(1, "siftom.likelihood.asr")]
