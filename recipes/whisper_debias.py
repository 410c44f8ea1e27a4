"""Content-free debiasing of the Whisper factor: accuracy, confident wrong answers and NLL per lambda.

The acoustic likelihood scores each candidate text t as log P(t | audio) - lambda * log P(t | null),
null being digital silence as long as the clip's feature window (``[likelihoods.acoustic]
whisper_prior``; likelihood/whisper_factor.py). For every stimulus the evaluator's acoustic path
runs once (recognition of the whole clip, Whisper's encoding, transcript and text scores, kept
for the clip), then the full model's posterior is recomputed for each lambda (a clip where
nothing was recognised is answered from the actions alone, as the evaluator's ``siftom`` does). Per SNR band and
overall: accuracy, the share answered wrongly with P >= 0.8, and the mean NLL of the gold command.
Choose lambda on one dataset and report it on others (other seed, voices and noise).

    python recipes/whisper_debias.py --dataset DIR [--lambdas 0,0.25,0.5,1] [--limit N] [--json]
"""

from __future__ import annotations

import argparse
import hashlib
import json
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

LAMBDAS = (0.0, 0.25, 0.5, 0.75, 1.0)
CONFIDENT = 0.8


class PerClip:
    """A WhisperScorer whose encodings, transcripts and text scores are kept until :meth:`reset`
    (one clip), so every lambda reuses them; the content-free scores are memoised by the factor."""

    def __init__(self, inner: Any) -> None:
        self.inner, self.model_dir, self.pad_s = inner, inner.model_dir, inner.pad_s
        self._enc: dict[str, Any] = {}
        self._heard: dict[tuple[int, str | None], Any] = {}
        self._scores: dict[tuple[int, str], float] = {}

    def reset(self) -> None:
        """Forget the clip."""
        self._enc.clear()
        self._heard.clear()
        self._scores.clear()

    def encode(self, audio: Any) -> Any:
        """The inner scorer's encoding, once per distinct clip."""
        key = hashlib.sha1(np.ascontiguousarray(audio, dtype=np.float32).tobytes()).hexdigest()
        if key not in self._enc:
            self._enc[key] = self.inner.encode(audio)
        return self._enc[key]

    def hear_encoded(self, enc: Any, prompt: str | None = None) -> Any:
        """The inner scorer's transcript, once per encoding and prompt."""
        key = (id(enc), prompt)
        if key not in self._heard:
            self._heard[key] = self.inner.hear_encoded(enc, prompt=prompt)
        return self._heard[key]

    def score_encoded(self, enc: Any, texts: list[str]) -> np.ndarray:
        """The inner scorer's text scores; only texts not scored against ``enc`` yet are computed."""
        new = [t for t in dict.fromkeys(texts) if (id(enc), t) not in self._scores]
        if new:
            self._scores.update(zip([(id(enc), t) for t in new], self.inner.score_encoded(enc, new).tolist(),
                                    strict=True))
        return np.array([self._scores[(id(enc), t)] for t in texts], dtype=float)


def collect(dataset: str | Path, lambdas: tuple[float, ...] = LAMBDAS, limit: int | None = None,
            engine: str = "pocketsphinx-vocab") -> list[dict[str, Any]]:
    """Per stimulus: its band and, per lambda, (P(gold), P(chosen), chosen is right)."""

    def weight(lam: float) -> Callable[[Any, Any], None]:
        return lambda _lk, factor: setattr(factor, "prior_weight", float(lam))

    return sweep(dataset, {f"{lam:g}": weight(lam) for lam in lambdas}, limit, engine)


def sweep(dataset: str | Path, variants: dict[str, Callable[[Any, Any], None]], limit: int | None = None,
          engine: str = "pocketsphinx-vocab") -> list[dict[str, Any]]:
    """Per stimulus: its band and, per variant, (P(gold), P(chosen), chosen is right) of the full
    acoustic model; a variant sets itself on (the likelihood, its Whisper factor) before each
    clip's inference, and every variant reuses the clip's Whisper work."""
    from siftom import Observer, Settings
    from siftom.bench.acoustic_models import heard
    from siftom.bench.engines import engine as get_engine
    from siftom.bench.scoring import is_correct
    from siftom.bench.trials import dataset_vocabulary
    from siftom.inference.model import Observation
    from siftom.people.stimuli import load_dataset, scenario_for
    from siftom.speech.asr import DEFAULT_NBEST

    ds = load_dataset(dataset)
    asr = get_engine(engine, dataset_vocabulary(ds.stimuli))
    observer = Observer(Settings.load(env={}))
    model, actions_only = observer.model("full", "acoustic"), observer.model("action-only", "acoustic")
    factor: Any = getattr(model.likelihood, "_whisper", None)
    if factor is None:
        raise SystemExit("the acoustic likelihood has no Whisper factor here: install siftom[whisper]")
    cache = PerClip(factor.scorer)
    factor._scorer = cache  # noqa: SLF001 - every variant reuses the clip's Whisper work
    rows = []
    for s in ds.stimuli[:limit]:
        sc = scenario_for(s)
        instruction, _ = heard(ds.root / s.audio, asr, DEFAULT_NBEST)
        cache.reset()
        per: dict[str, tuple[float, float, bool]] = {}
        for name, apply in variants.items():
            apply(model.likelihood, factor)
            # nothing heard: the actions alone answer, as in the evaluator (the same for every variant)
            post = (model if instruction is not None else actions_only).infer(Observation.from_scenario(sc, instruction))
            per[name] = (post.prob(s.gold_command), post.commands[0][1],
                         bool(is_correct(post.command, s.gold_command, sc.verb)))
        rows.append({"id": s.id, "snr": "clean" if s.snr_db is None else f"{s.snr_db:g} dB",
                     "heard": instruction is not None, "per": per})
    return rows


def summarise(rows: list[dict[str, Any]]) -> dict[str, dict[str, dict[str, float]]]:
    """Per band (and "all"), per lambda: n, accuracy %, confident-wrong %, mean NLL of the gold command."""
    groups: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        groups[r["snr"]].append(r)
        groups["all"].append(r)
    out: dict[str, dict[str, dict[str, float]]] = {}
    for band, rs in sorted(groups.items()):
        out[band] = {}
        for lam in rs[0]["per"]:
            v = [r["per"][lam] for r in rs]
            out[band][lam] = {"n": len(v), "accuracy": round(100 * float(np.mean([ok for _, _, ok in v])), 1),
                              "confident_wrong": round(100 * float(np.mean([(not ok) and top >= CONFIDENT
                                                                            for _, top, ok in v])), 1),
                              "nll": round(float(np.mean([-np.log(max(g, 1e-9)) for g, _, _ in v])), 3)}
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description="Whisper factor content-free debiasing: the full model per lambda.")
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--lambdas", default=",".join(f"{x:g}" for x in LAMBDAS), help="comma-separated lambda values")
    ap.add_argument("--limit", type=int, default=None, help="first N stimuli only")
    ap.add_argument("--out", default=None, help="write the per-stimulus rows here (JSON lines)")
    ap.add_argument("--json", dest="as_json", action="store_true", help="print JSON")
    a = ap.parse_args(argv)
    if not Path(a.dataset).is_dir():
        ap.error(f"--dataset {a.dataset}: no such folder")
    rows = collect(a.dataset, tuple(float(x) for x in a.lambdas.split(",")), a.limit)
    report(rows, a.out, a.as_json, "lambda")


def report(rows: list[dict[str, Any]], out: str | None, as_json: bool, column: str) -> None:
    """Write the rows (``out``), then print the summary per band and setting (JSON or a table)."""
    if out:
        Path(out).write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
    result = summarise(rows)
    if as_json:
        print(json.dumps(result, indent=2))
        return
    print(f"band     {column:20s}    n   acc %  conf-wrong %   NLL")
    for band, per in result.items():
        for name, v in per.items():
            print(f"{band:8s} {name:20s} {v['n']:4.0f}  {v['accuracy']:5.1f}  {v['confident_wrong']:12.1f}  {v['nll']:.3f}")


if __name__ == "__main__":
    main()
