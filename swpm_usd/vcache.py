"""Vertex-cache ordering of triangle lists for a FIFO post-transform cache.

Every progressive-mesh encoder draws a static index buffer (or blocks of it) and wants its triangles in an
order that a FIFO vertex cache of ``cache_size`` entries serves well: few misses per triangle (ACMR, see
:mod:`swpm_usd.metrics`, whose cache model this module optimises for exactly). Only the *order* of the
triangles changes; every triangle keeps its three indices and its winding. With ``rotate=True`` the three
indices of a triangle may also be rotated cyclically (``(a, b, c)`` -> ``(b, c, a)``), which keeps the
winding and lets a hit be looked up before a miss evicts it.

Method
    Tom Forsyth, "Linear-Speed Vertex Cache Optimisation" (2006), adapted to a FIFO cache of configurable
    size. Greedy: every vertex has a score (a term for its position in the simulated cache plus a term for
    its number of not-yet-emitted triangles), every triangle the sum of its vertices' scores, and the next
    triangle is the best-scoring one that touches a vertex in the cache. Changes from the paper:

    * The cache simulated while ordering is the FIFO of :mod:`swpm_usd.metrics` (push on a miss, evict the
      oldest, no reordering on a hit), simulated exactly, index by index. A vertex's cache position is the
      number of pushes since it entered the cache (0 = newest), so on a hit nothing moves and a triangle
      with three cached vertices is free.
    * The score tables were re-fitted for the FIFO model: the position term is piecewise linear in
      ``position / (cache_size - 1)`` (knots :data:`_CACHE_KNOTS`, values :data:`_CACHE_SCORES`; fairly
      flat, lower for the newest and clearly lower for the oldest entries, which are about to be evicted),
      which is how one table serves every cache size; the remaining-triangle term is
      :data:`_LIVE_SCORES`. They were fitted by random search on spot, bob, fandisk, dragon-20k and
      teapot (shuffled) jointly at cache sizes 8, 16 and 32, and checked on bunny, cow and nefertiti,
      which were not used for the fit.
    * Dead ends (no live triangle touches the cache) restart from the most recently emitted vertex that
      still has triangles (Tipsify's dead-end stack), then from the first triangle not emitted yet in input
      order.
    * A vertex of more than :data:`_HEAVY` triangles in a block (a non-manifold hub, a fan on one edge, a
      cone's apex) would cost a scan of its triangles for every triangle emitted while it is cached: a
      random hub of 20,000 triangles took 46 s inside Forsyth's sliding-window builder. Its score is kept
      out of its triangles' stored scores (added when one is read) and its live triangles sit in a max tree
      by stored score, whose earliest best leaf is the triangle the scan would pick. A triangle with two
      heavy corners is ranked in each one's tree without the other's score, which is exact when all of a
      heavy vertex's triangles share the other (a fan on an edge whose ends hold nothing else) and an
      approximation otherwise.

    Tipsify (Sander, Nehab, Barczak, "Fast Triangle Reordering for Vertex Locality and Reduced Overdraw",
    2007) was implemented FIFO-exactly as well (with and without fan walking, with cache-slack variants) and
    gives a *higher* FIFO ACMR than the re-fitted Forsyth greedy at cache sizes 8 and 16 (bunny at 16:
    0.644 at best against 0.624) and about the same at 32, so it is not used. Measured FIFO ACMR of the
    meshes in file order (this module / meshoptimizer 0.22 ``optimize_vertex_cache`` /
    ``optimize_vertex_cache_fifo`` at the same cache size), cache 16: bunny 0.624 / 0.682 / 0.657, cow
    0.650 / 0.671 / 0.665, nefertiti 0.650 / 0.665 / 0.684; cache 32: bunny 0.576 / 0.636 / 0.576, cow
    0.582 / 0.622 / 0.596, nefertiti 0.594 / 0.621 / 0.596. ``rotate=True`` picks, per triangle, the
    rotation with the fewest misses; it gains at most about 1 % and can lose a little (bunny at 16: 0.627).

Blocks (:func:`optimize_block_order`)
    Triangles are reordered only inside consecutive blocks that stay in place (sliding-window index pools
    need this). The FIFO state carries over: block ``i + 1`` is scored against the cache left by block
    ``i`` (or by ``cache_state`` for the first one). The remaining-triangle term counts a vertex's triangles
    in the current *and all later* blocks, so that vertices later blocks still need are fetched last and
    stay in the FIFO longest. One kernel runs all blocks; a block costs time proportional to its size (times
    the cache size), not to the mesh's, so thousands of tiny blocks are cheap (20,000 blocks of 3-8
    triangles: about 60 ms).

Fans (:func:`fan_order`, :func:`fan_order_nb`)
    Orders the triangles around one vertex so that consecutive triangles share an edge (a walk around the
    vertex; an open fan is walked from a boundary end, in winding direction where the winding allows).
    :func:`fan_order_nb` is a numba function that other kernels can call.
"""

from __future__ import annotations

import functools

import numpy as np
from numba import njit

from . import numba_cache  # noqa: F401 (before the kernels: it stamps them)

__all__ = [
    "apply_order",
    "fan_order",
    "fan_order_nb",
    "fifo_contents",
    "optimize_block_order",
    "optimize_triangle_order",
]

#: knots of the cache-position score, in ``position / (cache_size - 1)`` (0 = newest entry)
_CACHE_KNOTS = np.array([0.0, 0.25, 0.5, 0.75, 0.9, 1.0])
#: cache-position score at the knots (a vertex not in the cache scores 0)
_CACHE_SCORES = np.array([0.765, 0.870, 0.918, 0.936, 0.883, 0.714])
#: score for 1, 2, ..., 8 (and more) remaining triangles (a vertex without any scores 0)
_LIVE_SCORES = np.array([0.471, 0.680, 0.438, 0.257, 0.286, 0.298, 0.058, 0.076])


@functools.cache
def _score_tables(cache_size: int) -> tuple[np.ndarray, np.ndarray]:
    """(cache-position score per position 0..cache_size-1, score per remaining-triangle count 0..8): once
    per cache size (the kernels only read them; a small sliding-window level costs tens of microseconds)."""
    x = np.arange(cache_size, dtype=np.float64) / max(cache_size - 1, 1)
    cache_tab = np.interp(x, _CACHE_KNOTS, _CACHE_SCORES)
    live_tab = np.concatenate([[0.0], _LIVE_SCORES])
    return cache_tab, live_tab


# --------------------------------------------------------------------------------------------------------
# Kernels
# --------------------------------------------------------------------------------------------------------


@njit(cache=True, inline="always")
def _age(stamp_v: int, pushes: int, cache_size: int) -> int:
    """Cache position of a vertex (0 = newest), ``cache_size`` when it is not cached."""
    if stamp_v > 0 and pushes - stamp_v < cache_size:
        return pushes - stamp_v
    return cache_size


@njit(cache=True, inline="always")
def _is_repeat(tris: np.ndarray, t: int, k: int) -> bool:
    """Corner ``k`` of triangle ``t`` repeats an earlier corner (degenerate triangle)."""
    v = tris[t, k]
    return (k >= 1 and tris[t, 0] == v) or (k == 2 and tris[t, 1] == v)


#: a vertex with more triangles than this in a block is *heavy*: its score is added to its triangles' scores
#: when they are read, not stored in them, and its live triangles sit in a max tree (a non-manifold hub or
#: a large fan would otherwise cost time linear in its degree for every triangle emitted). Below it a scan
#: is cheap and keeps the running sums' rounding: fandisk's skip-strip levels reach 70 triangles at a
#: vertex, and at 64 a near tie broke the other way (the same ACMR, another order)
_HEAVY = 128


@njit(cache=True, inline="always")
def _heavy_part(tris: np.ndarray, t: int, loc: np.ndarray, heavy: np.ndarray, vsc: np.ndarray) -> float:
    """Sum of the scores of triangle ``t``'s heavy corners (each vertex once)."""
    s = 0.0
    for k in range(3):
        if not _is_repeat(tris, t, k):
            lv = loc[tris[t, k]]
            if heavy[lv]:
                s += vsc[lv]
    return s


@njit(cache=True, inline="always")
def _better(tsc: np.ndarray, adj: np.ndarray, first: int, x: int, y: int) -> int:
    """The leaf (-1 = none) of a heavy vertex's tree whose triangle ``adj[first + leaf]`` scores higher,
    the earlier leaf on ties."""
    if x < 0:
        return y
    if y < 0:
        return x
    a = tsc[adj[first + x]]
    b = tsc[adj[first + y]]
    return y if b > a or (b == a and y < x) else x


@njit(cache=True)
def _tree_set(tree: np.ndarray, tsc: np.ndarray, adj: np.ndarray, first: int, d: int, leaf: int, alive: bool):
    """Set leaf ``leaf`` of the max tree of a heavy vertex (nodes ``tree[2 * first + 1 .. 2 * first + 2 d)``,
    leaves ``d..2d-1`` for the triangles ``adj[first .. first + d)``, keyed by their ``tsc``) and update its
    ancestors."""
    base = 2 * first
    node = d + leaf
    tree[base + node] = leaf if alive else -1
    node //= 2
    while node >= 1:
        tree[base + node] = _better(tsc, adj, first, tree[base + 2 * node], tree[base + 2 * node + 1])
        node //= 2


@njit(cache=True, nogil=True)
def _order_blocks(
    tris: np.ndarray,
    starts: np.ndarray,
    cache_size: int,
    stamp: np.ndarray,
    ring: np.ndarray,
    pushes: int,
    cache_tab: np.ndarray,
    live_tab: np.ndarray,
    rotate: bool,
    segments: np.ndarray,
    heavy_degree: int,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Forsyth greedy on a FIFO cache, block by block, the cache carrying over between blocks.

    ``segments``: increasing block indices at which a new *segment* starts; a vertex's remaining-triangle
    count covers the later blocks of its own segment only (a segment is drawn on its own).

    FIFO state (updated in place): ``stamp[v]`` is the push number (1-based) at which ``v`` last entered
    the cache (0 = never), ``pushes`` the number of pushes so far and ``ring[p % cache_size]`` the vertex of
    push ``p``; ``v`` is cached iff ``stamp[v] > 0 and pushes - stamp[v] < cache_size``.
    Returns (perm, shift, pushes): output triangle ``i`` is ``tris[perm[i]]`` rotated left by ``shift[i]``.
    """
    n = tris.shape[0]
    nvert = stamp.shape[0]
    C = cache_size
    perm = np.empty(n, np.int64)
    shift = np.zeros(n, np.int8)
    # remaining triangles of every vertex over this and all later blocks of the segment (the scoring's live
    # count; filled in at the start of every segment, when the previous one has used its counts up)
    glive = np.zeros(nvert, np.int64)
    nb = starts.shape[0] - 1
    seg = 0
    # per-block scratch, indexed by local vertex / local triangle: sized for the largest block (a
    # sliding-window level is thousands of small blocks: 1 M triangles in one call needed 400 MB at 3 n)
    mb = 0
    for b in range(nb):
        mb = max(mb, starts[b + 1] - starts[b])
    loc = np.full(nvert, -1, np.int64)  # global -> local vertex id of the current block
    lvert = np.empty(3 * mb + 1, np.int64)
    off = np.empty(3 * mb + 2, np.int64)
    live = np.empty(3 * mb + 1, np.int64)  # live triangles of the vertex inside the block
    adj = np.empty(3 * mb + 1, np.int64)  # live triangles first in each vertex's range
    vsc = np.empty(3 * mb + 1, np.float64)
    mark = np.zeros(3 * mb + 1, np.int64)
    tsc = np.empty(mb + 1, np.float64)
    emitted = np.zeros(mb + 1, np.bool_)
    dead = np.empty(3 * mb + 1, np.int64)
    # heavy vertices (see _HEAVY): flag per local vertex, heavy corners per local triangle, the slot of
    # each corner in its vertex's list (kept for heavy vertices; a tree's leaf is a slot, so the tree's
    # earliest best leaf is the triangle a scan of the list would pick) and the max trees of the heavy
    # vertices' live triangles by stored score
    heavy = np.zeros(3 * mb + 1, np.bool_)
    hv = np.zeros(mb + 1, np.int64)
    cslot = np.empty(3 * mb + 3, np.int64)
    tree = np.empty(6 * mb + 6, np.int64)
    upd = np.empty(C + 8, np.int64)
    # the block's own pushes still in the FIFO, oldest first: push number and local vertex of entries
    # qhead..qtail-1. Walking these instead of the whole ring (cache_size entries, most of them other
    # blocks' vertices) finds the cached block vertices in the same newest-to-oldest order
    qpush = np.empty(3 * mb + C + 1, np.int64)
    qlv = np.empty(3 * mb + C + 1, np.int64)
    # vertex score by (cache position or C when not cached, remaining triangles capped at 8); a table
    # instead of a helper taking the two score arrays: numba reference-counted the arrays on every call
    # of the helper (atomic increments, ~15 % of this kernel's time)
    top = live_tab.shape[0] - 1
    score_tab = np.zeros((C + 1, top + 1), np.float64)
    for a in range(C + 1):
        for c in range(1, top + 1):  # a vertex without remaining triangles scores 0
            score_tab[a, c] = (cache_tab[a] if a < C else 0.0) + live_tab[c]
    out = 0
    step = 0
    for b in range(nb):
        if b == 0 or (seg < segments.shape[0] and segments[seg] == b):
            while seg < segments.shape[0] and segments[seg] <= b:
                seg += 1
            end = starts[segments[seg]] if seg < segments.shape[0] and segments[seg] < nb else n
            for t in range(starts[b], end):
                for k in range(3):
                    if not _is_repeat(tris, t, k):
                        glive[tris[t, k]] += 1
        lo = starts[b]
        m = starts[b + 1] - lo
        if m <= 0:
            continue
        # local adjacency (CSR) of the block
        nv = 0
        for t in range(lo, lo + m):
            for k in range(3):
                if _is_repeat(tris, t, k):
                    continue
                v = tris[t, k]
                if loc[v] < 0:
                    loc[v] = nv
                    lvert[nv] = v
                    live[nv] = 0
                    mark[nv] = 0
                    nv += 1
                live[loc[v]] += 1
        off[0] = 0
        for i in range(nv):
            off[i + 1] = off[i] + live[i]
            live[i] = 0
        for t in range(lo, lo + m):
            emitted[t - lo] = False
            for k in range(3):
                if not _is_repeat(tris, t, k):
                    lv = loc[tris[t, k]]
                    cslot[3 * (t - lo) + k] = off[lv] + live[lv]
                    adj[off[lv] + live[lv]] = t - lo
                    live[lv] += 1
        nheavy = 0
        for i in range(nv):
            v = lvert[i]
            vsc[i] = score_tab[_age(stamp[v], pushes, C), min(glive[v], top)]
            heavy[i] = live[i] > heavy_degree
            nheavy += heavy[i]
        for t in range(m):
            s = 0.0
            hv[t] = 0
            for k in range(3):
                if not _is_repeat(tris, lo + t, k):
                    lv = loc[tris[lo + t, k]]
                    if heavy[lv]:
                        hv[t] += 1
                    else:
                        s += vsc[lv]
            tsc[t] = s
        if nheavy > 0:
            for lv in range(nv):
                if heavy[lv]:
                    d = live[lv]
                    base = 2 * off[lv]
                    for i in range(d):
                        tree[base + d + i] = i
                    for node in range(d - 1, 0, -1):
                        tree[base + node] = _better(
                            tsc, adj, off[lv], tree[base + 2 * node], tree[base + 2 * node + 1]
                        )
        # the block's vertices in the carried-over cache, oldest first
        qhead = 0
        qtail = 0
        for p in range(max(pushes - C + 1, 1), pushes + 1):
            lv = loc[ring[p % C]]
            if lv >= 0:
                qpush[qtail] = p
                qlv[qtail] = lv
                qtail += 1
        # first candidate: best triangle touching the carried-over cache (newest entries first). This scan,
        # the dead end's and the per-step one are written out: one inlined helper taking the arrays made
        # bunny's order 5x slower (59 -> 289 ms; numba's reference counting per call)
        best = -1
        best_score = -1.0
        for j in range(qtail - 1, qhead - 1, -1):
            lv = qlv[j]
            qa, qb = off[lv], off[lv] + live[lv]
            if heavy[lv]:  # only its best stored score: its own score is the same for all its triangles
                leaf = tree[2 * off[lv] + 1]
                qa, qb = (off[lv] + leaf, off[lv] + leaf + 1) if leaf >= 0 else (0, 0)
            for q in range(qa, qb):
                s = tsc[adj[q]]
                if hv[adj[q]] > 0:
                    s += _heavy_part(tris, lo + adj[q], loc, heavy, vsc)
                if s > best_score:
                    best_score = s
                    best = adj[q]
        dtop = 0
        cursor = 0
        for _ in range(m):
            cur = best
            if cur < 0:  # dead end: most recent vertex with live triangles, else input order
                while dtop > 0 and cur < 0:
                    dtop -= 1
                    lv = dead[dtop]
                    qa, qb = off[lv], off[lv] + live[lv]
                    if heavy[lv]:
                        leaf = tree[2 * off[lv] + 1]
                        qa, qb = (off[lv] + leaf, off[lv] + leaf + 1) if leaf >= 0 else (0, 0)
                    cur_score = -1.0
                    for q in range(qa, qb):
                        s = tsc[adj[q]]
                        if hv[adj[q]] > 0:
                            s += _heavy_part(tris, lo + adj[q], loc, heavy, vsc)
                        if cur < 0 or s > cur_score:
                            cur = adj[q]
                            cur_score = s
                    if cur >= 0:
                        dtop += 1  # the vertex may have more triangles: keep it on the stack
                if cur < 0:
                    while emitted[cursor]:
                        cursor += 1
                    cur = cursor
            t = lo + cur
            r = 0
            if rotate:  # the cyclic rotation with the fewest misses (first one on ties)
                fewest = 4
                for rr in range(3):
                    misses = 0
                    p = pushes
                    s0 = stamp[tris[t, rr]]
                    if s0 == 0 or p - s0 >= C:
                        misses += 1
                        p += 1
                        s0 = p
                    v1 = tris[t, (rr + 1) % 3]
                    s1 = s0 if v1 == tris[t, rr] else stamp[v1]
                    if s1 == 0 or p - s1 >= C:
                        misses += 1
                        p += 1
                        s1 = p
                    v2 = tris[t, (rr + 2) % 3]
                    s2 = s0 if v2 == tris[t, rr] else (s1 if v2 == v1 else stamp[v2])
                    if s2 == 0 or p - s2 >= C:
                        misses += 1
                    if misses < fewest:
                        fewest = misses
                        r = rr
            perm[out] = t
            shift[out] = r
            out += 1
            emitted[cur] = True
            step += 1
            nupd = 0
            pushes0 = pushes
            # fetch the three indices through the FIFO; collect block vertices that get evicted
            for k in range(3):
                v = tris[t, (r + k) % 3]
                s = stamp[v]
                if s == 0 or pushes - s >= C:
                    pushes += 1
                    if qhead < qtail and qpush[qhead] == pushes - C:  # a block vertex is evicted
                        lv = qlv[qhead]
                        qhead += 1
                        if mark[lv] != step:
                            mark[lv] = step
                            upd[nupd] = lv
                            nupd += 1
                    ring[pushes % C] = v
                    stamp[v] = pushes
                    qpush[qtail] = pushes
                    qlv[qtail] = loc[v]
                    qtail += 1
            # retire the triangle from its vertices' live lists
            for k in range(3):
                if _is_repeat(tris, t, k):
                    continue
                v = tris[t, k]
                lv = loc[v]
                if heavy[lv]:  # the same swap with the last live triangle, found by its slot; leaves follow
                    d = off[lv + 1] - off[lv]
                    q = cslot[3 * cur + k]
                    last = off[lv] + live[lv] - 1
                    if q != last:
                        moved = adj[last]
                        adj[q] = moved
                        adj[last] = cur
                        for k2 in range(3):
                            if not _is_repeat(tris, lo + moved, k2) and loc[tris[lo + moved, k2]] == lv:
                                cslot[3 * moved + k2] = q
                        # (np.bool_, not a literal True / False: one compile of _tree_set, not two)
                        _tree_set(tree, tsc, adj, off[lv], d, q - off[lv], np.bool_(True))
                    _tree_set(tree, tsc, adj, off[lv], d, last - off[lv], np.bool_(False))
                else:
                    last = off[lv] + live[lv] - 1
                    for q in range(off[lv], last + 1):
                        if adj[q] == cur:
                            adj[q] = adj[last]
                            adj[last] = cur
                            break
                live[lv] -= 1
                glive[v] -= 1
                dead[dtop] = lv
                dtop += 1
                if mark[lv] != step:
                    mark[lv] = step
                    upd[nupd] = lv
                    nupd += 1
            # every cached vertex moved (or not): rescore cached, evicted and just-used vertices; without a
            # miss the other cached vertices kept their slot and counts, hence their scores: they are only
            # candidates then
            nres = nupd
            for j in range(qtail - 1, qhead - 1, -1):
                lv = qlv[j]
                if mark[lv] != step:
                    mark[lv] = step
                    upd[nupd] = lv
                    nupd += 1
            if pushes != pushes0:
                nres = nupd
            for i in range(nres):
                lv = upd[i]
                score = 0.0
                if live[lv] > 0:
                    v = lvert[lv]
                    score = score_tab[_age(stamp[v], pushes, C), min(glive[v], top)]
                diff = score - vsc[lv]
                if diff != 0.0:
                    vsc[lv] = score
                    if heavy[lv]:  # read with its triangles' scores, not stored in them
                        continue
                    for q in range(off[lv], off[lv] + live[lv]):
                        tsc[adj[q]] += diff
                        if hv[adj[q]] > 0:  # its place in the heavy corners' trees moves
                            ht = adj[q]
                            for k in range(3):
                                if not _is_repeat(tris, lo + ht, k):
                                    hl = loc[tris[lo + ht, k]]
                                    if heavy[hl]:
                                        _tree_set(
                                            tree,
                                            tsc,
                                            adj,
                                            off[hl],
                                            off[hl + 1] - off[hl],
                                            cslot[3 * ht + k] - off[hl],
                                            np.bool_(True),
                                        )
            best = -1
            best_score = -1.0
            for i in range(nupd):
                lv = upd[i]
                qa, qb = off[lv], off[lv] + live[lv]
                if heavy[lv]:
                    leaf = tree[2 * off[lv] + 1]
                    qa, qb = (off[lv] + leaf, off[lv] + leaf + 1) if leaf >= 0 else (0, 0)
                for q in range(qa, qb):
                    s = tsc[adj[q]]
                    if hv[adj[q]] > 0:
                        s += _heavy_part(tris, lo + adj[q], loc, heavy, vsc)
                    if s > best_score:
                        best_score = s
                        best = adj[q]
        for i in range(nv):
            loc[lvert[i]] = -1
    return perm, shift, pushes


@njit(cache=True, nogil=True)
def fan_order_nb(tris: np.ndarray, centre: int) -> np.ndarray:
    """Order of the rows of ``tris`` (k, 3) around vertex ``centre``: consecutive triangles share an edge.

    Each triangle is seen as ``centre`` plus its two rim vertices ``x, y`` (in winding order after
    ``centre``). The walk starts at a boundary end of the fan (a triangle whose ``x`` no other remaining
    triangle has as a rim vertex, so it walks in winding direction; else one whose ``y`` is free; for a
    closed fan the first remaining row) and moves to a remaining triangle sharing the current one's far
    rim vertex (preferring one with consistent winding). When none is left the walk restarts, so
    non-manifold fans, several arcs and rows without ``centre`` (appended as arcs of their own) still come
    out as a permutation. Only the order is returned; the rows are not changed. O(k^2).
    """
    k = tris.shape[0]
    xs = np.empty(k, np.int64)
    ys = np.empty(k, np.int64)
    for i in range(k):
        xs[i] = -1
        ys[i] = -1
        for j in range(3):
            if tris[i, j] == centre:
                xs[i] = tris[i, (j + 1) % 3]
                ys[i] = tris[i, (j + 2) % 3]
                break
    used = np.zeros(k, np.bool_)
    perm = np.empty(k, np.int64)
    cnt = 0
    while cnt < k:
        start = -1
        forward = True
        for pass_ in range(2):  # 0: x free (walk in winding order), 1: y free (walk against it)
            for i in range(k):
                if used[i] or xs[i] < 0:
                    continue
                e = xs[i] if pass_ == 0 else ys[i]
                free = True
                for j in range(k):
                    if j != i and not used[j] and (xs[j] == e or ys[j] == e):
                        free = False
                        break
                if free:
                    start = i
                    forward = pass_ == 0
                    break
            if start >= 0:
                break
        if start < 0:
            for i in range(k):
                if not used[i]:
                    start = i
                    break
        cur = start
        far = ys[cur] if forward else xs[cur]
        while cur >= 0:
            used[cur] = True
            perm[cnt] = cur
            cnt += 1
            if xs[cur] < 0:
                break
            nxt = -1
            for j in range(k):  # prefer the neighbour wound consistently with the walk
                if not used[j] and xs[j] >= 0 and ((xs[j] == far) if forward else (ys[j] == far)):
                    nxt = j
                    break
            if nxt < 0:
                for j in range(k):
                    if not used[j] and xs[j] >= 0 and (xs[j] == far or ys[j] == far):
                        nxt = j
                        break
            if nxt >= 0:
                if xs[nxt] == far and ys[nxt] != far:
                    far = ys[nxt]
                    forward = True
                elif ys[nxt] == far and xs[nxt] != far:
                    far = xs[nxt]
                    forward = False
            cur = nxt
    return perm


@njit(cache=True, nogil=True)
def _fifo_run(seq: np.ndarray, cache_size: int, stamp: np.ndarray, ring: np.ndarray, pushes: int) -> int:
    for i in range(seq.shape[0]):
        v = seq[i]
        s = stamp[v]
        if s == 0 or pushes - s >= cache_size:
            pushes += 1
            ring[pushes % cache_size] = v
            stamp[v] = pushes
    return pushes


# --------------------------------------------------------------------------------------------------------
# Python API
# --------------------------------------------------------------------------------------------------------


def _as_triangles(triangles: np.ndarray) -> np.ndarray:
    tri = np.asarray(triangles)
    if tri.size == 0:
        return np.zeros((0, 3), np.int64)
    if not np.issubdtype(tri.dtype, np.integer):
        raise ValueError(f"triangle indices must be integers, got {tri.dtype}")
    if tri.ndim != 2 or tri.shape[1] != 3:
        raise ValueError(f"triangles must have shape (n, 3), got {tri.shape}")
    tri = np.ascontiguousarray(tri, dtype=np.int64)
    if tri.min() < 0:
        raise ValueError(f"negative vertex index {int(tri.min())}")
    return tri


def _check_cache_size(cache_size: int) -> int:
    c = int(cache_size)
    if c < 1:
        raise ValueError(f"cache_size must be >= 1, got {cache_size}")
    return c


def _vertex_count(tri: np.ndarray, vertex_count: int | None, extra: np.ndarray | None = None) -> int:
    hi = int(tri.max()) + 1 if tri.size else 0
    if extra is not None and extra.size:
        hi = max(hi, int(extra.max()) + 1)
    if vertex_count is None:
        return hi
    if int(vertex_count) < hi:
        raise ValueError(f"vertex index {hi - 1} out of range for vertex_count={vertex_count}")
    return int(vertex_count)


def _as_state(cache_state: np.ndarray | None) -> np.ndarray | None:
    """Validated FIFO content (distinct vertex ids, oldest first) or None."""
    if cache_state is None:
        return None
    state = np.asarray(cache_state).reshape(-1)
    if state.size and not np.issubdtype(state.dtype, np.integer):
        raise ValueError(f"a cache state must be vertex ids, got {state.dtype}")
    state = state.astype(np.int64)
    if state.size and (state.min() < 0 or np.unique(state).size != state.size):
        raise ValueError("a cache state must hold distinct non-negative vertex ids")
    return state


def _compact(
    tri: np.ndarray, nvert: int, state: np.ndarray | None = None
) -> tuple[np.ndarray, int, np.ndarray | None, np.ndarray | None]:
    """Renumber sparse vertex ids densely when the id range is much larger than the ids used, so that the
    per-vertex work arrays stay small. The kernels only compare ids, so the order does not change.

    Returns (ids, vertex count, state, original id of each new id or None when nothing was renumbered).
    """
    used = tri.size + (0 if state is None else state.size)
    if nvert <= 4 * used + 1024:
        return tri, nvert, state, None
    ids = tri.reshape(-1) if state is None else np.concatenate([tri.reshape(-1), state])
    uniq, inverse = np.unique(ids, return_inverse=True)
    inverse = inverse.reshape(-1).astype(np.int64)
    out = np.ascontiguousarray(inverse[: tri.size].reshape(tri.shape))
    state = None if state is None else inverse[tri.size :]
    return out, int(uniq.size), state, uniq


def _seed_state(
    cache_state: np.ndarray | None, cache_size: int, nvert: int
) -> tuple[np.ndarray, np.ndarray, int]:
    stamp = np.zeros(nvert, np.int64)
    ring = np.full(cache_size, -1, np.int64)
    if cache_state is None or len(cache_state) == 0:
        return stamp, ring, 0
    state = np.asarray(cache_state, dtype=np.int64).reshape(-1)[-cache_size:]
    pushes = state.shape[0]
    stamp[state] = np.arange(1, pushes + 1)
    ring[np.arange(1, pushes + 1) % cache_size] = state
    return stamp, ring, pushes


def optimize_triangle_order(
    triangles: np.ndarray,
    vertex_count: int | None = None,
    cache_size: int = 16,
    *,
    rotate: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Permutation (int64) of the rows of ``triangles`` (n, 3) for a low FIFO ACMR of ``triangles[perm]``.

    Vertex ids need not be compact; ``vertex_count`` (default ``max + 1``) only sizes the work arrays.
    With ``rotate=True`` returns ``(perm, shift)``: output triangle ``i`` is ``triangles[perm[i]]`` rotated
    left cyclically by ``shift[i]`` (0, 1 or 2; see :func:`apply_order`), which keeps the winding.
    """
    tri = _as_triangles(triangles)
    c = _check_cache_size(cache_size)
    n = tri.shape[0]
    nvert = _vertex_count(tri, vertex_count)
    if n == 0:
        perm = np.zeros(0, np.int64)
        return (perm, np.zeros(0, np.int8)) if rotate else perm
    return _run_order_blocks(tri, nvert, np.array([0, n], np.int64), c, None, np.zeros(0, np.int64), rotate)


def optimize_block_order(
    triangles: np.ndarray,
    block_starts: np.ndarray,
    cache_size: int = 16,
    cache_state: np.ndarray | None = None,
    *,
    rotate: bool = False,
    segment_starts: np.ndarray | None = None,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Permutation of all rows of ``triangles`` that reorders them only inside each block.

    Block ``i`` is ``[block_starts[i], block_starts[i + 1])`` (a leading 0 and a trailing ``n`` are added
    when missing; empty blocks are allowed); ``perm[lo:hi]`` is a permutation of ``lo..hi-1`` for every
    block, so blocks stay in place. The FIFO content left by one block seeds the scoring of the next;
    ``cache_state`` is the content before the first block, oldest first (e.g. :func:`fifo_contents` of
    what is drawn before). ``rotate`` as in :func:`optimize_triangle_order`. ``segment_starts`` (triangle
    offsets, each a block start) split the blocks into segments that are drawn apart (e.g. the ``P`` and
    the ``Q`` half of a sliding-window level): the cache still carries over, but the remaining-triangle
    term of a vertex counts the triangles of its own segment only.
    """
    tri = _as_triangles(triangles)
    c = _check_cache_size(cache_size)
    n = tri.shape[0]
    starts = np.asarray(block_starts).reshape(-1)
    if starts.size and not np.issubdtype(starts.dtype, np.integer):
        raise ValueError(f"block_starts must be integers, got {starts.dtype}")
    starts = starts.astype(np.int64)
    if starts.size == 0 or starts[0] != 0:
        starts = np.concatenate([[0], starts])
    if starts[-1] != n:
        starts = np.concatenate([starts, [n]])
    if np.any(np.diff(starts) < 0) or starts[-1] != n:
        raise ValueError(f"block_starts must be non-decreasing within [0, {n}]")
    state = _as_state(cache_state)
    if n == 0:
        perm = np.zeros(0, np.int64)
        return (perm, np.zeros(0, np.int8)) if rotate else perm
    nvert = _vertex_count(tri, None, state)
    if segment_starts is None:
        segments = np.zeros(0, np.int64)
    else:
        seg = np.asarray(segment_starts, dtype=np.int64).reshape(-1)
        # ``starts`` is sorted: a binary search finds each segment start (np.isin costs more on small inputs)
        at = np.searchsorted(starts, seg, side="left")
        if np.any(at >= starts.shape[0]) or np.any(starts[np.minimum(at, starts.shape[0] - 1)] != seg):
            raise ValueError("segment_starts must be block starts")
        segments = np.unique(at).astype(np.int64)
    return _run_order_blocks(tri, nvert, np.ascontiguousarray(starts), c, state, segments, rotate)


def block_order_trusted(
    triangles: np.ndarray, block_starts: np.ndarray, cache_size: int, segment_start: int | None, rotate: bool
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """:func:`optimize_block_order` without a cache state, for the package's own callers whose inputs are
    valid by construction (the sliding-window layout, :mod:`swpm_usd.encode.sw_layout`, calls it once per
    level and a level of a small mesh costs tens of microseconds): ``triangles`` (n >= 1, 3) of
    non-negative integer vertex ids, ``block_starts`` non-decreasing from 0 to ``n``, ``segment_start``
    one of them (or None). None of the public function's checks; the same kernel on the same arrays, so
    the same permutation (and rotations), bit for bit."""
    tri = np.ascontiguousarray(triangles, dtype=np.int64)
    starts = np.ascontiguousarray(block_starts, dtype=np.int64)
    if segment_start is None:
        segments = np.zeros(0, np.int64)
    else:
        segments = np.array([np.searchsorted(starts, segment_start, side="left")], np.int64)
    return _run_order_blocks(tri, int(tri.max()) + 1, starts, int(cache_size), None, segments, rotate)


def _run_order_blocks(
    tri: np.ndarray,
    nvert: int,
    starts: np.ndarray,
    cache_size: int,
    state: np.ndarray | None,
    segments: np.ndarray,
    rotate: bool,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """The block-ordering kernel on checked arrays (``tri`` int64 (n >= 1, 3), ``starts`` int64 block
    starts from 0 to n, ``segments`` indices into ``starts``): ids compacted, the cache seeded with
    ``state``; the tail the three ordering functions share."""
    tri, nvert, state, _ = _compact(tri, nvert, state)
    cache_tab, live_tab = _score_tables(cache_size)
    stamp, ring, pushes = _seed_state(state, cache_size, nvert)
    perm, shift, _ = _order_blocks(
        tri, starts, cache_size, stamp, ring, pushes, cache_tab, live_tab, bool(rotate), segments, _HEAVY
    )
    return (perm, shift) if rotate else perm


@njit(cache=True, nogil=True)
def _rotate_rows(out: np.ndarray, shift: np.ndarray) -> None:
    """Rotate row ``i`` of ``out`` (n, 3) left cyclically by ``shift[i]`` (any integer), in place."""
    for i in range(out.shape[0]):
        r = shift[i] % 3  # Python's modulo (numba keeps it): -1 -> 2, 3 -> 0, as the take_along_axis path
        if r != 0:
            a, b, c = out[i, 0], out[i, 1], out[i, 2]
            if r == 1:
                out[i, 0], out[i, 1], out[i, 2] = b, c, a
            else:
                out[i, 0], out[i, 1], out[i, 2] = c, a, b


def _read_only(a: np.ndarray) -> np.ndarray:
    """A read-only view of ``a``, for :func:`_rotate_rows`: numba compiles a kernel once for writable and once
    for read-only arrays, and the shifts came as both (a cold suite: 6 signatures, 3 dtypes of rows)."""
    view = a.view()
    view.setflags(write=False)
    return view


def apply_order(triangles: np.ndarray, perm: np.ndarray, shift: np.ndarray | None = None) -> np.ndarray:
    """``triangles[perm]``, row ``i`` rotated left cyclically by ``shift[i]`` when ``shift`` is given."""
    tri = np.asarray(triangles)
    out = tri[np.asarray(perm, dtype=np.int64)]
    if shift is None or out.shape[0] == 0:
        return out
    s = np.asarray(shift, dtype=np.int64).reshape(-1)
    if out.ndim == 2 and out.shape[1] == 3 and np.issubdtype(out.dtype, np.integer) and out.dtype.isnative:
        # the kernel reads shift[i] unchecked: a shorter shift must fail (or broadcast) as it did before
        s = _read_only(np.ascontiguousarray(np.broadcast_to(s, out.shape[:1])))
        _rotate_rows(out, s)  # in place, one pass (take_along_axis cost ~1 ms per 10,000 rows)
        return out
    cols = (np.arange(3)[None, :] + s.reshape(-1, 1)) % 3
    return np.take_along_axis(out, cols, axis=1)


def fifo_contents(indices: np.ndarray, cache_size: int = 16, initial: np.ndarray | None = None) -> np.ndarray:
    """Content (vertex ids, oldest first) of the FIFO of :mod:`swpm_usd.metrics` after ``indices``.

    ``initial`` is the content before ``indices`` (oldest first), as for :func:`optimize_block_order`.
    """
    c = _check_cache_size(cache_size)
    seq = np.asarray(indices).reshape(-1)
    if seq.size and not np.issubdtype(seq.dtype, np.integer):
        raise ValueError(f"indices must be integers, got {seq.dtype}")
    seq = np.ascontiguousarray(seq, dtype=np.int64)
    init = _as_state(initial)
    if seq.size and seq.min() < 0:
        raise ValueError(f"negative vertex index {int(seq.min())}")
    nvert = _vertex_count(seq, None, init)
    seq, nvert, init, ids = _compact(seq, nvert, init)
    stamp, ring, pushes = _seed_state(init, c, nvert)
    pushes = _fifo_run(seq, c, stamp, ring, pushes)
    k = min(c, pushes)
    content = ring[np.arange(pushes - k + 1, pushes + 1) % c]
    return content.copy() if ids is None else ids[content]


def fan_order(triangles: np.ndarray, centre: int) -> np.ndarray:
    """Order (int64 permutation of the rows) of the triangles around vertex ``centre``; see
    :func:`fan_order_nb`. Every triangle must contain ``centre``.
    """
    tri = _as_triangles(triangles)
    if tri.shape[0] == 0:
        return np.zeros(0, np.int64)
    if not np.all(np.any(tri == int(centre), axis=1)):
        raise ValueError(f"every triangle of a fan must contain the centre vertex {centre}")
    return fan_order_nb(tri, int(centre))
