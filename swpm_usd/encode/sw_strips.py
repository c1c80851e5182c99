"""The sliding-window pool stored as triangle strips (``primitive="strip"``): the list pool cut at every
window's first and last triangle, each piece between two cuts turned into strips by the skip strips'
stripifier (:func:`.strips.stripify`, Evans-Skiena-Varshney with a look-ahead window, as meshoptimizer) and
the pieces joined by a restart index (skip-strip's value, :func:`.skipstrip.restart_value`). Every window
then starts at the pool's start or right after a restart index and ends right before one (or at the pool's
end), so it is still ONE contiguous range of the pool: one strip draw with primitive restart per LOD, as
Forsyth's sliding window draws one list range. A window's strip decodes (spec/format.md 3.7's rule, parity
from each restart) to its list triangles as an oriented multiset, in the list's order as far as the
stripifier keeps it.

Ten shared meshes, lambda (pool indices over three a LOD-0 triangle): defaults 5.30 -> 3.79 (mean), cluster
and swaps 4.43 -> 3.35 (``slidingwindow.md``, "Strips").
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .skipstrip import restart_value
from .strips import _stripify
from .sw_mesh import SlidingWindowProgressiveMesh


@nb.njit(cache=True)
def _strip_pieces(tris: np.ndarray, cuts: np.ndarray, restart: int, window: int) -> tuple:
    """The pieces ``tris[cuts[i]:cuts[i + 1]]`` stripified and joined by ``restart``: (the strip pool, the
    first index of every piece in it, the index past its last)."""
    S = cuts.shape[0] - 1
    # a piece of t triangles: at most 4 t indices with restarts (3, then a restart and 3 or a swap's 2 a
    # triangle), and one restart between pieces
    out = np.empty(4 * tris.shape[0] + S, np.int64)
    start = np.empty(S, np.int64)
    end = np.empty(S, np.int64)
    n = 0
    for s in range(S):
        a, b = cuts[s], cuts[s + 1]
        if s > 0:
            out[n] = restart
            n += 1
        piece = _stripify(tris[a:b], True, restart, max(1, min(window, b - a)))
        start[s] = n
        out[n : n + piece.shape[0]] = piece
        n += piece.shape[0]
        end[s] = n
    return out[:n].copy(), start, end


def strip_pool(
    index_pool: np.ndarray, window_records: np.ndarray, vertex_count: int, window: int = 4
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The strip pool of a list pool.

    ``index_pool``: the list pool (3 indices a triangle); ``window_records`` (L, 3): first index offset,
    triangle count, vertex count of every window in it; ``window``: the stripifier's look-ahead. Returns
    (the strip pool, uint32; the window records in it, (L, 3) uint32: first index, the same triangle count
    and vertex count; every window's number of pool indices, (L,) uint32; the restart index). A window of
    no triangles keeps 0 indices, at its piece's start (the pool's end past the last piece)."""
    pool = np.asarray(index_pool, np.int64).reshape(-1, 3)
    rec = np.asarray(window_records, np.int64).reshape(-1, 3)
    rv = restart_value(int(vertex_count))
    T = pool.shape[0]
    first_tri = rec[:, 0] // 3
    end_tri = first_tri + rec[:, 1]
    # every window's first and last triangle is a cut: no window starts or ends inside a piece
    cuts = np.unique(np.concatenate([[0, T], first_tri, end_tri]))
    cuts = cuts[(cuts >= 0) & (cuts <= T)]
    strips, start, end = _strip_pieces(pool, cuts, rv, int(window))
    i = np.searchsorted(cuts, first_tri)
    j = np.searchsorted(cuts, end_tri)
    if start.shape[0]:
        # an empty window sits at its piece's start (or at the pool's end when no piece is left)
        first = np.where(i < start.shape[0], start[np.minimum(i, start.shape[0] - 1)], strips.shape[0])
        last = np.where(rec[:, 1] > 0, end[np.maximum(j - 1, 0)], first)
    else:  # no triangles at all
        first = last = np.zeros(rec.shape[0], np.int64)
    out_rec = rec.copy()
    out_rec[:, 0] = first
    return strips.astype(np.uint32), out_rec.astype(np.uint32), (last - first).astype(np.uint32), rv


def use_strips(pm: SlidingWindowProgressiveMesh, window: int) -> None:
    """Turn ``pm``'s list pool into its strip pool (:func:`strip_pool`) in place, with its parameters
    (``primitive``, ``restart_index``, ``strip_window``) recorded as skip-strip records them."""
    pool, rec, counts, rv = strip_pool(pm.index_pool, pm.window_records, pm.vertex_count, window)
    pm.index_pool, pm.window_records, pm.window_index_counts = pool, rec, counts
    pm.primitive, pm.restart_index = "strip", rv
    pm.params.update(primitive="strip", restart_index=rv, strip_window=int(window))
