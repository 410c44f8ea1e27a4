"""The benchmark end to end on a tiny dataset: build, evaluate, resume, report, determinism."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from siftom.bench.dataset import build_dataset
from siftom.bench.evaluate import RESULTS, EvalOptions, evaluate, load_results
from siftom.bench.report import write_report
from siftom.errors import DatasetError
from siftom.people.stimuli import BuildOptions, load_dataset

pytestmark = pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")

TINY = BuildOptions(scenarios=2, speakers=1, voices=("flite-slt",), noises=("pink",), snrs=(10.0,), seed=3)
SUMMARY_KEYS = {"accuracy", "accuracy_ci", "speedup", "neg_speedup_share", "helpful_error_share", "n"}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("tiny") / "ds"
    build_dataset(TINY, out)
    return out


@pytest.fixture(scope="module")
def tiny_results(tiny: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("res") / "r"
    evaluate(tiny, out)
    write_report(out)
    return out


def test_build_writes_manifest_audio_and_datasheet(tiny: Path) -> None:
    ds = load_dataset(tiny)
    assert len(ds.stimuli) == 2 * 1 * 2  # scenarios x speakers x (clean + one SNR)
    assert {s.condition for s in ds.stimuli} == {"clean", "pink@10dB"}
    for s in ds.stimuli:
        assert (tiny / s.audio).is_file()
        assert s.reference and s.gold_command.startswith("deliver(")
        assert s.observed_actions
    assert (tiny / "README.md").read_text().startswith("# Datasheet")


def test_same_seed_same_manifest(tiny: Path, tmp_path: Path) -> None:
    again = tmp_path / "again"
    build_dataset(TINY, again)
    assert (again / "manifest.jsonl").read_text() == (tiny / "manifest.jsonl").read_text()
    assert (again / "audio" / "000-s1-pink-10db.wav").read_bytes() == (tiny / "audio" / "000-s1-pink-10db.wav").read_bytes()


def test_eval_writes_results_summary_report_and_figures(tiny_results: Path) -> None:
    for name in ("results.jsonl", "summary.json", "report.md", "accuracy_speedup.png", "speedup_hist.png"):
        assert (tiny_results / name).is_file(), name
    summary = json.loads((tiny_results / "summary.json").read_text())
    assert set(summary["models"]) == {"literal-asr", "speech-only", "action-only", "siftom", "siftom-phonetic",
                                      "siftom-oracle-text", "siftom-eb", "siftom-ask", "siftom-teammate"}
    for m in summary["models"].values():
        assert {"questions_per_trial", "confident_wrong_share", "no_speedup", "no_speedup_reasons"} <= set(m)
        assert set(m) >= SUMMARY_KEYS
        assert m["n"] == 4
        lo, hi = m["accuracy_ci"]
        assert lo <= m["accuracy"] <= hi
    rows = [json.loads(x) for x in (tiny_results / RESULTS).read_text().splitlines()]
    # the reference transcript always names the class (the count may go unsaid)
    for row in rows:
        chosen = row["models"]["siftom-oracle-text"]["command"]
        assert chosen.split(",")[0] == row["gold_command"].split(",")[0]
        assert row["models"]["siftom-oracle-text"]["helpful"] or row["models"]["siftom-oracle-text"]["correct"]
    r = rows[0]["models"]["siftom"]
    assert {"command", "correct", "helpful", "l_single", "l_team", "remedy_steps", "speedup"} <= set(r)



def test_summary_and_report_give_accuracy_per_voice(tiny_results: Path) -> None:
    summary = json.loads((tiny_results / "summary.json").read_text())
    by_voice = summary["breakdowns"]["voice"]
    assert set(by_voice) == {"flite-slt"}
    for m, cell in by_voice["flite-slt"].items():
        assert cell["n"] == 4 and cell["accuracy"] == summary["models"][m]["accuracy"]
    assert set(summary["asr_wer"]["voice"]) == {"flite-slt"}
    report = (tiny_results / "report.md").read_text()
    assert "## By voice" in report and "| flite-slt |" in report


def test_the_siftom_row_is_the_products_default_path(tiny: Path, tmp_path: Path) -> None:
    """``siftom`` runs the likelihood a recording gets by default (acoustic with the whisper extra);
    ``siftom-acoustic`` is its alias and ``siftom-phonetic`` keeps the N-best one."""
    from siftom.likelihood.whisper_factor import whisper_available

    out = tmp_path / "d"
    evaluate(tiny, out, EvalOptions(models=("siftom", "siftom-acoustic", "siftom-phonetic")), workers=1)
    run = json.loads((out / "run.json").read_text())
    want = "acoustic" if whisper_available() else "phonetic"
    assert run["options"]["siftom_likelihood"] == want
    for row in load_results(out):
        m = row["models"]
        assert want == "phonetic" or (m["siftom"]["command"], m["siftom"]["prob"]) == (m["siftom-acoustic"]["command"],
                                                                  m["siftom-acoustic"]["prob"])
        assert 0 < m["siftom-phonetic"]["prob"] <= 1


def test_asking_model_speaks_the_answer_and_pays_for_the_question(tiny: Path, tmp_path: Path) -> None:
    from siftom.assist.askcost import QuestionCost

    evaluate(tiny, tmp_path / "ask", EvalOptions(models=("siftom-eb", "siftom-ask")))
    rows = load_results(tmp_path / "ask")
    asked = [r for r in rows if r["models"]["siftom-ask"]["asked"]]
    assert asked, "a tiny household set always has an unsaid count worth asking about"
    for r in asked:
        a = r["models"]["siftom-ask"]
        assert a["question_kind"] in ("confirm", "choose", "count") and a["question"].endswith("?")
        # asked because the question was worth more than its spoken time; it pays the time it took
        assert a["answer"] and a["evi"] > a["question_cost"]
        assert a["ask_cost"] == pytest.approx(QuestionCost().steps(a["question"], a["answer"]), abs=1e-3)
        # the question's time is on the team's clock
        assert a["l_team"] == pytest.approx(r["models"]["siftom-eb"]["l_team"] + a["ask_cost"]) or \
            a["command"] != r["models"]["siftom-eb"]["command"]
        assert a["speedup"] == pytest.approx(a["l_single"] / a["l_team"] - 1, abs=1e-6)
    summary = write_report(tmp_path / "ask", figures=False)
    assert summary["models"]["siftom-ask"]["questions_per_trial"] == pytest.approx(len(asked) / len(rows))
    assert summary["models"]["siftom-ask"]["accuracy_after_answer"] is not None
    # deterministic: the same answers are heard again
    evaluate(tiny, tmp_path / "ask2", EvalOptions(models=("siftom-eb", "siftom-ask")))
    again = {r["id"]: r["models"]["siftom-ask"] for r in load_results(tmp_path / "ask2")}
    for r in rows:
        assert again[r["id"]] == r["models"]["siftom-ask"]  # timings are in timings.jsonl


def test_same_seed_same_summary(tiny: Path, tiny_results: Path, tmp_path: Path) -> None:
    evaluate(tiny, tmp_path / "r2", workers=2)
    again = write_report(tmp_path / "r2", figures=False)
    first = json.loads((tiny_results / "summary.json").read_text())
    assert again["models"] == first["models"]


def test_interrupted_eval_resumes_without_redoing(tiny: Path, tmp_path: Path) -> None:
    out = tmp_path / "r"

    def stop_after_two(done: int, total: int) -> None:
        if done >= 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        evaluate(tiny, out, progress=stop_after_two)
    assert len((out / RESULTS).read_text().splitlines()) == 2
    run = evaluate(tiny, out)
    assert (run.resumed, run.evaluated) == (2, 2)
    ids = [json.loads(x)["id"] for x in (out / RESULTS).read_text().splitlines()]
    assert sorted(ids) == sorted(s.id for s in load_dataset(tiny).stimuli)


def test_torn_last_line_is_dropped_on_resume(tiny: Path, tiny_results: Path, tmp_path: Path) -> None:
    out = tmp_path / "r"
    shutil.copytree(tiny_results, out)
    lines = (out / RESULTS).read_text().splitlines(keepends=True)
    (out / RESULTS).write_text("".join(lines[:-1]) + lines[-1][:20])  # killed mid-write
    run = evaluate(tiny, out)
    assert run.evaluated == 1
    assert len((out / RESULTS).read_text().splitlines()) == 4


def test_other_settings_refuse_to_mix_results(tiny: Path, tiny_results: Path, tmp_path: Path) -> None:
    out = tmp_path / "r"
    shutil.copytree(tiny_results, out)
    with pytest.raises(DatasetError, match="another run"):
        evaluate(tiny, out, EvalOptions(models=("siftom",)))


def test_report_rerenders_from_results(tiny_results: Path) -> None:
    (tiny_results / "report.md").unlink()
    summary = write_report(tiny_results, figures=False)
    text = (tiny_results / "report.md").read_text()
    assert "| siftom |" in text and summary["n_stimuli"] == 4


def test_cli_check_report_and_error_message(tiny: Path, tiny_results: Path, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    from siftom.cli import main

    assert main(["dataset", "check", str(tiny)]) == 0
    assert "ok: 4 stimuli" in capsys.readouterr().out
    assert main(["report", str(tiny_results), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_stimuli"] == 4
    assert main(["eval", "--dataset", str(tmp_path / "none"), "--out", str(tmp_path / "r")]) == 2
    assert "siftom dataset build" in capsys.readouterr().err


def test_cli_build_and_eval_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from siftom.cli import main

    ds, res = tmp_path / "ds", tmp_path / "res"
    assert main(["dataset", "build", "--out", str(ds), "--scenarios", "1", "--speakers", "1",
                 "--voices", "flite-slt", "--snr", "none", "--workers", "1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["stimuli"] == 1
    assert main(["eval", "--dataset", str(ds), "--out", str(res), "--models", "literal-asr,siftom",
                 "--workers", "1", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert set(summary["models"]) == {"literal-asr", "siftom"}


def test_llm_baselines_run_in_the_evaluator_with_any_scorer(tiny: Path, tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    from siftom.bench import llm_baselines as lb

    class Prefers:  # an LM that always prefers forks: the baseline must follow its scores
        model_id = "fake"

        def score(self, prefix, items):
            return [0.0 if "fork" in t else -3.0 for _c, t in items]

    choosers = {m: lb.LLMChooser(Prefers(), m == "llm-ablated-siftom") for m in lb.LLM_MODELS}
    monkeypatch.setattr(lb, "chooser", lambda m, config=None: choosers[m])
    evaluate(tiny, tmp_path / "llm", EvalOptions(models=("siftom", *lb.LLM_MODELS)), workers=1)
    write_report(tmp_path / "llm")
    rows = load_results(tmp_path / "llm")
    assert all(r["models"][m]["command"].startswith("deliver(fork,") for r in rows for m in lb.LLM_MODELS)
    summary = json.loads((tmp_path / "llm" / "summary.json").read_text())
    assert set(summary["models"]) == {"siftom", *lb.LLM_MODELS}


def test_siftom_llm_and_chat_baselines_run_against_an_endpoint(tiny: Path, tmp_path: Path, fake_openai) -> None:
    """siftom-llm scores prompts at /completions; the baselines, finding no echo log-probs
    there for their prompts, ask /chat/completions instead (multiple choice)."""
    import re

    from siftom.backends.config import LLMConfig
    from support.fake_openai import Reply, chat_answer, echo_logprobs

    def likes_forks(text, offset, token):
        return -0.1 if "forks" in text.rsplit("Command:", 1)[-1] else -2.0

    def completions(req):
        if any("Choose the robot command" in p for p in req.body["prompt"]):
            return Reply.error(400, "echo is not supported with logprobs for this model")
        return echo_logprobs(likes_forks)(req)

    def chat(req):
        opts = dict(re.findall(r"^(\d+)\. (.*)$", req.body["messages"][-1]["content"], flags=re.M))
        k = next(n for n, c in opts.items() if "forks, 2" in c)
        return Reply.json(chat_answer(k, top_logprobs=[[(k, -0.05)]]))

    fake_openai.on("completions", completions).on("chat/completions", chat)
    llm = LLMConfig(backend="openai", base_url=fake_openai.url, model="m", cache_dir=tmp_path / "cache")
    models = ("siftom-llm", "llm-end-to-end", "llm-ablated-siftom")
    evaluate(tiny, tmp_path / "r", EvalOptions(models=models, llm=llm), workers=1)
    rows = load_results(tmp_path / "r")
    assert all(r["models"]["llm-end-to-end"]["command"] == "deliver(fork,2)" for r in rows)
    assert all(r["models"]["siftom-llm"]["command"].startswith("deliver(fork,") for r in rows)
    assert fake_openai.bodies("chat/completions") and fake_openai.bodies("completions")
    run = json.loads((tmp_path / "r" / "run.json").read_text())
    assert run["options"]["llm"] == {"backend": "openai", "base_url": fake_openai.url, "model": "m",
                                     "prompt": "sounds"}


def test_a_trial_whose_answer_cannot_be_said_is_not_evaluable_and_the_eval_goes_on(
        tiny: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # a dataset whose noise is not available here (e.g. built from recordings elsewhere)
    ds = tmp_path / "ds"
    shutil.copytree(tiny, ds)
    manifest = ds / "manifest.jsonl"
    # (every stimulus: the clean ones are mixed at 20 dB, so any question's answer needs the noise)
    manifest.write_text(manifest.read_text().replace('"noise": "pink"', '"noise": "cat_meowing"')
                        .replace('"noise": null, "snr_db": null', '"noise": "cat_meowing", "snr_db": 20.0'))
    run = evaluate(ds, tmp_path / "r", EvalOptions(models=("siftom", "siftom-ask")))
    rows = load_results(tmp_path / "r")
    assert len(rows) == len(load_dataset(ds).stimuli) == run.evaluated
    skipped = [r for r in rows if "siftom-ask" in r.get("not_evaluable", {})]
    assert skipped, "the asking model asks on a tiny household set"
    assert all("siftom" in r["models"] for r in rows)  # the other models were evaluated on every trial
    assert "cat_meowing" in skipped[0]["not_evaluable"]["siftom-ask"]
    summary = write_report(tmp_path / "r", figures=False)
    assert summary["not_evaluable"]["siftom-ask"]["n"] == len(skipped)
    if "siftom-ask" in summary["models"]:
        assert summary["models"]["siftom-ask"]["n"] == len(rows) - len(skipped)
    assert "Not evaluable for siftom-ask" in (tmp_path / "r" / "report.md").read_text()
