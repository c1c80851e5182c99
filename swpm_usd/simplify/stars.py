"""Reading a position's star: its live triangles, their positions and its distinct neighbours.

One position at a time from the corner lists (:func:`gather_triangles`, :func:`triangle_positions`,
:func:`neighbours`, or into reusable buffers: :func:`star_into`, :func:`star_rows`), or every star at once
(:func:`star_snapshot`, :class:`Stars`). Walking a corner list unlinks the corners of dead triangles.
"""

from __future__ import annotations

from collections import namedtuple

import numba as nb
import numpy as np

from .state import CollapseState

#: a snapshot of every position's star in a state (:func:`star_snapshot`): what :func:`gather_triangles`,
#: :func:`triangle_positions` and :func:`neighbours` return for position ``p``, as CSR rows ``p``
Stars = namedtuple(
    "Stars",
    [
        "start",  # (P+1,) i64 rows of tris / tp
        "tris",  # (n,) i32 alive triangles around each position
        "tp",  # (n,3) i32 their positions
        "nbr_start",  # (P+1,) i64 rows of nbr
        "nbr",  # (m,) i32 distinct neighbouring positions
    ],
)


@nb.njit(cache=True, nogil=True)
def gather_triangles(st: CollapseState, p: int) -> np.ndarray:
    """Alive triangles around position ``p`` (each once); unlinks dead corners on the way."""
    n = 0
    c = st.corner_head[p]
    while c >= 0:
        n += 1
        c = st.corner_next[c]
    out = np.empty(n, np.int32)
    return out[: _gather_into(st, p, out, 0)]


@nb.njit(cache=True, inline="always")
def _gather_into(st: CollapseState, p: int, out: np.ndarray, m: int) -> int:
    """:func:`gather_triangles` written to ``out[m:]`` (room for all of p's corners); returns the end."""
    return _gather_rows(st.corner_head, st.corner_next, st.tri_alive, p, out, m)


@nb.njit(cache=True, inline="always")
def _gather_rows(
    corner_head: np.ndarray, corner_next: np.ndarray, tri_alive: np.ndarray, p: int, out: np.ndarray, m: int
) -> int:
    """:func:`_gather_into` on the state's arrays."""
    prev = -1
    c = corner_head[p]
    while c >= 0:
        nxt = corner_next[c]
        t = c // 3
        if tri_alive[t]:
            out[m] = t
            m += 1
            prev = c
        else:
            if prev < 0:
                corner_head[p] = nxt
            else:
                corner_next[prev] = nxt
        c = nxt
    return m


@nb.njit(cache=True, nogil=True)
def triangle_positions(st: CollapseState, tris: np.ndarray) -> np.ndarray:
    """(n,3) positions of the given triangles (read once: namedtuple field access costs a refcount)."""
    tv = st.tri_verts
    vp = st.vertex_pos
    out = np.empty((tris.shape[0], 3), np.int32)
    for j in range(tris.shape[0]):
        for i in range(3):
            out[j, i] = vp[tv[tris[j], i]]
    return out


@nb.njit(cache=True, nogil=True)
def neighbours(p: int, tp: np.ndarray) -> np.ndarray:
    """Distinct positions sharing a triangle with ``p`` (``tp``: positions of p's triangles)."""
    buf = np.empty(2 * tp.shape[0], np.int32)
    return buf[: _neighbours_into(p, tp, buf, 0)]


@nb.njit(cache=True, inline="always")
def _neighbours_into(p: int, tp: np.ndarray, buf: np.ndarray, m0: int) -> int:
    """:func:`neighbours` written to ``buf[m0:]`` (room for ``2 * len(tp)``); returns the end."""
    return _neighbours_rows(p, tp, 0, tp.shape[0], buf, m0)


# stars of more triangles than this find their distinct neighbours by a sort, not by comparing each with
# those found so far: a fan of thousands of triangles on one edge made every collapse there quadratic
_LARGE_STAR = 48


@nb.njit(cache=True, nogil=True)
def _neighbours_rows_sorted(p: int, tp: np.ndarray, j0: int, j1: int, buf: np.ndarray, m0: int) -> int:
    """:func:`_neighbours_rows` by a stable sort, n log n: the same positions in the same order (first
    occurrence)."""
    c = m0
    for j in range(j0, j1):
        for i in range(3):
            if tp[j, i] != p:
                # every row holds p, so two corners each fit the callers' room of two per row; numba checks
                # no bounds, so a row without p must not write past the buffer
                if c >= buf.shape[0]:
                    raise IndexError("neighbour buffer too small: a star row without its position")
                buf[c] = tp[j, i]
                c += 1
    order = np.argsort(buf[m0:c], kind="mergesort")
    first = np.zeros(c - m0, np.bool_)
    for r in range(order.shape[0]):
        if r == 0 or buf[m0 + order[r]] != buf[m0 + order[r - 1]]:
            first[order[r]] = True  # the stable sort puts a value's first occurrence first
    m = m0
    for r in range(c - m0):
        if first[r]:
            buf[m] = buf[m0 + r]
            m += 1
    return m


@nb.njit(cache=True, inline="always")
def _neighbours_rows(p: int, tp: np.ndarray, j0: int, j1: int, buf: np.ndarray, m0: int) -> int:
    """:func:`_neighbours_into` for rows ``j0:j1`` of ``tp`` (no slice: numba's reference counting)."""
    if j1 - j0 > _LARGE_STAR:
        # (np.int64: inlined, a caller's literal 0 would compile the sorted search once more)
        return _neighbours_rows_sorted(p, tp, np.int64(j0), j1, buf, np.int64(m0))
    m = m0
    for j in range(j0, j1):
        for i in range(3):
            q = tp[j, i]
            if q == p:
                continue
            dup = False
            for r in range(m0, m):
                if buf[r] == q:
                    dup = True
                    break
            if not dup:
                buf[m] = q
                m += 1
    return m


@nb.njit(cache=True, inline="always")
def _positions_rows(
    head: np.ndarray,
    cnext: np.ndarray,
    talive: np.ndarray,
    tv: np.ndarray,
    vp: np.ndarray,
    p: int,
    tris: np.ndarray,
    tp: np.ndarray,
    m0: int,
) -> int:
    """``p``'s live triangles into ``tris[m0:]`` and their positions into ``tp[m0:]``, on the state's arrays
    (``corner_head``, ``corner_next``, ``tri_alive``, ``tri_verts``, ``vertex_pos``); returns the end."""
    m = _gather_rows(head, cnext, talive, p, tris, m0)
    for j in range(m0, m):
        for i in range(3):
            tp[j, i] = vp[tv[tris[j], i]]
    return m


@nb.njit(cache=True, nogil=True)
def _star_arrays_at(st: CollapseState, positions: np.ndarray):
    """Every star's rows (start, triangles, their positions, neighbour start, neighbours) with only
    ``positions`` (increasing) read: every other position's rows empty."""
    P = st.pos_points.shape[0]
    n = st.corner_next.shape[0]
    start = np.empty(P + 1, np.int64)
    tris = np.empty(n, np.int32)
    tp = np.empty((n, 3), np.int32)
    nbr_start = np.empty(P + 1, np.int64)
    nbr = np.empty(2 * n, np.int32)
    tv = st.tri_verts
    vp = st.vertex_pos
    head = st.corner_head
    cnext = st.corner_next
    talive = st.tri_alive
    start[0] = 0
    nbr_start[0] = 0
    q = 0  # rows filled up to position q
    for i in range(positions.shape[0]):
        p = positions[i]
        while q < p:
            start[q + 1] = start[q]
            nbr_start[q + 1] = nbr_start[q]
            q += 1
        s1 = _positions_rows(head, cnext, talive, tv, vp, p, tris, tp, start[p])
        start[p + 1] = s1
        nbr_start[p + 1] = _neighbours_rows(p, tp, start[p], s1, nbr, nbr_start[p])
        q = p + 1
    while q < P:
        start[q + 1] = start[q]
        nbr_start[q + 1] = nbr_start[q]
        q += 1
    return start, tris, tp, nbr_start, nbr


def star_snapshot(st: CollapseState, positions: np.ndarray | None = None) -> Stars:
    """Every position's star in the current state, read once (a level's passes over all positions then
    read contiguous rows instead of walking the corner lists again); valid until the next collapse.
    ``positions`` (increasing): every position with a live triangle, if the caller knows them (a coarse
    level of a large mesh reads its few stars, not every position's corner list); the same snapshot."""
    if positions is None:
        positions = np.arange(st.pos_points.shape[0], dtype=np.int64)
    return Stars(*_star_arrays_at(st, positions))


@nb.njit(cache=True, nogil=True)
def star_into(
    st: CollapseState, p: int, tris: np.ndarray, tp: np.ndarray, nbr: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``p``'s star as :func:`gather_triangles`, :func:`triangle_positions` and :func:`neighbours` give it,
    written to reusable buffers instead of three new arrays (room: ``tris`` and ``tp`` one row per triangle
    of the state, ``nbr`` twice that: :func:`star_buffers`); returns views of them, valid until the next
    call with the same buffers."""
    n, m = star_rows(
        st.corner_head, st.corner_next, st.tri_alive, st.tri_verts, st.vertex_pos, p, tris, tp, nbr
    )
    return tris[:n], tp[:n], nbr[:m]


@nb.njit(cache=True, nogil=True)
def _positions_into(st: CollapseState, p: int, tris: np.ndarray, tp: np.ndarray) -> int:
    """``p``'s live triangles into ``tris[:n]`` and their positions into ``tp[:n]``; returns ``n``."""
    return _positions_rows(
        st.corner_head, st.corner_next, st.tri_alive, st.tri_verts, st.vertex_pos, p, tris, tp, 0
    )


@nb.njit(cache=True, nogil=True)
def star_rows(
    corner_head: np.ndarray,
    corner_next: np.ndarray,
    tri_alive: np.ndarray,
    tv: np.ndarray,
    vp: np.ndarray,
    p: int,
    tris: np.ndarray,
    tp: np.ndarray,
    nbr: np.ndarray,
) -> tuple[int, int]:
    """:func:`star_into` on the state's arrays (``tri_verts``, ``vertex_pos``), returning the row counts
    ``(n, m)`` of ``tris[:n]``, ``tp[:n]``, ``nbr[:m]`` instead of views (a hot loop makes no slices)."""
    n = _positions_rows(corner_head, corner_next, tri_alive, tv, vp, p, tris, tp, 0)
    return n, _neighbours_rows(p, tp, 0, n, nbr, 0)


@nb.njit(cache=True, nogil=True)
def star_buffers(st: CollapseState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Buffers for :func:`star_into` (any star of ``st`` fits)."""
    T = st.tri_verts.shape[0]
    return np.empty(T, np.int32), np.empty((T, 3), np.int32), np.empty(2 * T, np.int32)


@nb.njit(cache=True, inline="always")
def _has(tp: np.ndarray, j: int, p: int) -> bool:
    return tp[j, 0] == p or tp[j, 1] == p or tp[j, 2] == p
