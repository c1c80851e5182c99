"""A topology-driven level's positions, their edge graph and their error ranking (TD-VIPM section 3.1 with
SWPM section 3's ``mu``).

* :func:`level_positions` - the positions of the level's triangles and those in use.
* :func:`position_graph` - their edge graph (CSR over positions), of which the patch centres
  (:mod:`.sw_centres`) are an independent set.
* :func:`level_costs` - the best valid collapse of every position and its quadric cost: the error ranking
  behind ``mu`` (with :mod:`.sw_deviation`'s distance of the collapse's new fan from the input).
* :func:`ties_by_index`, :func:`rank_centres` - that ranking in one pass: the fraction ``mu`` of the
  costliest positions may not be centres (SWPM 3, "the factor of error control"), the others get a
  tiebreak by their place in it.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..simplify import kernels as K


@nb.njit(cache=True, nogil=True)
def level_positions(
    alive_t: np.ndarray, tri_verts: np.ndarray, vertex_pos: np.ndarray, P: int
) -> tuple[np.ndarray, np.ndarray]:
    """``(tp, positions)`` of a level: the positions of the triangles ``alive_t`` (``(n, 3)``, the dtype of
    ``vertex_pos``) and the positions they use, increasing (as ``vertex_pos[tri_verts[alive_t]]`` and
    ``np.flatnonzero(np.bincount(tp.ravel(), minlength=P))``, in one pass: numpy's fancy indexing cost
    ~0.2 ms per level on cow)."""
    n = alive_t.shape[0]
    tp = np.empty((n, 3), vertex_pos.dtype)
    used = np.zeros(P, np.bool_)
    for j in range(n):
        for i in range(3):
            q = vertex_pos[tri_verts[alive_t[j], i]]
            tp[j, i] = q
            used[q] = True
    m = 0
    for q in range(P):
        if used[q]:
            m += 1
    positions = np.empty(m, np.int64)
    m = 0
    for q in range(P):
        if used[q]:
            positions[m] = q
            m += 1
    return tp, positions


@nb.njit(cache=True, nogil=True)
def ties_by_index(keys: np.ndarray, order: np.ndarray) -> np.ndarray:
    """``order`` (an argsort of ``keys``, any tie order) with every run of equal keys in increasing index
    order, in place: ``np.argsort(keys, kind="stable")`` from the default sort (numpy's stable argsort took
    ~0.2 ms on cow's 2,900 costs, its quicksort ~0.05). NaNs count as equal to each other. The runs are
    refilled by a counting pass over the indices in increasing order (no np.sort and slice assignment:
    numba's sort and broadcast code took ~6 s of a cold build's compile time)."""
    n = order.shape[0]
    run = np.empty(n, np.int64)  # first slot of every index's run
    fill = np.empty(n, np.int64)  # next free slot of the run starting there
    i = 0
    while i < n:
        a = keys[order[i]]
        j = i + 1
        while j < n:
            b = keys[order[j]]
            if not (a == b or (a != a and b != b)):
                break
            j += 1
        for r in range(i, j):
            run[order[r]] = i
        fill[i] = i
        i = j
    for x in range(n):
        s = run[x]
        order[fill[s]] = x
        fill[s] += 1
    return order


@nb.njit(cache=True, nogil=True)
def rank_centres(
    positions: np.ndarray,
    ks: np.ndarray,
    cs: np.ndarray,
    order: np.ndarray,
    P: int,
    n_excl: int,
    weight: float,
) -> tuple[np.ndarray, np.ndarray, float, bool]:
    """A level's ranking of its patch centres in one pass (about 20 numpy calls a level before, ~50 us on
    suzanne's small levels): ``positions`` with a valid collapse (``ks >= 0``) are eligible, each with the
    tiebreak ``weight * j / m`` of its place ``j`` among the ``m`` valid ones in ``order`` (their stable
    order by rank cost); the last ``min(n_excl, m)`` of that order are not eligible, and the largest
    quadric cost ``cs`` of the others is the level's cost cut (inf if none is excluded, 0 if none is
    left; NaN propagates as in ``np.max``). Returns ``(eligible, tiebreak, cut, any eligible)``."""
    n = positions.shape[0]
    eligible = np.zeros(P, np.bool_)
    tiebreak = np.zeros(P)
    idx = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        if ks[i] >= 0:
            idx[m] = i
            m += 1
            eligible[positions[i]] = True
    n_excl = max(0, min(n_excl, m))  # (a negative count excludes none: any eligible iff m > 0)
    cut = np.inf
    for j in range(m):
        tiebreak[positions[idx[order[j]]]] = weight * j / m
    if m > 0 and n_excl > 0:
        for j in range(m - n_excl, m):
            eligible[positions[idx[order[j]]]] = False
        cut = -np.inf if m > n_excl else 0.0
        for j in range(m - n_excl):
            c = cs[idx[order[j]]]
            if c != c:
                cut = c
                break
            cut = max(cut, c)
    return eligible, tiebreak, cut, m > n_excl


@nb.njit(cache=True, nogil=True)
def position_graph(tp: np.ndarray, P: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR ``(start, nbr)`` of the edge graph of the triangles ``tp`` (positions; each neighbour once, in
    increasing order)."""
    cnt = np.zeros(P + 1, np.int64)
    for t in range(tp.shape[0]):
        for i in range(3):
            cnt[tp[t, i] + 1] += 2
    raw_start = np.cumsum(cnt)
    fill = raw_start[:-1].copy()
    raw = np.empty(raw_start[P], np.int64)
    for t in range(tp.shape[0]):
        for i in range(3):
            a = tp[t, i]
            raw[fill[a]] = tp[t, (i + 1) % 3]
            raw[fill[a] + 1] = tp[t, (i + 2) % 3]
            fill[a] += 2
    start = np.zeros(P + 1, np.int64)
    nbr = np.empty(raw_start[P], np.int64)
    mark = np.full(P, -1, np.int64)
    m = 0
    for a in range(P):
        first = m
        hub = raw_start[a + 1] - raw_start[a] > 2 * K.HUB_SIZE
        for j in range(raw_start[a], raw_start[a + 1]):
            b = raw[j]
            if mark[b] != a:
                mark[b] = a
                # insertion into the sorted run (a hub's run is sorted at the end: quadratic otherwise)
                k = m
                while not hub and k > first and nbr[k - 1] > b:
                    nbr[k] = nbr[k - 1]
                    k -= 1
                nbr[k] = b
                m += 1
        if hub:
            nbr[first:m].sort()
        start[a + 1] = m
    return start, nbr[:m].copy()


@nb.njit(cache=True, nogil=True)
def level_costs(st: K.CollapseState, positions: np.ndarray, stars: K.Stars) -> tuple[np.ndarray, np.ndarray]:
    """Best valid collapse target and its quadric cost for every position of ``positions`` (``stars``: a
    snapshot of ``st``, :func:`swpm_usd.simplify.kernels.star_snapshot`)."""
    n = positions.shape[0]
    ks = np.empty(n, np.int32)
    cs = np.empty(n, np.float64)
    maxd = 1
    for p in range(stars.nbr_start.shape[0] - 1):
        maxd = max(maxd, stars.nbr_start[p + 1] - stars.nbr_start[p])
    costs = np.empty(maxd)  # one buffer for every star's costs
    # K.best_of_star written out on the state's arrays and the snapshot's rows, read once here: the
    # namedtuple field reads and star slices per position and per test cost most of the time in numba's
    # reference counting
    locked = st.pos_locked
    alive = st.pos_alive
    boundary = st.pos_boundary
    pts = st.pos_points
    quadric = st.quadric
    qw = st.quadric_weight
    min_area2 = st.min_area2[0]
    tv = st.tri_verts
    pv = st.pos_verts
    vstart = st.pos_vstart
    s_start = stars.start
    s_tris = stars.tris
    s_tp = stars.tp
    s_nstart = stars.nbr_start
    s_nbr = stars.nbr
    for i in range(n):
        b = positions[i]
        s0 = s_start[b]
        s1 = s_start[b + 1]
        ks[i] = -1
        cs[i] = np.inf
        if locked[b] & K.LOCK_FIXED or not alive[b] or s0 == s1:  # as best_collapse
            continue
        n0 = s_nstart[b]
        n1 = s_nstart[b + 1]
        nn = n1 - n0
        best = 0
        for j in range(nn):
            costs[j] = K._cost_of(pts, quadric, qw, b, s_nbr[n0 + j])
            if costs[j] < costs[best]:
                best = j
        k = np.int64(s_nbr[n0 + best])  # one specialisation of the helpers (int64 positions)
        if K.valid_collapse_in(
            alive, locked, boundary, pts, min_area2, tv, pv, vstart, b, k, s_tris, s_tp, s0, s1,
            s_nbr, n0, n1, s_tp, s_start[k], s_start[k + 1], s_nbr, s_nstart[k], s_nstart[k + 1],
        ):  # fmt: skip
            ks[i] = k
            cs[i] = costs[best]
            continue
        order = np.argsort(costs[:nn])
        for r in range(1, min(nn, K.MAX_TARGET_TRIES)):
            k = np.int64(s_nbr[n0 + order[r]])
            if K.valid_collapse_in(
                alive, locked, boundary, pts, min_area2, tv, pv, vstart, b, k, s_tris, s_tp, s0, s1,
                s_nbr, n0, n1, s_tp, s_start[k], s_start[k + 1], s_nbr, s_nstart[k], s_nstart[k + 1],
            ):  # fmt: skip
                ks[i] = k
                cs[i] = costs[order[r]]
                break
    return ks, cs
