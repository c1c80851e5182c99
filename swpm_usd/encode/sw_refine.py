"""Local search on a sliding-window level's patch order: fewer FIFO vertex-cache misses over all its windows.

A level's pool is ``P_1..P_n || M || Q_1..Q_n`` and its window ``j`` is the slice from ``P_{j+1}`` to ``Q_j``,
drawn from a cold cache. The greedy order (:func:`.sw_order.order_patches`, TD-VIPM 3.2) picks one patch at
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
evaluates every move exactly. On a level of a few patches it can still end above its greedy start (a move's
evaluation leaves out the cold starts of the windows just before it and those reaching its moved ``Q``
blocks, a large share of so few windows): :func:`.sw_layout._finish` counts both orders of a small level
exactly (:func:`exact_window_misses`) and keeps the better. A move counted exactly under this model (every
window whose cold start reads a changed position simulated again, the warm run followed until it agrees)
cost the search 1.9 times its time for 0.12 % fewer misses and no better ACMR (``slidingwindow.md``, "Exact
moves"); ``tests/test_sw_refine_delta.py`` recounts the model in Python.

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
#: a vertex in more patches than this does not make them neighbours (``long_reach``: a hub's patches are
#: not near each other in any useful sense, and its list would make the neighbour lists quadratic)
_NEIGHBOUR_HUB = 16


# A simulation's state, one tuple for every helper: ``(blocks, block_start, key, log)``. A vertex is in the
# cache if pushed in this simulation within the last ``C`` pushes: ``key`` holds ``version * _KEY + push
# count`` of its last push, so that is ``key >= version * _KEY + t - C`` (``t >= C`` at every draw: a
# simulation starts at ``C``), one array read per index instead of a version and a push count apart (the
# search's time -6 to -9 %, the same orders: its 57 calls in builds of cow, teapot, suzanne and fandisk);
# ``log`` lists the pushes, so the cache is ``log[t - C:t]`` (oldest first).
# Every helper is inlined into :func:`refine_patch_order` (``inline="always"``): called, they took 11-13 %
# more of the search's time (cow, fandisk, beetle: the tuples passed on every call), for ~3 s more of a cold
# compile.


#: a simulation's ``version`` times this, plus a push count (below it: at most ``C`` + the level's indices)
_KEY = np.int64(1) << 32


@nb.njit(cache=True, inline="always")
def _load(snap, r, sim, version):
    """Start a simulation from the cache content ``snap[r]`` (-1: empty): returns the push count."""
    key, log = sim[2], sim[3]
    C = snap.shape[1]
    base = version * _KEY
    for i in range(C):
        v = snap[r, i]
        log[i] = v
        if v >= 0:
            key[v] = base + i
    return C


@nb.njit(cache=True, inline="always")
def _draw(sim, b, version, t, C):
    """FIFO misses of block ``b`` from push count ``t``. Returns ``(misses, push count)``."""
    blocks, block_start, key, log = sim
    base = version * _KEY
    t0 = t
    # without a branch on the miss (about a fifth of the indices miss, unpredictably): the index written
    # to the log at ``t`` whatever, kept only by a miss moving ``t`` on (the log past ``t`` is not read),
    # and the key rewritten unchanged on a hit (the search -20 %, 166-181 -> 134-138 ms over 98 captured
    # levels of seven meshes, two alternating runs; the same orders)
    for i in range(block_start[b], block_start[b + 1]):
        v = blocks[i]
        kv = key[v]
        miss = kv < base + t - C
        log[t] = v
        key[v] = base + t if miss else kv
        t += np.int64(miss)
    return t - t0, t


@nb.njit(cache=True, inline="always")
def _agrees(sim, t, snap, r):
    log = sim[3]
    C = snap.shape[1]
    for i in range(C):
        if log[t - C + i] != snap[r, i]:
            return False
    return True


@nb.njit(cache=True, inline="always")
def _agrees_log(sim, t, other, u, C):
    """Whether the cache of ``sim`` at push count ``t`` equals ``other[u - C:u]`` (another run's log)."""
    log = sim[3]
    for i in range(C):
        if log[t - C + i] != other[u - C + i]:
            return False
    return True


@nb.njit(cache=True, inline="always")
def _weight(a: int, n: int) -> int:
    """Windows that draw the block at run position ``a`` (``P``: ``a < n``, ``M``: ``a == n``, then ``Q``)."""
    if a <= n:
        return a + 1
    return 2 * n + 1 - a


@nb.njit(cache=True, inline="always")
def _run(seq, lo, cap, q_change, snap, out_snap, out_t, snap_until, out_m, sim, version, horizon):
    """Simulate the run ``seq`` from position ``lo`` (cache ``snap[lo]``): ``out_m[a]`` the misses at
    position ``a``, ``out_snap[a + 1]`` the cache after it (up to ``snap_until``). Stops at the first
    position ``a >= cap`` whose cache equals the stored ``snap[a]`` (nothing later changes), or ``horizon``
    positions past ``cap`` (``horizon < 0``: never). Reaching ``q_change = (first, end)``, the changed
    ``Q`` blocks, moves ``cap`` to their end. With ``out_t`` not empty, ``out_t[a + 1]`` gets the push
    count after position ``a`` instead (the cache then is ``log[out_t[a + 1] - C:out_t[a + 1]]`` while no
    other simulation writes that log). Returns the end position."""
    N = seq.shape[0]
    C = snap.shape[1]
    t = _load(snap, lo, sim, version)
    a = lo
    while a < N:
        m, t = _draw(sim, seq[a], version, t, C)
        out_m[a] = m
        a += 1
        if a > q_change[0] and cap < q_change[1]:
            cap = q_change[1]
        same = a >= cap and _agrees(sim, t, snap, a)
        if a <= snap_until:
            if out_t.shape[0]:
                out_t[a] = t
            else:
                for i in range(C):
                    out_snap[a, i] = sim[3][t - C + i]
        if same:
            return a
        if horizon >= 0 and a >= cap + horizon:
            return a
    return a


@nb.njit(cache=True, inline="always")
def _cold_extra(seq, a, snap, m_run, new, sim, version):
    """Extra misses of the window starting cold at position ``a`` over the warm run. ``new = (lo, end,
    new_m, new_t, new_log)``: positions in ``[lo, end)`` read the candidate run's misses and caches (the
    cache before position ``b``: ``new_log[new_t[b] - C:new_t[b]]``, :func:`_run`'s ``out_t``); ``sim``'s
    log must not be ``new_log``."""
    lo, end, new_m, new_t, new_log = new
    C = snap.shape[1]
    log = sim[3]
    t = C
    for i in range(C):
        log[i] = -1
    extra = 0
    b = a
    while b < seq.shape[0] and b < a + _COLD_BLOCKS:
        m, t = _draw(sim, seq[b], version, t, C)
        extra += m - (new_m[b] if lo <= b < end else m_run[b])
        b += 1
        if lo < b <= end:
            if _agrees_log(sim, t, new_log, new_t[b], C):
                break
        elif _agrees(sim, t, snap, b):
            break
    return extra


@nb.njit(cache=True, inline="always")
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


@nb.njit(cache=True, inline="always")
def _arrange(seq, cand, n, i, s, k):
    """``cand`` = ``seq`` with its run of patches ``[i, i + s)`` moved to place ``k`` (of the order
    without it), the ``P`` places and the ``Q`` places alike; returns the changed ``P`` places
    ``(lo, hi)``."""
    if k < i:
        for x in range(s):
            cand[k + x] = seq[i + x]
        for x in range(k, i):
            cand[x + s] = seq[x]
        lo, hi = k, i + s
    else:
        for x in range(i, k):
            cand[x] = seq[x + s]
        for x in range(s):
            cand[k + x] = seq[i + x]
        lo, hi = i, k + s
    for x in range(lo, hi):
        cand[n + 1 + x] = n + 1 + cand[x]
    return lo, hi


@nb.njit(cache=True, inline="always")
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


@nb.njit(cache=True, inline="always")
def _move_delta(cand, lo, hi, n, best, run, sim, sim2, version):
    """The change of the window-weighted sum if the run were ``cand`` (changed in ``[lo, hi)`` and the same
    ``Q`` places), or any value ``>= best`` once the move cannot beat ``best``. ``run = (snap, m_run,
    cold, new_t, new_m)``. ``sim2``: ``sim`` with a log of its own, for the simulations after the first
    (whose caches stay in ``sim``'s log, read through ``new_t``). Returns ``(delta, version)``."""
    snap, m_run, cold, new_t, new_m = run
    N = cand.shape[0]
    q_change = (n + 1 + lo, n + 1 + hi)
    version += 1
    # the candidate's caches as push counts into its log, not copied: the cold starts below read a few
    # of them, and only for a move that could win (the search -3 %, medians of three alternating runs
    # over 98 captured levels of seven meshes: 172.7 -> 166.8 ms)
    end = _run(cand, lo, hi, q_change, snap, snap, new_t, hi + _COLD_BLOCKS, new_m, sim, version, _HORIZON)
    d = 0
    for a in range(lo, end):
        d += _weight(a, n) * (new_m[a] - m_run[a])
    if end <= q_change[0]:  # stopped before the changed Q blocks: follow them on their own
        version += 1
        end_q = _run(
            cand, q_change[0], q_change[1], (N, N), snap, snap, new_t[:0], 0, new_m, sim2, version, _HORIZON
        )
        for a in range(q_change[0], end_q):
            d += _weight(a, n) * (new_m[a] - m_run[a])
    d += _settled_windows(hi, min(n + 1, end), end, m_run, new_m, cold, False)
    # the cold starts inside the change can lower d by at most their old terms and warm misses: simulate
    # them only if that could make this move the best
    bound = 0
    for a in range(max(1, lo), min(n + 1, hi)):
        bound += cold[a]
        for b in range(a, min(a + _COLD_BLOCKS, N)):
            bound += new_m[b] if lo <= b < end else m_run[b]
    if d - bound >= best:
        return d - bound, version
    # then each one simulated in turn, its term no longer bounded: the bound of those left may settle the
    # move before the last (exact: a value >= best once it cannot win, as above)
    for a in range(max(1, lo), min(n + 1, hi)):
        version += 1
        d += _cold_extra(cand, a, snap, m_run, (lo, end, new_m, new_t, sim[3]), sim2, version) - cold[a]
        bound -= cold[a]
        for b in range(a, min(a + _COLD_BLOCKS, N)):
            bound -= new_m[b] if lo <= b < end else m_run[b]
        if d - bound >= best:
            return d - bound, version
    return d, version


@nb.njit(cache=True, inline="always")
def _apply_move(seq, lo, hi, n, run, sim, version):
    """Re-simulate the stored run after ``seq`` changed in ``[lo, hi)`` (and the same ``Q`` places), until
    its caches agree with the stored ones (at most :data:`_SETTLE` blocks past the change). Returns
    ``(end of the change, version)``."""
    snap, m_run, cold, new_t, new_m = run
    N = seq.shape[0]
    q_change = (n + 1 + lo, n + 1 + hi)
    version += 1
    end = _run(seq, lo, hi, q_change, snap, snap, new_t[:0], N, new_m, sim, version, _SETTLE)
    _settled_windows(hi, min(n + 1, end), end, m_run, new_m, cold, True)
    for a in range(lo, end):
        m_run[a] = new_m[a]
    if end <= q_change[0]:  # (settled at the first changed Q place too: those blocks did change)
        version += 1
        _run(seq, q_change[0], q_change[1], (N, N), snap, snap, new_t[:0], N, m_run, sim, version, _SETTLE)
    no_change = (0, 0, m_run, new_t[:0], sim[3])
    for a in range(max(1, lo - _COLD_BLOCKS), min(n + 1, hi)):
        version += 1
        cold[a] = _cold_extra(seq, a, snap, m_run, no_change, sim, version)
    return end, version


@nb.njit(cache=True, inline="always")
def _try_move(seq, cand, n, i, s, k, search, marks, best, version):
    """The change of the search's sum if the run of ``s`` patches at place ``i`` moved to place ``k``
    (:func:`_move_delta`; ``best``, no better, where the move would cross a patch sharing its target), with
    ``cand`` left equal to ``seq`` again. ``search = (target_start, targets, mark, run, sim, sim2)``.
    Returns the change and the simulation's version."""
    target_start, targets, mark, run, sim, sim2 = search
    if _crosses_target(seq, i, s, k, target_start, targets, mark, marks):
        return best, version
    lo, hi = _arrange(seq, cand, n, i, s, k)
    d, version = _move_delta(cand, lo, hi, n, best, run, sim, sim2, version)
    cand[lo:hi] = seq[lo:hi]
    cand[n + 1 + lo : n + 1 + hi] = seq[n + 1 + lo : n + 1 + hi]
    return d, version


@nb.njit(cache=True)
def _patch_neighbours(block_start, blocks, n, vertex_count, wanted):
    """CSR of the patches that share a vertex with each patch (their ``P`` blocks; a vertex in more than
    :data:`_NEIGHBOUR_HUB` patches is left out). Empty unless ``wanted``."""
    nb_start = np.zeros(n + 1, np.int64)
    if not wanted:
        return nb_start, np.empty(0, np.int64)
    vcnt = np.zeros(vertex_count + 1, np.int64)
    last = np.full(vertex_count, -1, np.int64)
    for p in range(n):
        for x in range(block_start[p], block_start[p + 1]):
            v = blocks[x]
            if last[v] != p:
                last[v] = p
                vcnt[v + 1] += 1
    for v in range(vertex_count):
        vcnt[v + 1] += vcnt[v]
    vl = np.empty(vcnt[vertex_count], np.int64)
    fill = vcnt[:-1].copy()
    last[:] = -1
    for p in range(n):
        for x in range(block_start[p], block_start[p + 1]):
            v = blocks[x]
            if last[v] != p:
                last[v] = p
                vl[fill[v]] = p
                fill[v] += 1
    seen = np.full(n, -1, np.int64)
    # two passes: the count, then the fill (no growing array)
    for rnd in range(2):
        cnt = 0
        if rnd == 1:
            nbl = np.empty(nb_start[n], np.int64)
        else:
            nbl = np.empty(0, np.int64)
        seen[:] = -1
        for p in range(n):
            seen[p] = p
            for x in range(block_start[p], block_start[p + 1]):
                v = blocks[x]
                if vcnt[v + 1] - vcnt[v] > _NEIGHBOUR_HUB:
                    continue
                for y in range(vcnt[v], vcnt[v + 1]):
                    q = vl[y]
                    if seen[q] != p:
                        seen[q] = p
                        if rnd == 1:
                            nbl[cnt] = q
                        cnt += 1
            if rnd == 0:
                nb_start[p + 1] = cnt
    return nb_start, nbl


@nb.njit(cache=True, inline="always")
def _jump(seq, pos, i, nb_start, nbl):
    """Whether the patch at place ``i`` shares no vertex with the one at place ``i - 1``."""
    if i == 0:
        return True
    p = seq[i]
    for y in range(nb_start[p], nb_start[p + 1]):
        if pos[nbl[y]] == i - 1:
            return False
    return True


@nb.njit(cache=True, nogil=True)
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
    skip_tried_swaps: bool = True,
    long_reach: int = 0,
) -> np.ndarray:
    """New order (old patch index per place) of a level's ``n`` patches, drawn in index order so far.

    ``blocks[block_start[b]:block_start[b + 1]]`` is block ``b``'s index sequence: ``P`` of patch ``p`` is
    block ``p``, ``M`` block ``n``, ``Q`` of patch ``p`` block ``n + 1 + p``. Patch ``p``'s collapse
    targets are ``targets[target_start[p]:target_start[p + 1]]`` (ids below ``target_count``). A pass ends
    the search when it moves nothing; the evaluation is local, so passes can also undo and redo moves:
    ``passes`` bounds the work (the builder allows at most ``MAX_ORDER_PASSES``).

    ``skip_tried_swaps`` (the default): a swap of neighbouring patches tried from the place before, with no
    move made since, is not evaluated again from the second place (the same candidate run on the same stored
    state, whose change was not below 0 then: it cannot be taken now). False evaluates it again: the same
    order, about 12 % more of the search's time (tests compare the two).

    ``long_reach`` > 0: a patch that shares no vertex with the one drawn before it (the greedy left it
    behind and came back to it cold) may also move next to any patch it shares a vertex with, up to
    ``long_reach`` places away (0: no such moves)."""
    order = np.arange(n, dtype=np.int64)
    if n < 3:
        return order
    C = cache_size
    N = 2 * n + 1
    seq = np.empty(N, np.int64)  # the run: P places, M, Q places (block ids)
    for a in range(n):
        seq[a] = a
        seq[n + 1 + a] = n + 1 + a
    seq[n] = n
    # cache content before each run position, oldest first (int32: 19 MB for 150,000 patches)
    snap = np.full((N + 1, C), -1, np.int32)
    new_t = np.zeros(N + 1, np.int64)  # a candidate run's push count before each position (_move_delta)
    m_run = np.zeros(N, np.int64)
    new_m = np.zeros(N, np.int64)
    cold = np.zeros(n + 1, np.int64)  # window j's cold start, at run position j (M for j = n)
    log = np.empty(C + blocks.shape[0] + 1, np.int32)
    key = np.zeros(vertex_count, np.int64)
    sim = (blocks, block_start, key, log)
    sim2 = (blocks, block_start, key, np.empty_like(log))  # (the versions keep the two apart in ``key``)
    run = (snap, m_run, cold, new_t, new_m)
    version = 1
    _run(seq, 0, N, (N, N), snap, snap, new_t[:0], N, m_run, sim, version, -1)
    no_change = (0, 0, m_run, new_t[:0], log)
    for a in range(1, n + 1):
        version += 1
        cold[a] = _cold_extra(seq, a, snap, m_run, no_change, sim, version)
    mark = np.zeros(target_count, np.int64)
    search = (target_start, targets, mark, run, sim, sim2)  # (what every tried move reads: _try_move)
    marks = 0
    dont_look = np.zeros(n, np.bool_)  # per patch: no move of its improved the last time it was tried
    cand = seq.copy()
    pos = np.arange(n, dtype=np.int64)  # the place of each patch
    nb_start, nbl = _patch_neighbours(block_start, blocks, n, vertex_count, long_reach > 0)
    # a place's candidate moves, listed first and then tried at one call site of ``_try_move``: numba
    # inlines the whole move evaluation at each call site (two cost ~6 s more of a cold compile)
    most = 0
    for p in range(n):
        most = max(most, nb_start[p + 1] - nb_start[p])
    ks = np.empty(2 * min(reach, n) + 1 + 2 * most, np.int64)
    tried = np.zeros(n if long_reach > 0 else 0, np.int64)  # a long move's place, tried for ``tried_id``
    tried_id = 0
    # the swap of the patches at places i - 1 and i, tried from place i - 1 (its k = i) with no move made
    # since, is the same candidate run from place i (its k = i - 1) on the same stored state: its change was
    # not below 0 then (else place i - 1 would have moved), so it cannot beat this place's best (at most 0)
    # either; evaluating it again cost 11-12 % of the search (captured levels of suzanne, cow, teapot,
    # beetle, spot and fandisk, the same orders)
    moves = 0
    swap_at = -1
    swap_moves = -1
    for _ in range(passes):
        improved = False
        swap_at = -1
        for i in range(n):
            if dont_look[seq[i]]:
                continue
            moved = False
            for s in range(1, max_run + 1):
                if i + s > n:
                    break
                nk = 0
                for k in range(max(0, i - reach), min(n - s, i + reach) + 1):
                    if k == i:
                        continue
                    if s == 1 and skip_tried_swaps:
                        if k == i - 1 and swap_at == k and swap_moves == moves:
                            continue
                        if k == i + 1:
                            swap_at = i
                            swap_moves = moves
                    ks[nk] = k
                    nk += 1
                if s == 1 and long_reach > 0 and _jump(seq, pos, i, nb_start, nbl):
                    # next to each of the patch's neighbours, before or after it, beyond ``reach``; a place
                    # two neighbours share (next to both) is tried once: the same candidate on the same
                    # stored run, it cannot beat the best its first try left (16 % of these tries, the
                    # greedy orders of 82 levels of six meshes)
                    tried_id += 1
                    p = seq[i]
                    for y in range(nb_start[p], nb_start[p + 1]):
                        pq = pos[nbl[y]]
                        for k in (pq + 1 if pq < i else pq, pq if pq < i else pq - 1):
                            if k < 0 or k > n - 1 or abs(k - i) <= reach or abs(k - i) > long_reach:
                                continue
                            if tried[k] == tried_id:
                                continue
                            tried[k] = tried_id
                            ks[nk] = k
                            nk += 1
                best = 0
                best_k = -1
                for j in range(nk):
                    k = ks[j]
                    marks += 1
                    d, version = _try_move(seq, cand, n, i, s, k, search, marks, best, version)
                    if d < best:
                        best = d
                        best_k = k
                if best_k < 0:
                    continue
                lo, hi = _arrange(seq, cand, n, i, s, best_k)
                seq[lo:hi] = cand[lo:hi]
                seq[n + 1 + lo : n + 1 + hi] = cand[n + 1 + lo : n + 1 + hi]
                end, version = _apply_move(seq, lo, hi, n, run, sim, version)
                for x in range(lo, hi):
                    pos[seq[x]] = x
                moves += 1
                for x in range(max(0, lo - reach - 1), min(n, end + reach + 1)):
                    dont_look[seq[x]] = False
                moved = True
                improved = True
            if not moved:
                dont_look[seq[i]] = True
        if not improved:
            break
    order[:] = seq[:n]
    return order


@nb.njit(cache=True, nogil=True)
def exact_window_misses(
    block_start: np.ndarray, blocks: np.ndarray, n: int, orders: np.ndarray, cache_size: int
) -> np.ndarray:
    """The misses summed over a level's windows, each drawn on its own from a cold FIFO cache, for each
    order (row of ``orders``: old patch per place), as :func:`window_misses` counts them; the blocks as
    :func:`refine_patch_order` reads them. Its cost is ``orders`` times the level's indices times its
    ``n + 1`` windows: for small levels only (:func:`.sw_layout._finish`)."""
    m0 = block_start[n]
    m1 = block_start[n + 1]
    # dense ids (a small level of a large mesh: no key array of the whole mesh's vertices)
    uniq = np.unique(blocks)
    ids = np.searchsorted(uniq, blocks)
    key = np.zeros(uniq.shape[0], np.int64)
    C = cache_size
    out = np.zeros(orders.shape[0], np.int64)
    t = np.int64(C + 1)
    for o in range(orders.shape[0]):
        total = 0
        for j in range(n + 1):
            t += C + 1  # every key older than the cache: a cold start
            for x in range(j, 2 * n + 1):
                if x < n:
                    b = orders[o, x]
                elif x == n:
                    b = n
                else:
                    b = n + 1 + orders[o, x - n - 1]
                    if x - n - 1 >= j:
                        break
                lo, hi = (m0, m1) if b == n else (block_start[b], block_start[b + 1])
                for i in range(lo, hi):
                    v = ids[i]
                    if key[v] < t - C:
                        key[v] = t
                        t += 1
                        total += 1
        out[o] = total
    return out


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


@nb.njit(cache=True, nogil=True)
def _reorder(perm, starts, tris, p_start, p_out, q_start, q_out, patch_steps, info, recs, step0):
    """:func:`reorder_patches` on flat arrays (rows of 3: ``tris``, ``info``, ``recs``), all int64 but
    ``info``: few array types, so little to compile (about a second of a cold build's 45 s)."""
    n = perm.shape[0]
    pool = np.empty(tris.shape[0], np.int64)
    w = 0
    for x in range(2 * n + 1):
        b = perm[x] if x < n else (n if x == n else n + 1 + perm[x - n - 1])
        for t in range(3 * starts[b], 3 * starts[b + 1]):
            pool[w] = tris[t]
            w += 1
    new_p_start = np.zeros(n + 1, np.int64)
    new_q_start = np.zeros(n + 1, np.int64)
    new_p_out = np.empty(p_start[n], np.int64)
    new_q_out = np.empty(q_start[n], np.int64)
    new_patch_steps = np.empty(n, np.int64)
    step_start = np.zeros(n + 1, np.int64)
    for p in range(n):
        step_start[p + 1] = step_start[p] + patch_steps[p]
    S = step_start[n]
    new_step = np.empty(S, np.int64)
    new_info = np.empty(3 * S, np.float64)
    a = 0
    b = 0
    s = 0
    for x in range(n):
        p = perm[x]
        for i in range(p_start[p], p_start[p + 1]):
            new_p_out[a] = p_out[i]
            a += 1
        new_p_start[x + 1] = a
        for i in range(q_start[p], q_start[p + 1]):
            new_q_out[b] = q_out[i]
            b += 1
        new_q_start[x + 1] = b
        new_patch_steps[x] = patch_steps[p]
        for i in range(step_start[p], step_start[p + 1]):
            new_step[i] = s
            for c in range(3):
                new_info[3 * s + c] = info[3 * i + c]
            s += 1
    # the records by their new step, stably (a counting sort: numpy's stable argsort of the new steps)
    R = recs.shape[0] // 3
    first = np.zeros(S + 1, np.int64)
    for r in range(R):
        first[new_step[recs[3 * r + 2] - step0] + 1] += 1
    for i in range(S):
        first[i + 1] += first[i]
    new_recs = np.empty(3 * R, np.int64)
    for r in range(R):
        k = new_step[recs[3 * r + 2] - step0]
        j = first[k]
        first[k] += 1
        new_recs[3 * j] = recs[3 * r]
        new_recs[3 * j + 1] = recs[3 * r + 1]
        new_recs[3 * j + 2] = k + step0
    return pool, new_p_start, new_p_out, new_q_start, new_q_out, new_patch_steps, new_info, new_recs


def reorder_patches(
    perm: np.ndarray,
    starts: np.ndarray,
    tris: np.ndarray,
    p_start: np.ndarray,
    p_out: np.ndarray,
    q_start: np.ndarray,
    q_out: np.ndarray,
    patch_steps: np.ndarray,
    info: np.ndarray,
    recs: np.ndarray,
    step0: int,
) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """A level's patches put in the order ``perm`` (old patch per place, :func:`refine_patch_order`), in one
    kernel pass where numpy took about 45 calls (0.06-0.09 ms per level of 10-150 patches): the pool
    ``tris`` (rows of 3, blocks ``starts``: ``P`` of the patches, ``M``, ``Q`` of the patches) as its blocks
    moved with their patches; the ``P`` and ``Q`` CSRs (``p_start``, ``p_out``, ``q_start``, ``q_out``);
    ``patch_steps``; each step's ``info`` row in its new order; and the collapse records ``recs`` (binned,
    kept, step from ``step0``) with their steps renumbered, ordered by the new step (the records of one step
    in their old order). The arrays are int64 (``info`` float64), rows of 3 for ``tris``, ``info`` and
    ``recs``. Returns ``(p_start, p_out, q_start, q_out, patch_steps, recs, info)`` and the pool."""
    pool, ps, po, qs, qo, steps, new_info, new_recs = _reorder(
        np.ascontiguousarray(perm, np.int64),
        np.ascontiguousarray(starts, np.int64),
        np.ascontiguousarray(tris, np.int64).reshape(-1),
        np.ascontiguousarray(p_start, np.int64),
        np.ascontiguousarray(p_out, np.int64),
        np.ascontiguousarray(q_start, np.int64),
        np.ascontiguousarray(q_out, np.int64),
        np.ascontiguousarray(patch_steps, np.int64),
        np.ascontiguousarray(info, np.float64).reshape(-1),
        np.ascontiguousarray(recs, np.int64).reshape(-1),
        int(step0),
    )
    return (ps, po, qs, qo, steps, new_recs.reshape(-1, 3), new_info.reshape(-1, 3)), pool.reshape(-1, 3)
