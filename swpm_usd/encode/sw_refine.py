"""Local search on a sliding-window level's patch order: fewer FIFO vertex-cache misses over all its windows.

A level's pool is ``P_1..P_n || M || Q_1..Q_n`` and its window ``j`` is the slice from ``P_{j+1}`` to ``Q_j``,
drawn from a cold cache. The greedy order (:func:`.sw_kernels.order_patches`, TD-VIPM 3.2) picks one patch at
a time; this pass then moves runs of patches (``max_run`` long) by up to ``reach`` places (or-opt) wherever
that lowers the misses summed over the level's windows, the cache simulated index by index (FIFO).

How the sum is counted: every window is a slice of one run over the whole level, so a block's misses in
that run count once per window that draws it (``P`` at position ``a``, from 0: ``a + 1`` windows; ``M``:
``n + 1``; ``Q`` at position ``a``: ``n - a``), plus each window's cold start: the extra misses of the run
started cold at its first block over the warm run, simulated until the two caches hold the same or for
:data:`_COLD_BLOCKS` blocks. A move changes the warm run from the moved place until the caches agree
again; it is evaluated up to :data:`_HORIZON` blocks past the change, with the cold starts inside the
change simulated again (only if they could make the move the best one: they can gain at most their old
terms and warm misses) and those past it (which draw only unchanged blocks) corrected by what the warm run
lost or gained there; a move taken is simulated until the caches agree (at most :data:`_SETTLE` blocks).
The sum is then close to the exact one: on levels of spot, suzanne and beetle the search lowers the exact
sum (every window simulated on its own, :func:`window_misses`) by 1.5-4 %, within 0.6 % of a search that
evaluates every move exactly.

Patches that collapse onto a common target keep their relative order: a target's quadric grows with every
collapse onto it, so every collapse then costs what it cost when the level was built. Otherwise the
patches of a level are independent (their inner vertices are not adjacent and their triangles disjoint),
so any order draws valid meshes; the caller permutes the level's records with the patches.
"""

from __future__ import annotations

import numba as nb
import numpy as np

#: blocks a move's effect on the warm run is followed past the moved place (ten meshes, ACMR ratio mean
#: over 40 fractions with the search: 2 loses about half its gain, 10 gains no more than 4)
_HORIZON = 4
#: the same for a move taken: past it the run's stored caches and misses are kept as they were
_SETTLE = 40
#: blocks a window's cold start is simulated (8 gives the same sums within 0.3 % for twice the time)
_COLD_BLOCKS = 3


@nb.njit(cache=True, inline="always")
def _load(
    snap: np.ndarray, r: int, stamp: np.ndarray, ver: np.ndarray, version: int, log: np.ndarray, C: int
) -> int:
    """Start a simulation from the cache content ``snap[r]`` (oldest first, -1 empty): returns the push
    count."""
    for i in range(C):
        v = snap[r, i]
        log[i] = v
        if v >= 0:
            ver[v] = version
            stamp[v] = i
    return C


@nb.njit(cache=True, inline="always")
def _draw(vs, a0, a1, stamp, ver, version, log, t, C):
    """FIFO misses of ``vs[a0:a1]``: a vertex is cached if pushed (``stamp``) in this simulation
    (``ver == version``) within the last ``C`` pushes. Returns ``(misses, push count)``."""
    m = 0
    for i in range(a0, a1):
        v = vs[i]
        if ver[v] != version or t - stamp[v] > C:
            ver[v] = version
            stamp[v] = t
            log[t] = v
            t += 1
            m += 1
    return m, t


@nb.njit(cache=True, inline="always")
def _agrees(log: np.ndarray, t: int, snap: np.ndarray, r: int, C: int) -> bool:
    for i in range(C):
        if log[t - C + i] != snap[r, i]:
            return False
    return True


@nb.njit(cache=True, inline="always")
def _weight(a: int, n: int) -> int:
    """Windows that draw the block at run position ``a`` (``P``: ``a < n``, ``M``: ``a == n``, then ``Q``)."""
    if a <= n:
        return a + 1
    return 2 * n + 1 - a


@nb.njit(cache=True)
def _run(
    seq,
    lo,
    cap,
    qlo,
    qhi,
    vs,
    vstart,
    snap,
    out_snap,
    snap_until,
    out_m,
    stamp,
    ver,
    version,
    log,
    C,
    horizon,
):
    """Simulate the run ``seq`` from position ``lo`` (cache ``snap[lo]``): ``out_m[a]`` the misses at
    position ``a``, ``out_snap[a + 1]`` the cache after it (up to ``snap_until``). Stops at the first
    position ``a >= cap`` whose cache equals the stored ``snap[a]`` (nothing later changes), or ``horizon``
    positions past ``cap`` (``horizon < 0``: never). Reaching ``qlo`` (the first changed ``Q`` block) moves
    ``cap`` to ``qhi``. Returns the end position."""
    N = seq.shape[0]
    t = _load(snap, lo, stamp, ver, version, log, C)
    a = lo
    while a < N:
        b = seq[a]
        m, t = _draw(vs, vstart[b], vstart[b + 1], stamp, ver, version, log, t, C)
        out_m[a] = m
        a += 1
        if a > qlo and cap < qhi:
            cap = qhi
        same = a >= cap and _agrees(log, t, snap, a, C)
        if a <= snap_until:
            for i in range(C):
                out_snap[a, i] = log[t - C + i]
        if same:
            return a
        if horizon >= 0 and a >= cap + horizon:
            return a
    return a


@nb.njit(cache=True)
def _cold_extra(seq, a, n, vs, vstart, snap, new_snap, new_m, lo, end, m_run, stamp, ver, version, log, C):
    """Extra misses of the window starting cold at position ``a`` over the warm run (positions in
    ``[lo, end)`` read the candidate run's ``new_m`` / ``new_snap``), and the blocks simulated."""
    t = C
    for i in range(C):
        log[i] = -1
    extra = 0
    b = a
    while b < seq.shape[0] and b < a + _COLD_BLOCKS:
        blk = seq[b]
        m, t = _draw(vs, vstart[blk], vstart[blk + 1], stamp, ver, version, log, t, C)
        extra += m - (new_m[b] if lo <= b < end else m_run[b])
        b += 1
        if lo < b <= end:
            if _agrees(log, t, new_snap, b, C):
                break
        elif _agrees(log, t, snap, b, C):
            break
    return extra, b - a


@nb.njit(cache=True)
def _settled_windows(a0, a1, end, m_run, new_m, cold, write):
    """Windows starting at ``a`` in ``[a0, a1)``, past the moved patches, draw only unchanged blocks and
    agree with the *old* warm run: their cold-start term changes by what the warm run's misses change over
    ``[a, end)``. Returns the summed change (``write``: also applied to ``cold``)."""
    total = 0
    suffix = 0
    for a in range(end - 1, a0 - 1, -1):
        suffix += m_run[a] - new_m[a]
        if a < a1:
            total += suffix
            if write:
                cold[a] += suffix
    return total


@nb.njit(cache=True)
def _arrange(order, out, i, s, k):
    """``out`` = ``order`` with its run ``[i, i + s)`` moved to place ``k`` (of the order without it), in
    ``out[lo:hi]``; returns ``(lo, hi)``."""
    if k < i:
        for x in range(s):
            out[k + x] = order[i + x]
        for x in range(k, i):
            out[x + s] = order[x]
        return k, i + s
    for x in range(i, k):
        out[x] = order[x + s]
    for x in range(s):
        out[k + x] = order[i + x]
    return i, k + s


@nb.njit(cache=True)
def _crosses_target(order, i, s, k, target_start, targets, mark, stamp_id):
    """Whether moving run ``[i, i + s)`` to ``k`` passes a patch with a collapse target of the run's."""
    for x in range(i, i + s):
        p = order[x]
        for r in range(target_start[p], target_start[p + 1]):
            mark[targets[r]] = stamp_id
    a, b = (k, i) if k < i else (i + s, k + s)
    for x in range(a, b):
        p = order[x]
        for r in range(target_start[p], target_start[p + 1]):
            if mark[targets[r]] == stamp_id:
                return True
    return False


@nb.njit(cache=True)
def refine_patch_order(
    block_start: np.ndarray,
    blocks: np.ndarray,
    n: int,
    target_start: np.ndarray,
    targets: np.ndarray,
    target_count: int,
    vertex_count: int,
    cache_size: int,
    reach: int,
    max_run: int,
    passes: int,
) -> np.ndarray:
    """New order (old patch index per place) of a level's ``n`` patches, drawn in index order so far.

    ``blocks[block_start[b]:block_start[b + 1]]`` is block ``b``'s index sequence: ``P`` of patch ``p`` is
    block ``p``, ``M`` block ``n``, ``Q`` of patch ``p`` block ``n + 1 + p``. Patch ``p``'s collapse
    targets are ``targets[target_start[p]:target_start[p + 1]]`` (ids below ``target_count``)."""
    order = np.arange(n, dtype=np.int64)
    if n < 3:
        return order
    C = cache_size
    N = 2 * n + 1
    seq = np.empty(N, np.int64)
    for a in range(n):
        seq[a] = a
        seq[n + 1 + a] = n + 1 + a
    seq[n] = n
    # cache content before each run position, oldest first (int32: 19 MB each for 150,000 patches)
    snap = np.full((N + 1, C), -1, np.int32)
    new_snap = np.full((N + 1, C), -1, np.int32)
    m_run = np.zeros(N, np.int64)
    new_m = np.zeros(N, np.int64)
    cold = np.zeros(n + 1, np.int64)  # window j's cold start, at run position j (M for j = n)
    stamp = np.zeros(vertex_count, np.int64)
    ver = np.zeros(vertex_count, np.int64)
    log = np.empty(C + blocks.shape[0] + 1, np.int32)
    mark = np.zeros(target_count, np.int64)
    version = 1
    _run(seq, 0, N, N, N, blocks, block_start, snap, snap, N, m_run, stamp, ver, version, log, C, -1)
    for a in range(1, n + 1):
        version += 1
        cold[a], _ = _cold_extra(
            seq, a, n, blocks, block_start, snap, snap, m_run, 0, 0, m_run, stamp, ver, version, log, C
        )
    dont_look = np.zeros(n, np.bool_)  # per patch: no move of its improved the last time it was tried
    cand = seq.copy()
    marks = 0
    for _ in range(passes):
        improved = False
        for i in range(n):
            if dont_look[seq[i]]:
                continue
            moved = False
            for s in range(1, max_run + 1):
                if i + s > n:
                    break
                best = 0
                best_k = -1
                for k in range(max(0, i - reach), min(n - s, i + reach) + 1):
                    if k == i:
                        continue
                    marks += 1
                    if _crosses_target(seq, i, s, k, target_start, targets, mark, marks):
                        continue
                    lo, hi = _arrange(seq, cand, i, s, k)
                    for x in range(lo, hi):
                        cand[n + 1 + x] = n + 1 + cand[x]
                    version += 1
                    end = _run(
                        cand,
                        lo,
                        hi,
                        n + 1 + lo,
                        n + 1 + hi,
                        blocks,
                        block_start,
                        snap,
                        new_snap,
                        hi + _COLD_BLOCKS,
                        new_m,
                        stamp,
                        ver,
                        version,
                        log,
                        C,
                        _HORIZON,
                    )
                    d = 0
                    for a in range(lo, end):
                        d += _weight(a, n) * (new_m[a] - m_run[a])
                    if end < n + 1 + lo:  # settled before the Q blocks: follow them on their own
                        version += 1
                        end_q = _run(
                            cand,
                            n + 1 + lo,
                            n + 1 + hi,
                            N,
                            N,
                            blocks,
                            block_start,
                            snap,
                            new_snap,
                            0,
                            new_m,
                            stamp,
                            ver,
                            version,
                            log,
                            C,
                            _HORIZON,
                        )
                        for a in range(n + 1 + lo, end_q):
                            d += _weight(a, n) * (new_m[a] - m_run[a])
                    d += _settled_windows(hi, min(n + 1, end), end, m_run, new_m, cold, False)
                    # the cold starts inside the change can lower d by at most their warm misses and old
                    # terms: simulate them only if that could make this move the best
                    bound = 0
                    for a in range(max(1, lo), min(n + 1, hi)):
                        bound += cold[a]
                        for b in range(a, min(a + _COLD_BLOCKS, N)):
                            bound += new_m[b] if lo <= b < end else m_run[b]
                    if d - bound >= best:
                        for x in range(lo, hi):
                            cand[x] = seq[x]
                            cand[n + 1 + x] = seq[n + 1 + x]
                        continue
                    for a in range(max(1, lo), min(n + 1, hi)):
                        version += 1
                        extra, _ = _cold_extra(
                            cand,
                            a,
                            n,
                            blocks,
                            block_start,
                            snap,
                            new_snap,
                            new_m,
                            lo,
                            end,
                            m_run,
                            stamp,
                            ver,
                            version,
                            log,
                            C,
                        )
                        d += extra - cold[a]
                    if d < best:
                        best = d
                        best_k = k
                    for x in range(lo, hi):
                        cand[x] = seq[x]
                        cand[n + 1 + x] = seq[n + 1 + x]
                if best_k < 0:
                    continue
                moved = True
                lo, hi = _arrange(seq, cand, i, s, best_k)
                for x in range(lo, hi):
                    seq[x] = cand[x]
                    seq[n + 1 + x] = n + 1 + cand[x]
                    cand[n + 1 + x] = seq[n + 1 + x]
                version += 1
                end = _run(
                    seq,
                    lo,
                    hi,
                    n + 1 + lo,
                    n + 1 + hi,
                    blocks,
                    block_start,
                    snap,
                    snap,
                    N,
                    new_m,
                    stamp,
                    ver,
                    version,
                    log,
                    C,
                    _SETTLE,
                )
                _settled_windows(hi, min(n + 1, end), end, m_run, new_m, cold, True)
                for a in range(lo, end):
                    m_run[a] = new_m[a]
                if end < n + 1 + lo:
                    version += 1
                    _run(
                        seq,
                        n + 1 + lo,
                        n + 1 + hi,
                        N,
                        N,
                        blocks,
                        block_start,
                        snap,
                        snap,
                        N,
                        m_run,
                        stamp,
                        ver,
                        version,
                        log,
                        C,
                        _SETTLE,
                    )
                for a in range(max(1, lo - _COLD_BLOCKS), min(n + 1, hi)):
                    version += 1
                    cold[a], _ = _cold_extra(
                        seq,
                        a,
                        n,
                        blocks,
                        block_start,
                        snap,
                        snap,
                        m_run,
                        0,
                        0,
                        m_run,
                        stamp,
                        ver,
                        version,
                        log,
                        C,
                    )
                for x in range(max(0, lo - reach - 1), min(n, end + reach + 1)):
                    dont_look[seq[x]] = False
                improved = True
            if not moved:
                dont_look[seq[i]] = True
        if not improved:
            break
    for a in range(n):
        order[a] = seq[a]
    return order


def window_misses(
    block_start: np.ndarray, blocks: np.ndarray, n: int, order: np.ndarray, cache_size: int
) -> int:
    """The misses summed over a level's windows, each simulated on its own (for tests: what
    :func:`refine_patch_order` lowers)."""
    from ..metrics import cache_misses

    total = 0
    for j in range(n + 1):
        parts = [blocks[block_start[p] : block_start[p + 1]] for p in order[j:]]
        parts.append(blocks[block_start[n] : block_start[n + 1]])
        parts += [blocks[block_start[n + 1 + p] : block_start[n + 2 + p]] for p in order[:j]]
        total += cache_misses(np.concatenate(parts), cache_size)[0]
    return int(total)
