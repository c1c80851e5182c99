"""Winding-preserving triangle stripifier and strip decoder (for skip strips, Forsyth 4.1 / El-Sana 1999).

A strip ``s`` draws triangle ``i`` (counted from the start of its strip) as ``(s[i], s[i+1], s[i+2])`` when
``i`` is even and ``(s[i+1], s[i], s[i+2])`` when ``i`` is odd (the OpenGL / Direct3D rule), so a strip
alternates the order of its indices while keeping every triangle's facing. :func:`stripify` keeps the
input order as far as possible (it is meant to follow a vertex-cache order). As in meshoptimizer's
stripifier (after Evans, Skiena and Varshney, "Optimizing Triangle Strips for Fast Rendering", 1996), the
triangle that continues a strip is looked for only among the first ``window`` not yet emitted triangles of the
input, and as each triangle is emitted: across the strip's last edge, else across the triangle's other edge
on its new vertex, reached by a *swap* (one repeated index, a degenerate triangle, instead of a new strip). A
new strip starts at the first triangle not yet emitted, rotated so that its continuation comes earliest.
Every decoded non-degenerate triangle is an input triangle with its winding (possibly rotated). Strips are
joined either by a restart index (``restart_index``) or, when that is ``None``, by two repeated indices
(degenerate joins; a new strip's first triangle is emitted in the order its parity needs, so no extra parity
index is spent). *Barriers* (:func:`_stripify_barriers`, for the sliding-window strip pool) are input
positions the look-ahead does not cross, so that a prefix of the strip draws exactly the triangles before one:
a window that ends there. There the strip goes on, where it can, more cheaply than by a restart
(:func:`_join_at_barrier`): across its last edge, its last triangle turned or swapped to end on an edge the
next triangle shares, or through its last vertex (``q q``, two degenerate triangles); with ``joins`` that
vertex join replaces a restart inside a block too, and with ``exact`` a block of at most that many triangles
is written by a bounded search (:func:`_strip_block`) instead of the look-ahead. Neither is used for skip
strips (:func:`_stripify` is bit for bit the stripifier without them).

The window trades indices for cache misses: each triangle taken ahead of the input order delays the ones it
skips. Ten shared meshes, skip strips at the defaults: FIFO misses over meshoptimizer's
``optimize_vertex_cache`` of the same triangles at 100/50/25/10 % of the triangles (mean of 40 points), and
the levels' uncollapsed strips (``level_indices``) over LOD 0's three indices a triangle: window 3 0.992 and
2.73, 4 (the default) 0.996 and 2.60, 5 1.006 and 2.49, 8 1.066 and 2.32. The former stripifier (no swap,
strips started at the least used vertex in the window): window 8 1.075 and 2.82, window 4 1.008 and 3.38.
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["decode_strip", "stripify"]

_BUDGET = 300  # nodes of a block's search (:func:`_search_block`)
# the lower-bound search that decides whether a block's other start is searched at all (:func:`_strip_block`)
# stops at this many times the budget, that start then left out: unbounded, one block of spot's cluster-swap
# pool in blocks of 10 took 0.39 s of the pool's 0.66 s
_LOWER_NODES = 8


@nb.njit(cache=True, inline="always")
def _needed_edge(out: np.ndarray, n: int, pos0: int) -> tuple[int, int]:
    """The directed edge ``(a, b)`` an input triangle must have to be the next triangle of the strip
    ``out[pos0:n]`` (its last two indices, flipped when that triangle's index in the strip is odd)."""
    if ((n - 2 - pos0) & 1) == 1:
        return out[n - 1], out[n - 2]
    return out[n - 2], out[n - 1]


@nb.njit(cache=True)
def _find_next(tris: np.ndarray, buf: np.ndarray, bsize: int, a: int, b: int) -> tuple[int, int]:
    """The first buffered triangle with directed edge ``a -> b``: ``(its buffer slot, its third vertex)``,
    or ``(-1, -1)``."""
    for i in range(bsize):
        t = buf[i]
        for j in range(3):
            if tris[t, j] == a and tris[t, (j + 1) % 3] == b:
                return i, tris[t, (j + 2) % 3]
    return -1, -1


@nb.njit(cache=True, inline="always")
def _block_start(
    tris: np.ndarray, out: np.ndarray, n: int, lt_pos: int, lt_tri: int, turnable: bool, v: int
) -> int:
    """The strip ``out[:n]`` with its last triangle turned to rotation ``v`` (``turnable``: a strip's first
    triangle, at ``lt_pos``), or written by a swap (``v`` = 3): its new count (a join at a barrier, a block's
    start)."""
    if turnable:
        for j in range(3):
            out[lt_pos + j] = tris[lt_tri, (v + j) % 3]
    elif v == 3:
        x = out[n - 1]
        out[n - 1] = out[n - 3]
        out[n] = x
        return n + 1
    return n


@nb.njit(cache=True)
def _join_at_barrier(
    tris: np.ndarray,
    buf: np.ndarray,
    bsize: int,
    out: np.ndarray,
    n: int,
    pos0: int,
    lt_kind: int,
    lt_pos: int,
    lt_tri: int,
) -> tuple[int, int, int, int]:
    """How the strip ``out[:n]`` goes on across a barrier to a buffered triangle (those after it), the
    cheapest way first: across its last edge (one index); across another edge of its last triangle, turned
    (a strip's first triangle, rewritten in another rotation: one index) or reached by a swap written before
    it ("x a v" -> "x a x v": two); through its last vertex q, "q q j" and the triangle's third vertex (two
    degenerate triangles, three indices, the parity kept); else none (a restart and three indices).
    Rewriting the last triangle keeps the prefix up to every earlier barrier. Returns (the index count, the
    barrier's position: the count that draws exactly the triangles before it, the continuation's buffer
    slot and vertex, or -1, -1)."""
    a, b = _needed_edge(out, n, pos0)
    cont, cont_v = _find_next(tris, buf, bsize, a, b)
    if cont >= 0:
        return n, n, cont, cont_v
    turnable = lt_kind == 0 and lt_pos == pos0 and n == lt_pos + 3
    t = lt_tri
    if turnable:
        # (a strip's first triangle is written at even parity: u v w, continued across w -> v)
        best_r = -1
        for r in range(3):
            s, c = _find_next(tris, buf, bsize, tris[t, (r + 2) % 3], tris[t, (r + 1) % 3])
            if s >= 0 and (best_r < 0 or s < cont):
                cont, cont_v, best_r = s, c, r
        if best_r >= 0:
            _block_start(tris, out, n, lt_pos, t, True, best_r)
            return n, n, cont, cont_v
    elif lt_kind == 1 and lt_pos == n - 1 and n - 3 >= pos0:
        v = out[n - 1]
        _block_start(tris, out, n, lt_pos, t, False, 3)
        a, b = _needed_edge(out, n + 1, pos0)
        cont, cont_v = _find_next(tris, buf, bsize, a, b)
        if cont >= 0:
            return n + 1, n + 1, cont, cont_v
        out[n - 1] = v
    # through a shared vertex: the first buffered triangle holding the last vertex (any of a turnable
    # triangle's, turned to end on it)
    for i in range(bsize):
        u = buf[i]
        for j in range(3):
            q = tris[u, j]
            r = -1
            if turnable:
                for k in range(3):
                    if tris[t, (k + 2) % 3] == q:
                        r = k
            elif q == out[n - 1]:
                r = 3
            if r < 0:
                continue
            if r < 3:
                _block_start(tris, out, n, lt_pos, t, True, r)
            # "q q j2 j3" draws (q, j2, j3) at even parity, (j2, q, j3) at odd: the triangle (q, y, z)
            out[n] = q
            out[n + 1] = tris[u, (j + 1) % 3] if ((n - pos0) & 1) == 0 else tris[u, (j + 2) % 3]
            a, b = _needed_edge(out, n + 2, pos0)
            cont, cont_v = _find_next(tris, buf, bsize, a, b)
            return n + 2, n, cont, cont_v
    return n, n, -1, -1


@nb.njit(cache=True)
def _apply(tris: np.ndarray, t: int, m: int, out: np.ndarray, n: int, pos0: int, restart: int) -> tuple:
    """Writes triangle ``t`` after the strip ``out[:n]`` in mode ``m`` (0 across the last edge, 1 the same by
    a swap, 2 through the last vertex, 3-5 a new strip in rotation m - 3): (the new count, the strip's first
    index, where the triangle sits for a later rewrite: modes 0-2 the position of its last index, the vertex
    it adds, which a swap test reads as ``n - 1``; modes 3-5 its first index, where a turn rewrites it), or
    n = -1 where the mode does not fit."""
    if m <= 2:
        if n - pos0 < 2:
            return -1, pos0, 0
        if m <= 1:
            a, b = _needed_edge(out, n, pos0)
            for j in range(3):
                if tris[t, j] == a and tris[t, (j + 1) % 3] == b:
                    if m == 0:
                        out[n] = tris[t, (j + 2) % 3]
                        return n + 1, pos0, n
                    out[n] = out[n - 2]
                    out[n + 1] = tris[t, (j + 2) % 3]
                    return n + 2, pos0, n + 1
            return -1, pos0, 0
        q = out[n - 1]
        for j in range(3):
            if tris[t, j] == q:
                out[n] = q
                if ((n - pos0) & 1) == 0:
                    out[n + 1] = tris[t, (j + 1) % 3]
                    out[n + 2] = tris[t, (j + 2) % 3]
                else:
                    out[n + 1] = tris[t, (j + 2) % 3]
                    out[n + 2] = tris[t, (j + 1) % 3]
                return n + 3, pos0, n + 2
        return -1, pos0, 0
    if n > 0:
        out[n] = restart
        n += 1
    r = m - 3
    for j in range(3):
        out[n + j] = tris[t, (r + j) % 3]
    return n + 3, n, n


@nb.njit(cache=True)
def _block_tables(
    tris: np.ndarray, lo: int, hi: int, em: np.ndarray, vm: np.ndarray, adj: np.ndarray, lbm: np.ndarray
) -> None:
    """For triangles ``lo..hi``: ``em[3 k + j]``, the bit mask of those with the directed edge ``j + 1 -> j``
    of triangle ``lo + k`` (the edge a strip goes on across after it), ``vm[3 k + j]`` those holding its
    vertex j, ``adj[k]`` those a strip may go on to from ``lo + k`` or from which to it (across an edge), and
    ``lbm[mask]`` a lower bound on the indices that the set ``mask`` of them takes after a strip."""
    K = hi - lo
    for k in range(K):
        for j in range(3):
            a = tris[lo + k, (j + 1) % 3]
            b = tris[lo + k, j]
            e = 0
            v = 0
            for i in range(K):
                t = lo + i
                for r in range(3):
                    if tris[t, r] == a and tris[t, (r + 1) % 3] == b:
                        e |= 1 << i
                    if tris[t, r] == b:
                        v |= 1 << i
            em[3 * k + j] = e
            vm[3 * k + j] = v
    for k in range(K):
        adj[k] = 0
    for k in range(K):
        for j in range(3):
            adj[k] |= em[3 * k + j]
            for i in range(K):
                if (em[3 * k + j] >> i) & 1:
                    adj[i] |= 1 << k
    # each set's triangles one index each, and two more for each of its connected parts (a chain across edges
    # starts through a vertex or as a new strip: 3 or 4 indices)
    lbm[0] = 0
    for mask in range(1, 1 << K):
        low = mask & -mask
        seen = 0
        grow = low
        while grow:
            seen |= grow
            nxt = 0
            for k in range(K):
                if (grow >> k) & 1:
                    nxt |= adj[k]
            grow = nxt & mask & ~seen
        lbm[mask] = lbm[mask & ~seen] + 2
        rest = seen
        while rest:
            lbm[mask] += 1
            rest &= rest - 1


@nb.njit(cache=True)
def _search_block(
    tris: np.ndarray,
    lo: int,
    hi: int,
    out: np.ndarray,
    n: int,
    pos0: int,
    restart: int,
    budget: int,
    best: np.ndarray,
    memo: np.ndarray,
    stamp: int,
    ws: np.ndarray,
    bound: int,
    lower: bool,
) -> int:
    """The least count after writing triangles ``lo..hi`` (any order, any modes of :func:`_apply`) after
    ``out[:n]``, depth-first within ``budget`` nodes; the choices (mode * (hi - lo) + triangle) into
    ``best``. ``ws`` (11, at least max(3 K, 2 ** K, 3) for K = hi - lo): scratch, so that a search allocates
    nothing (rows 7 to 10: :func:`_block_tables`). With ``lower``, only ways below ``bound`` are looked for,
    pruned by :func:`_block_tables`' lower bound and ended at the first one (or ``bound`` returned).

    Candidates are tried in the order (mode, triangle), the cheaper modes first, so that the first descent is
    the greedy one; one that cannot beat the best count so far (every triangle left costs one index at
    least) is not a node. Two shortcuts leave the nodes, the budget's count and the result as they were
    without them: a depth stops at the first mode too dear for the bound (the modes' least costs, 1 2 3 4
    indices, only grow), and the search ends at a count no way can go below (one index a triangle, or the
    lower bound of :func:`_block_tables` at the start)."""
    K = hi - lo
    ns = ws[0]
    ps = ws[1]
    cs = ws[2]
    um = ws[3]  # the triangles out at each depth, a bit mask
    fe = ws[4]  # the triangles left across the last edge at each depth, a bit mask
    fq = ws[5]  # the triangles left through the last vertex
    kl = ws[6]  # the last triangle written at each depth
    em = ws[7]  # the triangles across each triangle's edges (3 k + j: the edge j -> j + 1, reversed)
    vm = ws[8]  # the triangles through each triangle's vertices (3 k + j)
    lbm = ws[10]  # a lower bound on the count of each set of triangles (bit mask)
    ns[0] = n
    ps[0] = pos0
    cs[0] = -1
    um[0] = 0
    best_n = bound
    stop = n + K
    if lower:  # (asked whether any way beats bound: the first one found answers)
        stop = max(stop, bound - 1)
    full = (1 << K) - 1
    hmask = memo.shape[0] - 1  # (a power of two rows: the remainder as a mask)
    d = 0
    nodes = 0
    while d >= 0:
        if d == K:
            if ns[d] < best_n:
                best_n = ns[d]
                for k in range(K):
                    best[k] = cs[k]
                if best_n <= stop:
                    return best_n
            d -= 1
            continue
        if nodes >= budget:
            return best_n
        nd = ns[d]
        c = cs[d] + 1
        if c == 0:
            # first visit: the triangles left that fit the last edge (modes 0 and 1) and the last vertex (2)
            e0 = 0
            e2 = 0
            if nd - ps[d] >= 2:
                a, b = _needed_edge(out, nd, ps[d])
                q = out[nd - 1]
                found = 0
                if d > 0:
                    # the last edge and vertex are those of the last triangle (written by this search): its
                    # tables
                    k = kl[d]
                    t = lo + k
                    for j in range(3):
                        if tris[t, j] == b and tris[t, (j + 1) % 3] == a:
                            e0 = em[3 * k + j] & ~um[d]
                            found |= 1
                        if tris[t, j] == q:
                            e2 = vm[3 * k + j] & ~um[d]
                            found |= 2
                if found != 3:
                    e0 = 0
                    e2 = 0
                    for k in range(K):
                        if (um[d] >> k) & 1 == 0:
                            t = lo + k
                            for j in range(3):
                                if tris[t, j] == a and tris[t, (j + 1) % 3] == b:
                                    e0 |= 1 << k
                                if tris[t, j] == q:
                                    e2 |= 1 << k
            fe[d] = e0
            fq[d] = e2
            if lower or d == 0:
                # a bound on the count: every triangle left costs one index, and each chain of them across
                # edges (at least one a connected set of them, but the one that goes on across the last
                # edge) starts with two more (through the last vertex or a new strip)
                floor = nd + lbm[full & ~um[d]] - (2 if e0 != 0 else 0)
                if lower and floor >= best_n:
                    cs[d] = -1
                    d -= 1
                    continue
                if d == 0:  # a way at the bound is the least: the search may end there
                    stop = max(stop, floor)
        # (without a last edge or vertex fe and fq are empty: only a new strip) the first mode whose least
        # cost cannot beat best_n: the modes' least costs 1, 2, 3, then 4 (3 for a first strip)
        slack = best_n - nd - (K - d - 1)  # a candidate must cost less than this
        if slack <= 1:
            mend = 0
        elif slack == 2:
            mend = 1
        elif slack == 3:
            mend = 2
        elif slack == 4 and nd > 0:
            mend = 3
        else:
            mend = 6
        moved = False
        m = c // K  # (c = m * K + i; the candidates that fit walked as bits)
        i = c - m * K
        while m < mend:
            bits = (fe[d] if m <= 1 else (fq[d] if m == 2 else ~um[d] & ((1 << K) - 1))) >> i
            if bits == 0:
                m += 1
                i = 0
                continue
            while bits & 1 == 0:
                bits >>= 1
                i += 1
            nn, pp, _ = _apply(tris, lo + i, m, out, nd, ps[d], restart)
            ok = nn >= 0 and nn + (K - d - 1) < best_n
            if ok:
                # a state reached before at no more indices (the same triangles out, the same last two
                # indices and parity: the rest costs the same) is not searched again
                mask = um[d] | (1 << i)
                fa = out[nn - 2] if nn - pp >= 2 else -1
                fb = out[nn - 1] if nn - pp >= 2 else -1
                par = (nn - pp) & 1
                h = (mask * 1000003 + fa * 8191 + fb * 131071 + par * 17) & 0x7FFFFFFF & hmask
                key = (stamp << 24) | (mask << 1) | par  # (blocks of at most 23 triangles)
                if memo[h, 0] == key and memo[h, 1] == fa and memo[h, 2] == fb:
                    if memo[h, 3] <= nn:
                        ok = False
                    else:
                        memo[h, 3] = nn
                else:
                    memo[h, 0] = key
                    memo[h, 1] = fa
                    memo[h, 2] = fb
                    memo[h, 3] = nn
                if ok:
                    nodes += 1
                    cs[d] = m * K + i
                    ns[d + 1] = nn
                    ps[d + 1] = pp
                    cs[d + 1] = -1
                    um[d + 1] = mask
                    kl[d + 1] = i
                    d += 1
                    moved = True
                    break
            i += 1
        if not moved:
            cs[d] = -1
            d -= 1
    return best_n


@nb.njit(cache=True)
def _strip_block(
    tris: np.ndarray,
    lo: int,
    hi: int,
    out: np.ndarray,
    n: int,
    pos0: int,
    restart: int,
    budget: int,
    lt_kind: int,
    lt_pos: int,
    lt_tri: int,
    memo: np.ndarray,
    stamp: int,
    ws: np.ndarray,
) -> tuple:
    """Triangles ``lo..hi`` (a block between barriers) written after ``out[:n]`` at the least count
    :func:`_search_block` finds, the strip's last triangle first rewritten as a join at a barrier may
    (:func:`_join_at_barrier`: turned, or by a swap). ``ws`` (14, as :func:`_search_block`'s): scratch.
    Returns (the count, the position where the triangles before ``lo`` are drawn, pos0, and the last
    triangle's lt_kind, lt_pos, lt_tri, the memo's last stamp)."""
    K = hi - lo
    sw = ws[:11]
    tmp = ws[11]
    best = ws[12]
    saved = ws[13]
    _block_tables(tris, lo, hi, ws[7], ws[8], ws[9], ws[10])
    a0 = max(n - 3, 0)
    for j in range(n - a0):
        saved[j] = out[a0 + j]
    turnable = n > 0 and lt_kind == 0 and lt_pos == pos0 and n == lt_pos + 3
    swappable = n > 0 and lt_kind == 1 and lt_pos == n - 1 and n - 3 >= pos0
    best_total = np.int64(1 << 60)  # (int64, not a literal: the bound _search_block is compiled for)
    best_v = 0
    for v in range(4):
        # 0-2: the last triangle turned to rotation v (a strip's first one) or as written (v = 0); 3: a swap
        if best_total == n + K:  # one index a triangle: nothing does better
            break
        if (v > 0 and v < 3 and not turnable) or (v == 3 and not swappable):
            continue
        nv = _block_start(tris, out, n, lt_pos, lt_tri, turnable, v)
        stamp += 1
        # past the first start, a search with the lower bound first (at most _LOWER_NODES budgets): where no
        # way from this start beats the best count so far, neither does its budgeted search (which would not
        # be chosen)
        if best_total == 1 << 60 or (
            _search_block(
                tris,
                lo,
                hi,
                out,
                nv,
                pos0,
                restart,
                _LOWER_NODES * budget,
                tmp,
                memo,
                stamp,
                sw,
                best_total,
                np.bool_(True),
            )
            < best_total
        ):
            stamp += 1
            total = _search_block(
                tris,
                lo,
                hi,
                out,
                nv,
                pos0,
                restart,
                budget,
                tmp,
                memo,
                stamp,
                sw,
                np.int64(1 << 60),
                np.bool_(False),
            )
            if total < best_total:
                best_total = total
                best_v = v
                best[:K] = tmp[:K]
        for j in range(n - a0):
            out[a0 + j] = saved[j]
    nv = _block_start(tris, out, n, lt_pos, lt_tri, turnable, best_v)
    wend = nv
    n = nv
    for d in range(K):
        t = lo + best[d] % K
        m = best[d] // K
        n, pos0, p = _apply(tris, t, m, out, n, pos0, restart)
        lt_kind = 0 if m >= 3 else (2 if m == 1 else 1)
        lt_pos = p
        lt_tri = t
    return n, wend, pos0, lt_kind, lt_pos, lt_tri, stamp


@nb.njit(cache=True)
def _stripify(tris: np.ndarray, use_restart: bool, restart: int, window: int) -> np.ndarray:
    return _stripify_barriers(
        tris, use_restart, restart, window, np.empty(0, np.int64), np.bool_(False), np.int64(0)
    )[0]


@nb.njit(cache=True)
def _stripify_barriers(
    tris: np.ndarray,
    use_restart: bool,
    restart: int,
    window: int,
    barriers: np.ndarray,
    joins: bool,
    exact: int,
) -> tuple:
    """:func:`_stripify` with ``barriers``, sorted triangle positions the look-ahead never crosses (every
    triangle before one is emitted before any after it), so that a prefix of the strip draws exactly the
    triangles before it (a sliding window that ends there, :mod:`.sw_strips`); the strip goes on across a
    barrier by :func:`_join_at_barrier` where it can (else a restart). ``joins``: that function's vertex join
    (``q q``) also where the look-ahead would start a new strip inside a block; ``exact`` > 0: a block between
    barriers of at most that many triangles is written by :func:`_strip_block` instead (with restart indices
    only: ignored when ``use_restart`` is False). Returns (the strip, the strip position of every barrier:
    the index count that draws the triangles before it). No barrier, no joins: :func:`_stripify`'s strip."""
    memo, ws = _search_scratch(exact)
    strip, bpos, _ = _stripify_blocks(
        tris, use_restart, restart, window, barriers, joins, exact, memo, ws, np.int64(0), np.int64(_BUDGET)
    )
    return strip, bpos


@nb.njit(cache=True)
def _search_scratch(exact: int) -> tuple:
    """The block search's memo (:func:`_search_block`) and scratch (:func:`_strip_block`) for blocks of at
    most ``exact`` triangles, to be shared by every call of :func:`_stripify_blocks` (a memo entry counts
    only under its own stamp, so one that was written before never matches)."""
    if exact > 20:  # (a memo key holds the block's triangles as bits, a window of 2 ** exact bound entries)
        raise ValueError("blocks of at most 20 triangles")
    memo = np.zeros((512 if exact > 0 else 1, 4), np.int64)
    ws = np.zeros((14, max(3 * exact, 1 << exact, 3)), np.int64)
    return memo, ws


@nb.njit(cache=True)
def _stripify_blocks(
    tris: np.ndarray,
    use_restart: bool,
    restart: int,
    window: int,
    barriers: np.ndarray,
    joins: bool,
    exact: int,
    memo: np.ndarray,
    ws: np.ndarray,
    stamp: int,
    budget: int,
) -> tuple:
    """:func:`_stripify_barriers` with the search's scratch (:func:`_search_scratch`) passed in and its
    last memo stamp, ``budget`` the nodes of a block's search: (the strip, the barriers' strip positions,
    the stamp)."""
    T = tris.shape[0]
    B = barriers.shape[0]
    # (call arguments typed int64, not Literal[int](0): one compile of :func:`_strip_block` for every call)
    zero = np.int64(0)
    # at most 5 indices a triangle: a strip's first one after a degenerate join (2 + 3), a swap 2; a swap
    # across a barrier is one more index (at most one a barrier)
    out = np.empty(5 * T + 2 + B, np.int64)
    bpos = np.zeros(B, np.int64)
    if T == 0:
        return out[:0], bpos, stamp
    buf = np.empty(window, np.int64)
    bsize = 0
    next_in = 0
    n = np.int64(0)
    pos0 = np.int64(0)  # first index of the current strip (parity origin)
    cont = -1  # buffer slot of the triangle that continues the strip, found as the last one was emitted
    cont_v = -1  # its vertex off the strip's last edge
    nb_ = 0  # barriers passed
    limit = T  # the input is buffered up to the next barrier only
    # the last emitted triangle, for a join at a barrier: how it was written (0 a strip's first triangle, 1 a
    # continuation by one index, 2 by a swap), its first index's position, its input triangle
    lt_kind = np.int64(2)
    lt_pos = np.int64(0)
    lt_tri = np.int64(0)
    while nb_ < B and barriers[nb_] <= 0:
        nb_ += 1
    if nb_ < B:
        limit = min(barriers[nb_], T)
    if not use_restart:
        # the block search starts its new strips after a restart index (:func:`_apply`): without restarts
        # (degenerate joins) it would write the restart value into the strip as a vertex
        exact = 0
    if exact > 0 and 0 < limit <= exact:
        n, _, pos0, lt_kind, lt_pos, lt_tri, stamp = _strip_block(
            tris, zero, limit, out, zero, zero, restart, budget, lt_kind, lt_pos, lt_tri, memo, stamp, ws
        )
        next_in = limit
    while True:
        while bsize < window and next_in < limit:
            buf[bsize] = next_in
            bsize += 1
            next_in += 1
        if bsize == 0:
            if next_in >= T:
                break
            # every triangle before the barrier is out: the strip's prefix up to here draws exactly them
            nb0 = nb_
            while nb_ < B and barriers[nb_] <= next_in:
                nb_ += 1
            limit = min(barriers[nb_], T) if nb_ < B else T
            if exact > 0 and 0 < limit - next_in <= exact:
                # a short block: the least count a search finds, in any order
                n, wend, pos0, lt_kind, lt_pos, lt_tri, stamp = _strip_block(
                    tris,
                    next_in,
                    limit,
                    out,
                    n,
                    pos0,
                    restart,
                    budget,
                    lt_kind,
                    lt_pos,
                    lt_tri,
                    memo,
                    stamp,
                    ws,
                )
                for i in range(nb0, nb_):
                    bpos[i] = wend
                next_in = limit
                cont = -1
                continue
            while bsize < window and next_in < limit:
                buf[bsize] = next_in
                bsize += 1
                next_in += 1
            if n > 0:
                n, wend, cont, cont_v = _join_at_barrier(
                    tris, buf, bsize, out, n, pos0, lt_kind, lt_pos, lt_tri
                )
            else:
                wend = n
            for i in range(nb0, nb_):
                bpos[i] = wend
            continue
        # the continuation found as the last triangle was emitted, else a new strip at the first buffered
        # triangle (the input's order)
        if cont < 0 and joins and n > 0:
            # a buffered triangle through the last vertex: a join of three indices, not a restart and three
            n, _, cont, cont_v = _join_at_barrier(tris, buf, bsize, out, n, pos0, lt_kind, lt_pos, lt_tri)
        pick = cont if cont >= 0 else 0
        t = buf[pick]
        for i in range(pick, bsize - 1):
            buf[i] = buf[i + 1]
        bsize -= 1
        # the next triangle is looked for among the buffered ones, the freed slot refilled first
        if next_in < limit:
            buf[bsize] = next_in
            bsize += 1
            next_in += 1
        lt_tri = t
        if cont >= 0:
            v = cont_v
            lt_kind = 1
            lt_pos = n
            # emitted as v, the strip goes on across (last, v); if no buffered triangle is there but one is
            # across (second last, v), a swap reaches it: "a b" -> "a b a v" (a degenerate triangle, then
            # this one with its winding) for one index more than a restart would cost
            out[n] = v
            a, b = _needed_edge(out, n + 1, pos0)
            cont, cont_v = _find_next(tris, buf, bsize, a, b)
            if cont < 0:
                out[n] = out[n - 2]
                out[n + 1] = v
                a, b = _needed_edge(out, n + 2, pos0)
                cont, cont_v = _find_next(tris, buf, bsize, a, b)
                if cont >= 0:
                    lt_kind = 2
                    n += 2
                    continue
                out[n] = v
            n += 1
            continue
        # rotation (u, v, w): the strip goes on across v-w (an input triangle with edge w -> v, whatever
        # the parity); the rotation whose continuation comes first in the buffer, the input (cache) order
        best_r = 0
        cont = -1
        for r in range(3):
            s, c = _find_next(tris, buf, bsize, tris[t, (r + 2) % 3], tris[t, (r + 1) % 3])
            if s >= 0 and (cont < 0 or s < cont):
                cont, cont_v = s, c
                best_r = r
        u = tris[t, best_r]
        v = tris[t, (best_r + 1) % 3]
        w = tris[t, (best_r + 2) % 3]
        if n > 0:
            if use_restart:
                out[n] = restart
                n += 1
                pos0 = n
            else:
                out[n] = out[n - 1]
                out[n + 1] = u
                n += 2
        lt_kind = 0
        lt_pos = n
        out[n] = u
        if ((n - pos0) & 1) == 0:
            out[n + 1] = v
            out[n + 2] = w
        else:
            out[n + 1] = w
            out[n + 2] = v
        n += 3
        # (cont, cont_v): the rotation's continuation found above, across the edge _needed_edge gives now
    while nb_ < B:  # barriers at or past the end
        bpos[nb_] = n
        nb_ += 1
    return out[:n].copy(), bpos, stamp


def stripify(
    triangles: np.ndarray, vertex_count: int, restart_index: int | None = 0xFFFFFFFF, window: int = 4
) -> np.ndarray:
    """Turn ``triangles`` (T, 3), in their preferred (vertex-cache) order, into one strip (int64).

    ``vertex_count``: every index must be below it. ``restart_index`` separates strips (``None``: join them
    with degenerate triangles instead). ``window`` is how many of the next not yet emitted input triangles
    may continue a strip (module docstring), an integer (below 1 taken as 1; a window past the triangle count
    draws as one of the triangle count, and allocates no more). Decoding the result with :func:`decode_strip`
    gives exactly the input triangles (as a multiset) with their winding.
    """
    if isinstance(window, (bool, np.bool_)) or not isinstance(window, (int, np.integer)):
        raise ValueError(f"window must be an integer, got {window!r}")
    tris = np.ascontiguousarray(np.asarray(triangles).reshape(-1, 3), dtype=np.int64)
    use_restart = restart_index is not None
    r = int(restart_index) if use_restart else -1
    top = int(tris.max()) if tris.size else -1
    if tris.size and (top >= int(vertex_count) or tris.min() < 0):
        raise ValueError(f"vertex indices must be in [0, {int(vertex_count)})")
    if use_restart and top >= r:
        raise ValueError("vertex indices must be non-negative and below the restart index")
    # the buffer never holds more than the T triangles: a larger window allocated window * 8 bytes for nothing
    # (window=2**40: a MemoryError)
    return _stripify(tris, use_restart, r, max(1, min(int(window), tris.shape[0])))


@nb.njit(cache=True)
def _decode(strip: np.ndarray, restart: int, has_restart: bool, keep_degenerate: bool) -> np.ndarray:
    out = np.empty((max(strip.shape[0] - 2, 0), 3), np.int64)
    n = 0
    run = 0
    a = -1
    b = -1
    for i in range(strip.shape[0]):
        c = strip[i]
        if has_restart and c == restart:
            run = 0
            continue
        if run >= 2 and (keep_degenerate or (a != b and b != c and a != c)):
            if ((run - 2) & 1) == 0:
                out[n, 0] = a
                out[n, 1] = b
            else:
                out[n, 0] = b
                out[n, 1] = a
            out[n, 2] = c
            n += 1
        a = b
        b = c
        run += 1
    return out[:n].copy()


def decode_strip(
    strip: np.ndarray, restart_index: int | None = None, keep_degenerate: bool = False
) -> np.ndarray:
    """The triangles a strip draws, (n, 3) int64 with their winding (odd triangles flipped back).

    Restart indices end a strip; degenerate triangles are skipped unless ``keep_degenerate``.
    """
    s = np.ascontiguousarray(np.asarray(strip).reshape(-1), dtype=np.int64)
    has = restart_index is not None
    return _decode(s, int(restart_index) if has else -1, has, bool(keep_degenerate))
