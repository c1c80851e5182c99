"""Which positions become patch centres: independent sets on a level's position graph (CSR
``adj_start``/``adj``, see :func:`.sw_levels.position_graph`) for the topology builder of
:mod:`.slidingwindow`.

A patch is the star of its inner vertices; two patches may share vertices but no triangle, so inner
vertices of different patches are never neighbours. With one inner vertex per patch the centres are an
independent set, and the pool shrinks as the set grows (TD-VIPM section 3.1, SWPM appendix).

* :func:`select_patches` - greedy minimum-degree independent set (TD-VIPM 3.1, SWPM 3.2's greedy search),
  optionally grown to several inner vertices per patch (SWPM 3.3).
* :func:`grow_independent_set` - more centres by iterated local search ((1,2)-swaps, forced insertions).
* :func:`lower_error_centres` - 1-for-1 swaps of centres for cheaper neighbours.
* :func:`lower_costly_centres` - exchanges that take centres off the top of the error ranking.
* :func:`merge_patches` - several inner vertices by merging two levels (SWPM 3.3 via clustering).
* :func:`grow_component_set` - several inner vertices by large-neighbourhood search.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..simplify import kernels as K


@nb.njit(cache=True, nogil=True)
def _grow_i64(a: np.ndarray, n: int) -> np.ndarray:
    if n < a.shape[0]:
        return a
    b = np.empty(max(2 * a.shape[0], n + 16), a.dtype)
    for i in range(a.shape[0]):  # a loop, not b[: len(a)] = a: see sw_collapse._grow_tris
        b[i] = a[i]
    return b


@nb.njit(cache=True, nogil=True)
def _mark_inner(
    x: int,
    p: int,
    adj_start: np.ndarray,
    adj: np.ndarray,
    deleted: np.ndarray,
    owner: np.ndarray,
    degree: np.ndarray,
    tiebreak: np.ndarray,
    eligible: np.ndarray,
    hk: np.ndarray,
    hi: np.ndarray,
    hs: np.ndarray,
    size: int,
    stamp: np.ndarray,
):
    """Make ``x`` an inner vertex of patch ``p``: colour it and its free neighbours (SWPM's greedy search:
    "delete it and its neighbours by marking them and decrementing the degrees of their neighbours")."""
    deleted[x] = True
    owner[x] = p
    for a in range(adj_start[x], adj_start[x + 1]):
        y = adj[a]
        if not deleted[y]:
            deleted[y] = True
            owner[y] = p
            for b in range(adj_start[y], adj_start[y + 1]):
                z = adj[b]
                if not deleted[z]:
                    degree[z] -= 1
                    if eligible[z]:
                        stamp[z] += 1
                        size = K._heap_push_into(hk, hi, hs, size, degree[z] + tiebreak[z], z, stamp[z])
        elif owner[y] != p and owner[y] >= 0:
            owner[y] = -2  # ring vertex of two patches: may never join either
    return size


@nb.njit(cache=True, nogil=True)
def select_patches(
    adj_start: np.ndarray, adj: np.ndarray, eligible: np.ndarray, tiebreak: np.ndarray, inner_max: int
) -> tuple[np.ndarray, np.ndarray]:
    """Greedy patch cover on the position graph (CSR ``adj_start``/``adj``).

    Vertices that are not ``eligible`` (locked, no valid collapse, or among the ``mu`` highest-error ones)
    are deleted first. Then, while eligible vertices remain, the one of lowest remaining degree plus
    ``tiebreak`` (an error rank) seeds a patch; with ``inner_max > 1`` the patch grows by eligible neighbours
    that touch no other patch (each the one that colours fewest new vertices). Returns the CSR
    ``(inner_start, inner)`` of every patch's inner positions, in selection order.
    """
    P = eligible.shape[0]
    deleted = np.empty(P, np.bool_)
    owner = np.full(P, -1, np.int64)
    degree = np.zeros(P, np.float64)
    stamp = np.zeros(P, np.int64)
    for x in range(P):
        deleted[x] = not eligible[x]
        if deleted[x]:
            owner[x] = -3
    for x in range(P):
        if deleted[x]:
            continue
        d = 0
        for a in range(adj_start[x], adj_start[x + 1]):
            if not deleted[adj[a]]:
                d += 1
        degree[x] = d
    # room for every push: one per position, then one per degree decrement. A decrement comes from the
    # first of an edge's two ends to be deleted (the other end is then still live), so there is at most one
    # per undirected edge: half of ``adj``, which lists every edge both ways
    cap = 16 + P + adj.shape[0] // 2
    hk = np.empty(cap, np.float64)
    hi = np.empty(cap, np.int64)
    hs = np.empty(cap, np.int64)
    size = np.int64(0)
    for x in range(P):
        if not deleted[x]:
            size = K._heap_push_into(hk, hi, hs, size, degree[x] + tiebreak[x], x, stamp[x])
    inner = np.empty(P, np.int64)
    inner_start = np.zeros(P + 1, np.int64)
    is_inner = np.zeros(P, np.bool_)
    n_inner = np.int64(0)
    n_patch = np.int64(0)
    while size > 0:
        _, x, s, size = K._heap_pop(hk, hi, hs, size)
        if deleted[x] or s != stamp[x]:
            continue
        p = n_patch
        first = n_inner
        inner[n_inner] = x
        n_inner += 1
        is_inner[x] = True
        size = _mark_inner(
            x, p, adj_start, adj, deleted, owner, degree, tiebreak, eligible, hk, hi, hs, size, stamp
        )
        for _ in range(1, inner_max):
            best = np.int64(-1)
            best_key = np.inf
            for r in range(first, n_inner):
                u = inner[r]
                for a in range(adj_start[u], adj_start[u + 1]):
                    y = adj[a]
                    if is_inner[y] or owner[y] != p or not eligible[y]:
                        continue
                    c = 0
                    for b in range(adj_start[y], adj_start[y + 1]):
                        if not deleted[adj[b]]:
                            c += 1
                    key = c + tiebreak[y]
                    if key < best_key:
                        best_key = key
                        best = y
            if best < 0:
                break
            inner[n_inner] = best
            n_inner += 1
            is_inner[best] = True
            size = _mark_inner(
                best, p, adj_start, adj, deleted, owner, degree, tiebreak, eligible, hk, hi, hs, size, stamp
            )
        n_patch += 1
        inner_start[n_patch] = n_inner
    return inner_start[: n_patch + 1].copy(), inner[:n_inner].copy()


@nb.njit(cache=True, nogil=True)
def lower_error_centres(
    adj_start: np.ndarray, adj: np.ndarray, eligible: np.ndarray, centres: np.ndarray, rank: np.ndarray
) -> np.ndarray:
    """Centres of the independent set traded for cheaper neighbours, the set's size kept or grown (the
    pool does not grow). Highest ``rank`` (error) first: a centre gives way to the lowest-ranked eligible
    neighbour whose only centre neighbour it is (a 1-for-1 swap keeps the set independent), and
    neighbours that no centre covers any more join. The minimum-degree greedy picks 28-31 % of the
    vertices and has to take some with an error just under the ``mu`` cut; this moves them off the
    costliest ones (the 10 shared meshes at 50/25/10 % of the triangles, 20,000 samples, with / without in
    one run: Hausdorff error ratio 0.92 as a geometric mean, RMS error 0.99, lambda unchanged; single LODs
    move either way). Returns the new centres (sorted)."""
    P = eligible.shape[0]
    sol = np.zeros(P, np.bool_)
    tight = np.zeros(P, np.int64)  # centre neighbours of every vertex
    for c in centres:
        sol[c] = True
    for x in range(P):
        if sol[x]:
            for a in range(adj_start[x], adj_start[x + 1]):
                tight[adj[a]] += 1
    order = np.argsort(-rank[centres])
    for oi in range(order.shape[0]):
        c = centres[order[oi]]
        best = -1
        best_rank = rank[c]
        for a in range(adj_start[c], adj_start[c + 1]):
            u = adj[a]
            if eligible[u] and not sol[u] and tight[u] == 1 and rank[u] < best_rank:
                best_rank = rank[u]
                best = u
        if best < 0:
            continue
        sol[c] = False
        for a in range(adj_start[c], adj_start[c + 1]):
            tight[adj[a]] -= 1
        sol[best] = True
        for a in range(adj_start[best], adj_start[best + 1]):
            tight[adj[a]] += 1
        for a in range(adj_start[c], adj_start[c + 1]):
            z = adj[a]
            if eligible[z] and not sol[z] and tight[z] == 0:
                sol[z] = True
                for b in range(adj_start[z], adj_start[z + 1]):
                    tight[adj[b]] += 1
    return np.flatnonzero(sol).astype(np.int64)


# ----------------------------------------------------------------------------------------------------
# larger independent sets: iterated local search (Andrade, Resende & Werneck, "Fast local search for the
# maximum independent set problem", 2012): (1,2)-swaps plus random forced insertions
# ----------------------------------------------------------------------------------------------------
# ``log`` is sized by the caller for every entry it can take: returning the array (to grow it) from the
# search loops' helpers would cost numba's reference counting on every call (see
# :func:`swpm_usd.simplify.kernels._heap_push_into`). Inlined: called, the helpers incref and decref their
# four array arguments on every call (numba does not prune them here; grow_independent_set and
# lower_costly_centres about -8 % on cow)
@nb.njit(cache=True, inline="always")
def _set_insert(v, sol, tight, adj_start, adj, log, nlog):
    if nlog >= log.shape[0]:  # numba checks no bounds: a wrong capacity must not write past ``log``
        raise IndexError("set log capacity exceeded")
    sol[v] = True
    for a in range(adj_start[v], adj_start[v + 1]):
        tight[adj[a]] += 1
    log[nlog] = v
    return nlog + 1


@nb.njit(cache=True, inline="always")
def _set_remove(v, sol, tight, adj_start, adj, log, nlog):
    if nlog >= log.shape[0]:  # numba checks no bounds: a wrong capacity must not write past ``log``
        raise IndexError("set log capacity exceeded")
    sol[v] = False
    for a in range(adj_start[v], adj_start[v + 1]):
        tight[adj[a]] -= 1
    log[nlog] = -v - 1
    return nlog + 1


@nb.njit(cache=True, nogil=True)
def _undo(log, nlog, sol, tight, adj_start, adj):
    """Take back the last ``nlog`` insertions (``+v``) and removals (``-v-1``) of ``log``."""
    for r in range(nlog - 1, -1, -1):
        v = log[r]
        if v >= 0:
            sol[v] = False
            for a in range(adj_start[v], adj_start[v + 1]):
                tight[adj[a]] -= 1
        else:
            sol[-v - 1] = True
            for a in range(adj_start[-v - 1], adj_start[-v]):
                tight[adj[a]] += 1


@nb.njit(cache=True, nogil=True)
def _xorshift_seed(seed: int) -> np.uint64:
    return np.uint64(seed) * np.uint64(0x9E3779B97F4A7C15) | np.uint64(1)  # xorshift64 state, never 0


@nb.njit(cache=True, nogil=True)
def _xorshift(rng):
    rng ^= rng << np.uint64(13)
    rng ^= rng >> np.uint64(7)
    rng ^= rng << np.uint64(17)
    return rng


@nb.njit(cache=True, inline="always")
def _queue_near(v, sol, tight, adj_start, adj, queue, nq, queued):
    """Queue the set members next to ``v`` or owning a 1-tight neighbour of ``v``: the only ones whose
    (1,2)-swaps a change at ``v`` can create. Inlined, as the helpers above (grow_independent_set -5 %: 113
    captured calls of seven meshes, 51.7-53.2 -> 49.5 ms, two alternating runs; inlining _undo and
    _xorshift as well gained nothing more)."""
    for a in range(adj_start[v], adj_start[v + 1]):
        y = adj[a]
        if sol[y]:
            if not queued[y]:
                queued[y] = True
                queue[nq] = y
                nq += 1
        elif tight[y] == 1:
            for b in range(adj_start[y], adj_start[y + 1]):
                z = adj[b]
                if sol[z] and not queued[z]:
                    queued[z] = True
                    queue[nq] = z
                    nq += 1
    return nq


@nb.njit(cache=True, nogil=True)
def grow_independent_set(
    adj_start: np.ndarray,
    adj: np.ndarray,
    eligible: np.ndarray,
    centres: np.ndarray,
    iterations: int,
    seed: int,
) -> np.ndarray:
    """A larger independent set of ``eligible`` vertices, starting from ``centres`` (independent).

    Local search: a member ``x`` with two non-adjacent neighbours whose only member neighbour is ``x``
    leaves for both (a (1,2)-swap), and neighbours left free join. Each of ``iterations`` then forces a
    random non-member in (its member neighbours leave), runs the local search around it and keeps the
    result unless the set got smaller (equal sizes are kept: a walk over the plateau). Every patch centre
    removes two triangles, so the pool shrinks with the set: bunny's first three levels, 9847 / 7761 /
    5182 centres by the minimum-degree greedy, 10138 / 7941 / 5330 with 3 iterations per vertex (an exact
    solver reaches 7952 on the second level). Deterministic for a ``seed``. Returns the set (sorted)."""
    rng = _xorshift_seed(seed)
    P = eligible.shape[0]
    sol = np.zeros(P, np.bool_)
    tight = np.zeros(P, np.int64)  # members among each vertex's neighbours
    # +v inserted, -v-1 removed since the last kept state. Between two resets the forced insertion removes
    # at most P members, every other removal is a (1,2)-swap's that grows the set (at most P of them), and
    # insertions exceed removals by at most P (the set's size): at most P + 2 * 2P entries
    log = np.empty(5 * P + 64, np.int64)
    for c in centres:
        _set_insert(c, sol, tight, adj_start, adj, log, np.int64(0))
    nlog = np.int64(0)
    queue = np.empty(4 * P + 64, np.int64)
    queued = np.zeros(P, np.bool_)
    mark = np.zeros(P, np.int64)
    removed_at = np.full(P, -1, np.int64)  # the iteration whose forced insertion removed the vertex
    stamp = 0
    ones = np.empty(64, np.int64)
    size = centres.shape[0]
    best = size
    pool = np.flatnonzero(eligible)
    nq = 0
    for c in centres:
        queued[c] = True
        queue[nq] = c
        nq += 1
    it = 0
    while True:
        head = 0
        while head < nq:
            x = queue[head]
            head += 1
            queued[x] = False
            if not sol[x]:
                continue
            n1 = 0
            for a in range(adj_start[x], adj_start[x + 1]):
                u = adj[a]
                if eligible[u] and not sol[u] and tight[u] == 1 and n1 < ones.shape[0]:
                    ones[n1] = u
                    n1 += 1
            fu = -1
            fw = -1
            for i in range(n1 - 1):
                stamp += 1
                for b in range(adj_start[ones[i]], adj_start[ones[i] + 1]):
                    mark[adj[b]] = stamp
                for j in range(i + 1, n1):
                    if mark[ones[j]] != stamp:
                        fu = ones[i]
                        fw = ones[j]
                        break
                if fu >= 0:
                    break
            if fu < 0:
                continue
            nlog = _set_remove(x, sol, tight, adj_start, adj, log, nlog)
            nlog = _set_insert(fu, sol, tight, adj_start, adj, log, nlog)
            nlog = _set_insert(fw, sol, tight, adj_start, adj, log, nlog)
            size += 1
            for i in range(n1):
                z = ones[i]
                if not sol[z] and tight[z] == 0:
                    nlog = _set_insert(z, sol, tight, adj_start, adj, log, nlog)
                    size += 1
            if nq + P >= queue.shape[0]:  # at most P vertices are queued at once
                nq -= head
                for i in range(nq):  # forward, so no overlap (a loop: see sw_collapse._grow_tris)
                    queue[i] = queue[head + i]
                head = 0
            nq = _queue_near(x, sol, tight, adj_start, adj, queue, nq, queued)
        nq = 0
        if size >= best:
            best = size
        else:  # undo back to the last kept state
            _undo(log, nlog, sol, tight, adj_start, adj)
            size = best
        nlog = np.int64(0)
        if it >= iterations or pool.shape[0] == 0:
            break
        it += 1
        v = -1
        for _ in range(64):
            rng = _xorshift(rng)
            c = pool[np.int64(rng % np.uint64(pool.shape[0]))]
            if not sol[c]:
                v = c
                break
        if v < 0:
            continue
        for a in range(adj_start[v], adj_start[v + 1]):
            if sol[adj[a]]:
                nlog = _set_remove(adj[a], sol, tight, adj_start, adj, log, nlog)
                size -= 1
                removed_at[adj[a]] = it
        nlog = _set_insert(v, sol, tight, adj_start, adj, log, nlog)
        size += 1
        for a in range(adj_start[v], adj_start[v + 1]):
            y = adj[a]
            if K.is_hub(adj_start, y) and removed_at[y] != it:
                # a hub's neighbours are all over the mesh (a cone's apex): linear per iteration. Only a hub
                # that just left the set can have left them free
                continue
            for b in range(adj_start[y], adj_start[y + 1]):
                z = adj[b]
                if eligible[z] and not sol[z] and tight[z] == 0:
                    nlog = _set_insert(z, sol, tight, adj_start, adj, log, nlog)
                    size += 1
        queued[v] = True
        queue[nq] = v
        nq += 1
        nq = _queue_near(v, sol, tight, adj_start, adj, queue, nq, queued)
        for a in range(adj_start[v], adj_start[v + 1]):
            if not K.is_hub(adj_start, adj[a]):  # (as above)
                nq = _queue_near(adj[a], sol, tight, adj_start, adj, queue, nq, queued)
    return np.flatnonzero(sol).astype(np.int64)


@nb.njit(cache=True, nogil=True)
def _sort_by(keys: np.ndarray, items: np.ndarray, n: int) -> None:
    """Insertion sort of ``items[:n]`` by ``keys[item]`` (a handful of items)."""
    for i in range(1, n):
        x = items[i]
        k = keys[x]
        j = i - 1
        while j >= 0 and keys[items[j]] > k:
            items[j + 1] = items[j]
            j -= 1
        items[j + 1] = x


@nb.njit(cache=True, nogil=True)
def lower_costly_centres(
    adj_start: np.ndarray,
    adj: np.ndarray,
    eligible: np.ndarray,
    centres: np.ndarray,
    rank: np.ndarray,
    power: float,
    tries: int,
    passes: int,
    min_rank: float = 0.0,
) -> np.ndarray:
    """Centres of the independent set traded for cheaper ones around them, the set's size kept or grown.

    The Hausdorff error of a level's LODs comes from its few costliest collapses, so the search lowers the
    penalty ``sum(rank ** power)`` over the centres (``rank``: error rank in [0, 1]; a high ``power``
    weighs the top of the ranking): costliest centre first (those ranked ``min_rank`` or more), one of its
    ``tries`` cheapest eligible non-member neighbours ``u`` is forced in (its member neighbours leave: a
    (1,1)-exchange, or a (2,2)- or (3,3)-exchange when ``u`` touched more), then the vertices around that no
    member covers any more join, cheapest first. The move stays if the set did not shrink and the penalty
    dropped, else it is undone. ``passes`` rounds over the centres. Returns the new centres (sorted)."""
    P = eligible.shape[0]
    # read for members and eligible vertices only: the others' pow is skipped (one per position and level;
    # most positions of a later level are gone)
    pen = np.zeros(P)
    for x in range(P):
        if eligible[x]:
            pen[x] = rank[x] ** power
    for c in centres:
        pen[c] = rank[c] ** power
    sol = np.zeros(P, np.bool_)
    tight = np.zeros(P, np.int64)
    cand = np.empty(64, np.int64)
    free = np.empty(256, np.int64)
    # one move's removals are distinct vertices (at most P), its insertions ``u`` and members of ``free``
    log = np.empty(P + free.shape[0] + 1, np.int64)
    for c in centres:
        _set_insert(c, sol, tight, adj_start, adj, log, np.int64(0))
    for _ in range(passes):
        members = np.flatnonzero(sol & (rank >= min_rank))
        order = members[np.argsort(-rank[members])]
        moved = 0
        for oi in range(order.shape[0]):
            c = order[oi]
            if not sol[c]:
                continue
            nc = np.int64(0)
            for a in range(adj_start[c], adj_start[c + 1]):
                u = adj[a]
                # not a hub: forced in, it would push out hundreds of members (linear per try)
                if K.is_hub(adj_start, u):
                    continue
                if eligible[u] and not sol[u] and rank[u] < rank[c] and nc < cand.shape[0]:
                    cand[nc] = u
                    nc += 1
            _sort_by(rank, cand, nc)
            for t in range(min(tries, nc)):
                u = cand[t]
                if sol[u] or not sol[c]:
                    break
                nlog = np.int64(0)
                dsize = 0
                dpen = 0.0
                nf = np.int64(0)
                for a in range(adj_start[u], adj_start[u + 1]):
                    y = adj[a]
                    if sol[y]:
                        nlog = _set_remove(y, sol, tight, adj_start, adj, log, nlog)
                        dsize -= 1
                        dpen -= pen[y]
                        for b in range(adj_start[y], adj_start[y + 1]):
                            z = adj[b]
                            if nf < free.shape[0] and eligible[z] and z != u:
                                free[nf] = z
                                nf += 1
                nlog = _set_insert(u, sol, tight, adj_start, adj, log, nlog)
                dsize += 1
                dpen += pen[u]
                _sort_by(rank, free, nf)
                for i in range(nf):
                    z = free[i]
                    if not sol[z] and tight[z] == 0:
                        nlog = _set_insert(z, sol, tight, adj_start, adj, log, nlog)
                        dsize += 1
                        dpen += pen[z]
                if dsize >= 0 and dpen < -1e-12:
                    moved += 1
                    break
                _undo(log, nlog, sol, tight, adj_start, adj)
        if moved == 0:
            break
    return np.flatnonzero(sol).astype(np.int64)


@nb.njit(cache=True, nogil=True)
def merge_patches(
    adj_start: np.ndarray,
    adj: np.ndarray,
    eligible: np.ndarray,
    tiebreak: np.ndarray,
    inner_max: int,
    centres: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Patches with several inner vertices made by merging two levels (SWPM 3.3: "one method to build
    the patches with multiple inner vertices is the clustering algorithm": the next level's patch takes
    the simplified patches around its centre and their intermediate ``Q`` is never stored).

    ``centres`` is this level's independent set (one inner vertex per patch). A second-level centre ``c``
    (eligible, not a centre) takes ALL the centres next to it, ``B(c)``, into one patch ``{c} + B(c)``,
    if ``1 <= |B(c)| <= inner_max - 1``, no other merged patch took one of them and ``c`` is not next to
    an accepted ``c'``; then no inner vertex of one patch is next to one of another, so the patches
    (unions of stars) are disjoint. Candidates are taken by fewest ``B``, then lowest degree plus
    ``tiebreak``; the centres nobody took stay single patches. Returns the CSR ``(inner_start, inner)``
    (each merged patch lists ``B(c)`` then ``c``)."""
    P = eligible.shape[0]
    is_centre = np.zeros(P, np.bool_)
    for v in centres:
        is_centre[v] = True
    key = np.full(P, np.inf)
    for x in range(P):
        if is_centre[x] or not eligible[x]:
            continue
        nb0 = 0
        for a in range(adj_start[x], adj_start[x + 1]):
            if is_centre[adj[a]]:
                nb0 += 1
        if 1 <= nb0 <= inner_max - 1:
            key[x] = nb0 * 1e6 + (adj_start[x + 1] - adj_start[x]) + tiebreak[x]
    order = np.argsort(key)
    taken = np.zeros(P, np.bool_)
    blocked = np.zeros(P, np.bool_)
    inner = np.empty(P, np.int64)
    inner_start = np.zeros(P + 1, np.int64)
    m = 0
    n_patch = 0
    for r in range(P):
        c = order[r]
        if key[c] == np.inf:
            break
        if blocked[c]:
            continue
        free = True
        for a in range(adj_start[c], adj_start[c + 1]):
            y = adj[a]
            if is_centre[y] and taken[y]:
                free = False
                break
        if not free:
            continue
        for a in range(adj_start[c], adj_start[c + 1]):
            y = adj[a]
            blocked[y] = True
            if is_centre[y]:
                taken[y] = True
                inner[m] = y
                m += 1
        inner[m] = c
        m += 1
        n_patch += 1
        inner_start[n_patch] = m
    for v in centres:
        if not taken[v]:
            inner[m] = v
            m += 1
            n_patch += 1
            inner_start[n_patch] = m
    return inner_start[: n_patch + 1].copy(), inner[:m].copy()


# ----------------------------------------------------------------------------------------------------
# patches of up to k inner vertices: large-neighbourhood search on sets whose components have <= k vertices
# ----------------------------------------------------------------------------------------------------
@nb.njit(cache=True, nogil=True)
def _component_fits(v, in_set, adj_start, adj, k, mark, stamp, stack):
    """Whether ``v`` joined to the set lies in a component of at most ``k`` members."""
    mark[v] = stamp
    stack[0] = v
    n = 1
    head = 0
    while head < n:
        x = stack[head]
        head += 1
        for a in range(adj_start[x], adj_start[x + 1]):
            y = adj[a]
            if in_set[y] and mark[y] != stamp:
                mark[y] = stamp
                if n == k:
                    return False
                stack[n] = y
                n += 1
    return True


@nb.njit(cache=True, nogil=True)
def grow_component_set(
    adj_start: np.ndarray,
    adj: np.ndarray,
    eligible: np.ndarray,
    tiebreak: np.ndarray,
    k: int,
    init: np.ndarray,
    iterations: int,
    seed: int,
    jitter: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Patches of at most ``k`` inner vertices, as many inner vertices as possible (SWPM 3.3).

    Inner vertices of two patches may not be neighbours (the stars would share triangles), so the inner
    vertices of a level form a set of ``eligible`` vertices whose connected components have at most ``k``
    members, each component a patch. Starting from ``init`` (such a set), a large-neighbourhood search:
    each of ``iterations`` empties the 2-ring of a random eligible vertex and refills it greedily (the
    vertex that colours the fewest new vertices, plus ``tiebreak`` (error rank) and a random jitter), keeping
    the result unless it holds fewer members. Deterministic for a ``seed``. Returns the CSR
    ``(inner_start, inner)`` of the components."""
    rng = _xorshift_seed(seed)
    P = eligible.shape[0]
    in_set = np.zeros(P, np.bool_)
    tight = np.zeros(P, np.int64)
    for v in init:
        in_set[v] = True
        for a in range(adj_start[v], adj_start[v + 1]):
            tight[adj[a]] += 1
    mark = np.zeros(P, np.int64)
    stamp = np.int64(0)
    stack = np.empty(k + 1, np.int64)
    rmark = np.zeros(P, np.int64)
    rstamp = np.int64(0)
    region = np.empty(256, np.int64)
    removed = np.empty(256, np.int64)
    added = np.empty(256, np.int64)
    pool = np.flatnonzero(eligible)
    # complete the initial set: every eligible vertex that fits, fewest free neighbours first
    key0 = np.empty(pool.shape[0])
    for i in range(pool.shape[0]):
        x = pool[i]
        key0[i] = (adj_start[x + 1] - adj_start[x]) + tiebreak[x]
    for i in np.argsort(key0):
        x = pool[i]
        if not in_set[x]:
            stamp += 1
            if _component_fits(x, in_set, adj_start, adj, k, mark, stamp, stack):
                in_set[x] = True
                for a in range(adj_start[x], adj_start[x + 1]):
                    tight[adj[a]] += 1
    for _ in range(iterations):
        if pool.shape[0] == 0:
            break
        rng = _xorshift(rng)
        v = pool[np.int64(rng % np.uint64(pool.shape[0]))]
        rstamp += 1
        nr = 0
        rmark[v] = rstamp
        region[nr] = v
        nr += 1
        h = 0
        for _d in range(2):
            end = nr
            while h < end:
                x = region[h]
                h += 1
                if K.is_hub(adj_start, x):
                    continue  # a hub's ring is all over the mesh (a cone's apex)
                for a in range(adj_start[x], adj_start[x + 1]):
                    y = adj[a]
                    if rmark[y] != rstamp and nr < region.shape[0]:
                        rmark[y] = rstamp
                        region[nr] = y
                        nr += 1
        nrem = 0
        for i in range(nr):
            x = region[i]
            if in_set[x]:
                in_set[x] = False
                for a in range(adj_start[x], adj_start[x + 1]):
                    tight[adj[a]] -= 1
                removed[nrem] = x
                nrem += 1
        nadd = 0
        while True:
            best = -1
            best_key = np.inf
            for i in range(nr):
                x = region[i]
                # a hub is no inner vertex here: its patch would be its thousands of triangles, and
                # counting its free neighbours is linear per candidate
                if in_set[x] or not eligible[x] or K.is_hub(adj_start, x):
                    continue
                stamp += 1
                if not _component_fits(x, in_set, adj_start, adj, k, mark, stamp, stack):
                    continue
                c = 0
                for a in range(adj_start[x], adj_start[x + 1]):
                    y = adj[a]
                    if not in_set[y] and tight[y] == 0:
                        c += 1
                if tight[x] == 0:
                    c += 1
                rng = _xorshift(rng)
                key = c + tiebreak[x] + jitter * np.float64(rng >> np.uint64(11)) / 9007199254740992.0
                if key < best_key:
                    best_key = key
                    best = x
            if best < 0:
                break
            in_set[best] = True
            for a in range(adj_start[best], adj_start[best + 1]):
                tight[adj[a]] += 1
            added[nadd] = best
            nadd += 1
        if nadd < nrem:  # worse: restore the region
            for i in range(nadd):
                x = added[i]
                in_set[x] = False
                for a in range(adj_start[x], adj_start[x + 1]):
                    tight[adj[a]] -= 1
            for i in range(nrem):
                x = removed[i]
                in_set[x] = True
                for a in range(adj_start[x], adj_start[x + 1]):
                    tight[adj[a]] += 1
    # components -> patches
    comp = np.full(P, -1, np.int64)
    inner = np.empty(P, np.int64)
    inner_start = np.zeros(P + 1, np.int64)
    m = 0
    n_patch = 0
    for s in range(P):
        if not in_set[s] or comp[s] >= 0:
            continue
        comp[s] = n_patch
        first = m
        inner[m] = s
        m += 1
        h = first
        while h < m:
            x = inner[h]
            h += 1
            for a in range(adj_start[x], adj_start[x + 1]):
                y = adj[a]
                if in_set[y] and comp[y] < 0:
                    comp[y] = n_patch
                    inner[m] = y
                    m += 1
        n_patch += 1
        inner_start[n_patch] = m
    return inner_start[: n_patch + 1].copy(), inner[:m].copy()
