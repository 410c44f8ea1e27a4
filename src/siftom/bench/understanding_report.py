"""The understanding benchmark's reading of its results (:mod:`siftom.bench.understanding`): the
targets it is read against (:data:`GATES`), the shares per kind, and the tables and lines that
show a summary. :mod:`siftom.bench.understanding` re-exports every public name here."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from siftom.bench.understanding_items import BLIND, BLIND_KINDS
from siftom.bench.utterances import DOMAINS
from siftom.errors import DatasetError

# The targets the benchmark is read against: (set or None for any, condition, measure, kind or None
# for every kind, most or least share, "max"/"min").  ``understood`` is the share understood,
# ``nothing``, ``other_object`` and ``acted_unasked`` the shares of :func:`outcome` among the items
# where they can happen.
GATES: tuple[tuple[str | None, str, str, bool, float, str], ...] = (
    ("dev", "text", "understood", False, 0.95, "min"),
    (BLIND, "text", "understood", True, 0.90, "min"),
    (None, "10dB", "nothing", True, 0.05, "max"),
    (None, "10dB", "other_object", True, 0.03, "max"),
    (None, "10dB", "acted_unasked", True, 0.02, "max"),
    (None, "5dB", "nothing", True, 0.10, "max"),
)


MEASURES = ("nothing", "other_object", "acted_unasked", "asked_unasked")


def _count(rows: Sequence[dict[str, Any]], measure: str) -> dict[str, Any]:
    """How many rows ``measure`` (of :func:`outcome`) happened to, among those it can happen to."""
    can = [r for r in rows if r.get(measure) is not None]
    k = sum(1 for r in can if r[measure])
    return {"n": len(can), "count": k, "share": round(k / len(can), 4) if can else None}


def _share(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    n = len(rows)
    ok = sum(1 for r in rows if r["understood"])
    return {"n": n, "understood": ok, "share": round(ok / n, 4) if n else None,
            **{m: _count(rows, m) for m in MEASURES}}


def _order(values: Sequence[str], known: Sequence[str]) -> list[str]:
    """``values`` once each: those of ``known`` in its order, then the others sorted."""
    got = set(values)
    return [v for v in known if v in got] + sorted(got - set(known))


def gates(summary: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The :data:`GATES` this run's summary can be read against, each with its value and whether
    it holds (per kind: the worst kind, and every kind that misses)."""
    out: list[dict[str, Any]] = []
    for set_name, cond, measure, per_kind, limit, side in GATES:
        if (set_name is not None and summary.get("set") != set_name) or cond not in summary.get("overall", {}):
            continue
        cells = dict(summary["by_kind"][cond]) if per_kind else {"all": summary["overall"][cond]}

        def value(cell: Mapping[str, Any], measure: str = measure) -> float | None:
            v = cell["share"] if measure == "understood" else cell[measure]["share"]
            return None if v is None else float(v)

        vals = {k: v for k, cell in cells.items() if (v := value(cell)) is not None}
        if not vals:
            continue
        worst_kind = (min if side == "min" else max)(vals, key=lambda k: vals[k])
        missed = sorted(k for k, v in vals.items() if (v < limit if side == "min" else v > limit))
        out.append({"set": set_name, "condition": cond, "measure": measure, "per_kind": per_kind,
                    "limit": limit, "side": side, "worst": vals[worst_kind], "worst_kind": worst_kind,
                    "missed": missed, "holds": not missed})
    return out


def _summarize(rows: Sequence[dict[str, Any]], conditions: Sequence[str],
               meta: Mapping[str, object] | None = None) -> dict[str, Any]:
    """Per condition (of ``conditions``, in their order), overall, per kind, per domain and per kind and domain: the share understood
    and the counts of :data:`MEASURES`; then the :func:`gates`."""
    conds = [c for c in conditions if any(r["condition"] == c for r in rows)]
    kinds = _order([r["kind"] for r in rows], BLIND_KINDS)
    domains = _order([r["domain"] for r in rows], DOMAINS)
    out: dict[str, Any] = {**(meta or {}), "rows": len(rows), "overall": {}, "by_kind": {}, "by_domain": {},
                           "by_kind_domain": {}, "seconds_per_item": {}}
    for c in conds:
        rc = [r for r in rows if r["condition"] == c]
        out["overall"][c] = _share(rc)
        out["by_kind"][c] = {k: _share([r for r in rc if r["kind"] == k]) for k in kinds
                             if any(r["kind"] == k for r in rc)}
        out["by_domain"][c] = {d: _share([r for r in rc if r["domain"] == d]) for d in domains
                               if any(r["domain"] == d for r in rc)}
        out["by_kind_domain"][c] = {f"{k}/{d}": _share([r for r in rc if r["kind"] == k and r["domain"] == d])
                                    for k in kinds for d in domains
                                    if any(r["kind"] == k and r["domain"] == d for r in rc)}
        out["seconds_per_item"][c] = round(float(np.mean([r["seconds"] for r in rc])), 4) if rc else None
    out["gates"] = gates(out)
    out["request_calibration"] = {c: request_calibration([r for r in rows if r["condition"] == c]) for c in conds}
    return out


CALIBRATION_BINS = 5  # equal-width bins of P(somebody asked) for the reliability diagram


def request_calibration(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """How well P(somebody asked) is calibrated on ``rows`` (those with an understanding): per
    equal-width bin, the items, their mean P and the share that were requests (a reliability
    diagram to re-plot), the expected calibration error (the bins' |share - mean P|, weighed by
    their items) and the Brier score."""
    got = [(float(r["understanding"]["p_request"]), bool(r["expected"]["request"])) for r in rows
           if r.get("understanding") and r["understanding"].get("p_request") is not None and not r.get("pending")]
    if not got:
        return {"n": 0, "bins": [], "ece": None, "brier": None}
    p = np.array([g[0] for g in got])
    y = np.array([g[1] for g in got], dtype=float)
    k = np.minimum((p * CALIBRATION_BINS).astype(int), CALIBRATION_BINS - 1)
    bins = [{"from": b / CALIBRATION_BINS, "to": (b + 1) / CALIBRATION_BINS, "n": int((k == b).sum()),
             "mean_p": round(float(p[k == b].mean()), 4) if (k == b).any() else None,
             "requests": round(float(y[k == b].mean()), 4) if (k == b).any() else None}
            for b in range(CALIBRATION_BINS)]
    ece = sum(int((k == b).sum()) * abs(float(y[k == b].mean()) - float(p[k == b].mean()))
              for b in range(CALIBRATION_BINS) if (k == b).any()) / len(got)
    return {"n": len(got), "bins": bins, "ece": round(float(ece), 4), "brier": round(float(np.mean((p - y) ** 2)), 4)}


def calibration_lines(summary: Mapping[str, Any]) -> list[str]:
    """One line per condition: the calibration of P(somebody asked) (:func:`request_calibration`)."""
    return [f"P(somebody asked), {c}: ECE {v['ece']:.3f}, Brier {v['brier']:.3f} over {v['n']} items "
            "(reliability diagram: request_calibration in the summary)"
            for c, v in summary.get("request_calibration", {}).items() if v.get("n")]


def _pct(s: Mapping[str, Any] | None) -> str:
    if not s or not s["n"]:
        return "-"
    return f"{s['count']}/{s['n']} {100 * s['share']:.0f} %"


def table(run: Any) -> Any:
    """Rich tables of the run (a :class:`~siftom.bench.understanding.Run`), one per condition, a row per kind: the share understood, then
    requests answered with nothing, carried out on another object, and nobody-asked words acted
    on (each among the items where it can happen)."""
    from rich.console import Group
    from rich.table import Table

    summary = run.summary
    version = (summary.get("machine") or {}).get("version", "?")
    where = f"world seed {summary.get('world_seed')}, " if summary.get("world_seed") is not None else ""
    kinds_of = _order([k for c in summary["overall"] for k in summary["by_kind"][c]], BLIND_KINDS)
    domains_of = _order([d for c in summary["overall"] for d in summary["by_domain"][c]], DOMAINS)

    def _cell(s: Mapping[str, Any] | None) -> str:
        if not s or not s["n"]:
            return "-"
        return f"{s['understood']}/{s['n']} {100 * s['share']:.0f} %"

    tables = []
    for c in summary["overall"]:
        t = Table(title=f"{summary.get('set', '?')} set, {c}",
                  caption=f"{where}{summary.get('items', '?')} items, siftom {version}")
        for head in ("kind", "understood", "nothing", "other object", "unasked acted"):
            t.add_column(head, justify="left" if head == "kind" else "right")

        def _row(x: Mapping[str, Any] | None) -> list[str]:
            return [_cell(x), *(_pct(x[m]) if x else "-" for m in ("nothing", "other_object", "acted_unasked"))]

        for k in kinds_of:
            if k in summary["by_kind"][c]:
                t.add_row(k, *_row(summary["by_kind"][c][k]))
        t.add_section()
        for d in domains_of:
            if d in summary["by_domain"][c]:
                t.add_row(d, *_row(summary["by_domain"][c][d]))
        t.add_row("all", *_row(summary["overall"][c]), style="bold")
        tables.append(t)
    return Group(*tables)


def gate_lines(summary: Mapping[str, Any]) -> list[str]:
    """One line per gate of the summary: what it asks, the worst value and whether it holds."""
    out = []
    for g in summary.get("gates", []):
        what = {"understood": "understood", "nothing": "requests answered with nothing",
                "other_object": "carried out on another object",
                "acted_unasked": "nobody asked, acted on"}[g["measure"]]
        op = ">=" if g["side"] == "min" else "<="
        scope = "per kind" if g["per_kind"] else "overall"
        worst = f"{100 * g['worst']:.1f} %" + (f" ({g['worst_kind']})" if g["per_kind"] else "")
        miss = f"; missed by {', '.join(g['missed'])}" if g["missed"] and g["per_kind"] else ""
        out.append(f"{'holds' if g['holds'] else 'MISSES'}: {g['condition']} {what} {scope} {op} "
                   f"{100 * g['limit']:.0f} %: worst {worst}{miss}")
    return out


def markdown(summaries: Sequence[tuple[str, Mapping[str, Any]]], measure: str = "understood") -> str:
    """A Markdown table from result summaries: a row per kind, a column per (label, condition);
    ``measure`` ``understood`` (the share understood) or one of :data:`MEASURES` (its count among
    the items where it can happen)."""
    if measure != "understood" and measure not in MEASURES:
        raise DatasetError(f"unknown measure {measure!r}; choose understood or one of {', '.join(MEASURES)}")
    cols = [(label, c, s) for label, s in summaries for c in s.get("overall", {})]
    kinds = _order([k for _, c, s in cols for k in s["by_kind"][c]], BLIND_KINDS)

    def cell(x: Mapping[str, Any] | None) -> str:
        if measure == "understood":
            return "-" if not x or not x["n"] else f"{100 * x['share']:.0f} % ({x['understood']}/{x['n']})"
        y = x.get(measure) if x else None
        return "-" if not y or not y["n"] else f"{100 * y['share']:.0f} % ({y['count']}/{y['n']})"

    lines = ["| kind | " + " | ".join(f"{label}, {c}" for label, c, _ in cols) + " |",
             "|---|" + "---|" * len(cols)]
    for k in kinds:
        cells = [cell(s["by_kind"][c].get(k)) for _, c, s in cols]
        if any(x != "-" for x in cells):
            lines.append(f"| {k} | " + " | ".join(cells) + " |")
    lines.append("| **all** | " + " | ".join(cell(s["overall"][c]) for _, c, s in cols) + " |")
    return "\n".join(lines)
