"""The command line: scenarios, simulate, infer and bench, as a user types them."""

import json
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

# register both built-in domains whatever was imported first (tests/world/test_domains.py, xfail)
import siftom.world.domains.household  # noqa: F401
import siftom.world.domains.kitchen  # noqa: F401
from siftom.cli import main, root

VIRTUALHOME = Path(__file__).parents[1] / "data" / "virtualhome" / "apartment_graph.json"
SILVER = "can you pass me the silver"


@pytest.fixture
def cli():
    runner = CliRunner()

    def invoke(*args):
        res = runner.invoke(root, list(args), catch_exceptions=False)
        assert res.exit_code == 0, res.output
        return res.output

    return invoke


def test_scenarios_list_json(cli):
    out = json.loads(cli("scenarios", "list", "--json"))
    assert {d["id"] for d in out["domains"]} == {"household-table-v0", "kitchen-v0"}
    ids = [r["id"] for r in out["scenarios"]]
    assert "kitchen-cereal-v0" in ids
    assert sum(1 for i in ids if i.startswith("household-table-v0/")) == 26
    row = next(r for r in out["scenarios"] if r["id"] == "kitchen-cereal-v0")
    assert row["command"] == "fetch(cereal)" and row["goal"] == "breakfast_cereal" and row["num_goals"] >= 100


def test_scenarios_list_filters_by_domain(cli):
    out = json.loads(cli("scenarios", "list", "--json", "--domain", "kitchen-v0"))
    assert out["scenarios"] and all(r["domain"] == "kitchen-v0" for r in out["scenarios"])


def test_scenarios_list_fits_80_columns_without_cutting_ids(cli, monkeypatch):
    rows = json.loads(cli("scenarios", "list", "--json"))["scenarios"]
    monkeypatch.setenv("COLUMNS", "80")
    lines = cli("scenarios", "list").splitlines()
    assert all(len(line) <= 80 for line in lines), max(lines, key=len)
    assert "\u2026" not in "\n".join(lines)  # nothing shortened with an ellipsis
    starts = {line.split()[0] for line in lines if line and not line.startswith(" ")}
    for r in rows:  # every id and gold command in full, on the scenario's own line
        assert r["id"] in starts
        line = next(ln for ln in lines if ln.startswith(r["id"] + " "))
        assert line.split()[1:] == [str(r["num_goals"]), str(r["num_actions"]), r["command"]]
    assert "for the waterglasses" in "\n".join(lines) and "waterglasss" not in "\n".join(lines)


def test_scenarios_show_writes_a_png(cli, tmp_path):
    png = tmp_path / "maps" / "cereal.png"
    out = cli("scenarios", "show", "kitchen-cereal-v0", "--png", str(png))
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 5000
    assert "kitchen-cereal-v0" in out and "fetch(cereal)" in out
    info = json.loads(cli("scenarios", "show", "kitchen-cereal-v0", "--json"))
    assert info["goal"]["name"] == "breakfast_cereal" and len(info["actions"]) == 10


def test_simulate_json(cli):
    out = json.loads(cli("simulate", "household-table-v0/6", "--command", "deliver(fork,3)", "--json"))
    assert {"l_single", "l_team", "speedup"} <= set(out)
    assert out["speedup"] == pytest.approx(out["l_single"] / out["l_team"] - 1)
    text = cli("simulate", "kitchen-cereal-v0", "--command", "fetch(cereal)")
    assert "L_single" in text and "speedup" in text


@pytest.mark.parametrize("command", ["deliver fork", "deliver(fork,0)", "fetch(spaceship)"])
def test_simulate_bad_command_exits_2_and_lists_valid_forms(capsys, command):
    assert main(["simulate", "kitchen-cereal-v0", "--command", command]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "alid forms" in err
    assert "Traceback" not in err


def test_unknown_scenario_exits_2_with_suggestions(capsys):
    assert main(["scenarios", "show", "kitchen-cereal-v1"]) == 2
    assert "Did you mean 'kitchen-cereal-v0'" in capsys.readouterr().err


def test_infer_scenario_json(cli):
    out = json.loads(cli("infer", "--scenario", "kitchen-cereal-v0", "--transcript", SILVER, "--json"))
    assert out["top_command"] == "fetch(cereal)" and out["action"] in ("act", "ask")
    assert out["action"] == "act" or "cereal" in out["decision"]["question"]  # a question names it
    assert out["commands"][0] == {"command": "fetch(cereal)", "prob": out["commands"][0]["prob"]}
    assert {"goal", "prob"} == set(out["goals"][0])
    table = cli("infer", "--scenario", "kitchen-cereal-v0", "--transcript", SILVER)
    assert "most probable command: fetch(cereal)" in table and "rule teammate" in table


def test_infer_words_name_no_recogniser_and_the_rule(cli):
    out = json.loads(cli("infer", "--scenario", "kitchen-cereal-v0", "--transcript", SILVER, "--json"))
    assert out["recogniser"] is None  # the words were given: nothing heard them
    assert out["likelihood"] == "phonetic" and out["rule"] == out["decision"]["rule"] == "teammate"
    text = " ".join(cli("infer", "--scenario", "kitchen-cereal-v0", "--transcript", SILVER).split())
    assert f'words given as a transcript (--transcript), no recogniser ran: "{SILVER}"' in text
    assert "scored by the likelihood phonetic" in text and "decision rule teammate" in text


def test_infer_audio_names_who_heard_it(cli, tmp_path):
    from support.streaming import say

    wav = tmp_path / "cereal.wav"
    say("can you pass me the cereal", wav)
    out = json.loads(cli("infer", "--scenario", "kitchen-cereal-v0", "--audio", str(wav), "--json"))
    assert out["recogniser"] == out["asr"]["engine"] == "pocketsphinx-vocab"  # the default engine, with the scene
    assert out["likelihood"] in ("acoustic", "phonetic") and out["likelihood"] == out["evidence"]["likelihood"]
    assert out["rule"] == out["decision"]["rule"] == "teammate"
    text = " ".join(cli("infer", "--scenario", "kitchen-cereal-v0", "--audio", str(wav)).split())
    assert f'heard by the recogniser pocketsphinx-vocab: "{out["transcript"]}"' in text
    assert f"scored by the likelihood {out['likelihood']} (" in text
    assert "decision rule teammate" in text


def test_infer_help_states_the_real_defaults(cli):
    from siftom.inference.model import ModelConfig
    from siftom.options import InferOptions

    # click wraps help at 80 columns, also after a hyphen: undo both
    text = re.sub(r"(\w-) (\w)", r"\1\2", " ".join(cli("infer", "--help").split()))
    infer, model = InferOptions(), ModelConfig()
    assert f"setting infer.decide, default {infer.decide}" in text and f"{infer.decide} (default)" in text
    assert f"setting infer.likelihood, default {infer.likelihood}:" in text
    assert f"setting infer.engine, default {infer.engine};" in text and f"{infer.engine} (default)" in text
    assert f"setting model.mode, default {model.mode}" in text
    # one "(default)" per registry list, each the setting's default: never the registry's own
    assert text.count("(default)") == 2, text
    assert "phonetic (default)" not in text and "map (default)" not in text


def test_infer_ablation_flag(cli):
    out = json.loads(cli("infer", "--scenario", "kitchen-cereal-v0", "--model", "action-only", "--json"))
    assert out["mode"] == "action-only" and out["transcript"] == ""


def test_infer_with_actions_on_a_registered_scenario(cli, tmp_path):
    acts = tmp_path / "acts.txt"
    acts.write_text("# the human fetches the milk\nwalk(human, fridge)\nopen(human, fridge)\n"
                    "grab(human, milk, fridge)\n")
    out = json.loads(cli("infer", "--scenario", "kitchen-cereal-v0", "--actions", str(acts),
                         "--transcript", SILVER, "--json"))
    assert out["n_actions"] == 3


WORLD = {
    "places": [{"name": "table", "kind": "surface", "room": "dining", "pos": [0, 0]},
               {"name": "drawer", "kind": "container", "room": "kitchen", "pos": [5, 1], "closable": True},
               {"name": "shelf", "kind": "surface", "room": "kitchen", "pos": [6, -2]}],
    "doors": [{"rooms": ["dining", "kitchen"], "pos": [2, 0]}],
    "items": [{"name": "fork_1", "class": "fork", "at": "drawer"},
              {"name": "fork_2", "class": "fork", "at": "drawer"},
              {"name": "plate_1", "class": "plate", "at": "shelf"},
              {"name": "plate_2", "class": "plate", "at": "shelf"}],
    "agents": {"human": "table", "robot": "table"},
    "target": "table",
    "verb": "deliver",
    "goals": [{"name": "two forks and two plates", "counts": {"fork": 2, "plate": 2}},
              {"name": "two forks", "counts": {"fork": 2}}],
}


def test_infer_on_a_user_world_with_actions(cli, tmp_path):
    scene = tmp_path / "world.json"
    scene.write_text(json.dumps(WORLD))
    acts = tmp_path / "acts.json"
    acts.write_text(json.dumps(["walk(human, shelf)", "grab(human, plate_1, shelf)", "walk(human, table)",
                                "put(human, plate_1, table)"]))
    out = json.loads(cli("infer", "--scene", str(scene), "--actions", str(acts), "--transcript",
                         "bring me the forks", "--json"))
    assert out["command"] == "deliver(fork,2)" and out["n_actions"] == 4
    assert {g["goal"] for g in out["goals"]} >= {"two forks and two plates", "two forks"}


@pytest.mark.parametrize("rule", ["expected-benefit", "ask-or-act"])
def test_infer_decides_on_a_user_world(cli, tmp_path, rule):
    scene = tmp_path / "world.json"
    scene.write_text(json.dumps(WORLD))
    out = json.loads(cli("infer", "--scene", str(scene), "--transcript", "bring me two forks", "--decide", rule,
                         "--json"))
    d = out["decision"]
    assert d["rule"] == rule and d["action"] in ("deliver(fork,2)", "deliver(fork,1)", "ask")
    assert d["benefits"][0]["expected_benefit"] > 0


def test_infer_on_a_user_world_refuses_an_impossible_action(tmp_path, capsys):
    scene = tmp_path / "world.json"
    scene.write_text(json.dumps(WORLD))
    acts = tmp_path / "acts.txt"
    acts.write_text("walk(human, drawer)\ngrab(human, fork_1, drawer)\n")  # the drawer is closed
    assert main(["infer", "--scene", str(scene), "--actions", str(acts), "--transcript", "forks"]) == 2
    err = capsys.readouterr().err
    assert "action 2" in err and "closed; open it first" in err


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["infer", "--transcript", "x"], "exactly one of --scenario ID or --scene FILE"),
        (["infer", "--scenario", "kitchen-cereal-v0"], "give --transcript"),
        (["infer", "--scenario", "kitchen-cereal-v0", "--transcript", "  "], "transcript is empty"),
    ],
)
def test_infer_usage_errors_exit_2(capsys, args, message):
    assert main(args) == 2
    assert message in capsys.readouterr().err


@pytest.mark.skipif(not VIRTUALHOME.exists(), reason=f"VirtualHome apartment not found at {VIRTUALHOME}")
def test_infer_on_the_virtualhome_apartment(cli):
    out = json.loads(cli("infer", "--scene", str(VIRTUALHOME), "--transcript", "bring me two forks", "--json"))
    assert out["command"] == "deliver(fork,2)"
    assert len(out["warnings"]) > 2  # each one, with its fix, for programs


@pytest.mark.skipif(not VIRTUALHOME.exists(), reason=f"VirtualHome apartment not found at {VIRTUALHOME}")
def test_infer_on_the_virtualhome_apartment_warns_in_one_line(capsys):
    # the README's command: what the graph leaves out is one line before the answer, not one per class
    assert main(["infer", "--scene", str(VIRTUALHOME), "--transcript", "bring me two forks"]) == 0
    got = capsys.readouterr()
    lines = [ln for ln in got.err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("warning: "), got.err
    assert "banana" in lines[0] and "--json" in lines[0]
    assert "deliver(fork,2)" in got.out


def test_bench_planner_json(cli):
    out = json.loads(cli("bench", "planner", "--json", "--repeats", "2"))
    assert {"num_goals", "num_actions", "q_values", "q_table_p50_ms", "v_per_second", "astar_nodes_expanded",
            "astar_nodes_per_second"} <= set(out)
    assert out["num_goals"] >= 100 and out["num_actions"] == 10 and out["q_values"] > 0


def test_infer_with_no_instruction_says_no_likelihood_scored_it(capsys):
    # "thanks" asks for nothing: the posterior is the actions' alone, and the console says so
    # rather than "scored by the likelihood none" beside the reason the phonetic one was chosen
    assert main(["infer", "--scenario", "kitchen-cereal-v0", "--transcript", "thanks"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "scored by no likelihood: no instruction to score" in out
    assert "the likelihood none" not in out
