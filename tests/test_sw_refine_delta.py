"""The patch-order search (:mod:`.sw_refine`) against its model, recounted from scratch in Python.

The model (``sw_refine``'s docstring): the warm run over ``P || M || Q`` with each block's misses weighted by
the windows that draw it, plus each window's cold start (the cold run's extra misses over the warm run, for
at most ``_COLD_BLOCKS`` blocks or until the two caches agree). The search's stored start is the recount's
(random levels, levels of suzanne and cow). A move's change (:func:`.sw_refine._move_delta`) is counted
locally: on random small levels it is the recount's after minus before for most moves, not all (on the
real levels for 21-26 % of them, when written): it leaves out the cold starts of the windows just before the
change and those reaching its moved ``Q`` blocks, and follows the warm run only ``_HORIZON`` blocks. An
exact count cost the search 1.9 times its time for 0.12 % fewer misses (``slidingwindow.md``, "Exact
moves")."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest
from test_sw_finish import _captured_levels

from swpm_usd.encode import sw_layout as swl
from swpm_usd.encode import sw_refine as swr

_BIG = np.int64(1) << 60


def _draw(cache: list, blk: list, C: int) -> int:
    m = 0
    for v in blk:
        if v not in cache:
            cache.append(v)
            m += 1
            if len(cache) > C:
                cache.pop(0)
    return m


def _model(bs, blocks, n: int, order, C: int) -> tuple[int, list, list, list]:
    """The search's sum for ``order``, recounted from scratch; its warm misses, caches before each position
    and cold terms."""
    seq = list(order) + [n] + [n + 1 + p for p in order]
    blk = [blocks[bs[b] : bs[b + 1]].tolist() for b in range(2 * n + 1)]
    cache: list = []
    snaps: list = [[]]
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
    return total + sum(cold), m, snaps, cold


@nb.njit
def _search(block_start, blocks, n, C, V, moves):
    """The search's stored start for the run in patch order (as :func:`.sw_refine.refine_patch_order` sets
    it up) and its change for each move ``(i, s, k)`` of ``moves`` on it (no bound: ``best`` never
    reached)."""
    N = 2 * n + 1
    seq = np.empty(N, np.int64)
    for a in range(n):
        seq[a] = a
        seq[n + 1 + a] = n + 1 + a
    seq[n] = n
    snap = np.full((N + 1, C), -1, np.int32)
    new_t = np.zeros(N + 1, np.int64)
    m_run = np.zeros(N, np.int64)
    cold = np.zeros(n + 1, np.int64)
    log = np.empty(C + blocks.shape[0] + 1, np.int32)
    key = np.zeros(V, np.int64)
    sim = (blocks, block_start, key, log)
    sim2 = (blocks, block_start, key, np.empty_like(log))
    run = (snap, m_run, cold, new_t, np.zeros(N, np.int64))
    version = 1
    swr._run(seq, 0, N, (N, N), snap, snap, new_t[:0], N, m_run, sim, version, -1)
    for a in range(1, n + 1):
        version += 1
        cold[a] = swr._cold_extra(seq, a, snap, m_run, (0, 0, m_run, new_t[:0], log), sim, version)
    search = (np.zeros(n + 1, np.int64), np.zeros(0, np.int64), np.zeros(1, np.int64), run, sim, sim2)
    cand = seq.copy()
    out = np.zeros(moves.shape[0], np.int64)
    for x in range(moves.shape[0]):
        out[x], version = swr._try_move(
            seq, cand, n, moves[x, 0], moves[x, 1], moves[x, 2], search, 0, _BIG, version
        )
    return out, m_run, cold


def _moved(order: list, i: int, s: int, k: int) -> list:
    rest = [p for x, p in enumerate(order) if not i <= x < i + s]
    return rest[:k] + order[i : i + s] + rest[k:]


def _moves(n: int, rng: np.random.Generator, count: int) -> np.ndarray:
    """Moves at the start, the middle, next to ``M`` and at the end, and random ones."""
    out = [(0, 1, 1), (1, 1, 0), (0, 1, 2), (0, 2, 1), (n // 2, 1, n // 2 - 1), (n - 1, 1, n - 2)]
    out += [(n - 2, 2, n - 3), (n - 2, 1, 0), (0, 1, n - 1), (n - 1, 1, 0)]
    while len(out) < count:
        s = int(rng.integers(1, 3))
        i = int(rng.integers(0, n - s + 1))
        k = int(rng.integers(0, n - s + 1))
        if k != i:
            out.append((i, s, k))
    return np.array([m for m in out if m[0] + m[1] <= n and 0 <= m[2] <= n - m[1]], np.int64)


def _check(bs, blocks, n: int, C: int, rng: np.random.Generator, count: int) -> tuple[int, int]:
    """Asserts the search's start is the model's; returns (moves whose change the search counts as the
    recount does, moves)."""
    bs = np.ascontiguousarray(bs, np.int64)
    blocks = np.ascontiguousarray(blocks, np.int64)
    moves = _moves(n, rng, count)
    got, m_run, cold = _search(bs, blocks, n, C, int(blocks.max()) + 1, moves)
    order = list(range(n))
    before, m0, _, c0 = _model(bs, blocks, n, order, C)
    assert m_run.tolist() == m0 and cold.tolist() == c0  # the search's start is the model's
    exact = 0
    for (i, s, k), d in zip(moves.tolist(), got.tolist(), strict=True):
        exact += d == _model(bs, blocks, n, _moved(order, i, s, k), C)[0] - before
    return exact, len(moves)


def _random_level(rng: np.random.Generator, n: int, V: int) -> tuple[np.ndarray, np.ndarray]:
    """``2n + 1`` blocks of random triangles over ``V`` vertices, neighbours sharing vertices often."""
    sizes = rng.integers(0, 8, 2 * n + 1) * 3
    bs = np.concatenate(([0], np.cumsum(sizes))).astype(np.int64)
    centre = rng.integers(0, V, 2 * n + 1)
    blocks = np.concatenate([(centre[b] + rng.integers(-6, 7, sizes[b])) % V for b in range(2 * n + 1)])
    return bs, blocks.astype(np.int64)


def test_search_against_the_models_recount_on_random_levels() -> None:
    rng = np.random.default_rng(0)
    exact = moves = 0
    for seed in range(6):
        for n in (3, 4, 5, 6, 9, 17):
            bs, blocks = _random_level(rng, n, 12 + 4 * n)
            a, b = _check(bs, blocks, n, 4 + 4 * (seed % 2), rng, 16)
            exact += a
            moves += b
    # the search's count is local: most moves of these small levels (650 of 864 when written), not all
    assert exact >= 0.6 * moves, (exact, moves)


@pytest.mark.parametrize("name", ["suzanne", "cow"])
def test_search_start_is_the_models_recount_on_real_levels(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = np.random.default_rng(1)
    levels = 0
    for gtris, start_gids, collapsed, _s, _V, _P, cs, _passes, _reach in _captured_levels(name, monkeypatch):
        p_start, p_out, q_start, q_out, patch_steps, _recs, _info = collapsed
        n = patch_steps.shape[0]
        if n < 3 or n > 60:
            continue
        tris, starts = swl.level_pool(gtris, start_gids, p_start, p_out, q_start, q_out, cs)
        _check(3 * starts, np.asarray(tris).reshape(-1), n, cs, rng, 24)
        levels += 1
    assert levels >= 5, levels
