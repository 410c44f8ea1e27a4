"""No module imports from a layer above its own (docs/architecture.md draws the layers).

Imports inside functions count too: a lazy import is still a dependency.
"""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "siftom"

# Lowest first. A package may import from its own layer and any layer below.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("errors", "registry", "observation", "logspace", "concurrency", "safejson", "memo", "private", "jsonlines"),
    ("world",),
    ("options", "settings"),  # the option classes of every stage and door, and settings: every SIFTOM_* variable
    ("planning",),
    ("agents",),
    ("scenarios",),
    ("backends", "speech"),
    ("likelihood", "language"),  # language: the utterance model (the words' slots and roles)
    ("inference",),
    ("assist", "perception"),
    ("inputs", "answer"),  # the scene a door was given and the one answer shape
    ("observer", "listener"),  # the one path behind every door; a home listening through it
    ("people",),  # participants: the dataset format, recording, annotation, ratings (bench and service)
    ("api", "bench", "service", "__init__"),  # the package root is the public facade
    ("cli",),
)
LAYER_OF = {name: k for k, names in enumerate(LAYERS) for name in names}


def _part(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _imports(path: Path):
    """(line, module) of every siftom import; the package root (``import siftom``, ``from siftom
    import infer``) is the facade, the top of the house, and is reported as ``siftom``."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module == "siftom":
                for a in node.names:
                    sub = SRC / a.name
                    yield node.lineno, f"siftom.{a.name}" if sub.is_dir() or sub.with_suffix(".py").is_file() else "siftom"
            elif node.module.startswith("siftom."):
                yield node.lineno, node.module
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name == "siftom" or a.name.startswith("siftom."):
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


def test_the_layer_test_sees_the_package_root(tmp_path):
    mod = tmp_path / "mod.py"
    mod.write_text("import siftom\nfrom siftom import infer\nfrom siftom import errors\n")
    assert list(_imports(mod)) == [(1, "siftom"), (2, "siftom"), (3, "siftom.errors")]
    assert LAYER_OF[_part("siftom")] == LAYER_OF["__init__"]


def test_the_layer_test_sees_registration_strings(tmp_path):
    bad = tmp_path / "mod.py"
    bad.write_text('REG.register("x", "siftom.likelihood.asr:open_engine")\n')
    assert list(_entry_points(bad)) == [(1, "siftom.likelihood.asr")]


# -- module circles -----------------------------------------------------------------------------

def _module_name(path: Path, src: Path = SRC) -> str:
    rel = path.relative_to(src.parent).with_suffix("")
    name = ".".join(rel.parts)
    return name.removesuffix(".__init__")


def import_graph(src: Path = SRC) -> dict[str, set[str]]:
    """module -> the siftom modules it imports (module level, lazy and type-only imports alike;
    ``from pkg import mod`` counts as importing ``pkg.mod``)."""
    paths = {_module_name(p, src): p for p in sorted(src.rglob("*.py"))}

    def resolve(m: str) -> str:
        while m and m not in paths:
            m = m.rpartition(".")[0]
        return m

    graph: dict[str, set[str]] = {}
    for name, path in paths.items():
        out = graph.setdefault(name, set())
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            targets: list[str] = []
            if isinstance(node, ast.ImportFrom) and node.module:
                if node.level:
                    base = name.split(".")[: len(name.split(".")) - node.level + (path.name == "__init__.py")]
                    mod = ".".join([*base, node.module])
                else:
                    mod = node.module
                if mod.startswith("siftom"):
                    targets += [f"{mod}.{a.name}" if f"{mod}.{a.name}" in paths else mod for a in node.names]
            elif isinstance(node, ast.Import):
                targets += [a.name for a in node.names if a.name.startswith("siftom")]
            out.update(r for r in map(resolve, targets) if r and r not in (name, "siftom"))
    return graph


def circles(graph: dict[str, set[str]]) -> list[set[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[set[str]] = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            node, it = work[-1]
            nxt = next(it, None)
            if nxt is not None:
                if nxt not in index:
                    index[nxt] = low[nxt] = len(index)
                    stack.append(nxt)
                    on.add(nxt)
                    work.append((nxt, iter(sorted(graph.get(nxt, ())))))
                elif nxt in on:
                    low[node] = min(low[node], index[nxt])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = set()
                while True:
                    m = stack.pop()
                    on.discard(m)
                    comp.add(m)
                    if m == node:
                        break
                if len(comp) > 1:
                    found.append(comp)
    return found


def test_no_import_circles():
    found = circles(import_graph())
    assert not found, "import circles (break each by moving what both need below both): " + "; ".join(
        " <-> ".join(sorted(c)) for c in found)


def test_the_circle_finder_finds_a_circle(tmp_path):
    pkg = tmp_path / "siftom"
    (pkg / "a").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a" / "__init__.py").write_text("")
    (pkg / "a" / "x.py").write_text("def f():\n    from siftom.a.y import g\n")  # a lazy import counts
    (pkg / "a" / "y.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from siftom.a import x\n")
    (pkg / "a" / "z.py").write_text("from siftom.a.x import f\n")
    assert circles(import_graph(pkg)) == [{"siftom.a.x", "siftom.a.y"}]


# -- never: edges no layering change may bring back ---------------------------------------------

# (importer, imported): neither may import the other in any way (module level, lazy, type-only).
# The layers above would let some of these in (service and bench share a layer; settings sit
# above speech's users); these rules keep them out whatever LAYERS becomes.
NEVER: tuple[tuple[str, str], ...] = (
    ("siftom.service", "siftom.bench"),  # the service serves people through siftom.people
    ("siftom.bench", "siftom.service"),  # the bench listens through siftom.listener
    ("siftom.settings", "siftom.service"),  # settings are read by every door, the service is one
    ("siftom.speech", "siftom.likelihood"),  # speech produces what the likelihoods score
)
# (importer module, imported module) edges of NEVER that still exist, each with why; empty now.
KNOWN_EXCEPTIONS: frozenset[tuple[str, str]] = frozenset()


def _within(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def never_edges(graph: dict[str, set[str]], rules=NEVER) -> list[tuple[str, str]]:
    """The (importer, imported) module edges that break a rule of ``rules``."""
    return sorted((m, t) for m, targets in graph.items() for t in targets
                  for a, b in rules if _within(m, a) and _within(t, b))


def test_never_rules():
    found = [e for e in never_edges(import_graph()) if e not in KNOWN_EXCEPTIONS]
    assert not found, "forbidden imports (tests/test_layers.py NEVER): " + "; ".join(f"{m} -> {t}" for m, t in found)


def test_known_exceptions_still_exist():
    """A known exception that was removed must leave the list (so it cannot come back unnoticed)."""
    gone = KNOWN_EXCEPTIONS - set(never_edges(import_graph()))
    assert not gone, f"remove from KNOWN_EXCEPTIONS, these edges are gone: {sorted(gone)}"


def test_the_never_rules_see_lazy_and_type_only_imports(tmp_path):
    pkg = tmp_path / "siftom"
    for sub in ("service", "bench", "speech", "likelihood"):
        (pkg / sub).mkdir(parents=True)
        (pkg / sub / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "settings.py").write_text("from siftom.service import app\n")
    (pkg / "service" / "app.py").write_text("def f():\n    from siftom.bench.stuff import g\n")  # lazy
    (pkg / "bench" / "stuff.py").write_text("def g():\n    pass\n")
    (pkg / "speech" / "asr.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from siftom import likelihood\n")  # type-only
    assert never_edges(import_graph(pkg)) == [("siftom.service.app", "siftom.bench.stuff"),
                                              ("siftom.settings", "siftom.service.app"),
                                              ("siftom.speech.asr", "siftom.likelihood")]


# -- the environment: read in one place -------------------------------------------------------

def _environment_reads(path: Path):
    """(line, key) of every read of the process environment: ``os.environ.get(K)``,
    ``os.getenv(K)``, ``os.environ[K]`` (a write, ``os.environ[K] = v``, is not a read)."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        key = None
        if isinstance(node, ast.Call) and node.args:
            f = node.func
            if isinstance(f, ast.Attribute) and (
                    (f.attr == "get" and isinstance(f.value, ast.Attribute) and f.value.attr == "environ")
                    or f.attr == "getenv"):
                key = node.args[0]
        elif isinstance(node, ast.Subscript) and isinstance(node.ctx, ast.Load) and \
                isinstance(node.value, ast.Attribute) and node.value.attr == "environ":
            key = node.slice
        if key is not None:
            yield node.lineno, key.value if isinstance(key, ast.Constant) else ast.unparse(key)


@pytest.mark.parametrize("path", [p for p in _modules() if p.relative_to(SRC).parts[0] != "settings"],
                         ids=lambda p: str(p.relative_to(SRC)))
def test_siftom_variables_are_read_only_by_the_settings(path):
    """Every ``SIFTOM_*`` variable is read by ``siftom.settings`` (its ``environment`` module lists
    them all); elsewhere only other programs' variables (``PYTHONPATH``, ``OMP_NUM_THREADS``)."""
    bad = [f"line {n}: {k}" for n, k in _environment_reads(path)
           if not (isinstance(k, str) and k.isupper() and not k.startswith("SIFTOM_") and " " not in k)]
    assert not bad, ("reads the environment outside siftom.settings (ask siftom.settings.environment, "
                     "which lists every variable): " + "; ".join(bad))


def test_the_environment_check_sees_reads(tmp_path):
    mod = tmp_path / "mod.py"
    mod.write_text('import os\nos.environ.get("SIFTOM_X")\nos.getenv(NAME)\nos.environ["A"]\nos.environ["B"] = "1"\n')
    assert list(_environment_reads(mod)) == [(2, "SIFTOM_X"), (3, "NAME"), (4, "A")]


def test_every_variable_the_settings_read_is_listed():
    from siftom.settings import environment

    text = "\n".join(p.read_text(encoding="utf-8") for p in SRC.rglob("*.py"))
    import re

    named = set(re.findall(r'"(SIFTOM_[A-Z0-9_]+)"', text)) - {environment.PREFIX}
    assert named <= set(environment.VARIABLES), f"list these in environment.VARIABLES: {sorted(named - set(environment.VARIABLES))}"


def _model_builds(path: Path) -> list[int]:
    """Lines that construct SIFToM or a likelihood from its registry (``get_likelihood``)."""
    return [node.lineno for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
            if isinstance(node, ast.Call) and (
                (isinstance(node.func, ast.Name) and node.func.id in ("SIFToM", "get_likelihood"))
                or (isinstance(node.func, ast.Attribute) and node.func.attr in ("SIFToM", "get_likelihood")))]


def test_no_model_is_built_outside_the_observer():
    """Every door and the evaluator take their models from ``Observer.model`` (built from the
    settings, cached per mode, likelihood and lexicon), so none may build one of its own."""
    builds = {str(p.relative_to(SRC)): lines for p in _modules()
              if p.relative_to(SRC).as_posix() != "observer.py" and (lines := _model_builds(p))}
    assert not builds, f"build models with siftom.Observer(settings).model(mode, likelihood) instead: {builds}"


def test_the_model_check_sees_a_build(tmp_path):
    mod = tmp_path / "mod.py"
    mod.write_text("from siftom.inference.model import SIFToM\nm = SIFToM(cfg, lk)\nx = reg.get_likelihood('p')\n")
    assert _model_builds(mod) == [2, 3]
