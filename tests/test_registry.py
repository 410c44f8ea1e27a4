"""The one registry shape: lazy entry points, refusals explained before construction."""

import sys

import pytest

import siftom.registry
from siftom.errors import BackendUnavailableError, SiftomError, UnknownNameError
from siftom.registry import Registry, load_all


@pytest.fixture
def reg(request):
    r = Registry(f"test thing {request.node.name}", default="b")
    yield r
    siftom.registry._ALL.pop(r.kind, None)


def test_make_imports_lazily_and_constructs(reg):
    reg.register("a", "fractions:Fraction", summary="a fraction")
    reg.register("b", "collections:OrderedDict")
    assert reg.names() == ("b", "a")  # default first
    assert reg.make("a", numerator=3, denominator=6) == 0.5
    assert reg.make() == {}  # the default


def test_unknown_names_suggest_close_matches(reg):
    reg.register("pocketsphinx", "fractions:Fraction")
    with pytest.raises(UnknownNameError, match="Did you mean 'pocketsphinx'"):
        reg.spec("pocketsphinks")


def test_a_missing_module_is_explained_before_anything_is_imported(reg):
    reg.register("ghost", "no_such_module_xyz.sub:Thing", requires=("no_such_module_xyz",), extra="ghost")
    e = reg.spec("ghost")
    assert "pip install \"siftom[ghost]\"" in e.missing()
    with pytest.raises(BackendUnavailableError, match=r'siftom\[ghost\]'):
        reg.make("ghost")
    assert "no_such_module_xyz" not in sys.modules
    assert reg.available() == ()
    assert reg.describe()[0].available is False


def test_a_missing_program_names_the_apt_package(reg):
    reg.register("tts", "fractions:Fraction", binaries=("no-such-binary-xyz",))
    with pytest.raises(BackendUnavailableError, match="apt-get install -y no-such-binary-xyz"):
        reg.check("tts")


def test_a_custom_checker_can_refuse(reg):
    reg.register("endpoint", "fractions:Fraction", checker="tests.test_registry:_refuse")
    assert reg.spec("endpoint").missing() == "set SIFTOM_TEST_URL"
    assert "(unavailable)" in reg.help_line()


def _refuse():
    return "set SIFTOM_TEST_URL"


def test_names_register_once_and_entry_points_are_checked(reg):
    reg.register("x", "fractions:Fraction")
    with pytest.raises(SiftomError, match="registered already"):
        reg.register("x", "fractions:Fraction")
    reg.register("bad", "fractions.Fraction")
    with pytest.raises(SiftomError, match="module:attr"):
        reg.make("bad")


def test_lazy_loaders_run_on_first_lookup(reg):
    calls = []
    reg.on_first_use(lambda: (calls.append(1), reg.register("late", "fractions:Fraction")))
    assert calls == []
    assert "late" in reg
    assert calls == [1]


def test_every_builtin_registry_entry_describes_itself():
    regs = load_all()
    assert "domain" in regs
    for r in regs.values():
        for line in r.describe():
            assert line.name and isinstance(line.to_json()["available"], bool)


def test_plugins_command_lists_every_registry(capsys):
    import json

    from siftom.cli import main

    assert main(["plugins", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"domain", "voice", "decision rule"} <= set(out)
    assert {"household-table-v0", "kitchen-v0"} == {e["name"] for e in out["domain"]}
    assert main(["plugins", "--kind", "domian"]) == 2
    assert "Did you mean 'domain'" in capsys.readouterr().err


def test_healthz_lists_the_plugins(tmp_path):
    pytest.importorskip("fastapi")
    from siftom.service.app import create_app
    from support.client import local_client

    with local_client(create_app(tmp_path)) as c:
        body = c.get("/healthz").json()
    assert {e["name"] for e in body["plugins"]["decision rule"]} == {"map", "expected-benefit", "ask-or-act", "teammate"}


KINDS = ("domain", "voice", "decision rule", "instruction likelihood", "ASR engine", "LLM backend")


@pytest.mark.parametrize("kind", KINDS)
def test_each_kind_is_one_registry_that_explains_refusals_before_construction(kind, monkeypatch):
    import importlib.util

    regs = load_all()
    assert kind in regs, f"{kind} is not registered through siftom.registry"
    reg = regs[kind]
    with pytest.raises(UnknownNameError, match="Valid:"):
        reg.spec("no-such-thing")
    needing = [reg.spec(n) for n in reg.names() if reg.spec(n).requires or reg.spec(n).binaries]
    if not needing:
        return
    entry = needing[0]
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name in entry.requires else real(name, *a))
    monkeypatch.setattr("shutil.which", lambda name: None)
    with pytest.raises(BackendUnavailableError, match=r"pip install|apt-get install"):
        reg.make(entry.name)
