"""Clustered and linked patches (``cluster=True``, SWPM section 3.2; with section 3.3 for several inner
vertices): a level that reuses the previous level's tail takes patch centres whose stars are pairwise
disjoint intervals of that tail, so the patches read their ``P`` blocks out of it.

* :func:`cluster_patches` - one inner position per patch, greedy by earliest end.
* :func:`cluster_components` - patches of up to ``inner_vertices`` adjacent inner positions.
* :func:`_cheapest_prefix` - how many of them a level keeps: the prefix that stores the fewest tail
  triangles per inner position (the rest of the tail is the next level's, for free).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..simplify import kernels as K


@nb.njit(cache=True, nogil=True)
def _tail_intervals(
    st: K.CollapseState, cands: np.ndarray, tpos: np.ndarray, rank: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`cluster_patches` / :func:`cluster_components`: each candidate's star as the interval
    ``[lo, hi]`` of tail places (``hi`` = ``1 << 62`` if the star leaves the tail or is empty), and the
    candidates (indices into ``cands``) by earliest end, ties: the later start, then the lower ``rank``."""
    n = cands.shape[0]
    big = np.int64(1) << 62
    lo = np.empty(n, np.int64)
    hi = np.empty(n, np.int64)
    for i in range(n):
        tris = K.gather_triangles(st, cands[i])
        a = big
        b = np.int64(-1)
        for j in range(tris.shape[0]):
            p = tpos[tris[j]]
            if p < 0:
                b = big  # not in the tail: never an inner position
            a = min(a, p)
            b = max(b, p)
        if tris.shape[0] == 0:
            b = big
        lo[i] = a
        hi[i] = b
    by_rank = np.argsort(rank, kind="mergesort")
    span = np.int64(tpos.shape[0] + 1)
    key = np.empty(n, np.int64)
    for r in range(n):
        i = by_rank[r]
        key[r] = min(hi[i], span) * span + (span - 1 - min(lo[i], span - 1))
    return lo, hi, by_rank[np.argsort(key, kind="mergesort")]


@nb.njit(cache=True, nogil=True)
def _cheapest_prefix(pick_hi: np.ndarray, start: np.ndarray, m: int, min_picks: int) -> int:
    """The number ``r >= min_picks`` of the ``m`` greedy patches (ends ``pick_hi``, ``start[r]`` inner
    positions in the first ``r``) that minimises ``(end of the r-th patch + 1) / start[r]`` (all ``m`` if
    there are fewer than ``min_picks``): the run read so far is stored again as the ``Q`` blocks and the
    untouched triangles in it; what follows the last patch stays for the next level, for free."""
    best_m = m
    best_ratio = np.inf
    for r in range(min_picks - 1, m):
        ratio = (pick_hi[r] + 1.0) / start[r + 1]
        if ratio < best_ratio:
            best_ratio = ratio
            best_m = r + 1
    return min(m, best_m)


@nb.njit(cache=True, nogil=True)
def cluster_patches(
    st: K.CollapseState, cands: np.ndarray, tpos: np.ndarray, rank: np.ndarray, min_picks: int
) -> tuple[np.ndarray, np.ndarray]:
    """Clustered / linked patch centres of a level that reuses the previous level's tail (SWPM 3.2).

    ``tpos[t]`` is the place of state triangle ``t`` in that tail (the fixed order in which the level's
    starting mesh is stored). A centre's patch (its star) then spans the interval ``[lo, hi]`` of places,
    and the patches, drawn in tail order, can read their ``P`` blocks out of the tail only if their
    intervals do not overlap. So the centres are a maximum set of pairwise disjoint intervals (greedy by
    earliest end; ties: the later start, then the lower ``rank``). Disjoint intervals mean triangle-disjoint
    stars, hence non-adjacent centres: the independent-set condition of the plain builder holds. The
    level then keeps the first ``r >= min_picks`` of them that minimise ``(end of the r-th interval + 1) / r``
    (the tail up to there is stored again, as new or unchanged ``Q`` triangles; the rest is left to the
    next level for free). Returns the CSR ``(inner_start, inner)`` (one inner position per patch) in tail
    order."""
    n = cands.shape[0]
    lo, hi, order = _tail_intervals(st, cands, tpos, rank)
    inner = np.empty(n, np.int64)
    pick_hi = np.empty(n, np.int64)
    m = np.int64(0)  # (not a literal 0: it reached _cheapest_prefix as one, a second compile)
    last = np.int64(-1)
    for r in range(n):
        i = order[r]
        if hi[i] >= (np.int64(1) << 62):
            continue
        if lo[i] > last:
            inner[m] = cands[i]
            pick_hi[m] = hi[i]
            m += 1
            last = hi[i]
    inner_start = np.arange(m + 1).astype(np.int64)  # one inner position per patch
    m = _cheapest_prefix(pick_hi, inner_start, m, min_picks)
    return inner_start[: m + 1].copy(), inner[:m].copy()


@nb.njit(cache=True, nogil=True)
def cluster_components(
    st: K.CollapseState,
    cands: np.ndarray,
    tpos: np.ndarray,
    rank: np.ndarray,
    min_picks: int,
    adj_start: np.ndarray,
    adj: np.ndarray,
    inner_vertices: int,
    reach: int,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`cluster_patches` for patches of up to ``inner_vertices`` adjacent inner positions (SWPM 3.2
    with 3.3, the papers' case (d)). A patch spans the interval of tail places of the union of its inner
    positions' stars; the patches' intervals are pairwise disjoint (so the patches share no triangle, and no
    inner position of one is next to one of another: an edge lies on a triangle of both stars). Greedy by
    earliest end as :func:`cluster_patches`: the candidate of earliest star end not overlapping the last
    patch starts a patch, which then takes, one at a time, the neighbour (``adj_start``, ``adj``: the
    position graph) of its inner positions whose star starts after the last patch and ends earliest, while
    that moves the patch's end by at most ``reach`` places (0: only stars within the patch's interval). The
    level keeps the first ``r >= min_picks`` patches that minimise ``(end of the r-th patch + 1) / (inner
    positions of the first r)``. Returns the CSR ``(inner_start, inner)`` in tail order."""
    n = cands.shape[0]
    big = np.int64(1) << 62
    lo, hi, order = _tail_intervals(st, cands, tpos, rank)
    idx = np.full(adj_start.shape[0] - 1, -1, np.int64)  # candidate index of a position
    idx[cands] = np.arange(n)
    used = np.zeros(n, np.bool_)
    inner = np.empty(n, np.int64)
    start = np.zeros(n + 1, np.int64)
    pick_hi = np.empty(n, np.int64)
    m = np.int64(0)
    q = 0
    last = np.int64(-1)
    for r in range(n):
        i = order[r]
        if used[i] or hi[i] >= big or lo[i] <= last:
            continue
        used[i] = True
        inner[q] = cands[i]
        q += 1
        cnt = 1
        end = hi[i]
        while cnt < inner_vertices:
            best = np.int64(-1)
            best_end = big
            for s in range(q - cnt, q):
                v = inner[s]
                for e in range(adj_start[v], adj_start[v + 1]):
                    j = idx[adj[e]]
                    if j < 0 or used[j] or hi[j] >= big or lo[j] <= last:
                        continue
                    h = max(hi[j], end)
                    if h < best_end or (h == best_end and rank[j] < rank[best]):
                        best = j
                        best_end = h
            if best < 0 or best_end - end > reach:
                break
            used[best] = True
            inner[q] = cands[best]
            q += 1
            cnt += 1
            end = best_end
        pick_hi[m] = end
        m += 1
        start[m] = q
        last = end
    m = _cheapest_prefix(pick_hi, start, m, min_picks)
    return start[: m + 1].copy(), inner[: start[m]].copy()
