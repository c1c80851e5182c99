"""The order of a level's patches for a FIFO vertex cache (TD-VIPM section 3.2, eq. 2), scored for both
sequences a window draws, ``P_{j+1}..P_n`` and ``Q_1..Q_j``.

* :func:`order_patches` - greedy: the next patch is the one with the fewest misses per triangle in the two
  simulated caches, plus :data:`ORDER_LIVE_WEIGHT` times the mean number of other patches left on its
  vertices.
* :func:`reassign_middle` - each triangle :func:`.sw_patches.absorb_middle` added moves to the patch where
  that order draws it with the fewest misses.
* :func:`ordered_patches` - a fully stored level's patches from its inner vertices to their order: the
  patches' triangles, the absorbed middle, the order and the reassignment in one kernel call.

:mod:`.sw_refine` then searches the order further (``order_passes``).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..simplify import kernels as K
from .sw_patches import absorb_middle, patch_triangles

#: weight of the "live" term in the patch order: the mean number of other unvisited patches on a patch's
#: vertices (Forsyth's remaining-triangle score at patch level: finish vertices off rather than leave
#: isolated patches for a cold visit later; the collapsed region stays compact, so the seam between a
#: window's ``P`` and ``Q`` parts stays short). 0.3 until 2026-12-02's third session; with the order search,
#: ten meshes, 400 points: ACMR ratio mean 1.0357 -> 1.0332, within 1.10 377 -> 384 (``slidingwindow.md``)
ORDER_LIVE_WEIGHT = 1.0
#: ... and with ``cluster=True``, whose linked levels read their patches out of this order: 0.3 (at 1.0 the
#: edge swaps and clustering give lambda 4.424 -> 4.465 on average over the ten meshes, bunny 3.74 -> 3.79)
ORDER_LIVE_WEIGHT_CLUSTER = 0.3


@nb.njit(cache=True, nogil=True)
def _fifo_misses(verts: np.ndarray, skip: np.ndarray, stamp: np.ndarray, pushes: int, cache_size: int) -> int:
    """Misses of ``verts`` (those not ``skip``-ped) against a FIFO of ``cache_size`` (``stamp``: push count
    at which each vertex entered; a vertex is cached while fewer than ``cache_size`` pushes followed)."""
    miss = 0
    for j in range(verts.shape[0]):
        v = verts[j]
        if skip[v]:
            continue
        s = stamp[v]
        if s == 0 or pushes - s + 1 > cache_size:
            miss += 1
    return miss


@nb.njit(cache=True, nogil=True)
def _fifo_push(verts: np.ndarray, skip: np.ndarray, stamp: np.ndarray, ring: np.ndarray, pushes: int) -> int:
    """Draw ``verts`` (in order, those not ``skip``-ped) through the FIFO; returns the new push count."""
    cache_size = ring.shape[0]
    for j in range(verts.shape[0]):
        v = verts[j]
        if skip[v]:
            continue
        s = stamp[v]
        if s == 0 or pushes - s + 1 > cache_size:
            pushes += 1
            stamp[v] = pushes
            ring[pushes % cache_size] = v
    return pushes


@nb.njit(cache=True, nogil=True)
def order_patches(
    pt_start: np.ndarray,
    pt: np.ndarray,
    tri_verts: np.ndarray,
    binned_vertex: np.ndarray,
    inner_count: np.ndarray,
    vertex_count: int,
    cache_size: int,
    live_weight: float,
) -> np.ndarray:
    """Greedy vertex-cache order of patches (TD-VIPM section 3.2, eq. 2, for both halves of the level).

    A window of the level draws ``P_{j+1}..P_n`` and then ``Q_1..Q_j`` in the same patch order, so two FIFO
    caches of ``cache_size`` entries are simulated: one for the ``P`` sequence (the patch's triangles) and
    one for the ``Q`` sequence (the patch's vertices but its ``binned_vertex`` ones, which is what its
    ``Q`` draws). The next patch is, among those touching a vertex in the ``P`` cache, the one with the
    fewest misses per triangle in both caches (``Q`` has ``2 * inner_count`` triangles fewer) plus
    ``live_weight`` (:data:`ORDER_LIVE_WEIGHT`) times the mean number of other unvisited patches on its
    vertices; with none, the nearest unvisited patch on a stack of recently drawn vertices, else the first
    unvisited one."""
    n = pt_start.shape[0] - 1
    order = np.empty(n, np.int64)
    if n == 0:
        return order
    # vertex sets of patches and the patches of every vertex
    vmark = np.full(vertex_count, -1, np.int64)
    pv_start = np.zeros(n + 1, np.int64)
    # int32 vertex ids, as the triangle rows drawn through the same FIFO helpers (one specialisation each)
    pv = np.empty(3 * pt.shape[0] + 1, np.int32)
    m = np.int64(0)
    for p in range(n):
        for j in range(pt_start[p], pt_start[p + 1]):
            for i in range(3):
                v = tri_verts[pt[j], i]
                if vmark[v] != p:
                    vmark[v] = p
                    pv[m] = v
                    m += 1
        pv_start[p + 1] = m
    # loops, not a slice fill and fancy indexing (numba's broadcast code), and int64 keys: one
    # specialisation of K.group_by
    patch_of = np.empty(m, np.int64)
    keys = np.empty(m, np.int64)
    for p in range(n):
        for j in range(pv_start[p], pv_start[p + 1]):
            patch_of[j] = p
            keys[j] = pv[j]
    vp_start, idx = K.group_by(keys, vertex_count)
    vp = np.empty(m, np.int64)
    for j in range(m):
        vp[j] = patch_of[idx[j]]
    remaining = np.empty(
        vertex_count, np.int64
    )  # np.diff(vp_start) as a loop (np.diff: see sw_collapse._grow_tris)
    for v in range(vertex_count):
        remaining[v] = vp_start[v + 1] - vp_start[v]
    no_skip = np.zeros(vertex_count, np.bool_)
    done = np.zeros(n, np.bool_)
    stamp_p = np.zeros(vertex_count, np.int64)
    ring_p = np.full(cache_size, -1, np.int64)
    stamp_q = np.zeros(vertex_count, np.int64)
    ring_q = np.full(cache_size, -1, np.int64)
    push_p = np.int64(0)
    push_q = np.int64(0)
    first_left = vp_start[:-1].copy()
    stack = np.empty(m + 1, np.int64)
    sp = np.int64(0)
    scan = np.int64(0)
    # the step at which each patch was last scored: a patch with several vertices in the cache is scored
    # once per step, not once per such vertex (the same score again never wins: the same order; its 60
    # calls in builds of cow, teapot and bunny -9 %)
    scored = np.full(n, -1, np.int64)
    for o in range(n):
        best = -1
        best_score = np.inf
        for r in range(cache_size):
            v = ring_p[r]
            if v < 0 or K.is_hub(vp_start, v):
                continue
            for a in range(vp_start[v], vp_start[v + 1]):
                p = vp[a]
                if done[p] or scored[p] == o:
                    continue
                scored[p] = o
                verts = pv[pv_start[p] : pv_start[p + 1]]
                miss_p = _fifo_misses(verts, no_skip, stamp_p, push_p, cache_size)
                miss_q = _fifo_misses(verts, binned_vertex, stamp_q, push_q, cache_size)
                live = 0.0
                for j in range(verts.shape[0]):
                    live += remaining[verts[j]] - 1
                ntri = pt_start[p + 1] - pt_start[p]
                ntri_q = max(ntri - 2 * inner_count[p], 1)
                score = miss_p / ntri + miss_q / ntri_q + live_weight * live / verts.shape[0]
                score += 1e-9 * p
                if score < best_score:
                    best_score = score
                    best = p
        while best < 0 and sp > 0:
            sp -= 1
            v = stack[sp]
            # the first of v's patches not drawn yet; the ones before it stay drawn (a hub is on the
            # stack once per patch drawn: scanning its whole list each time was quadratic)
            while first_left[v] < vp_start[v + 1] and done[vp[first_left[v]]]:
                first_left[v] += 1
            if first_left[v] < vp_start[v + 1]:
                best = vp[first_left[v]]
        if best < 0:
            while done[scan]:
                scan += 1
            best = scan
        order[o] = best
        done[best] = True
        for j in range(pt_start[best], pt_start[best + 1]):
            push_p = _fifo_push(tri_verts[pt[j]], no_skip, stamp_p, ring_p, push_p)
        verts = pv[pv_start[best] : pv_start[best + 1]]
        push_q = _fifo_push(verts, binned_vertex, stamp_q, ring_q, push_q)
        for j in range(verts.shape[0]):
            remaining[verts[j]] -= 1
            stack[sp] = verts[j]
            sp += 1
    return order


@nb.njit(cache=True, nogil=True)
def reassign_middle(
    st: K.CollapseState,
    own_start: np.ndarray,
    pt_start: np.ndarray,
    pt: np.ndarray,
    order: np.ndarray,
    binned_vertex: np.ndarray,
    cache_size: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The triangles :func:`.sw_patches.absorb_middle` added to the patches, each moved to the patch where it
    costs the fewest FIFO misses once the patch order ``order`` is known.

    ``own_start``: CSR offsets of the patches' own triangles (those of :func:`.sw_patches.patch_triangles`,
    first in every patch of ``pt_start`` / ``pt``, the absorbed ones after them). The candidates of an
    absorbed triangle are the patches with an own triangle at one of its positions. The ``P`` and ``Q`` caches
    of :func:`order_patches` are simulated along ``order`` (each patch's own triangles, its ``Q`` without the
    ``binned_vertex`` ones, then its absorbed triangles, drawn in both); right after a candidate's own
    triangles, the absorbed triangle's misses in both caches are its cost there. It moves only to a strictly
    cheaper candidate (the first cheapest), else stays: :func:`.sw_patches.absorb_middle` picks by shared
    vertices alone, so an edge shared with one patch can lose to a corner of a patch drawn right after the
    neighbours that hold its other corners. Returns the new CSR (own triangles first, as before)."""
    tv = st.tri_verts
    vpos = st.vertex_pos
    V = vpos.shape[0]
    n = pt_start.shape[0] - 1
    nab = 0
    for p in range(n):
        nab += pt_start[p + 1] - (pt_start[p] + own_start[p + 1] - own_start[p])
    ab = np.empty(nab, np.int64)
    ab_cur = np.empty(nab, np.int64)
    k = 0
    for p in range(n):
        own_end = pt_start[p] + own_start[p + 1] - own_start[p]
        for j in range(own_end, pt_start[p + 1]):
            ab[k] = pt[j]
            ab_cur[k] = p
            k += 1
    # candidate patches of every absorbed triangle: the patches with an own triangle at one of its positions
    P = np.int64(0)
    for v in range(V):
        P = max(P, vpos[v] + 1)
    corner_pos = np.empty(3 * pt.shape[0], np.int64)
    corner_patch = np.empty(3 * pt.shape[0], np.int64)
    nk = 0
    for p in range(n):
        for j in range(pt_start[p], pt_start[p] + own_start[p + 1] - own_start[p]):
            for kk in range(3):
                corner_pos[nk] = vpos[tv[pt[j], kk]]
                corner_patch[nk] = p
                nk += 1
    pp_start, idx = K.group_by(corner_pos[:nk], P)
    pp = np.empty(nk, np.int64)
    for j in range(nk):  # corner_patch[idx] as a loop (numba's fancy indexing: compile time)
        pp[j] = corner_patch[idx[j]]
    cand_start = np.zeros(nab + 1, np.int64)
    # at most the patches listed at the three corners: sized once, the loop reassigns no array
    n_cand = np.int64(16)
    for i in range(nab):
        for r in range(3):
            w = vpos[tv[ab[i], r]]
            if not K.is_hub(pp_start, w):
                n_cand += pp_start[w + 1] - pp_start[w]
    cand = np.empty(n_cand, np.int64)
    nc = 0
    for i in range(nab):
        t = ab[i]
        first = nc
        for r in range(3):
            w = vpos[tv[t, r]]
            if K.is_hub(pp_start, w):
                continue
            for a in range(pp_start[w], pp_start[w + 1]):
                p = pp[a]
                dup = False
                for m in range(first, nc):
                    if cand[m] == p:
                        dup = True
                        break
                if not dup:
                    cand[nc] = p
                    nc += 1
        cand_start[i + 1] = nc
    # patch -> (absorbed triangle, candidate slot)
    pc_start, pc = K.group_by(cand[:nc], n)
    slot_tri = np.empty(nc, np.int64)
    for i in range(nab):
        for m in range(cand_start[i], cand_start[i + 1]):
            slot_tri[m] = i
    cost = np.zeros(nc, np.int64)
    no_skip = np.zeros(V, np.bool_)
    stamp_p = np.zeros(V, np.int64)
    ring_p = np.full(cache_size, -1, np.int64)
    stamp_q = np.zeros(V, np.int64)
    ring_q = np.full(cache_size, -1, np.int64)
    push_p = np.int64(0)
    push_q = np.int64(0)
    for o in range(order.shape[0]):
        p = order[o]
        own_end = pt_start[p] + own_start[p + 1] - own_start[p]
        for j in range(pt_start[p], own_end):
            push_p = _fifo_push(tv[pt[j]], no_skip, stamp_p, ring_p, push_p)
            push_q = _fifo_push(tv[pt[j]], binned_vertex, stamp_q, ring_q, push_q)
        for a in range(pc_start[p], pc_start[p + 1]):
            m = pc[a]
            verts = tv[ab[slot_tri[m]]]
            cost[m] = _fifo_misses(verts, no_skip, stamp_p, push_p, cache_size) + _fifo_misses(
                verts, no_skip, stamp_q, push_q, cache_size
            )
        for j in range(own_end, pt_start[p + 1]):
            push_p = _fifo_push(tv[pt[j]], no_skip, stamp_p, ring_p, push_p)
            push_q = _fifo_push(tv[pt[j]], no_skip, stamp_q, ring_q, push_q)
    size = np.empty(n, np.int64)  # np.diff(pt_start) as a loop (np.diff: see sw_collapse._grow_tris)
    for p in range(n):
        size[p] = pt_start[p + 1] - pt_start[p]
    newp = ab_cur.copy()
    for i in range(nab):
        cur_cost = -1
        for m in range(cand_start[i], cand_start[i + 1]):
            if cand[m] == ab_cur[i]:
                cur_cost = cost[m]
        best = -1
        for m in range(cand_start[i], cand_start[i + 1]):
            if cost[m] < cur_cost:
                if best < 0 or cost[m] < cost[best]:
                    best = m
        if best >= 0:
            size[ab_cur[i]] -= 1
            newp[i] = cand[best]
            size[cand[best]] += 1
    new_start = np.zeros(n + 1, np.int64)
    for p in range(n):
        new_start[p + 1] = new_start[p] + size[p]
    out = np.empty(new_start[n], np.int64)
    fill2 = np.empty(n, np.int64)
    for p in range(n):
        m = new_start[p]
        for j in range(pt_start[p], pt_start[p] + own_start[p + 1] - own_start[p]):
            out[m] = pt[j]
            m += 1
        fill2[p] = m
    for i in range(nab):
        p = newp[i]
        out[fill2[p]] = ab[i]
        fill2[p] += 1
    return new_start, out


@nb.njit(cache=True, nogil=True)
def ordered_patches(
    st: K.CollapseState,
    inner_start: np.ndarray,
    inner: np.ndarray,
    stars: K.Stars,
    alive_t: np.ndarray,
    min_shared: int,
    rounds: int,
    max_middle: float,
    vertex_count: int,
    cache_size: int,
    live_weight: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A fully stored level's patches of inner vertices ``inner_start`` / ``inner`` (positions) in cache
    order, as the builder's steps made them one call each (about 30 us of numpy and Python a level):
    their triangles (:func:`.sw_patches.patch_triangles`); if ``min_shared`` > 0 and the patches cover at
    least ``1 - max_middle`` of the level's ``alive_t``, the middle absorbed, ``rounds`` rounds or until
    none is taken (:func:`.sw_patches.absorb_middle`); the patch order (:func:`order_patches`); and the
    absorbed triangles moved where that order draws them best (:func:`reassign_middle`). Returns
    ``(pt_start, pt, order)``."""
    pt_start, pt = patch_triangles(st, inner_start, inner, stars)
    own_start = pt_start
    absorb = min_shared > 0 and alive_t.shape[0] - pt_start[-1] <= max_middle * alive_t.shape[0]
    if absorb:
        for _ in range(rounds):
            grown_start, grown = absorb_middle(st, pt_start, pt, alive_t, min_shared, stars)
            if grown.shape[0] == pt.shape[0]:
                break
            pt_start, pt = grown_start, grown
    # a vertex is binned by the level if its position is an inner one
    inner_pos = np.zeros(st.pos_points.shape[0], np.bool_)
    for i in range(inner.shape[0]):
        inner_pos[inner[i]] = True
    vpos = st.vertex_pos
    binned_vertex = np.empty(vpos.shape[0], np.bool_)
    for v in range(vpos.shape[0]):
        binned_vertex[v] = inner_pos[vpos[v]]
    n = inner_start.shape[0] - 1
    inner_count = np.empty(n, np.int64)
    for p in range(n):
        inner_count[p] = inner_start[p + 1] - inner_start[p]
    order = order_patches(
        pt_start, pt, st.tri_verts, binned_vertex, inner_count, vertex_count, cache_size, live_weight
    )
    if absorb:
        pt_start, pt = reassign_middle(st, own_start, pt_start, pt, order, binned_vertex, cache_size)
    return pt_start, pt, order
