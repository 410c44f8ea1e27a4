"""The done-when table of issue 9 from saved N-best lists: SIFToM (and literal-asr, speech-only)
accuracy and object-word error per SNR for pocketsphinx-vocab, -open and -dual on each dataset.

Run: python benchmarks/engine_table.py CLOSED_DIR OPEN_DIR DATASET [DATASET ...]
CLOSED_DIR / OPEN_DIR: ``benchmarks/engine_sweep.py pocketsphinx-vocab|pocketsphinx-open '{}' DIR
DATASET ... --nbest 10`` output folders; each engine's rows use the first 5 hypotheses (as
``siftom eval``), the dual's mix them with the engine's own ``mix_nbest`` (w = 0.5).
"""

from __future__ import annotations

import contextlib
import io
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from engine_sweep import score  # noqa: E402
from mix_sweep import _load, mixed  # noqa: E402


def main() -> None:
    closed, open_, *datasets = sys.argv[1:]
    out = Path("runs/engine-table")
    out.mkdir(parents=True, exist_ok=True)
    for d in datasets:
        a, b = _load(closed, d), _load(open_, d)
        for label, w in (("pocketsphinx-vocab", 0.0), ("pocketsphinx-open", 1.0), ("pocketsphinx-dual", 0.5)):
            trs = {sid: mixed(a[sid], b[sid], w, 5, 5) for sid in a}
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                score(d, trs, out, label)
            lines = buf.getvalue().splitlines()
            print(f"{Path(d).name} {label}")
            for ln in lines[1:]:
                if "WER" not in ln:
                    print("   " + ln.strip())


if __name__ == "__main__":
    main()
