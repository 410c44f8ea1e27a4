"""Smoke tests: each recipe under recipes/ runs on the public API and says what it measured."""

from __future__ import annotations

import ast
import importlib.util
import inspect
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from siftom.bench.sweep import load_config

ROOT = Path(__file__).resolve().parents[1]
RECIPES = ROOT / "recipes"


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("script", sorted(RECIPES.glob("*.py")), ids=lambda p: p.name)
def test_recipes_use_public_names_only(script: Path) -> None:
    tree = ast.parse(script.read_text(encoding="utf-8"))
    private = [f"{n.module}.{a.name}" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module
               and n.module.startswith("siftom") for a in n.names if a.name.startswith("_")]
    private += [n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module and n.module.startswith("siftom")
                and any(part.startswith("_") for part in n.module.split("."))]
    assert not private, f"{script.name} imports private names: {private}"
    assert ast.get_docstring(tree), f"{script.name} has no docstring saying how to run it"


def test_costtogo_recipe_runs(tmp_path: Path) -> None:
    res = _run(str(RECIPES / "costtogo_scenarios.py"), "--goals", "none", "--scenarios", "kitchen-cereal-v0",
               cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "fast - A* = +0" in res.stdout and "differing cases: 0" in res.stdout


def test_sweep_example_loads() -> None:
    cfg = load_config(RECIPES / "sweep_example.toml")
    assert cfg is not None


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
def test_ray_scaling_recipe_runs_locally(tmp_path: Path) -> None:
    res = _run(str(RECIPES / "ray_scaling.py"), "--backend", "local", "--workers", "1", "--out", str(tmp_path),
               "--models", "siftom", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "identical results.jsonl: True" in res.stdout


@pytest.mark.skipif(shutil.which("flite") is None, reason="flite is not installed")
def test_instruction_gate_recipe_runs(tmp_path: Path) -> None:
    res = _run(str(RECIPES / "instruction_gate.py"), "--out", str(tmp_path / "gate"), "--scenarios", "1",
               "--speakers", "1", "--snr", "none", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    summary = json.loads((tmp_path / "gate" / "summary.json").read_text())
    assert set(summary["rates"]) == {"request", "off-topic"}
    assert summary["rates"]["off-topic"]["all"]["n"] == summary["rates"]["request"]["all"]["n"] == 1
    assert "off-topic" in res.stdout and "refused" in res.stdout


# -- the studies (tuning and diagnostics) on a tiny dataset and its evaluation -------------------

def _load(name: str):
    """A recipe as a module (its functions, without running its command line)."""
    spec = importlib.util.spec_from_file_location(f"recipe_{name}", RECIPES / f"{name}.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


TINY_MODELS = ("siftom", "siftom-phonetic", "siftom-oracle-text", "siftom-phonetic-eb")


@pytest.fixture(scope="module")
def tiny_eval(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(dataset, results): one kitchen scenario, clean and pink@10dB, evaluated with TINY_MODELS."""
    if shutil.which("flite") is None:
        pytest.skip("flite is not installed")
    from siftom.bench.dataset import build_dataset
    from siftom.bench.evaluate import EvalOptions, evaluate
    from siftom.people.stimuli import BuildOptions

    root = tmp_path_factory.mktemp("tiny-eval")
    build_dataset(BuildOptions(scenarios=1, speakers=1, voices=("flite-slt",), noises=("pink",), snrs=(10.0,),
                               seed=3), root / "ds")
    evaluate(root / "ds", root / "res", EvalOptions(models=TINY_MODELS), workers=1)
    return root / "ds", root / "res"


def test_calibrate_collects_with_the_library_nbest() -> None:
    from siftom.speech.asr import DEFAULT_NBEST

    mod = _load("calibrate")
    assert inspect.signature(mod.collect).parameters["nbest"].default == DEFAULT_NBEST
    assert mod.ece([1.0, 0.0], [True, False]) == 0.0


@pytest.mark.slow  # the acoustic likelihood (and Whisper, when installed) per stimulus
def test_calibrate_recipe_runs(tiny_eval: tuple[Path, Path], tmp_path: Path) -> None:
    ds, _res = tiny_eval
    res = _run(str(RECIPES / "calibrate.py"), "--dataset", str(ds), "--limit", "2", "--out", str(tmp_path / "cal"),
               "--json", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    fit = json.loads(res.stdout)
    assert fit["all"]["n"] == 2 and {"best_T", "nll", "accuracy", "ece_at_best"} <= set(fit["all"])
    saved = json.loads((tmp_path / "cal" / "calibration.json").read_text())
    assert saved["fit"] == fit and len(saved["rows"]) == 2


def test_loss_aversion_curve_reproduces_the_evaluated_models(tiny_eval: tuple[Path, Path]) -> None:
    from siftom.assist.decide import DEFAULT_LOSS_AVERSION
    from siftom.bench.evaluate import load_results

    _ds, results = tiny_eval
    # the curve re-infers with the run's (phonetic) likelihood: compare with the phonetic models
    curve = _load("loss_aversion").loss_aversion_curve(results, lambdas=(0.0, DEFAULT_LOSS_AVERSION), alphas=(1.0,))
    rows = load_results(results)

    def mean(model: str) -> float:
        return sum(r["models"][model]["speedup"] for r in rows) / len(rows)

    assert curve["n"] == len(rows)
    # re-inferred from the cached transcripts, the MAP and the default rule match the evaluator's N-best rows
    assert curve["siftom"]["speedup"] == pytest.approx(mean("siftom-phonetic"))
    assert curve["loss_aversion"][1]["speedup"] == pytest.approx(mean("siftom-phonetic-eb"))
    # no chance constraint (alpha = 1) is the risk-neutral rule
    assert curve["chance_constraint"][0]["speedup"] == pytest.approx(curve["loss_aversion"][0]["speedup"])


def test_loss_aversion_recipe_runs(tiny_eval: tuple[Path, Path], tmp_path: Path) -> None:
    _ds, results = tiny_eval
    res = _run(str(RECIPES / "loss_aversion.py"), str(results), "--json", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    out = json.loads(res.stdout)
    assert out["target"] == 0.03 and len(out["curves"]) == 1 and "loss_aversion" in out
    text = _run(str(RECIPES / "loss_aversion.py"), str(results), cwd=tmp_path)
    assert text.returncode == 0 and "smallest loss aversion with <= 3 % negative" in text.stdout


def test_decide_speed_recipe_runs(tmp_path: Path) -> None:
    res = _run(str(RECIPES / "decide_speed.py"), "--repeats", "1", "--json", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    out = json.loads(res.stdout)
    assert out["repeats"] == 1 and len(out["cases"]) == len(_load("decide_speed").CASES)
    assert all(r["infer_ms"] > 0 and r["expected-benefit_ms"] > 0 for r in out["cases"])


@pytest.mark.slow  # the acoustic likelihood (and Whisper, when installed) per stimulus
def test_acoustic_weight_recipe_runs(tiny_eval: tuple[Path, Path], tmp_path: Path) -> None:
    ds, _res = tiny_eval
    rows = tmp_path / "aw.jsonl"
    res = _run(str(RECIPES / "acoustic_weight.py"), "collect", str(ds), str(rows), "--step", "1", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert len(rows.read_text().splitlines()) == 2
    res = _run(str(RECIPES / "acoustic_weight.py"), "score", str(rows), "--gammas", "1,0.5", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "(2 stimuli)" in res.stdout and "1.00 |" in res.stdout and "0.50 |" in res.stdout


@pytest.mark.slow  # the acoustic likelihood (and Whisper, when installed) per stimulus
def test_count_diagnostics_recipe_runs(tiny_eval: tuple[Path, Path], tmp_path: Path) -> None:
    ds, _res = tiny_eval
    rows = tmp_path / "cd.jsonl"
    res = _run(str(RECIPES / "count_diagnostics.py"), str(ds), str(rows), "--limit", "2", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    first = json.loads(rows.read_text().splitlines()[0])
    assert {"heard", "whisper", "chosen", "tied", "count_heard", "gold_class"} <= set(first)
    res = _run(str(RECIPES / "count_diagnostics.py"), str(rows), "--summary", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "| n | 1 | 1 |" in res.stdout and "counts nobody heard tied" in res.stdout


def test_count_words_lost_recipe_runs(tiny_eval: tuple[Path, Path], tmp_path: Path) -> None:
    _ds, results = tiny_eval
    res = _run(str(RECIPES / "count_words_lost.py"), str(results), cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "| n | 1 | 1 |" in res.stdout and "| object word lost |" in res.stdout


def test_default_path_recipe_runs(tiny_eval: tuple[Path, Path], tmp_path: Path) -> None:
    _ds, results = tiny_eval
    res = _run(str(RECIPES / "default_path.py"), str(results), cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.count("| res | ") == 3  # siftom, siftom-phonetic, siftom-oracle-text
    res = _run(str(RECIPES / "default_path.py"), str(results), "--compact", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "| res (2) |" in res.stdout


@pytest.mark.parametrize("script", sorted(RECIPES.glob("*.py")), ids=lambda p: p.name)
def test_recipe_answers_help(script: Path, tmp_path: Path) -> None:
    res = _run(str(script), "--help", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "usage:" in res.stdout


def test_every_recipe_has_a_smoke_test() -> None:
    """Each recipe (and each config under recipes/) is run by a test of this file."""
    text = Path(__file__).read_text(encoding="utf-8")
    tested = {n.value for n in ast.walk(ast.parse(text)) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    untested = [p.name for p in sorted(RECIPES.glob("*.py")) if p.name not in tested and p.stem not in tested]
    untested += [p.name for p in sorted(RECIPES.glob("*.toml")) if p.name not in tested]
    assert not untested, f"recipes without a smoke test here: {untested}"


def test_whisper_debias_summary_counts_confident_wrong_answers() -> None:
    rows = [{"snr": "clean", "per": {"0": (0.9, 0.9, True), "1": (0.6, 0.6, True)}},
            {"snr": "5 dB", "per": {"0": (0.05, 0.9, False), "1": (0.3, 0.7, False)}}]
    out = _load("whisper_debias").summarise(rows)
    assert out["all"]["0"] == {"n": 2, "accuracy": 50.0, "confident_wrong": 50.0, "nll": pytest.approx(1.551, abs=1e-3)}
    assert out["all"]["1"]["confident_wrong"] == 0.0 and out["5 dB"]["1"]["accuracy"] == 0.0


@pytest.mark.slow  # the acoustic likelihood and Whisper per stimulus
def test_whisper_debias_recipe_runs(tiny_eval: tuple[Path, Path], tmp_path: Path) -> None:
    pytest.importorskip("faster_whisper")
    ds, _res = tiny_eval
    res = _run(str(RECIPES / "whisper_debias.py"), "--dataset", str(ds), "--limit", "2", "--lambdas", "0,1",
               "--out", str(tmp_path / "rows.jsonl"), "--json", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    out = json.loads(res.stdout)
    assert set(out["all"]) == {"0", "1"} and out["all"]["0"]["n"] == 2
    assert len((tmp_path / "rows.jsonl").read_text().splitlines()) == 2


def test_expert_pooling_settings_parse_and_reject_unknown_pools() -> None:
    mod = _load("expert_pooling")
    assert mod.parse_settings("product:full, mixture:confidence") == [
        ("product:full", "product", False), ("mixture:confidence", "mixture", True)]
    with pytest.raises(SystemExit, match="POOL:SLOT"):
        mod.parse_settings("vote:full")


@pytest.mark.slow  # the acoustic likelihood and Whisper per stimulus
def test_expert_pooling_recipe_runs(tiny_eval: tuple[Path, Path], tmp_path: Path) -> None:
    pytest.importorskip("faster_whisper")
    ds, _res = tiny_eval
    res = _run(str(RECIPES / "expert_pooling.py"), "--dataset", str(ds), "--limit", "2",
               "--settings", "product:full,mixture:confidence", "--out", str(tmp_path / "rows.jsonl"), "--json",
               cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    out = json.loads(res.stdout)
    assert set(out["all"]) == {"product:full", "mixture:confidence"} and out["all"]["product:full"]["n"] == 2
    assert len((tmp_path / "rows.jsonl").read_text().splitlines()) == 2


def test_dereverb_front_end_summary_groups_rooms_bands_and_counts_confident_wrong() -> None:
    def ans(ok: bool, p: float, w: float) -> dict:
        return {"correct": ok, "prob": p, "wer": w, "heard": ""}

    rows = [{"room": "kitchen 3 m", "snr": "clean", "audio_s": 2.0, "front_end_s": 0.2,
             "per": {"as-is": ans(False, 0.9, 0.5), "wpe": ans(True, 0.9, 0.25)}},
            {"room": "dry", "snr": "10 dB", "audio_s": 2.0, "front_end_s": 0.1,
             "per": {"as-is": ans(True, 0.7, 0.0), "wpe": ans(False, 0.85, 1.0)}}]
    mod = _load("dereverb_front_end")
    out = mod.summarise(rows)
    assert list(out) == ["dry", "kitchen 3 m", "10 dB", "clean", "all"]
    assert out["kitchen 3 m"]["as-is"] == {"n": 1, "accuracy": 0.0, "confident_wrong": 100.0, "wer": 50.0}
    assert out["all"]["wpe"] == {"n": 2, "accuracy": 50.0, "confident_wrong": 50.0, "wer": 62.5}
    assert mod.front_end_cost(rows) == {"seconds_per_clip": 0.15, "rtf": 0.075}


@pytest.mark.slow  # the default path twice per stimulus (the acoustic likelihood, and Whisper when installed)
def test_dereverb_front_end_recipe_runs(tiny_eval: tuple[Path, Path], tmp_path: Path) -> None:
    pytest.importorskip("nara_wpe")
    ds, _res = tiny_eval
    res = _run(str(RECIPES / "dereverb_front_end.py"), "--dataset", str(ds), "--limit", "2",
               "--out", str(tmp_path / "rows.jsonl"), "--json", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    out = json.loads(res.stdout)
    assert set(out["groups"]["all"]) == {"as-is", "wpe"} and out["groups"]["all"]["wpe"]["n"] == 2
    assert "dry" in out["groups"] and out["front_end"]["seconds_per_clip"] > 0
    assert len((tmp_path / "rows.jsonl").read_text().splitlines()) == 2


def test_service_profile_recipe_breaks_a_request_down_by_part(tmp_path: Path) -> None:
    pytest.importorskip("fastapi", reason="needs the serve extra")
    res = _run(str(RECIPES / "service_profile.py"), "--rounds", "1", "--requests", "12", "--json", cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    out = json.loads(res.stdout)
    ms = out["ms_per_request"]["this"]
    assert set(ms) == {"wall", "total", "middleware", "validation", "observer", "decision", "reply", "serialisation"}
    assert all(v > 0 for v in ms.values()), ms
    parts = sum(v for k, v in ms.items() if k not in ("total", "wall"))
    assert 0.8 * ms["total"] <= parts <= 1.05 * ms["total"], ms  # the parts account for the request
    assert out["machine"]["cpus"] >= 1 and out["machine"]["processor"]


def test_channel_cells_counts_and_fits_captured_hearings(tmp_path: Path) -> None:
    """The recipe reads captured hearings (as its own run keeps them), counts each recogniser's
    cells and prints the log loss with the stated and the counted tables."""
    import json

    hear = [{"id": "a", "condition": "10dB", "request": True, "classes": ["milk", "cereal"],
             "hearings": [{"texts": ["pass me the milk", "pass me the"], "weights": [0.7, 0.3], "channel": "scene",
                           "reliability": 0.7, "who": "the recogniser"},
                          {"texts": ["pass me the milk"], "weights": [1.0], "channel": "open", "reliability": 0.9,
                           "who": "Whisper"}]},
            {"id": "b", "condition": "10dB", "request": False, "classes": ["milk", "cereal"],
             "hearings": [{"texts": ["the weather is nice"], "weights": [1.0], "channel": "scene", "reliability": 0.7,
                           "who": "the recogniser"},
                          {"texts": ["the weather is nice today"], "weights": [1.0], "channel": "open",
                           "reliability": 0.8, "who": "Whisper"}]}]
    (tmp_path / "h.json").write_text(json.dumps(hear))
    res = _run(str(RECIPES / "channel_cells.py"), "--hearings", str(tmp_path / "h.json"), "--out",
               str(tmp_path / "o" / "x.jsonl"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "Whisper: 1 requests, 1 that asked nothing" in res.stdout
    # the stated table reads both right: a request well above 1/3, the weather talk below
    stated = next(line for line in res.stdout.splitlines() if line.strip().startswith("stated open cells"))
    assert stated.rstrip().endswith("0.0, 0.0)")


@pytest.mark.slow  # the acoustic likelihood and Whisper per stimulus and K
def test_whisper_share_recipe_runs(tiny_eval: tuple[Path, Path], tmp_path: Path) -> None:
    pytest.importorskip("faster_whisper")
    ds, _res = tiny_eval
    res = _run(str(RECIPES / "whisper_share.py"), "--dataset", str(ds), "--limit", "2", "--ks", "2,all", "--json",
               cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "all" in res.stdout
