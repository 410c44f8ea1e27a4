"""No module imports from a layer above its own (docs/architecture.md draws the layers).

Imports inside functions count too: a lazy import is still a dependency.
"""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "siftom"

# Lowest first. A package may import from its own layer and any layer below.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("errors", "registry", "observation", "logspace", "safejson"),
    ("world",),
    ("planning",),
    ("agents",),
    ("scenarios",),
    ("backends", "speech"),
    ("likelihood",),
    ("inference",),
    ("assist", "perception"),
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
