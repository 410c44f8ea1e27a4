"""A vectorised weighted edit distance over phoneme sequences, and a trie for many at once."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from siftom.likelihood.phonemes import PAD, PHONEME_ID, SUB_COST, indel_cost, substitution_cost

# -- weighted edit distance -------------------------------------------------------------------


def encode(phones: Sequence[str]) -> np.ndarray:
    """Phoneme ids for a phoneme sequence."""
    return np.fromiter((PHONEME_ID[p] for p in phones), dtype=np.int16, count=len(phones))


def edit_distance(
    a: Sequence[str],
    b: Sequence[str],
    insert_costs: Sequence[float] | None = None,
) -> float:
    """Weighted edit distance from said phonemes ``a`` to heard phonemes ``b`` (reference code).

    Substitutions cost :func:`substitution_cost`, deleting ``a[i]`` costs :func:`indel_cost`,
    inserting ``b[j]`` costs ``insert_costs[j]`` (default :func:`indel_cost`). With default
    costs the distance is a metric-like, symmetric, non-negative and zero on equal inputs.
    """
    ins = [indel_cost(p) for p in b] if insert_costs is None else list(insert_costs)
    prev = [0.0]
    for j in range(len(b)):
        prev.append(prev[-1] + ins[j])
    for i in range(len(a)):
        cur = [prev[0] + indel_cost(a[i])]
        for j in range(len(b)):
            cur.append(min(prev[j + 1] + indel_cost(a[i]), prev[j] + substitution_cost(a[i], b[j]),
                           cur[j] + ins[j]))
        prev = cur
    return prev[-1]


def batch_edit_distance(
    said: np.ndarray,
    said_del: np.ndarray,
    heard: np.ndarray,
    heard_ins: np.ndarray,
    heard_sub: np.ndarray | None = None,
) -> np.ndarray:
    """Weighted edit distances between every said and every heard sequence, vectorised.

    Args:
        said: (S, La) phoneme ids, right-padded with ``PAD``.
        said_del: (S, La) deletion costs (0 on padding).
        heard: (H, Lb) phoneme ids, right-padded with ``PAD``.
        heard_ins: (H, Lb) insertion costs (0 on padding).
        heard_sub: (H, Lb) extra cost of substituting onto each heard phoneme (default 0).

    Returns:
        (S, H) float array of distances.

    The DP runs row by row over the said sequence; within a row the insertion chain
    D[j] = min_k (T[k] + C[j] - C[k]) (C the cumulative insertion cost) is a running minimum,
    so each row is a handful of whole-array numpy operations.
    """
    n_s, la = said.shape
    n_h, lb = heard.shape
    cum = np.zeros((n_h, lb + 1), dtype=np.float32)
    np.cumsum(heard_ins, axis=1, out=cum[:, 1:])
    d = np.broadcast_to(cum, (n_s, n_h, lb + 1)).copy()
    t = np.empty_like(d)
    heard_idx = heard.astype(np.intp)
    extra = None if heard_sub is None else heard_sub[None, :, :]
    for i in range(la):
        dl = said_del[:, i].astype(np.float32)[:, None, None]
        sub = SUB_COST[said[:, i].astype(np.intp)[:, None, None], heard_idx[None, :, :]]
        if extra is not None:
            sub = sub + extra
        np.add(d, dl, out=t)
        np.minimum(t[:, :, 1:], d[:, :, :-1] + sub, out=t[:, :, 1:])
        t -= cum
        np.minimum.accumulate(t, axis=2, out=d)
        d += cum
    return d[:, :, lb]


def _pad(seqs: Sequence[np.ndarray], costs: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    width = max((len(s) for s in seqs), default=0)
    ids = np.full((len(seqs), max(width, 1)), PAD, dtype=np.int16)
    cst = np.zeros((len(seqs), max(width, 1)), dtype=np.float32)
    for k, (s, c) in enumerate(zip(seqs, costs, strict=True)):
        ids[k, : len(s)] = s
        cst[k, : len(c)] = c
    return ids, cst


@dataclass(frozen=True)
class PhonemeTrie:
    """Said sequences stored reversed in a trie, so shared endings are aligned once.

    "three forks", "two forks" and "forks" end alike; aligning reversed sequences lets every
    trie node's DP row serve all the sequences below it (about 5x fewer rows than padding on
    the default lexicon).
    """

    levels: tuple[tuple[np.ndarray, np.ndarray, np.ndarray], ...]  # (parent, phoneme id, del cost)
    terminal_level: np.ndarray  # (n_seq,) depth of each sequence's node
    terminal_node: np.ndarray  # (n_seq,) its index within the level

    @classmethod
    def build(cls, seqs: Sequence[tuple[np.ndarray, np.ndarray]]) -> PhonemeTrie:
        """Build from (phoneme ids, deletion costs) pairs."""
        nodes: list[dict[tuple[int, int, float], int]] = []
        tl = np.zeros(len(seqs), dtype=np.intp)
        tn = np.zeros(len(seqs), dtype=np.intp)
        for k, (ids, costs) in enumerate(seqs):
            node = 0
            for depth, (p, c) in enumerate(zip(ids[::-1].tolist(), costs[::-1].tolist(), strict=True)):
                if depth == len(nodes):
                    nodes.append({})
                level = nodes[depth]
                key = (node, p, c)
                node = level.setdefault(key, len(level))
            tl[k], tn[k] = len(ids), node
        levels = []
        for level in nodes:
            keys = list(level)  # insertion order == node index
            levels.append((np.array([k[0] for k in keys], dtype=np.intp),
                           np.array([k[1] for k in keys], dtype=np.intp),
                           np.array([k[2] for k in keys], dtype=np.float32)))
        return cls(tuple(levels), tl, tn)


def trie_edit_distance(
    trie: PhonemeTrie, heard: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]]
) -> np.ndarray:
    """Distances from every sequence in ``trie`` to every heard (ids, ins, sub) triple: (S, H)."""
    rev = [(h[0][::-1], h[1][::-1], h[2][::-1]) for h in heard]
    h_ids, h_ins = _pad([r[0] for r in rev], [r[1] for r in rev])
    _, h_sub = _pad([r[0] for r in rev], [r[2] for r in rev])
    n_h, lb = h_ids.shape
    cum = np.zeros((n_h, lb + 1), dtype=np.float32)
    np.cumsum(h_ins, axis=1, out=cum[:, 1:])
    heard_idx = h_ids.astype(np.intp)[None, :, :]
    extra = h_sub[None, :, :]
    finals = [cum[None, :, lb]]
    d = cum[None, :, :]
    for parent, phone, cost in trie.levels:
        prev = d[parent]
        t = prev + cost[:, None, None]
        np.minimum(t[:, :, 1:], prev[:, :, :-1] + SUB_COST[phone[:, None, None], heard_idx] + extra,
                   out=t[:, :, 1:])
        t -= cum
        np.minimum.accumulate(t, axis=2, out=t)
        t += cum
        d = t
        finals.append(t[:, :, lb])
    res = np.empty((len(trie.terminal_level), n_h), dtype=np.float32)
    for depth, fin in enumerate(finals):
        sel = np.nonzero(trie.terminal_level == depth)[0]
        if len(sel):
            res[sel] = fin[trie.terminal_node[sel]]
    return res


# -- the likelihood ---------------------------------------------------------------------------


