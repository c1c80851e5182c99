"""The sliding-window pool stored as triangle strips (``primitive="strip"``): the list pool cut at every
window's first triangle, each piece between two cuts turned into strips by the skip strips' stripifier
(:func:`.strips._stripify_barriers`, Evans-Skiena-Varshney with a look-ahead window, as meshoptimizer) and the
pieces joined by a restart index (skip-strip's: :func:`.skipstrip.restart_value`, then the file's index type's
largest value, :func:`.skipstrip.settle_restart`). A window's last
triangle where no window starts is a *barrier* instead of a cut: the look-ahead does not cross it, so the
strip's prefix up to it draws exactly the window's triangles, and the strip goes on across it when the next
triangle can continue it, or joins it through degenerate triangles (a swap, a repeated last index), else a
restart; a block of at most :data:`SEARCH_BLOCK` triangles between window ends (more in a small pool whose
order was not searched for the cache, :data:`SEARCH_TIERS`) is written by a bounded search for the fewest
indices, any order inside it. Every window then starts at the pool's start or right
after a restart index and ends at a cut or inside a strip, so it is still ONE contiguous range of the pool:
one strip draw with primitive restart per LOD, as Forsyth's sliding window draws one list range. A window's
strip decodes (spec/format.md 3.7's rule, parity from each restart) to its list triangles as an oriented
multiset, in the list's order as far as the stripifier keeps it.

Ten shared meshes, lambda (pool indices over three a LOD-0 triangle): defaults 5.30 -> 3.79 (mean), cluster
and swaps 4.43 -> 3.35 (``slidingwindow.md``, "Strips"); windows ending inside strips 3.70 and 3.26; joins and
the block search 3.53 and 3.06 (2026-12-05, "Joins across a window's end"); the search sized by the pool
(:func:`search_block`) 3.53 and 2.98 ("Where the strip indices go, and larger blocks for small pools").
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .skipstrip import restart_value, settle_restart
from .strips import _search_scratch, _stripify_blocks
from .sw_mesh import SlidingWindowProgressiveMesh

#: blocks (the triangles between two window ends) of at most this many triangles are stripified by a search
#: (``strips._strip_block``, 300 nodes) rather than the look-ahead, in a pool whose order was searched for the
#: cache (``order_passes`` > 0, the defaults): bunny, lambda defaults / cluster-swap 3.63 / 2.68 -> 3.53 /
#: 2.58, the strip pass 0.04 -> about 1-1.5 s (4, a budget of 100 nodes: 3.58 / 2.61, 0.4 s; 6: 3.49 / 2.55,
#: 4.5 s; 8, 4000 nodes: 3.39 / 2.51, 17 s); the same output faster since (helper 182): ``strip_pool`` on
#: bunny 1.26 -> 0.30 s (defaults), 0.74 -> 0.22 s (cluster-swap)
SEARCH_BLOCK = 5

#: (largest list pool in triangles, block, node budget), the first that holds the pool, where its order was
#: not searched for the cache (``cluster``: a linked level's order is its tail's): a smaller pool's blocks are
#: searched larger, for a strip pass of well under a second on each shared mesh. Larger blocks reorder more:
#: the defaults' searched order would take 1.1 % more cache misses (ten meshes, lambda 3.532 -> 3.424), so
#: they keep :data:`SEARCH_BLOCK`. Ten meshes' cluster-swap strip pools, lambda mean 3.058 -> 2.975, at
#: most 3.0 on 4 -> 5 meshes (bob 3.006 -> 2.917); the strip pass on bunny (261,441 pool triangles) 0.26 ->
#: 0.45 s, on beetle (10,517) 0.01 -> 0.11 s, a loaded machine (``slidingwindow.md``, "Where the strip
#: indices go")
SEARCH_TIERS = ((64_000, 10, 2000), (128_000, 8, 1000), (1 << 62, 6, 300))


def search_block(pool_triangles: int, ordered: bool = False) -> tuple[int, int]:
    """The block search's (largest block, node budget) for a list pool of ``pool_triangles``:
    :data:`SEARCH_BLOCK` where its order was searched for the cache (``ordered``), else by
    :data:`SEARCH_TIERS`."""
    if ordered:
        return SEARCH_BLOCK, 300
    for top, block, budget in SEARCH_TIERS:
        if pool_triangles <= top:
            return block, budget
    return SEARCH_TIERS[-1][1:]


@nb.njit(cache=True)
def _strip_pieces(
    tris: np.ndarray,
    cuts: np.ndarray,
    barriers: np.ndarray,
    restart: int,
    window: int,
    block: int,
    budget: int,
) -> tuple:
    """The pieces ``tris[cuts[i]:cuts[i + 1]]`` stripified with the ``barriers`` inside them (sorted, none
    on a cut) and joined by ``restart``, blocks of at most ``block`` triangles searched within ``budget``
    nodes: (the strip pool, the first index of every piece in it, the index past its last, the strip position
    of every barrier)."""
    S = cuts.shape[0] - 1
    # a piece of t triangles: at most 4 t indices with restarts (3, then a restart and 3 or a swap's 2 a
    # triangle), a swap across each barrier, and one restart between pieces
    out = np.empty(4 * tris.shape[0] + S + barriers.shape[0], np.int64)
    start = np.empty(S, np.int64)
    end = np.empty(S, np.int64)
    bpos = np.zeros(barriers.shape[0], np.int64)
    n = 0
    memo, ws = _search_scratch(block)
    stamp = np.int64(0)
    yes = np.bool_(True)  # (not Literal[bool](True): one compile of _stripify_blocks for every call)
    for s in range(S):
        a, b = cuts[s], cuts[s + 1]
        if s > 0:
            out[n] = restart
            n += 1
        i = np.searchsorted(barriers, a)
        j = np.searchsorted(barriers, b)
        piece, pos, stamp = _stripify_blocks(
            tris[a:b],
            yes,
            restart,
            max(1, min(window, b - a)),
            barriers[i:j] - a,
            yes,
            block,
            memo,
            ws,
            stamp,
            budget,
        )
        start[s] = n
        bpos[i:j] = pos + n
        out[n : n + piece.shape[0]] = piece
        n += piece.shape[0]
        end[s] = n
    return out[:n].copy(), start, end, bpos


def strip_pool(
    index_pool: np.ndarray,
    window_records: np.ndarray,
    vertex_count: int,
    window: int = 4,
    block: int | None = None,
    budget: int | None = None,
    ordered: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The strip pool of a list pool.

    ``index_pool``: the list pool (3 indices a triangle); ``window_records`` (L, 3): first index offset,
    triangle count, vertex count of every window in it; ``window``: the stripifier's look-ahead; ``block``
    and ``budget``: the block search's largest block and node budget (``None``: :func:`search_block` of the
    pool's size and ``ordered``, whether its order was searched for the cache; block 0: no search, the
    look-ahead only). Returns
    (the strip pool, uint32; the window records in it, (L, 3) uint32: first index, the same triangle count
    and vertex count; every window's number of pool indices, (L,) uint32; the restart index it joins strips
    with, :func:`.skipstrip.restart_value`, which :func:`use_strips` settles for the file). A window of
    no triangles keeps 0 indices, at its piece's start (the pool's end past the last piece)."""
    pool = np.asarray(index_pool, np.int64).reshape(-1, 3)
    rec = np.asarray(window_records, np.int64).reshape(-1, 3)
    rv = restart_value(int(vertex_count))
    T = pool.shape[0]
    first_tri = rec[:, 0] // 3
    end_tri = first_tri + rec[:, 1]
    # a window starts a strip (a cut: a restart before it), but may end inside one (a barrier the
    # stripifier's look-ahead does not cross, so the strip's prefix up to it draws the window)
    cuts = np.unique(np.concatenate([[0, T], first_tri]))
    cuts = cuts[(cuts >= 0) & (cuts <= T)]
    barriers = np.setdiff1d(end_tri[(end_tri > 0) & (end_tri < T)], cuts)
    auto_block, auto_budget = search_block(T, ordered)
    block = auto_block if block is None else int(block)
    budget = auto_budget if budget is None else int(budget)
    if not 0 <= block <= 20:
        raise ValueError(f"block must be in [0, 20], got {block}")
    strips, start, end, bpos = _strip_pieces(
        pool, cuts, barriers.astype(np.int64), rv, int(window), block, max(int(budget), 1)
    )
    i = np.searchsorted(cuts, first_tri)
    if start.shape[0]:
        # an empty window sits at its piece's start (or at the pool's end when no piece is left)
        first = np.where(i < start.shape[0], start[np.minimum(i, start.shape[0] - 1)], strips.shape[0])
        # a window's end: the end of the piece before a cut, or a barrier's strip position
        j = np.searchsorted(cuts, end_tri)
        at_cut = (j < cuts.shape[0]) & (cuts[np.minimum(j, cuts.shape[0] - 1)] == end_tri)
        m = np.searchsorted(barriers, end_tri)
        last = np.where(
            at_cut,
            end[np.clip(j - 1, 0, start.shape[0] - 1)],
            bpos[np.minimum(m, max(barriers.shape[0] - 1, 0))] if barriers.shape[0] else 0,
        )
        last = np.where(rec[:, 1] > 0, last, first)
    else:  # no triangles at all
        first = last = np.zeros(rec.shape[0], np.int64)
    out_rec = rec.copy()
    out_rec[:, 0] = first
    return strips.astype(np.uint32), out_rec.astype(np.uint32), (last - first).astype(np.uint32), rv


def use_strips(pm: SlidingWindowProgressiveMesh, window: int) -> None:
    """Turn ``pm``'s list pool into its strip pool (:func:`strip_pool`) in place, with its parameters
    (``primitive``, ``restart_index``, ``strip_window``) recorded as skip-strip records them; its block
    search sized by :func:`search_block` (``order_passes`` > 0: an order searched for the cache)."""
    ordered = int(pm.params.get("order_passes", 0)) > 0
    pool, rec, counts, rv = strip_pool(
        pm.index_pool, pm.window_records, pm.vertex_count, window, ordered=ordered
    )
    pm.index_pool, pm.window_records, pm.window_index_counts = pool, rec, counts
    pm.primitive, pm.restart_index = "strip", rv
    pm.params.update(primitive="strip", restart_index=rv, strip_window=int(window))
    settle_restart(pm)
