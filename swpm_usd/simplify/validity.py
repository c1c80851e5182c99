"""Whether binning position ``b`` onto ``k`` is a valid half-edge collapse, and how its vertices move.

:func:`valid_collapse` (on a state) and :func:`valid_collapse_in` (on its arrays and star rows) test the
topology (edge triangles, link condition, no duplicate face, boundary stays boundary), the geometry (no
flip, no zero area) and the seams: :func:`vertex_map` moves every vertex at ``b`` onto the vertex at ``k``
it shares an edge triangle with, and refuses Svarovsky's "difficult edges" (references/001). Complex
(non-manifold) positions slide along their edges (:func:`_valid_complex_collapse`); a hub's star is read
around the binned ring only (:func:`hub_side_rows`).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .quadrics import tri_normal
from .stars import Stars, _has, gather_triangles, neighbours, triangle_positions
from .state import HUB_SIZE, LOCK_COMPLEX, LOCK_FIXED, LOCK_FREE, CollapseState


@nb.njit(cache=True, nogil=True)
def vertex_map(st: CollapseState, b: int, k: int, tris_b: np.ndarray, tp_b: np.ndarray) -> np.ndarray:
    """For every vertex at ``b`` (in pos_verts order) the vertex at ``k`` it moves onto; -1 in slot 0 of a
    length-1 array when the collapse would split an attribute seam (a "difficult edge")."""
    return _vertex_map(st.tri_verts, st.pos_verts, st.pos_vstart, b, k, tris_b, tp_b)


@nb.njit(cache=True, nogil=True)
def _vertex_map(
    tv: np.ndarray,
    pv: np.ndarray,
    pos_vstart: np.ndarray,
    b: int,
    k: int,
    tris_b: np.ndarray,
    tp_b: np.ndarray,
) -> np.ndarray:
    """:func:`vertex_map` on the state's arrays."""
    v0, v1 = pos_vstart[b], pos_vstart[b + 1]
    nv = v1 - v0
    target = np.full(nv, -1, np.int32)
    used = np.zeros(nv, np.bool_)
    fallback = -1
    for j in range(tris_b.shape[0]):
        t = tris_b[j]
        ib = -1
        ik = -1
        for i in range(3):
            q = tp_b[j, i]
            if q == b:
                ib = i
            elif q == k:
                ik = i
        vb = tv[t, ib]
        local = 0
        for r in range(nv):
            if pv[v0 + r] == vb:
                local = r
                break
        used[local] = True
        if ik < 0:
            continue
        vk = tv[t, ik]
        fallback = vk
        if target[local] < 0:
            target[local] = vk
        elif target[local] != vk:
            return np.full(1, -1, np.int32)
    for r in range(nv):
        if target[r] < 0:
            if used[r]:
                return np.full(1, -1, np.int32)  # this vertex's triangles do not reach k
            target[r] = fallback  # vertex without triangles: rides along with any vertex at k
        # two vertices of b onto one vertex of k would merge a seam: banned
        for s in range(r):
            if used[r] and used[s] and target[s] == target[r]:
                return np.full(1, -1, np.int32)
    return target


@nb.njit(cache=True, nogil=True)
def _single_vertex_maps(
    tv: np.ndarray, k: int, tris_b: np.ndarray, tp_b: np.ndarray, j0: int, j1: int
) -> bool:
    """``vertex_map(...)[0] >= 0`` for a position ``b`` with one vertex (its star: rows ``j0:j1`` of
    ``tris_b``, ``tp_b``), without allocating: the edge triangles exist and all reach the same vertex at
    ``k``."""
    vk = -1
    for j in range(j0, j1):
        ik = -1
        for i in range(3):
            if tp_b[j, i] == k:
                ik = i
        if ik >= 0:
            v = tv[tris_b[j], ik]
            if vk >= 0 and v != vk:
                return False
            vk = v
    return vk >= 0


@nb.njit(cache=True, nogil=True)
def valid_collapse(
    st: CollapseState,
    b: int,
    k: int,
    tris_b: np.ndarray,
    tp_b: np.ndarray,
    nbr_b: np.ndarray,
    stars: Stars | None = None,
    tp_k: np.ndarray | None = None,
    nbr_k: np.ndarray | None = None,
) -> bool:
    """Can position ``b`` be binned onto ``k``? Checks topology (link condition, no duplicate faces,
    boundary vertices stay on the boundary), geometry (no flipped or zero-area face) and seams.
    ``stars``: a snapshot of the current state (:func:`star_snapshot`) to read ``k``'s star from; without
    one pass ``None`` explicitly (numba compiles an omitted argument apart from the ``None`` that
    :func:`best_collapse` passes on). ``tp_k``, ``nbr_k``: ``k``'s star read already by the caller (its
    triangles' positions and neighbours in the current state, e.g. by :func:`star_into`; ``stars`` None)."""
    pos_alive = st.pos_alive
    if st.pos_locked[b] & LOCK_FIXED or not pos_alive[b] or not pos_alive[k] or b == k:
        return False
    # (the ``is None`` tests are resolved at compile time: one branch per specialisation)
    if tp_k is not None and nbr_k is not None:
        tk = tp_k
        nk = nbr_k
    elif stars is None:
        if _alive_more_than(st, k, HUB_SIZE):
            if not edge_count_ok(st, b, k, tp_b):
                return False  # before reading the hub's star: see edge_count_ok
            tk, nk = _hub_side_of(st, k, nbr_b)
        else:
            tk = triangle_positions(st, gather_triangles(st, k))
            nk = neighbours(k, tk)
    else:
        tk = stars.tp[stars.start[k] : stars.start[k + 1]]
        nk = stars.nbr[stars.nbr_start[k] : stars.nbr_start[k + 1]]
    # (not literal 0s: numba compiled valid_collapse_in and three of its callees a second time for them)
    z = np.int64(0)
    return valid_collapse_in(
        pos_alive,
        st.pos_locked,
        st.pos_boundary,
        st.pos_points,
        st.min_area2[0],
        st.tri_verts,
        st.pos_verts,
        st.pos_vstart,
        b,
        k,
        tris_b,
        tp_b,
        z,
        tp_b.shape[0],
        nbr_b,
        z,
        nbr_b.shape[0],
        tk,
        z,
        tk.shape[0],
        nk,
        z,
        nk.shape[0],
    )


@nb.njit(cache=True, inline="always")
def _alive_more_than(st: CollapseState, p: int, n: int) -> bool:
    """Whether more than ``n`` triangles around ``p`` are alive: its corner list walked until ``n + 1``
    are found (a hub's thousands are not walked)."""
    return alive_more_than_in(st.corner_head, st.corner_next, st.tri_alive, p, n)


@nb.njit(cache=True, inline="always")
def alive_more_than_in(
    corner_head: np.ndarray, corner_next: np.ndarray, tri_alive: np.ndarray, p: int, n: int
) -> bool:
    """:func:`_alive_more_than` on the state's arrays."""
    c = corner_head[p]
    while c >= 0 and n >= 0:
        n -= tri_alive[c // 3]
        c = corner_next[c]
    return n < 0


@nb.njit(cache=True, nogil=True)
def _hub_side_of(st: CollapseState, k: int, nbr_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`hub_side_rows` into arrays of their own: (``k``'s triangle positions, neighbours) as
    :func:`valid_collapse_in` reads them for binning a position of neighbours ``nbr_b`` onto ``k``."""
    head = st.corner_head
    cnext = st.corner_next
    n_rows = 0
    for i in range(nbr_b.shape[0]):
        if nbr_b[i] == k:
            continue  # (k's own list is what this spares)
        c = head[nbr_b[i]]
        while c >= 0:
            n_rows += 1
            c = cnext[c]
    tk = np.empty((n_rows, 3), np.int32)
    nk = np.empty(nbr_b.shape[0], np.int32)
    n = nbr_b.shape[0]
    mt, mn = hub_side_rows(head, cnext, st.tri_alive, st.tri_verts, st.vertex_pos, k, nbr_b, n, tk, nk)
    return tk[:mt], nk[:mn]


@nb.njit(cache=True, nogil=True)
def hub_side_rows(
    corner_head: np.ndarray,
    corner_next: np.ndarray,
    tri_alive: np.ndarray,
    tv: np.ndarray,
    vp: np.ndarray,
    k: int,
    nbr_b: np.ndarray,
    nn: int,
    tk: np.ndarray,
    nk: np.ndarray,
) -> tuple[int, int]:
    """What :func:`valid_collapse_in` reads of a hub ``k``'s star, found from ``b``'s ring instead (``b``'s
    neighbours ``nbr_b[:nn]``): the triangles around ``k`` that hold one of
    ``b``'s neighbours, written to ``tk``, and those neighbours of ``b`` that are ``k``'s, to ``nk``.
    Returns their row counts, or (-1, -1) if ``tk`` has no room for them. The tests ask only whether a
    neighbour of ``b`` is ``k``'s and whether a triangle around ``k`` holds two given neighbours of ``b``,
    so the answer is the one ``k``'s whole star gives, read from a few small stars (a hub in every
    triangle: sorting its star for each test was most of a quadratic sequence)."""
    m = 0
    n_nk = 0
    for i in range(nn):
        q = nbr_b[i]
        if q == k:
            continue
        shared = False
        c = corner_head[q]
        while c >= 0:
            t = c // 3
            if tri_alive[t]:
                p0 = vp[tv[t, 0]]
                p1 = vp[tv[t, 1]]
                p2 = vp[tv[t, 2]]
                if p0 == k or p1 == k or p2 == k:
                    if m >= tk.shape[0]:
                        return -1, -1
                    shared = True
                    tk[m, 0] = p0
                    tk[m, 1] = p1
                    tk[m, 2] = p2
                    m += 1
            c = corner_next[c]
        if shared:
            nk[n_nk] = q
            n_nk += 1
    return m, n_nk


@nb.njit(cache=True, inline="always")
def edge_count_ok(st: CollapseState, b: int, k: int, tp_b: np.ndarray) -> bool:
    """The part of :func:`valid_collapse_in` that reads ``b``'s star alone: the edge ``b``-``k`` lies on
    as many triangles as binning ``b`` allows (two inside, one on the boundary, three or more between
    complex positions). A caller tests this before it reads ``k``'s star: most positions around a
    non-manifold hub (a vertex of every triangle, other corners random) lie on an edge of several
    triangles with it, and reading the hub's star for each such test made the quadric order cubic."""
    return edge_count_ok_in(st.pos_locked, st.pos_boundary, b, k, tp_b, tp_b.shape[0])


@nb.njit(cache=True, inline="always")
def edge_count_ok_in(
    pos_locked: np.ndarray, pos_boundary: np.ndarray, b: int, k: int, tp_b: np.ndarray, n_rows: int
) -> bool:
    """:func:`edge_count_ok` on the state's arrays, ``b``'s star in the first ``n_rows`` rows of ``tp_b``."""
    n_edge = 0
    for j in range(n_rows):
        if _has(tp_b, j, k):
            n_edge += 1
    if pos_locked[b] == LOCK_COMPLEX:
        return n_edge >= 3
    if pos_boundary[b]:
        return n_edge == 1
    return n_edge == 2


@nb.njit(cache=True, inline="always")
def _moved_face_ok(pts: np.ndarray, min_area2: float, tp_b: np.ndarray, j: int, b: int, k: int):
    """The surviving triangle ``j`` of ``b``'s star, ``b, x, y`` in winding order, before and after ``b``
    moves onto ``k``: (no zero area and no flip or near-flip, x, y). A normal turned by more than ~84
    degrees is refused."""
    p0 = tp_b[j, 0]
    p1 = tp_b[j, 1]
    p2 = tp_b[j, 2]
    if p0 == b:
        x, y = p1, p2
    elif p1 == b:
        x, y = p2, p0
    else:
        x, y = p0, p1
    n00, n01, n02 = tri_normal(pts, b, x, y)
    n10, n11, n12 = tri_normal(pts, k, x, y)
    l1 = n10 * n10 + n11 * n11 + n12 * n12
    if l1 <= min_area2:
        return False, x, y
    l0 = n00 * n00 + n01 * n01 + n02 * n02
    return n00 * n10 + n01 * n11 + n02 * n12 > 0.1 * np.sqrt(l0 * l1), x, y


@nb.njit(cache=True, nogil=True)
def valid_collapse_in(
    pos_alive: np.ndarray,
    pos_locked: np.ndarray,
    pos_boundary: np.ndarray,
    pts: np.ndarray,
    min_area2: float,
    tv: np.ndarray,
    pv: np.ndarray,
    pos_vstart: np.ndarray,
    b: int,
    k: int,
    tris_b: np.ndarray,
    tp_b: np.ndarray,
    b0: int,
    b1: int,
    nbr_b: np.ndarray,
    n0: int,
    n1: int,
    tk: np.ndarray,
    k0: int,
    k1: int,
    nk: np.ndarray,
    m0: int,
    m1: int,
) -> bool:
    """:func:`valid_collapse` on the state's arrays, the stars given as row ranges (``b``'s triangles and
    their positions: rows ``b0:b1`` of ``tris_b``, ``tp_b``; its neighbours ``nbr_b[n0:n1]``; ``k``'s
    triangles' positions ``tk[k0:k1]`` and neighbours ``nk[m0:m1]``): a hot loop over a star snapshot
    reads the state's fields and makes the slices of every star once, not per test (numba's reference
    counting)."""
    if not pos_alive[b] or not pos_alive[k] or b == k:
        return False
    if pos_locked[b] != LOCK_FREE:
        if pos_locked[b] != LOCK_COMPLEX or not pos_locked[k] & LOCK_COMPLEX:
            return False
        return _valid_complex_collapse(
            pts, min_area2, tv, pv, pos_vstart, b, k, tris_b, tp_b, b0, b1, nbr_b, n0, n1, tk, k0, k1, nk, m0,
            m1,
        )  # fmt: skip
    n_edge = 0
    opp0 = -1
    opp1 = -1
    for j in range(b0, b1):
        if _has(tp_b, j, k):
            o = -1
            for i in range(3):
                q = tp_b[j, i]
                if q != b and q != k:
                    o = q
            if n_edge == 0:
                opp0 = o
            else:
                opp1 = o
            n_edge += 1
    if n_edge == 0 or n_edge > 2:
        return False
    if pos_boundary[b]:
        if n_edge != 1:
            return False
    elif n_edge != 2:
        return False
    # link condition: common neighbours of b and k are exactly the edge's opposite vertices
    common = 0
    for i in range(n0, n1):
        q = nbr_b[i]
        if q == k:
            continue
        for j in range(m0, m1):
            if nk[j] == q:
                if q != opp0 and q != opp1:
                    return False
                common += 1
                break
    if common != n_edge:
        return False
    for j in range(b0, b1):
        if _has(tp_b, j, k):
            continue
        ok, x, y = _moved_face_ok(pts, min_area2, tp_b, j, b, k)
        if not ok:
            return False
        # duplicate face: (k, x, y) already exists around k. A face around k holds only k's neighbours,
        # and the link test above left only the edge's opposite vertices (and b) common to both, so
        # other x, y cannot repeat a face: skip the scan (same answer, most of the test's time)
        if (x == opp0 or x == opp1 or x == b) and (y == opp0 or y == opp1 or y == b):
            for jj in range(k0, k1):
                if _has(tk, jj, x) and _has(tk, jj, y):
                    return False
    if pos_vstart[b + 1] - pos_vstart[b] == 1:
        return _single_vertex_maps(tv, k, tris_b, tp_b, b0, b1)
    vm = _vertex_map(tv, pv, pos_vstart, b, k, tris_b[b0:b1], tp_b[b0:b1])
    if vm[0] < 0:
        return False
    return True


@nb.njit(cache=True, nogil=True)
def _valid_complex_collapse(
    pts: np.ndarray,
    min_area2: float,
    tv: np.ndarray,
    pv: np.ndarray,
    pos_vstart: np.ndarray,
    b: int,
    k: int,
    tris_b: np.ndarray,
    tp_b: np.ndarray,
    b0: int,
    b1: int,
    nbr_b: np.ndarray,
    n0: int,
    n1: int,
    tk: np.ndarray,
    k0: int,
    k1: int,
    nk: np.ndarray,
    m0: int,
    m1: int,
) -> bool:
    """:func:`valid_collapse_in` for a complex ``b`` onto a complex ``k`` (``LOCK_COMPLEX``): the edge
    ``b``-``k`` must be non-manifold (three or more triangles, their third corners distinct), and the
    link condition, the flip and zero-area tests and the duplicate-face test are the manifold ones with
    every edge triangle's third corner in place of the two. So the collapse removes the edge's triangles,
    creates no edge of more triangles than the two it merges had, and folds nothing over."""
    opp = np.empty(b1 - b0, np.int64)
    n_edge = 0
    for j in range(b0, b1):
        if _has(tp_b, j, k):
            o = -1
            for i in range(3):
                q = tp_b[j, i]
                if q != b and q != k:
                    o = q
            for i in range(n_edge):
                if opp[i] == o:
                    return False  # two triangles on the edge with one third corner: a doubled face
            opp[n_edge] = o
            n_edge += 1
    if n_edge < 3:
        return False
    # link condition: the common neighbours of b and k are exactly the edge triangles' third corners
    common = 0
    for i in range(n0, n1):
        q = nbr_b[i]
        if q == k:
            continue
        for j in range(m0, m1):
            if nk[j] == q:
                found = False
                for r in range(n_edge):
                    found = found or opp[r] == q
                if not found:
                    return False
                common += 1
                break
    if common != n_edge:
        return False
    for j in range(b0, b1):
        if _has(tp_b, j, k):
            continue
        ok, x, y = _moved_face_ok(pts, min_area2, tp_b, j, b, k)
        if not ok:
            return False
        for jj in range(k0, k1):  # (k, x, y) already around k: a duplicate face
            if _has(tk, jj, x) and _has(tk, jj, y):
                return False
    if pos_vstart[b + 1] - pos_vstart[b] == 1:
        return _single_vertex_maps(tv, k, tris_b, tp_b, b0, b1)
    vm = _vertex_map(tv, pv, pos_vstart, b, k, tris_b[b0:b1], tp_b[b0:b1])
    return vm[0] >= 0
