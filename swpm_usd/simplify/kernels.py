"""Numba kernels of the half-edge collapse simplifier (Garland-Heckbert quadrics, Svarovsky's VIPM).

The mesh is held twice: *vertices* (what the GPU draws, split at attribute seams) and *positions* (welded
points). Collapses are decided on positions: binning position ``b`` onto position ``k`` moves every vertex at
``b`` onto the vertex at ``k`` it shares an edge triangle with (Svarovsky's "difficult edges" are banned:
a vertex at ``b`` that touches no triangle of the edge, or two different vertices at ``k``, refuses the
collapse). The kept position never moves (half-edge collapse, no new vertices).

State lives in a namedtuple of arrays (:class:`CollapseState`) so that other builders (the sliding-window
levels) can reuse :func:`valid_collapse`, :func:`collapse_cost` and :func:`apply_collapse`.

Per position: a linked list of the triangle corners that sit on it (``corner_head``/``corner_next``,
corner ``3*t+i``), compacted lazily when walked; a quadric ``quadric[p, 0:10]`` (upper triangle of the 4x4
matrix) and the face area it sums in ``quadric_weight[p]``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .apply import (
    _corners_at,
    _count_hub_edges,
    _edge_count,
    _recount_edge,
    _refresh_kind,
    _row_corners_at,
    _set_kind,
    apply_collapse,
)
from .best import (
    MAX_TARGET_TRIES,
    best_collapse,
    best_collapse_sized,
    best_of_star,
)
from .heap import (
    _heap_pop,
    _heap_push,
    _heap_push_into,
)
from .quadrics import (
    _add_plane,
    _cost_of,
    _eval_quadric2,
    collapse_cost,
    init_quadrics,
    min_doubled_area2,
    tri_normal,
)
from .run import (
    run_sequence,
)
from .stars import (
    _LARGE_STAR,
    Stars,
    _gather_into,
    _gather_rows,
    _has,
    _neighbours_into,
    _neighbours_rows,
    _neighbours_rows_sorted,
    _positions_into,
    _positions_rows,
    _star_arrays_at,
    gather_triangles,
    neighbours,
    star_buffers,
    star_into,
    star_rows,
    star_snapshot,
    triangle_positions,
)
from .state import (
    HUB_SIZE,
    LOCK_COMPLEX,
    LOCK_FIXED,
    LOCK_FREE,
    CollapseState,
    build_corner_lists,
    is_hub,
)
from .validity import (
    _alive_more_than,
    _hub_side_of,
    _moved_face_ok,
    _single_vertex_maps,
    _valid_complex_collapse,
    _vertex_map,
    alive_more_than_in,
    edge_count_ok,
    edge_count_ok_in,
    hub_side_rows,
    valid_collapse,
    valid_collapse_in,
    vertex_map,
)

# every name of the collapse kernels, whichever module defines it: the encoders' ``K.xxx`` and the tests
# read them here
__all__ = [
    "CollapseState",
    "LOCK_FREE",
    "LOCK_FIXED",
    "LOCK_COMPLEX",
    "HUB_SIZE",
    "is_hub",
    "build_corner_lists",
    "Stars",
    "gather_triangles",
    "_gather_into",
    "_gather_rows",
    "triangle_positions",
    "neighbours",
    "_neighbours_into",
    "_LARGE_STAR",
    "_neighbours_rows_sorted",
    "_neighbours_rows",
    "_positions_rows",
    "_star_arrays_at",
    "star_snapshot",
    "star_into",
    "_positions_into",
    "star_rows",
    "star_buffers",
    "_has",
    "_add_plane",
    "_eval_quadric2",
    "init_quadrics",
    "tri_normal",
    "min_doubled_area2",
    "collapse_cost",
    "_cost_of",
    "vertex_map",
    "_vertex_map",
    "_single_vertex_maps",
    "valid_collapse",
    "_alive_more_than",
    "alive_more_than_in",
    "_hub_side_of",
    "hub_side_rows",
    "edge_count_ok",
    "edge_count_ok_in",
    "_moved_face_ok",
    "valid_collapse_in",
    "_valid_complex_collapse",
    "apply_collapse",
    "_corners_at",
    "_row_corners_at",
    "_edge_count",
    "_recount_edge",
    "_count_hub_edges",
    "_refresh_kind",
    "_set_kind",
    "best_collapse",
    "best_collapse_sized",
    "MAX_TARGET_TRIES",
    "best_of_star",
    "_heap_push",
    "_heap_push_into",
    "_heap_pop",
    "run_sequence",
    "group_by",
    "stable_order",
    "_find_root",
    "_SMALL_SORT",
    "fan_counts",
]


# ----------------------------------------------------------------------------------------------------
# quadrics
# ----------------------------------------------------------------------------------------------------


# ----------------------------------------------------------------------------------------------------
# adjacency
# ----------------------------------------------------------------------------------------------------


# ----------------------------------------------------------------------------------------------------
# collapse test, cost and application
# ----------------------------------------------------------------------------------------------------


# ----------------------------------------------------------------------------------------------------
# a binary min-heap on arrays (cost, position, stamp); stale entries are skipped on pop
# ----------------------------------------------------------------------------------------------------


# ----------------------------------------------------------------------------------------------------
# the full sequence
# ----------------------------------------------------------------------------------------------------


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
