"""The patch-order search's count of a move (:func:`.sw_refine._move_delta`) is exact under its own model.

The model (``sw_refine``'s docstring): the warm run over ``P || M || Q`` with each block's misses weighted by
the windows that draw it, plus each window's cold start (the cold run's extra misses over the warm run, for
at most ``_COLD_BLOCKS`` blocks or until the two caches agree). :func:`_model` recounts it from scratch in
Python; the search's change for a move must equal the recount after minus before, for moves at the start of
``P`` (whose cold starts reach the moved ``Q`` blocks), in the middle, next to ``M`` and at the end, and the
stored state after moves taken (:func:`.sw_refine._apply_move`) must be a fresh start's."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest
from test_sw_finish import _captured_levels

from swpm_usd.encode import sw_layout as swl
from swpm_usd.encode import sw_refine as swr

_BIG = np.int64(1) << 60


def _draw(cache: list, blk, C: int) -> int:
    m = 0
    for v in blk:
        if v not in cache:
            cache.append(v)
            m += 1
            if len(cache) > C:
                cache.pop(0)
    return m


def _model(bs, blocks, n: int, order, C: int) -> tuple[int, list, list]:
    """The search's sum for ``order``, recounted from scratch; and its warm misses and cold terms."""
    seq = list(order) + [n] + [n + 1 + p for p in order]
    blk = [blocks[bs[b] : bs[b + 1]].tolist() for b in range(2 * n + 1)]
    cache: list = []
    snaps = [[]]
    m = []
    for b in seq:
        m.append(_draw(cache, blk[b], C))
        snaps.append(list(cache))
    total = sum((a + 1 if a <= n else 2 * n + 1 - a) * m[a] for a in range(len(seq)))
    cold = [0]
    for a in range(1, n + 1):
        c: list = []
        extra = 0
        for b in range(a, min(a + swr._COLD_BLOCKS, len(seq))):
            extra += _draw(c, blk[seq[b]], C) - m[b]
            if c == snaps[b + 1]:
                break
        cold.append(extra)
    return total + sum(cold), m, cold


@nb.njit
def _search_moves(block_start, blocks, n, C, V, order, moves, take):
    """Each move ``(i, s, k)`` of ``moves`` evaluated on the stored state of the search started at
    ``order`` (no bound: its exact change), and taken if ``take``; returns the changes and the final
    stored warm misses and cold terms."""
    seq = np.empty(2 * n + 1, np.int64)
    for a in range(n):
        seq[a] = order[a]
        seq[n + 1 + a] = n + 1 + order[a]
    seq[n] = n
    run, sims, version = swr._start(seq, n, blocks, block_start, C, V)
    P = 1
    search = (np.zeros(n + 1, np.int64), np.zeros(0, np.int64), np.zeros(P, np.int64), run, sims)
    cand = seq.copy()
    out = np.zeros(moves.shape[0], np.int64)
    for x in range(moves.shape[0]):
        i, s, k = moves[x, 0], moves[x, 1], moves[x, 2]
        out[x], version = swr._try_move(seq, cand, n, i, s, k, search, 0, _BIG, version)
        if take[x]:
            lo, hi = swr._arrange(seq, cand, n, i, s, k)
            seq[lo:hi] = cand[lo:hi]
            seq[n + 1 + lo : n + 1 + hi] = cand[n + 1 + lo : n + 1 + hi]
            _, version = swr._apply_move(seq, lo, hi, n, run, sims[0], version)
    return out, run[1].copy(), run[2].copy(), seq[:n].copy()


def _moved(order, n: int, i: int, s: int, k: int) -> list:
    rest = [p for x, p in enumerate(order) if not i <= x < i + s]
    return rest[:k] + list(order[i : i + s]) + rest[k:]


def _moves(n: int, rng: np.random.Generator, count: int) -> np.ndarray:
    """Moves at the start, the middle, next to ``M`` and at the end, and random ones."""
    out = []
    for i, s, k in [(0, 1, 1), (1, 1, 0), (0, 1, 2), (0, 2, 1), (n // 2, 1, n // 2 - 1), (n - 1, 1, n - 2)]:
        out.append((i, s, k))
    out += [(n - 2, 2, n - 3), (n - 2, 1, 0), (0, 1, n - 1), (n - 1, 1, 0)]
    while len(out) < count:
        s = int(rng.integers(1, 3))
        i = int(rng.integers(0, n - s + 1))
        k = int(rng.integers(0, n - s + 1))
        if k != i:
            out.append((i, s, k))
    return np.array([m for m in out if 0 <= m[0] and m[0] + m[1] <= n and 0 <= m[2] <= n - m[1]], np.int64)


def _check(bs, blocks, n: int, C: int, rng: np.random.Generator, count: int = 40) -> None:
    bs = np.ascontiguousarray(bs, np.int64)
    blocks = np.ascontiguousarray(blocks, np.int64)
    V = int(blocks.max()) + 1
    order = np.arange(n, dtype=np.int64)
    moves = _moves(n, rng, count)
    # every move on the start's state
    got, _, _, _ = _search_moves(bs, blocks, n, C, V, order, moves, np.zeros(len(moves), np.bool_))
    before = _model(bs, blocks, n, order, C)[0]
    for (i, s, k), d in zip(moves.tolist(), got.tolist(), strict=True):
        after = _model(bs, blocks, n, _moved(order, n, i, s, k), C)[0]
        assert d == after - before, (n, i, s, k, d, after - before)
    # the moves taken one after another: each change exact on the state the last ones left
    take = np.ones(len(moves), np.bool_)
    got, m_run, cold, final = _search_moves(bs, blocks, n, C, V, order, moves, take)
    cur = list(range(n))
    for (i, s, k), d in zip(moves.tolist(), got.tolist(), strict=True):
        nxt = _moved(cur, n, i, s, k)
        assert d == _model(bs, blocks, n, nxt, C)[0] - _model(bs, blocks, n, cur, C)[0], (n, i, s, k)
        cur = nxt
    assert final.tolist() == cur
    _, m, c = _model(bs, blocks, n, cur, C)
    assert m_run.tolist() == m
    assert cold.tolist() == c


def _random_level(rng: np.random.Generator, n: int, V: int) -> tuple[np.ndarray, np.ndarray]:
    """``2n + 1`` blocks of random triangles over ``V`` vertices, neighbours sharing vertices often."""
    sizes = rng.integers(0, 8, 2 * n + 1) * 3
    bs = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
    centre = rng.integers(0, V, 2 * n + 1)
    blocks = np.concatenate([(centre[b] + rng.integers(-6, 7, sizes[b])) % V for b in range(2 * n + 1)])
    return bs, blocks.astype(np.int64)


@pytest.mark.parametrize("seed", range(6))
def test_move_delta_is_the_models_recount_on_random_levels(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for n in (3, 4, 5, 6, 9, 17):
        bs, blocks = _random_level(rng, n, 12 + 4 * n)
        _check(bs, blocks, n, 4 + 4 * (seed % 2), rng, count=16)


@pytest.mark.parametrize("name", ["suzanne", "cow"])
def test_move_delta_is_the_models_recount_on_real_levels(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(1)
    checked = 0
    for gtris, start_gids, collapsed, _s, _V, _P, cs, _passes, _reach in _captured_levels(name, monkeypatch):
        p_start, p_out, q_start, q_out, patch_steps, _recs, _info = collapsed
        n = patch_steps.shape[0]
        if n < 3 or n > 60:
            continue
        tris, starts = swl.level_pool(gtris, start_gids, p_start, p_out, q_start, q_out, cs)
        _check(3 * starts, np.asarray(tris).reshape(-1), n, cs, rng, count=24)
        checked += 1
    assert checked >= 3
