"""Confident wrong answers of the acoustic likelihood: how its experts are pooled, per setting.

The acoustic likelihood pools the N-best (phonetic channel) and the Whisper factor
(``[likelihoods.acoustic] pool``: "product", "mixture" or "tempered") and reads Whisper's own
transcript in the slot channel at full weight or weighed by Whisper's confidence
(``whisper_slot_confidence``; likelihood/pooling.py). For every stimulus the evaluator's acoustic
path runs once (recognition of the whole clip; Whisper's encoding, transcript and text scores are
kept for the clip, as in recipes/whisper_debias.py), then the full model's posterior is
recomputed for each setting (a clip where nothing was recognised is answered from the actions
alone, as the evaluator's ``siftom`` does). Per SNR band and overall: accuracy, the share
answered wrongly with P >= 0.8, and the mean NLL of the gold command. Choose on one dataset,
report on others.

    python recipes/expert_pooling.py --dataset DIR [--settings product:full,mixture:confidence] [--limit N] [--json]
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from whisper_debias import report, sweep  # noqa: E402 - the sibling recipe's sweep and report

# pool:slot; "product:full" is the acoustic likelihood before pooling, "mixture:confidence" the default
SETTINGS = ("product:full", "product:confidence", "mixture:full", "tempered:confidence", "mixture:confidence")


def parse_settings(text: str) -> list[tuple[str, str, bool]]:
    """"product:full,mixture:confidence" -> [(name, pool, slot weighed by confidence), ...]."""
    from siftom.likelihood.pooling import POOLS

    out = []
    for item in (t.strip() for t in text.split(",") if t.strip()):
        pool, _, slot = item.partition(":")
        if pool not in POOLS or slot not in ("full", "confidence"):
            raise SystemExit(f"--settings: {item!r} is not POOL:SLOT (POOL one of {', '.join(POOLS)}; "
                             "SLOT full or confidence)")
        out.append((item, pool, slot == "confidence"))
    return out


def collect(dataset: str | Path, settings: list[tuple[str, str, bool]], limit: int | None = None,
            engine: str = "pocketsphinx-vocab") -> list[dict[str, Any]]:
    """Per stimulus: its band and, per setting, (P(gold), P(chosen), chosen is right)."""

    def setting(pool: str, confidence: bool) -> Callable[[Any, Any], None]:
        def apply(lk: Any, _factor: Any) -> None:
            lk.pool, lk.whisper_slot_confidence = pool, confidence
        return apply

    return sweep(dataset, {name: setting(pool, conf) for name, pool, conf in settings}, limit, engine)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description="Acoustic likelihood: the full model per expert pooling setting.")
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--settings", default=",".join(SETTINGS), help="comma-separated POOL:SLOT settings")
    ap.add_argument("--limit", type=int, default=None, help="first N stimuli only")
    ap.add_argument("--out", default=None, help="write the per-stimulus rows here (JSON lines)")
    ap.add_argument("--json", dest="as_json", action="store_true", help="print JSON")
    a = ap.parse_args(argv)
    if not Path(a.dataset).is_dir():
        ap.error(f"--dataset {a.dataset}: no such folder")
    report(collect(a.dataset, parse_settings(a.settings), a.limit), a.out, a.as_json, "setting")


if __name__ == "__main__":
    main()
