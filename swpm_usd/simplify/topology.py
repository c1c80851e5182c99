"""Counting sorts and the fan count of each position (pinch vertices), on the collapse state.

:func:`group_by` and :func:`stable_order` sort integer keys by counting; :func:`fan_counts` counts the
edge-connected triangle fans around every position (more than one: a pinch vertex, locked by the caller).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .stars import _positions_rows
from .state import CollapseState


@nb.njit(cache=True, nogil=True)
def group_by(keys: np.ndarray, n_groups: int) -> tuple[np.ndarray, np.ndarray]:
    """Counting sort: CSR ``(start, idx)`` listing, for every group ``g < n_groups``, the indices ``j`` with
    ``keys[j] == g`` in increasing order."""
    cnt = np.zeros(n_groups + 1, np.int64)
    for j in range(keys.shape[0]):
        cnt[keys[j] + 1] += 1
    start = np.cumsum(cnt)
    fill = start[:-1].copy()
    idx = np.empty(keys.shape[0], np.int64)
    for j in range(keys.shape[0]):
        idx[fill[keys[j]]] = j
        fill[keys[j]] += 1
    return start, idx


@nb.njit(cache=True, nogil=True)
def stable_order(keys: np.ndarray, n_keys: int) -> np.ndarray:
    """``np.argsort(keys, kind="stable")`` for integer keys in ``[0, n_keys)`` (:func:`group_by`)."""
    return group_by(keys, n_keys)[1]


@nb.njit(cache=True, nogil=True)
def _find_root(parent: np.ndarray, i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]  # path halving: a fan of thousands of triangles stays near linear
        i = parent[i]
    return i


#: :func:`fan_counts` sorts a star of at most this many other corners in place (bunny's stars: 12; a
#: mergesort per position cost 20 ms of its 23)
_SMALL_SORT = 64


@nb.njit(cache=True, nogil=True)
def fan_counts(st: CollapseState) -> np.ndarray:
    """Number of edge-connected triangle fans around each position (>1 means a pinch vertex)."""
    P = st.pos_points.shape[0]
    out = np.zeros(P, np.int32)
    T = st.tri_verts.shape[0]
    # one buffer for every star (a new array per position cost more than the test itself)
    tris = np.empty(T, np.int32)
    tp = np.empty((T, 3), np.int32)
    parent = np.empty(T, np.int64)
    other = np.empty(3 * T, np.int64)  # (other position, star row) per corner that is not p
    row = np.empty(3 * T, np.int64)
    order_buf = np.empty(_SMALL_SORT, np.int64)
    head = st.corner_head  # read once (numba's reference counting per field read)
    cnext = st.corner_next
    talive = st.tri_alive
    tv = st.tri_verts
    vp = st.vertex_pos
    for p in range(P):
        n = _positions_rows(head, cnext, talive, tv, vp, p, tris, tp, 0)
        if n == 0:
            continue
        # two triangles of p's star are in one fan when they share an edge (p, q): group the star's rows
        # by their other positions q (a sort: n log n, where comparing every pair was cubic on a fan of
        # thousands of triangles on one edge)
        m = 0
        for i in range(n):
            parent[i] = i
            for a in range(3):
                if tp[i, a] != p:
                    other[m] = tp[i, a]
                    row[m] = i
                    m += 1
        # (the union below counts the same fans whatever order equal positions come in)
        if m <= _SMALL_SORT:
            order = order_buf[:m]
            for j in range(m):  # insertion sort: most stars are a dozen corners (no allocation)
                x = other[j]
                r = j
                while r > 0 and other[order[r - 1]] > x:
                    order[r] = order[r - 1]
                    r -= 1
                order[r] = j
        else:
            order = np.argsort(other[:m], kind="mergesort")
        roots = n
        for j in range(1, m):
            if other[order[j]] == other[order[j - 1]]:
                ri = _find_root(parent, row[order[j]])
                rj = _find_root(parent, row[order[j - 1]])
                if ri != rj:
                    parent[ri] = rj
                    roots -= 1
        out[p] = roots
    return out
