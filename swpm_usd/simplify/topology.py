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


@nb.njit(cache=True, nogil=True)
def classify_edges(tri_pos: np.ndarray, tris: np.ndarray, P: int):
    """Every edge of the triangles ``tri_pos`` (positions; ``tris``: their vertices) by its half-edges
    ``(a, b)``, grouped by position pair in the order of a stable sort of ``(lo, hi)``: the boundary edges
    (one half-edge) and their faces; the seam edges (two half-edges whose vertices differ at an end; the
    first half-edge of each, then the second) and their faces; per position, whether it is on the boundary,
    on a non-manifold edge (three half-edges or more, or two running the same way) and on an edge of three
    or more (complex). :func:`swpm_usd.simplify.sequence.mesh_topology`'s numpy steps in one pass (about 40
    numpy calls: suzanne 0.4 ms, bunny 22 ms)."""
    T = tri_pos.shape[0]
    H = 3 * T
    lo = np.empty(H, np.int64)
    hi = np.empty(H, np.int64)
    for t in range(T):
        for i in range(3):
            a = np.int64(tri_pos[t, i])
            b = np.int64(tri_pos[t, (i + 1) % 3])
            lo[3 * t + i] = min(a, b)
            hi[3 * t + i] = max(a, b)
    # = np.argsort(lo * P + hi, kind="stable"), as two counting sorts
    by_hi = stable_order(hi, P)
    lo_of = np.empty(H, np.int64)
    for j in range(H):
        lo_of[j] = lo[by_hi[j]]
    by_lo = stable_order(lo_of, P)
    srt = np.empty(H, np.int64)
    for j in range(H):
        srt[j] = by_hi[by_lo[j]]
    b_edges = np.empty((H, 2), np.int32)
    b_faces = np.empty(H, np.int32)
    s0_edges = np.empty((H, 2), np.int32)
    s0_faces = np.empty(H, np.int32)
    s1_edges = np.empty((H, 2), np.int32)
    s1_faces = np.empty(H, np.int32)
    pos_boundary = np.zeros(P, np.bool_)
    on_fin = np.zeros(P, np.bool_)
    on_inconsistent = np.zeros(P, np.bool_)
    nb_ = 0
    ns = 0
    j = 0
    while j < H:
        h0 = srt[j]
        k = j + 1
        while k < H and lo[srt[k]] == lo[h0] and hi[srt[k]] == hi[h0]:
            k += 1
        count = k - j
        t0, i0 = h0 // 3, h0 % 3
        ha0 = tri_pos[t0, i0]
        hb0 = tri_pos[t0, (i0 + 1) % 3]
        if count == 1:
            b_edges[nb_, 0] = ha0
            b_edges[nb_, 1] = hb0
            b_faces[nb_] = t0
            nb_ += 1
            pos_boundary[ha0] = True
            pos_boundary[hb0] = True
        elif count == 2:
            h1 = srt[j + 1]
            t1, i1 = h1 // 3, h1 % 3
            ha1 = tri_pos[t1, i1]
            hb1 = tri_pos[t1, (i1 + 1) % 3]
            if ha0 != hb1:  # inconsistent orientation
                on_inconsistent[lo[h0]] = True
                on_inconsistent[hi[h0]] = True
            va0, vb0 = tris[t0, i0], tris[t0, (i0 + 1) % 3]
            va1, vb1 = tris[t1, i1], tris[t1, (i1 + 1) % 3]
            up0 = ha0 == lo[h0]
            up1 = ha1 == lo[h1]
            # a seam: the two sides' vertices at (lo, hi) differ (on inconsistently oriented edges too)
            lo_differs = (va0 if up0 else vb0) != (va1 if up1 else vb1)
            if lo_differs or (vb0 if up0 else va0) != (vb1 if up1 else va1):
                s0_edges[ns, 0] = ha0
                s0_edges[ns, 1] = hb0
                s0_faces[ns] = t0
                s1_edges[ns, 0] = ha1
                s1_edges[ns, 1] = hb1
                s1_faces[ns] = t1
                ns += 1
        else:
            on_fin[lo[h0]] = True
            on_fin[hi[h0]] = True
        j = k
    seam_edges = np.empty((2 * ns, 2), np.int32)
    seam_faces = np.empty(2 * ns, np.int32)
    for r in range(ns):
        for c in range(2):
            seam_edges[r, c] = s0_edges[r, c]
            seam_edges[ns + r, c] = s1_edges[r, c]
        seam_faces[r] = s0_faces[r]
        seam_faces[ns + r] = s1_faces[r]
    pos_nonmanifold = np.empty(P, np.bool_)
    for p in range(P):
        pos_nonmanifold[p] = on_fin[p] or on_inconsistent[p]
    boundary_edges = b_edges[:nb_].copy()
    boundary_faces = b_faces[:nb_].copy()
    return boundary_edges, boundary_faces, seam_edges, seam_faces, pos_boundary, pos_nonmanifold, on_fin
