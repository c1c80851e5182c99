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
def run_sequence(st: CollapseState, max_passes: int, full_ring_update: bool = False):
    """Collapse greedily in quadric-error order until nothing valid remains. ``full_ring_update``: after a
    collapse, re-evaluate every ring position's whole star, not only its collapse onto the kept position
    (the same sequence up to ties of equal cost; for tests).

    Returns per vertex collapse: binned vertex, kept vertex, step (position collapse it belongs to), and per
    step its error (sqrt of the quadric cost, a distance) and the binned / kept positions.
    """
    P = st.pos_points.shape[0]
    V = st.vertex_pos.shape[0]
    binned = np.empty(V, np.int32)
    kept = np.empty(V, np.int32)
    step_of = np.empty(V, np.int32)
    step_error = np.empty(P, np.float64)
    step_b = np.empty(P, np.int32)
    step_k = np.empty(P, np.int32)
    n_rec = 0
    n_step = 0
    stamp = np.zeros(P, np.int64)
    # int64 targets: position arguments of one type for every callee (one numba specialisation each)
    target = np.full(P, -1, np.int64)
    target_cost = np.full(P, np.inf)  # the cost of ``target``, as pushed
    # the target is the cheapest neighbour, valid or not (not after a failed check picked a costlier one)
    cheapest = np.zeros(P, np.bool_)
    # collapses next to a position with no valid target left before it is checked again (see HUB_SIZE)
    wait = np.zeros(P, np.int64)
    # collapses onto each position while it was a hub, its star at the last of them, and their count when
    # each position's target was pushed: a collapse onto a hub re-evaluates only the binned position's ring
    # (see the ring loop)
    hub_grown = np.zeros(P, np.int64)
    hub_star = np.zeros(P, np.int64)
    target_grown = np.zeros(P, np.int64)
    keys = np.empty(max(16, P), np.float64)
    ids = np.empty(max(16, P), np.int64)
    stamps = np.empty(max(16, P), np.int64)
    size = np.int64(0)  # not a literal 0: one specialisation of the heap calls
    for _ in range(max_passes):
        progress = 0
        for p in range(P):
            k, cost = best_collapse(st, p, np.bool_(False))  # (np.bool_: one compile, not one per literal)
            wait[p] = 0
            stamp[p] += 1
            target[p] = k
            target_cost[p] = cost
            cheapest[p] = True
            target_grown[p] = hub_grown[k] if k >= 0 else 0
            if k >= 0:
                keys, ids, stamps, size = _heap_push(keys, ids, stamps, size, cost, p, stamp[p])
        while size > 0:
            cost, b, s, size = _heap_pop(keys, ids, stamps, size)
            if s != stamp[b] or not st.pos_alive[b]:
                continue
            k = target[b]
            if k >= 0 and hub_grown[k] - target_grown[b] > hub_star[k] // HUB_SIZE:
                # the target is a hub that took more than star // HUB_SIZE collapses since b's entry was
                # pushed: evaluate b again (after each one, most of the heap's top was such entries: 3.2
                # million evaluations for 5,819 collapses)
                k2, c2 = best_collapse(st, b, np.bool_(False))
                stamp[b] += 1
                target[b] = k2
                target_cost[b] = c2
                cheapest[b] = True
                if k2 >= 0:
                    target_grown[b] = hub_grown[k2]
                    keys, ids, stamps, size = _heap_push(keys, ids, stamps, size, c2, b, stamp[b])
                continue
            tris_b = gather_triangles(st, b)
            tp_b = triangle_positions(st, tris_b)
            nbr_b = neighbours(b, tp_b)
            if k < 0 or not valid_collapse(st, b, k, tris_b, tp_b, nbr_b, None):
                k2, c2 = best_collapse(st, b, np.bool_(True))
                wait[b] = tris_b.shape[0] // HUB_SIZE
                stamp[b] += 1
                target[b] = k2
                target_cost[b] = c2
                cheapest[b] = False
                target_grown[b] = hub_grown[k2] if k2 >= 0 else 0
                if k2 >= 0:
                    keys, ids, stamps, size = _heap_push(keys, ids, stamps, size, c2, b, stamp[b])
                continue
            cost = collapse_cost(st, b, k)
            vmap = vertex_map(st, b, k, tris_b, tp_b)
            v0 = st.pos_vstart[b]
            for r in range(vmap.shape[0]):
                binned[n_rec] = st.pos_verts[v0 + r]
                kept[n_rec] = vmap[r]
                step_of[n_rec] = n_step
                n_rec += 1
            step_error[n_step] = np.sqrt(cost)
            step_b[n_step] = b
            step_k[n_step] = k
            n_step += 1
            progress += 1
            apply_collapse(st, b, k, vmap)
            stamp[b] += 1
            # the kept position and its new ring see changed quadrics and topology. A ring position q's
            # collapses onto anything but k cost what they did (q's quadric and theirs are unchanged), so
            # unless its target was b or k (or a costlier valid one, ``cheapest``), its best is the old one
            # or k: one cost, not its whole star (run time halved: bunny 0.83 -> 0.52 s)
            #
            # A hub's ring is most of the mesh: a collapse onto a hub visits b's old ring alone (the
            # positions whose stars changed) and counts the collapse in ``hub_grown``. The rest of its ring
            # keep their entries, and an entry whose target is the hub is evaluated again when it comes up
            # (a random non-manifold hub, one vertex of all 10,000 triangles: a quadratic number of ring
            # visits, 18.6 million). The order is then approximate (a cost may fall as the hub's quadric
            # grows), which a hub's neighbourhood affords. A pass can then end with valid collapses left
            # around a hub (a position that waits is not queued again in it): the next pass finds them
            k_hub = not full_ring_update and _alive_more_than(st, k, HUB_SIZE)
            if k_hub:
                hub_grown[k] += 1
                ring = nbr_b
            else:
                ring = neighbours(k, triangle_positions(st, gather_triangles(st, k)))
            for i in range(ring.shape[0] + 1):
                q = k if i == ring.shape[0] else np.int64(ring[i])
                if q == k and i < ring.shape[0]:
                    continue
                tq = target[q]
                if q == k and k_hub:
                    # the hub itself is evaluated again every star // HUB_SIZE collapses onto it
                    if hub_grown[k] % max(1, hub_star[k] // HUB_SIZE) != 0:
                        continue
                    hub_star[k] = gather_triangles(st, k).shape[0]
                if wait[q] > 0 and q != k:
                    wait[q] -= 1
                    continue
                if q != k and tq >= 0 and tq != b and tq != k and cheapest[q] and not full_ring_update:
                    c2 = collapse_cost(st, q, k)
                    if not c2 < target_cost[q]:
                        continue  # a tie keeps the old target (a whole star's first minimum may differ)
                    k2 = k
                else:
                    k2, c2, n_q = best_collapse_sized(st, q, np.bool_(False), None)
                    if q != k:
                        wait[q] = n_q // HUB_SIZE
                stamp[q] += 1
                target[q] = k2
                target_cost[q] = c2
                cheapest[q] = True
                if k2 >= 0:
                    target_grown[q] = hub_grown[k2]
                    keys, ids, stamps, size = _heap_push(keys, ids, stamps, size, c2, q, stamp[q])
        if progress == 0:
            break
    return (
        binned[:n_rec].copy(),
        kept[:n_rec].copy(),
        step_of[:n_rec].copy(),
        step_error[:n_step].copy(),
        step_b[:n_step].copy(),
        step_k[:n_step].copy(),
    )


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
