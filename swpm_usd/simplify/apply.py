"""Applying a collapse to the state, and keeping the positions' boundary and complex kinds.

:func:`apply_collapse` redirects ``b``'s corners onto ``k``'s vertices, kills the edge's triangles and
merges the quadrics; the positions whose edges lost triangles then get their ``pos_boundary`` flag and
``LOCK_COMPLEX`` bits again from their stars (:func:`_refresh_kind`), or, for a counted hub, from the edge
counts each collapse keeps (:func:`_count_hub_edges`).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .stars import _has, gather_triangles, neighbours, triangle_positions
from .state import HUB_SIZE, LOCK_COMPLEX, LOCK_FIXED, LOCK_FREE, CollapseState


@nb.njit(cache=True, nogil=True)
def apply_collapse(st: CollapseState, b: int, k: int, vmap: np.ndarray) -> int:
    """Bin position ``b`` onto ``k``: redirect its corners, kill the edge's triangles, merge quadrics.
    Returns the number of triangles removed."""
    v0 = st.pos_vstart[b]
    tv = st.tri_verts
    vp = st.vertex_pos
    pv = st.pos_verts
    alive = st.tri_alive
    cnext = st.corner_next
    head = st.corner_head  # fields read once (numba's reference counting per read)
    _count_hub_edges(st, b, k)
    removed = 0
    c = head[b]
    last = -1
    while c >= 0:
        t = c // 3
        if alive[t]:
            if vp[tv[t, 0]] == k or vp[tv[t, 1]] == k or vp[tv[t, 2]] == k:
                alive[t] = False
                removed += 1
            else:
                vb = tv[t, c - 3 * t]
                for r in range(vmap.shape[0]):
                    if pv[v0 + r] == vb:
                        tv[t, c - 3 * t] = vmap[r]
                        break
        last = c
        c = cnext[c]
    first = head[b]
    if last >= 0:  # splice b's corners in front of k's
        cnext[last] = head[k]
        head[k] = head[b]
    head[b] = -1
    q = st.quadric
    for i in range(10):
        q[k, i] += q[b, i]
    qw = st.quadric_weight
    qw[k] += qw[b]
    st.pos_alive[b] = False
    # the killed triangles' corners (k and the edge's third corners) are the positions whose edges lost
    # triangles: a fin's foot or a boundary there may be gone
    locked = st.pos_locked
    boundary = st.pos_boundary
    pos_alive = st.pos_alive
    kinds = st.pos_edge_kinds
    c = first
    while c >= 0:
        t = c // 3
        if not alive[t]:
            for i in range(3):
                p = vp[tv[t, i]]
                if p != b and pos_alive[p] and (boundary[p] or locked[p] & LOCK_COMPLEX):
                    if kinds.shape[0] > 0 and kinds[p, 0] >= 0:
                        _set_kind(st, p, kinds[p, 0] > 0, kinds[p, 1] > 0)
                    else:
                        _refresh_kind(st, p)
        if c == last:
            break
        c = cnext[c]
    return removed


@nb.njit(cache=True, inline="always")
def _corners_at(vp: np.ndarray, tv: np.ndarray, t: int, p: int) -> int:
    """How many corners of triangle ``t`` lie at position ``p`` (two for a sliver across a seam)."""
    return np.int64(vp[tv[t, 0]] == p) + np.int64(vp[tv[t, 1]] == p) + np.int64(vp[tv[t, 2]] == p)


@nb.njit(cache=True, inline="always")
def _row_corners_at(tp: np.ndarray, j: int, p: int) -> int:
    """How many corners of row ``j`` of a star's positions ``tp`` are ``p``."""
    return np.int64(tp[j, 0] == p) + np.int64(tp[j, 1] == p) + np.int64(tp[j, 2] == p)


@nb.njit(cache=True, nogil=True)
def _edge_count(st: CollapseState, x: int, y: int) -> int:
    """The triangles on the edge ``x``-``y`` as :func:`_refresh_kind` counts them: over the alive
    triangles, corners at ``x`` times corners at ``y`` (``x``'s corner list holds a triangle once per
    corner at ``x``)."""
    tv = st.tri_verts
    vp = st.vertex_pos
    alive = st.tri_alive
    cnext = st.corner_next
    n = 0
    c = st.corner_head[x]
    while c >= 0:
        t = c // 3
        if alive[t]:
            n += _corners_at(vp, tv, t, y)
        c = cnext[c]
    return n


@nb.njit(cache=True, inline="always")
def _recount_edge(kinds: np.ndarray, p: int, before: int, after: int) -> None:
    """An edge of ``p`` went from ``before`` to ``after`` triangles: ``kinds[p]`` follows."""
    kinds[p, 0] += np.int32(after == 1) - np.int32(before == 1)
    kinds[p, 1] += np.int32(after >= 3) - np.int32(before >= 3)


@nb.njit(cache=True, nogil=True)
def _count_hub_edges(st: CollapseState, b: int, k: int) -> None:
    """Before ``b`` is binned onto ``k``: the edge kinds of the counted hubs among ``k`` and ``b``'s ring
    (``pos_edge_kinds``) follow the edges the collapse changes. ``b``'s edges go, and an edge ``k``-``x``
    (``x`` on ``b``'s ring) gains the triangles of ``b``-``x`` less twice those of ``b``-``k``-``x``, which
    die (a ring position's other edges keep their triangles). Returns at once unless ``k`` or a corner of
    ``b``'s triangles is a counted hub."""
    kinds = st.pos_edge_kinds
    if kinds.shape[0] == 0:
        return
    counted = kinds[k, 0] >= 0
    tv = st.tri_verts
    vp = st.vertex_pos
    c = st.corner_head[b]
    while c >= 0 and not counted:
        t = c // 3
        if st.tri_alive[t]:
            for i in range(3):
                counted = counted or kinds[vp[tv[t, i]], 0] >= 0
        c = st.corner_next[c]
    if not counted:
        return
    tris_b = gather_triangles(st, b)
    tp_b = triangle_positions(st, tris_b)
    ring = neighbours(b, tp_b)
    # the edges' triangles as _refresh_kind counts them (_edge_count): tp_b holds a triangle once per
    # corner at b. The edge b-k's triangles die
    on_bk = 0
    for j in range(tp_b.shape[0]):
        on_bk += _row_corners_at(tp_b, j, k)
    if kinds[k, 0] >= 0:
        _recount_edge(kinds, k, on_bk, 0)
    for i in range(ring.shape[0]):
        x = np.int64(ring[i])
        if x == k or (kinds[k, 0] < 0 and kinds[x, 0] < 0):
            continue
        on_bx = 0
        on_bkx = 0
        for j in range(tp_b.shape[0]):
            at_x = _row_corners_at(tp_b, j, x)
            on_bx += at_x
            on_bkx += at_x * _has(tp_b, j, k)  # (b, k, x: one corner each)
        # read the smaller star: a hub's ring positions have a few triangles each
        if kinds[k, 0] >= 0:
            on_kx = _edge_count(st, x, k)
        else:
            on_kx = _edge_count(st, k, x)
        after = on_kx + on_bx - 2 * on_bkx
        if kinds[k, 0] >= 0:
            _recount_edge(kinds, k, on_kx, after)
        if kinds[x, 0] >= 0:
            _recount_edge(kinds, x, on_bx, 0)
            _recount_edge(kinds, x, on_kx, after)


@nb.njit(cache=True, nogil=True)
def _refresh_kind(st: CollapseState, p: int) -> None:
    """``pos_boundary[p]`` and the complex bits of ``pos_locked[p]`` from ``p``'s current star: on an
    edge of one triangle, on an edge of three or more (the other corners of p's triangles, sorted: a run
    of one is a boundary edge, a run of three a fin; n log n, for a fan of thousands of triangles on one
    edge)."""
    tv = st.tri_verts
    vp = st.vertex_pos
    alive = st.tri_alive
    cnext = st.corner_next
    n = 0
    c = st.corner_head[p]
    while c >= 0:
        n += 1
        c = cnext[c]
    others = np.empty(2 * n, np.int64)
    m = 0
    c = st.corner_head[p]
    while c >= 0:
        t = c // 3
        if alive[t]:
            for i in range(3):
                x = vp[tv[t, i]]
                if x != p:
                    others[m] = x
                    m += 1
        c = cnext[c]
    others = np.sort(others[:m])
    n_boundary = 0
    n_fin = 0
    run = 1
    for r in range(1, m + 1):
        if r < m and others[r] == others[r - 1]:
            run += 1
            continue
        n_boundary += run == 1
        n_fin += run >= 3
        run = 1
    # a hub's counts are kept from here on by each collapse that changes its edges (_count_hub_edges):
    # sorting its star after every collapse around it made a sequence quadratic (a non-manifold hub in
    # every triangle: 10,000 triangles 9.6 s, of which 8.6 s here)
    kinds = st.pos_edge_kinds
    if kinds.shape[0] > 0 and m > 2 * HUB_SIZE:
        kinds[p, 0] = n_boundary
        kinds[p, 1] = n_fin
    _set_kind(st, p, n_boundary > 0, n_fin > 0)


@nb.njit(cache=True, inline="always")
def _set_kind(st: CollapseState, p: int, on_boundary: bool, on_fin: bool) -> None:
    """``pos_boundary[p]`` and the complex bits of ``pos_locked[p]`` for a position on an edge of one
    triangle (``on_boundary``) or of three or more (``on_fin``)."""
    st.pos_boundary[p] = on_boundary
    if st.pos_locked[p] & LOCK_COMPLEX:
        if not on_fin:
            st.pos_locked[p] = LOCK_FREE
        elif on_boundary:
            st.pos_locked[p] = LOCK_COMPLEX | LOCK_FIXED
        else:
            st.pos_locked[p] = LOCK_COMPLEX
