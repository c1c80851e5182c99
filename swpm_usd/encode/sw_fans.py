"""Fan order of a handful of triangles: consecutive ones share an edge where possible (a closed fan comes out
as a fan, an open one starts at one of its ends).

The order a patch's triangles start in (:func:`.sw_patches.patch_triangles`) and the order of the triangles
that replace them after its collapses (:func:`.sw_collapse._emit_into`, also Forsyth's builder,
:mod:`.sw_forsyth`), before every block is ordered for the vertex cache
(:func:`swpm_usd.vcache.optimize_block_order`). The papers' patches are sets of triangles: no section of
them is followed here. :func:`_chain_work` holds reusable buffers, so a caller orders patch after patch
without allocating.
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True)
def chain_order(tv: np.ndarray) -> np.ndarray:
    """Order of a handful of triangles (``tv`` (n,3) vertex ids) so consecutive ones share an edge where
    possible: a closed fan comes out as a fan, an open fan starts at one of its ends."""
    return _chain_order_into(tv, tv.shape[0], _chain_work(tv.shape[0])).copy()


@nb.njit(cache=True, nogil=True)
def _chain_work(n: int) -> tuple:
    """Reusable buffers for :func:`_chain_order_into` and :func:`.sw_collapse._emit_into`, up to ``n``
    triangles: (order, adjacency, neighbour counts, used, triangle ids, (n,3) vertex ids)."""
    return (
        np.empty(n, np.int64),
        np.zeros((n, n), np.bool_),
        np.empty(n, np.int64),
        np.empty(n, np.bool_),
        np.empty(n, np.int64),
        np.empty((n, 3), np.int64),
    )


@nb.njit(cache=True, nogil=True)
def _chain_work_for(w: tuple, n: int) -> tuple:
    """``w`` if it holds ``n`` triangles, else larger buffers."""
    if w[0].shape[0] >= n:
        return w
    return _chain_work(max(n, 2 * w[0].shape[0]))


@nb.njit(cache=True, nogil=True)
def _chain_order_into(tv: np.ndarray, n: int, w: tuple) -> np.ndarray:
    """:func:`chain_order` of the first ``n`` rows of ``tv`` in the buffers ``w`` (:func:`_chain_work`);
    returns a view of ``w``'s order buffer."""
    order, adj, nadj, used = w[0], w[1], w[2], w[3]
    if n == 0:
        return order[:0]
    for i in range(n):
        nadj[i] = 0
        used[i] = False
        for j in range(n):
            adj[i, j] = False
    for i in range(n):
        for j in range(i + 1, n):
            shared = 0
            for a in range(3):
                x = tv[i, a]
                if x == tv[j, 0] or x == tv[j, 1] or x == tv[j, 2]:
                    shared += 1
            if shared >= 2:
                adj[i, j] = True
                adj[j, i] = True
                nadj[i] += 1
                nadj[j] += 1
    cur = 0
    for i in range(n):
        if nadj[i] < nadj[cur]:
            cur = i
    for m in range(n):
        order[m] = cur
        used[cur] = True
        if m == n - 1:
            break
        nxt = -1
        for j in range(n):
            if not used[j] and adj[cur, j]:
                nxt = j
                break
        if nxt < 0:  # jump: the unused triangle with the fewest unused neighbours (an end of a chain)
            best = n + 1
            for j in range(n):
                if not used[j]:
                    c = 0
                    for i in range(n):
                        if not used[i] and adj[i, j]:
                            c += 1
                    if c < best:
                        best = c
                        nxt = j
        cur = nxt
    return order[:n]
