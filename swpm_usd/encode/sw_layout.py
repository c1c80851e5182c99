"""A sliding-window level as the pool stores it: ``P_1..P_n || M || Q_1..Q_n``, each block cache-ordered.

The topology-driven builder (:mod:`.slidingwindow`) collapses a level's patches and hands the result here:
:func:`finish_level` searches the patch order for fewer cache misses over the level's windows
(:mod:`.sw_refine`) and lays the level out (:func:`level_layout`, :func:`level_pool`) with every block's
triangles ordered for the vertex cache (:func:`block_order`, :func:`swpm_usd.vcache.optimize_block_order`),
in one kernel call (:func:`_finish`).
With ``cluster=True`` (SWPM 3.2) a level's head is the previous level's tail instead
(:func:`first_clustered_level`, :func:`linked_level`). :class:`Level` is what the pool assembly reads.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..errors import BuildError
from ..vcache import (
    _HEAVY,
    _compact,
    _order_blocks,
    _read_only,
    _rotate_rows,
    _score_tables,
    block_order_trusted,
)
from . import sw_refine as swr

#: the largest vertex id a level's pool stores as int32 (np.iinfo costs microseconds a call)
_INT32_MAX = int(np.iinfo(np.int32).max)


def block_perm(
    tris: np.ndarray, starts: np.ndarray, cache_size: int, tail: int | None = None, rotate: bool = False
):
    """The cache order of ``tris`` inside each block ``[starts[i], starts[i+1])`` (blocks stay in place),
    by :func:`swpm_usd.vcache.optimize_block_order`: the permutation, and with ``rotate`` the per-triangle
    rotations too. ``tail``: the offset of a level's ``Q_1`` (a block start): the head ``P_1..P_n || M`` and
    the tail ``Q_1..Q_n`` are drawn apart (a window takes the end of one and the start of the other), so a
    vertex's remaining-triangle count in the ordering covers its own half only (the FIFO still carries
    over). The clustered layout keeps its levels as global triangle ids, which must stay the stored
    triangles: it takes the permutation alone."""
    n = tris.shape[0]
    if n < 2:
        perm = np.arange(n)
        return (perm, np.zeros(n, np.int8)) if rotate else perm
    # the blocks and the tail come from the level's layout: the ordering without the public function's
    # checks (the same kernel and arrays; suzanne's 15 levels: about 0.5 ms of a 25 ms build)
    return block_order_trusted(tris, starts, cache_size, tail, rotate)


def block_order(tris: np.ndarray, starts: np.ndarray, cache_size: int, tail: int | None = None) -> np.ndarray:
    """``tris`` in the order of :func:`block_perm`, each triangle's indices also rotated cyclically (same
    winding) to the rotation with the fewest misses (ACMR / meshoptimizer, the ten benchmark meshes at 20
    fractions: -0.25 %)."""
    perm, shift = block_perm(tris, starts, cache_size, tail, rotate=True)
    out = tris[perm]  # as :func:`swpm_usd.vcache.apply_order`, whose checks these arrays pass
    if out.shape[0]:
        _rotate_rows(out, _read_only(shift.astype(np.int64)))  # (read-only: apply_order's one compile)
    return out


#: ``order_passes > 0``: :func:`.sw_refine.refine_patch_order` after the greedy patch order moves runs of up
#: to ``_REFINE_RUN`` patches by up to ``order_reach`` places (ten meshes, ACMR ratio mean over 40 fractions,
#: no search 1.0588: one pass of reach 1 / 2 / 3 1.0463 / 1.0418 / 1.0412, two passes of reach 1 / 2
#: 1.0442 / 1.0389; runs of up to two patches 1.0404 with reach 3 for 1.4 times the search's time)
_REFINE_RUN = 1
#: ... and a patch the greedy order drew cold (no vertex shared with the patch before it) may also move next
#: to any of its neighbouring patches up to this many places away (:func:`.sw_refine.refine_patch_order`'s
#: ``long_reach``): the greedy's sweep leaves such patches behind and draws them late, cold, in both the
#: ``P`` and the ``Q`` runs (spot level 1: 41 of 697 patches, 11 % of the ``Q`` run's misses). Ten meshes,
#: the bench's 40 ACMR points: 39 -> 40 within 1.10 (spot at 50 % 1.109 -> 1.097), mean 1.030 -> 1.027;
#: 400 points 385 -> 388, mean 1.0310 -> 1.0276 (``slidingwindow.md``, "missed targets")
_LONG_REACH = 64
#: ... and a level whose ``n + 1`` windows draw at most this many indices (``n + 1`` times the level's: a
#: bound) keeps the greedy order if the searched one has more misses over its windows, both counted exactly
#: (:func:`.sw_refine.exact_window_misses`, tens of microseconds there). The search evaluates a move locally
#: (cold starts before the moved place and those reaching the moved ``Q`` blocks left out), which on levels
#: of a few patches can end above its greedy start: ten meshes, 3 of 181 levels, of 5-6 patches and 60-82
#: triangles (suzanne, cow, nefertiti: +2 to +6 % of the level's misses; ``slidingwindow.md``, "small levels")
_EXACT_CHECK = 1 << 14


class Level:
    """One level of the cascade: its starting triangles (global ids) and its patches in draw order. A level
    finished by :func:`finish_level` keeps its ``pool`` and lets ``start_gids``, ``p_out`` and ``q_out`` go
    (None): :func:`.sw_assemble._assemble` then reads only ``pool``, the offsets and ``triangle_count``."""

    def __init__(self, start_gids, p_start, p_out, q_start, q_out, patch_steps, stored=None, shared=False):
        self.start_gids = start_gids
        self.triangle_count = int(start_gids.shape[0])
        self.p_start = p_start
        self.p_out = p_out
        self.q_start = q_start
        self.q_out = q_out
        self.patch_steps = patch_steps
        #: ``cluster=True``: the level's triangles appended to the pool, in their final order (None: built
        #: by the assembly), and whether its head ``P_1..P_n || M`` is the previous level's tail
        #: (``start_gids`` in that order, ``p_start`` offsets into it) instead of stored anew
        self.stored = stored
        self.shared = shared
        #: ``cluster=True``: the level's tail ``M || Q_1..Q_n`` (global ids, final order)
        self.tail = None
        #: the level's triangles as the pool stores them (vertex ids), when finished before the assembly
        self.pool = None

    @property
    def patch_count(self) -> int:
        return int(self.p_start.shape[0] - 1)


def gather(starts: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """The concatenated ranges ``[starts[i], starts[i] + sizes[i])``."""
    total = int(sizes.sum())
    if total == 0:
        return np.zeros(0, np.int64)
    ends = np.cumsum(sizes)
    return np.repeat(starts - (ends - sizes), sizes) + np.arange(total)


def level_layout(gtris, start_gids, p_start, p_out, q_start, q_out):
    """A level's triangles (global ids) as the pool lays them out, ``P_1..P_n || M || Q_1..Q_n`` (``M``: its
    starting triangles in no patch), and the block starts: ``n + 1`` for the patches and ``M``, then one per
    ``Q_i`` (``starts[n + 1]`` is where ``Q_1`` begins)."""
    in_p = np.zeros(gtris.shape[0], bool)
    in_p[p_out] = True
    middle = start_gids[~in_p[start_gids]]
    # np.concatenate: np.r_ costs tens of microseconds per call
    gids = np.concatenate((p_out, middle, q_out))
    starts = np.concatenate((p_start, p_start[-1] + middle.shape[0] + q_start))
    return gids, starts


@nb.njit(cache=True, nogil=True)
def _level_triangles(gtris, start_gids, p_start, p_out, q_start, q_out):
    """``gtris[gids]`` and ``starts`` of :func:`level_layout` in one pass, with what
    :func:`.vcache.block_order_trusted` computes of them: the first block starting at ``Q_1``
    (``np.searchsorted(starts, starts[n + 1])``, the tail's segment) and the largest vertex id plus one."""
    n = p_start.shape[0] - 1
    in_p = np.zeros(gtris.shape[0], np.bool_)
    for i in range(p_out.shape[0]):
        in_p[p_out[i]] = True
    n_mid = 0
    for i in range(start_gids.shape[0]):
        if not in_p[start_gids[i]]:
            n_mid += 1
    tris = np.empty((p_out.shape[0] + n_mid + q_out.shape[0], 3), np.int64)
    w = 0
    for i in range(p_out.shape[0]):
        for j in range(3):
            tris[w, j] = gtris[p_out[i], j]
        w += 1
    for i in range(start_gids.shape[0]):
        g = start_gids[i]
        if not in_p[g]:
            for j in range(3):
                tris[w, j] = gtris[g, j]
            w += 1
    for i in range(q_out.shape[0]):
        for j in range(3):
            tris[w, j] = gtris[q_out[i], j]
        w += 1
    starts = np.empty(2 * n + 2, np.int64)
    for i in range(n + 1):
        starts[i] = p_start[i]
        starts[n + 1 + i] = p_start[n] + n_mid + q_start[i]
    tail = 0
    while starts[tail] < starts[n + 1]:
        tail += 1
    top = -1
    for i in range(tris.shape[0]):
        for j in range(3):
            top = max(top, tris[i, j])
    return tris, starts, tail, top + 1


@nb.njit(cache=True, nogil=True)
def _permuted_rows(tris, perm, shift):
    """``tris[perm]``, row ``i`` rotated left cyclically by ``shift[i]`` (:func:`.vcache._rotate_rows`)."""
    out = np.empty((perm.shape[0], 3), tris.dtype)
    for i in range(perm.shape[0]):
        r = shift[i] % 3
        a, b, c = tris[perm[i], 0], tris[perm[i], 1], tris[perm[i], 2]
        if r == 0:
            out[i, 0], out[i, 1], out[i, 2] = a, b, c
        elif r == 1:
            out[i, 0], out[i, 1], out[i, 2] = b, c, a
        else:
            out[i, 0], out[i, 1], out[i, 2] = c, a, b
    return out


def level_pool(gtris, start_gids, p_start, p_out, q_start, q_out, cache_size):
    """The level's triangles as the pool stores them: :func:`level_layout`, each block reordered for the
    cache in place (the FIFO carried over, the head and the tail apart: :func:`block_order`); and the
    block starts. (:func:`block_order`'s steps with the layout gathered in one kernel pass: about 20 numpy
    calls a level less, the same kernel :func:`.vcache._order_blocks` on the same arrays.)"""
    tris, starts, tail, nvert = _level_triangles(gtris, start_gids, p_start, p_out, q_start, q_out)
    if tris.shape[0] < 2:
        return tris.astype(gtris.dtype, copy=False), starts  # (gathered as int64: gtris's dtype)
    ids, nvert, _, _ = _compact(tris, nvert, None)  # (as block_order_trusted: the same ids but sparse)
    cache_tab, live_tab = _score_tables(int(cache_size))
    perm, shift, _ = _order_blocks(
        ids,
        starts,
        int(cache_size),
        np.zeros(nvert, np.int64),
        np.full(int(cache_size), -1, np.int64),
        0,
        cache_tab,
        live_tab,
        True,
        np.array([tail], np.int64),
        _HEAVY,
    )
    return _permuted_rows(tris, perm, shift).astype(gtris.dtype, copy=False), starts


def finish_level(gtris, start_gids, collapsed, step0, V, P, cache_size, passes, reach):
    """A fully stored level after its collapses: its patch order searched (``passes`` > 0, three patches or
    more: :func:`.sw_refine.refine_patch_order` over the blocks in their cache order, fewer misses over the
    level's windows; its records and steps renumbered to follow, :func:`.sw_refine.reorder_patches`) and its
    triangles in pool order (:func:`level_pool`). Returns the :class:`Level` (with its ``pool``, its triangle
    ids let go), its collapse records and its steps' info. Reads only rows of ``gtris`` that later levels
    keep. One kernel call (:func:`_finish`)."""
    p_start, p_out, q_start, q_out, patch_steps, recs, info = collapsed
    cache_tab, live_tab = _score_tables(int(cache_size))
    pool, p_start, p_out, q_start, q_out, patch_steps, recs, info = _finish(
        gtris,
        start_gids,
        p_start,
        p_out,
        q_start,
        q_out,
        patch_steps,
        recs,
        info,
        int(step0),
        int(V),
        int(P),
        int(cache_size),
        cache_tab,
        live_tab,
        _HEAVY,
        int(passes),
        int(reach),
        _REFINE_RUN,
        _LONG_REACH,
        _EXACT_CHECK,
    )
    lev = Level(start_gids, p_start, p_out, q_start, q_out, patch_steps)
    # what the assembly (sw_assemble._assemble) needs: the pool (vertex ids, int32 where they fit), the
    # patch offsets and step counts; the triangle ids are let go (1 M triangles: 130 MB less at the peak
    # with the pools halved)
    lev.pool = pool.astype(np.int32) if V <= _INT32_MAX else pool
    lev.start_gids = lev.p_out = lev.q_out = None
    return lev, recs, info


@nb.njit(cache=True, nogil=True)
def _finish(
    gtris,
    start_gids,
    p_start,
    p_out,
    q_start,
    q_out,
    patch_steps,
    recs,
    info,
    step0,
    V,
    P,
    cache_size,
    cache_tab,
    live_tab,
    heavy,
    passes,
    reach,
    run,
    long_reach,
    exact_check,
):
    """:func:`finish_level`'s kernels in one call, on the arrays its steps passed them before (the level's
    pool as :func:`level_pool` orders it; then, ``passes`` > 0 and three patches or more, the patch order
    search, kept on a small level only if no worse exactly (``exact_check``, :data:`_EXACT_CHECK`), and the
    renumbering of :func:`.sw_refine.reorder_patches`): a level cost about 30 us (suzanne)
    to 70 us (teapot) of numpy and Python around its six kernel calls. Returns the pool (rows of 3, int64)
    and ``(p_start, p_out, q_start, q_out, patch_steps, recs, info)``, renumbered or as given."""
    tris, starts, tail, nvert = _level_triangles(gtris, start_gids, p_start, p_out, q_start, q_out)
    if tris.shape[0] >= 2:
        ids = tris
        if nvert > 4 * tris.size + 1024:  # as vcache._compact: dense ids, their order kept
            flat = tris.reshape(-1)
            uniq = np.unique(flat)
            ids = np.searchsorted(uniq, flat).reshape(tris.shape)
            nvert = uniq.shape[0]
        perm, shift, _ = _order_blocks(
            ids,
            starts,
            cache_size,
            np.zeros(nvert, np.int64),
            np.full(cache_size, -1, np.int64),
            np.int64(0),  # (not the literals 0 and True: a second signature, ~7 s more of a cold compile)
            cache_tab,
            live_tab,
            np.bool_(True),
            np.array([tail], np.int64),
            heavy,
        )
        tris = _permuted_rows(tris, perm, shift)
    n = patch_steps.shape[0]
    if passes <= 0 or n < 3:
        return tris, p_start, p_out, q_start, q_out, patch_steps, recs, info
    step_start = np.zeros(n + 1, np.int64)
    for p in range(n):
        step_start[p + 1] = step_start[p] + patch_steps[p]
    targets = np.empty(step_start[n], np.int64)
    for i in range(step_start[n]):
        targets[i] = np.int64(info[i, 2])
    order = swr.refine_patch_order(
        3 * starts,
        tris.reshape(-1),
        n,
        step_start,
        targets,
        P,
        V,
        cache_size,
        reach,
        run,
        passes,
        np.bool_(True),  # (as a Python caller's True: one signature, not a literal's second)
        long_reach,
    )
    same = True
    for i in range(n):
        if order[i] != i:
            same = False
            break
    if same:
        return tris, p_start, p_out, q_start, q_out, patch_steps, recs, info
    if (n + 1) * tris.size <= exact_check:  # a small level: the searched order only if no worse, exactly
        orders = np.empty((2, n), np.int64)
        for i in range(n):
            orders[0, i] = i
            orders[1, i] = order[i]
        misses = swr.exact_window_misses(3 * starts, tris.reshape(-1), n, orders, cache_size)
        if misses[1] > misses[0]:
            return tris, p_start, p_out, q_start, q_out, patch_steps, recs, info
    # the pool: the blocks as ordered for the search, moved with their patches
    pool, ps, po, qs, qo, steps, new_info, new_recs = swr._reorder(
        order,
        starts,
        tris.reshape(-1),
        p_start,
        p_out,
        q_start,
        q_out,
        patch_steps,
        info.reshape(-1),
        recs.reshape(-1),
        step0,
    )
    return pool.reshape(-1, 3), ps, po, qs, qo, steps, new_recs.reshape(-1, 3), new_info.reshape(-1, 3)


def first_clustered_level(gtris, start_gids, p_start, p_out, q_start, q_out, patch_steps, cache_size):
    """Level 0 with ``cluster=True``: laid out as usual (``P_1..P_n || M || Q_1..Q_n``), but its final
    order is fixed now, since the next level reads its patches out of this level's tail ``M || Q``."""
    gids, starts = level_layout(gtris, start_gids, p_start, p_out, q_start, q_out)
    gids = gids[block_perm(gtris[gids], starts, cache_size)]
    lev = Level(start_gids, p_start, p_out, q_start, q_out, patch_steps, stored=gids, shared=False)
    lev.tail = gids[p_start[-1] :]
    return lev


def linked_level(gtris, ng, head, p_start, p_out, q_start, q_out, patch_steps, cache_size):
    """A level after the first with ``cluster=True`` (SWPM 3.2, clustered and linked patches).

    The paper builds the next level's patches ``P^h_i`` as concatenations of consecutive simplified
    patches ``Q_j`` of the previous level (a ``Q_j`` split between two consecutive, "linked" patches), so
    the fragment ``P^h_1 || .. || P^h_m`` of the new level coincides with the fragment ``Q_1 || .. || Q_n``
    that ends the previous one and is stored once (its ``D^h``; the formulas of the extracted text are
    garbled, this is reconstructed from the prose). Here the previous level's tail ``head`` (its ``M || Q``
    in final order) is this level's starting mesh; :func:`.sw_cluster.cluster_patches` chose centres whose
    stars are disjoint intervals of it (:func:`.sw_cluster.cluster_components`: patches of several inner
    positions whose star unions are), so patch ``j`` is the run of ``head`` from its first star triangle to
    the next patch's first one (the first patch from 0): its star plus the untouched triangles in between,
    which reappear unchanged in ``Q_j`` (as with ``absorb_middle``). The untouched run after the last patch
    is this level's ``M``. Only ``Q_1 .. Q_m`` are appended to the pool."""
    place = np.full(ng, -1, np.int64)
    place[head] = np.arange(head.shape[0])
    m = p_start.shape[0] - 1
    own_place = place[p_out]
    if np.any(own_place < 0):  # pragma: no cover - every triangle of the level is in the previous tail
        raise BuildError("cluster: a patch triangle is not in the previous level's tail", code="BUILD_FAILED")
    pid = np.repeat(np.arange(m), np.diff(p_start))
    lo = np.full(m, np.iinfo(np.int64).max)
    hi = np.full(m, -1)
    np.minimum.at(lo, pid, own_place)
    np.maximum.at(hi, pid, own_place)
    if np.any(lo[1:] <= hi[:-1]):  # pragma: no cover - the cluster kernels pick disjoint intervals
        raise BuildError("cluster: overlapping patches", code="BUILD_FAILED")
    bounds = np.r_[0, lo[1:], hi[-1] + 1].astype(np.int64)
    own = np.zeros(ng, bool)
    own[p_out] = True
    run = head[: bounds[-1]]
    extra_at = np.flatnonzero(~own[run])
    extra = run[extra_at]
    extra_pid = np.searchsorted(bounds, extra_at, side="right") - 1
    q_pid = np.repeat(np.arange(m), np.diff(q_start))
    allq = np.concatenate([q_out, extra])
    allp = np.concatenate([q_pid, extra_pid])
    allq = allq[np.argsort(allp, kind="stable")]
    new_q_start = np.zeros(m + 1, np.int64)
    np.cumsum(np.bincount(allp, minlength=m), out=new_q_start[1:])
    allq = allq[block_perm(gtris[allq], new_q_start, cache_size)]
    lev = Level(head, bounds, p_out, new_q_start, allq, patch_steps, stored=allq, shared=True)
    lev.tail = np.concatenate([head[bounds[-1] :], allq])
    return lev
