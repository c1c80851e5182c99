"""Collapsing a level's patches in their order (TD-VIPM section 3.3's inner loop; SWPM section 3.3 for
patches of several inner vertices).

Both builders work on the half-edge collapse state of :mod:`swpm_usd.simplify.kernels`. Triangles are named
by *global triangle ids* (``gid``): the input triangles are ``0..T-1`` and every triangle a collapse rewrites
gets a fresh id whose vertices are appended to ``gtris``; ``cur_gid[t]`` is the id of the current version of
state triangle ``t``.

* :func:`collapse_patches` - removes the inner positions of every patch, cheapest first, each by its best
  valid half-edge collapse or to a target of higher degree within a slack of its cost
  (:func:`_shaped_collapse`; a hub target's star read only around the binned position's ring,
  :func:`_target_rows`).
* :func:`_record_collapse` - applies one collapse and records its vertex collapses.
* :func:`_emit_into` - appends a patch's surviving triangles as new global triangles (its ``Q``).

Forsyth's builder (:mod:`.sw_forsyth`) emits its patches with the same helpers.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..simplify import kernels as K
from .sw_fans import _chain_order_into, _chain_work


@nb.njit(cache=True, nogil=True)
def _grow_tris(a: np.ndarray, n: int) -> np.ndarray:
    if n < a.shape[0]:
        return a
    b = np.empty((max(2 * a.shape[0], n + 16), 3), a.dtype)
    # copies in the kernels are loops, not slice assignments (``b[: len(a)] = a``, also inside np.diff):
    # numba compiles and links a slice assignment's shape-mismatch message (string formatting), seconds of
    # compile time
    for i in range(a.shape[0]):
        for j in range(3):
            b[i, j] = a[i, j]
    return b


@nb.njit(cache=True, inline="always")
def _emit_into(
    st: K.CollapseState,
    tris: np.ndarray,
    cur_gid: np.ndarray,
    gtris: np.ndarray,
    ng: int,
    q_out: np.ndarray,
    nq: int,
    w: tuple,
) -> tuple[int, int]:
    """Append the surviving triangles of ``tris`` (after a collapse) as new global triangles, in fan
    order, to ``q_out``; triangles that did not change keep their id. ``gtris`` and ``q_out`` have room for
    ``len(tris)`` more rows each (the caller grows them: this returns ``(ng, nq)`` only, since a loop
    reassigning arrays pays numba's reference counting per call). ``w``: :func:`.sw_fans._chain_work` for
    ``len(tris)`` triangles."""
    tv = st.tri_verts
    alive = st.tri_alive
    surv = w[4]
    sub = w[5]
    ns = np.int64(0)  # not a literal 0: numba would compile _chain_order_into for Literal[int](0) too
    for j in range(tris.shape[0]):
        t = tris[j]
        if alive[t]:
            surv[ns] = t
            for i in range(3):
                sub[ns, i] = tv[t, i]
            ns += 1
    o = _chain_order_into(sub, ns, w)
    for j in range(ns):
        t = surv[o[j]]
        g = cur_gid[t]
        if gtris[g, 0] != tv[t, 0] or gtris[g, 1] != tv[t, 1] or gtris[g, 2] != tv[t, 2]:
            for i in range(3):
                gtris[ng, i] = tv[t, i]
            cur_gid[t] = ng
            g = ng
            ng += 1
        q_out[nq] = g
        nq += 1
    return ng, nq


@nb.njit(cache=True, nogil=True)
def _record_collapse(
    st: K.CollapseState, b: int, k: int, recs: np.ndarray, nrec: int, step: int, bbuf: tuple
):
    """Apply the collapse of position ``b`` onto ``k``; append its vertex collapses (binned, kept, step).
    ``bbuf``: :func:`swpm_usd.simplify.kernels.star_buffers` to read ``b``'s star into."""
    nv = max(1, st.pos_vstart[b + 1] - st.pos_vstart[b])  # vertex_map's length
    if recs.shape[0] < nrec + nv:
        grown = np.empty((2 * recs.shape[0] + nv, 3), np.int64)
        for i in range(nrec):  # a loop: see _grow_tris
            for j in range(3):
                grown[i, j] = recs[i, j]
        recs = grown
    return recs, _record_collapse_into(st, b, k, recs, nrec, step, bbuf)


@nb.njit(cache=True, inline="always")
def _record_collapse_into(
    st: K.CollapseState, b: int, k: int, recs: np.ndarray, nrec: int, step: int, bbuf: tuple
) -> int:
    """:func:`_record_collapse` into ``recs`` with room for the vertices at ``b``; returns ``nrec`` only.
    ``bbuf`` (:func:`swpm_usd.simplify.kernels.star_buffers`, not optional: numba compiled the branch
    without it too) takes b's triangles and their positions (not its neighbours: star_into's costliest
    part)."""
    n = K._positions_into(st, b, bbuf[0], bbuf[1])
    tris_b = bbuf[0][:n]
    tp_b = bbuf[1][:n]
    vmap = K.vertex_map(st, b, k, tris_b, tp_b)
    v0 = st.pos_vstart[b]
    pv = st.pos_verts
    for r in range(vmap.shape[0]):
        recs[nrec, 0] = pv[v0 + r]
        recs[nrec, 1] = vmap[r]
        recs[nrec, 2] = step
        nrec += 1
    K.apply_collapse(st, b, k, vmap)
    return nrec


@nb.njit(cache=True, nogil=True)
def collapse_patches(
    st: K.CollapseState,
    order: np.ndarray,
    inner_start: np.ndarray,
    inner: np.ndarray,
    pt_start: np.ndarray,
    pt: np.ndarray,
    cur_gid: np.ndarray,
    gtris: np.ndarray,
    ng: int,
    step0: int,
    max_cost: float,
    slack: float = 1.0,
):
    """Simplify the patches in ``order``: each inner vertex, cheapest first, by its best valid half-edge
    collapse in the current state, if its quadric cost is at most ``max_cost`` (the ``mu`` cut of the
    level); with ``slack > 0`` the target is the highest-degree one within ``slack * max_cost`` of the
    cheapest (:func:`_shaped_collapse`). A patch none of whose inner vertices can go is dropped (its
    triangles stay in the level's static middle).

    Returns ``(gtris, ng, p_start, p_out, q_start, q_out, recs, step_info, patch_steps)``: the CSR of the
    kept patches' old (``P``) and new (``Q``) global triangle ids in draw order, the vertex collapses
    ``recs`` (binned, kept, step), per step (error, binned position, kept position) and per kept patch the
    number of steps it made.
    """
    n = order.shape[0]
    alive_pos = st.pos_alive
    p_start = np.zeros(n + 1, np.int64)
    q_start = np.zeros(n + 1, np.int64)
    # every array the patch loop appends to is sized here for all it can take (each patch in ``order``
    # adds at most its triangles to p_out, q_out and gtris, and the vertices of each of its inner
    # positions, collapsed at most once, to recs), so that the loop reassigns none (numba's reference
    # counting per reassignment)
    n_tris = np.int64(0)
    n_recs = np.int64(0)
    for o in range(n):
        p = order[o]
        n_tris += pt_start[p + 1] - pt_start[p]
        for r in range(inner_start[p], inner_start[p + 1]):
            n_recs += max(1, st.pos_vstart[inner[r] + 1] - st.pos_vstart[inner[r]])
    p_out = np.empty(max(16, n_tris), np.int64)
    q_out = np.empty(max(16, n_tris), np.int64)
    gtris = _grow_tris(gtris, ng + n_tris)
    recs = np.empty((max(16, n_recs), 3), np.int64)
    step_info = np.empty((max(16, inner.shape[0]), 3), np.float64)
    patch_steps = np.zeros(n, np.int64)
    nrec = np.int64(0)
    nstep = np.int64(0)
    npatch = np.int64(0)
    npo = np.int64(0)
    nq = np.int64(0)
    bbuf = K.star_buffers(st)
    kbuf = K.star_buffers(st)
    costs = np.empty(bbuf[2].shape[0])
    # per-patch buffers, sized for the largest patch
    max_tris = np.int64(0)  # int64, not literals: one specialisation of _chain_work
    max_inner = np.int64(0)
    for p in range(pt_start.shape[0] - 1):
        max_tris = max(max_tris, pt_start[p + 1] - pt_start[p])
    for p in range(inner_start.shape[0] - 1):
        max_inner = max(max_inner, inner_start[p + 1] - inner_start[p])
    w = _chain_work(max_tris)
    remaining_buf = np.empty(max_inner, np.int64)
    p_snapshot = np.empty(max_tris, np.int64)
    for o in range(n):
        p = order[o]
        tris = pt[pt_start[p] : pt_start[p + 1]]
        m0 = inner_start[p]
        m1 = inner_start[p + 1]
        remaining = remaining_buf[: m1 - m0]
        for r in range(m1 - m0):  # a loop: see _grow_tris
            remaining[r] = inner[m0 + r]
        made = np.int64(0)
        for j in range(tris.shape[0]):
            p_snapshot[j] = cur_gid[tris[j]]
        while True:
            best_r = np.int64(-1)
            best_k = np.int64(-1)
            best_c = np.inf
            for r in range(remaining.shape[0]):
                b = remaining[r]
                if b < 0 or not alive_pos[b]:
                    continue
                k, c = _shaped_collapse(st, b, slack, max_cost, bbuf, kbuf, costs)
                if k >= 0 and c < best_c and c <= max_cost:
                    best_c = c
                    best_k = k
                    best_r = r
            if best_r < 0:
                break
            b = remaining[best_r]
            remaining[best_r] = -1
            nrec = _record_collapse_into(st, b, best_k, recs, nrec, step0 + nstep, bbuf)
            step_info[nstep, 0] = np.sqrt(best_c)
            step_info[nstep, 1] = b
            step_info[nstep, 2] = best_k
            nstep += 1
            made += 1
        if made == 0:
            continue
        patch_steps[npatch] = made
        for j in range(tris.shape[0]):
            p_out[npo] = p_snapshot[j]
            npo += 1
        ng, nq = _emit_into(st, tris, cur_gid, gtris, ng, q_out, nq, w)
        npatch += 1
        p_start[npatch] = npo
        q_start[npatch] = nq
    return (
        gtris,
        ng,
        p_start[: npatch + 1].copy(),
        p_out[:npo].copy(),
        q_start[: npatch + 1].copy(),
        q_out[:nq].copy(),
        recs[:nrec].copy(),
        step_info[:nstep].copy(),
        patch_steps[:npatch].copy(),
    )


# the degree a hub target counts with in _shaped_collapse's choice (more than any other position's: its
# neighbours are not sorted out of its thousands of triangles for it)
_HUB_DEGREE = 1 << 30


@nb.njit(cache=True, inline="always")  # (small: its call's reference counting of nine arrays, per target)
def _target_rows(
    head: np.ndarray,
    cnext: np.ndarray,
    talive: np.ndarray,
    tv: np.ndarray,
    vp: np.ndarray,
    k: int,
    b_nbr: np.ndarray,
    nn: int,
    kbuf: tuple,
) -> tuple[int, int, bool]:
    """Target ``k``'s star as binning a position of neighbours ``b_nbr[:nn]`` tests it, into ``kbuf``
    (:func:`.kernels.star_buffers`): its row counts and whether ``k`` is a hub, whose rows are those
    around that ring alone (:func:`.kernels.hub_side_rows`, the same answers for the test; its neighbour
    count is then not its degree)."""
    if K.alive_more_than_in(head, cnext, talive, k, K.HUB_SIZE):
        mt, mn = K.hub_side_rows(head, cnext, talive, tv, vp, k, b_nbr, nn, kbuf[1], kbuf[2])
        if mt >= 0:
            return mt, mn, True
    mt, mn = K.star_rows(head, cnext, talive, tv, vp, k, kbuf[0], kbuf[1], kbuf[2])
    return mt, mn, False


@nb.njit(cache=True, nogil=True)
def _shaped_collapse(
    st: K.CollapseState, b: int, slack: float, max_cost: float, bbuf: tuple, kbuf: tuple, costs: np.ndarray
) -> tuple[int, float]:
    """Valid collapse of ``b``: among the valid targets costing at most ``slack * max_cost`` more than the
    cheapest one (and at most ``max_cost``), the one of highest degree (ties: the cheaper; a hub counts as
    of the highest degree, ``_HUB_DEGREE``, as its neighbours are not counted). ``slack`` 0 or
    an unbounded ``max_cost``: :func:`swpm_usd.simplify.kernels.best_collapse`. ``bbuf``, ``kbuf``:
    :func:`swpm_usd.simplify.kernels.star_buffers` for the stars of ``b`` and of a target (read once per
    target, for its degree and its validity); ``costs``: room for the costs of ``b``'s neighbours."""
    locked = st.pos_locked
    alive = st.pos_alive
    if locked[b] & K.LOCK_FIXED or not alive[b]:
        return -1, np.inf
    # the state's arrays read once and the stars kept as row counts in the buffers, K.best_of_star written
    # out: namedtuple field reads and slices per target cost most of the time in numba's reference counting
    head = st.corner_head
    cnext = st.corner_next
    talive = st.tri_alive
    tv = st.tri_verts
    vp = st.vertex_pos
    boundary = st.pos_boundary
    pts = st.pos_points
    quadric = st.quadric
    qw = st.quadric_weight
    min_area2 = st.min_area2[0]
    pv = st.pos_verts
    vstart = st.pos_vstart
    b_tris, b_tp, b_nbr = bbuf
    # a typed zero for the row starts: a literal 0 made a second specialisation of K.valid_collapse_in
    z = np.int64(0)
    _, k_tp, k_nbr = kbuf
    # b's star read once, for best_collapse and the targets of the slack
    nt, nn = K.star_rows(head, cnext, talive, tv, vp, b, b_tris, b_tp, b_nbr)
    if nt == 0:
        return -1, np.inf
    best = 0
    for i in range(nn):
        costs[i] = K._cost_of(pts, quadric, qw, b, b_nbr[i])
        if costs[i] < costs[best]:
            best = i
    k0 = -1
    c0 = np.inf
    d0 = -1  # k0's degree as the slack's choice counts it (its star not read again there)
    k = np.int64(b_nbr[best])  # one specialisation of the helpers (int64 positions)
    # (the edge's triangle count first, from b's star: a target's star may be a hub's thousands)
    if K.edge_count_ok_in(locked, boundary, b, k, b_tp, nt):
        mt, mn, hub = _target_rows(head, cnext, talive, tv, vp, k, b_nbr, nn, kbuf)
        if K.valid_collapse_in(
            alive, locked, boundary, pts, min_area2, tv, pv, vstart, b, k, b_tris, b_tp, z, nt, b_nbr, z, nn,
            k_tp, z, mt, k_nbr, z, mn,
        ):  # fmt: skip
            k0 = k
            c0 = costs[best]
            d0 = _HUB_DEGREE if hub else mn
    if k0 < 0:
        order = np.argsort(costs[:nn])
        for i in range(1, min(nn, K.MAX_TARGET_TRIES)):
            k = np.int64(b_nbr[order[i]])
            if not K.edge_count_ok_in(locked, boundary, b, k, b_tp, nt):
                continue
            mt, mn, hub = _target_rows(head, cnext, talive, tv, vp, k, b_nbr, nn, kbuf)
            if K.valid_collapse_in(
                alive, locked, boundary, pts, min_area2, tv, pv, vstart, b, k, b_tris, b_tp, z, nt, b_nbr, z,
                nn, k_tp, z, mt, k_nbr, z, mn,
            ):  # fmt: skip
                k0 = k
                c0 = costs[order[i]]
                d0 = _HUB_DEGREE if hub else mn
                break
    if k0 < 0 or slack <= 0.0 or not np.isfinite(max_cost):
        return k0, c0
    lim = min(c0 + slack * max_cost, max_cost)
    best_k = k0
    best_c = c0
    best_d = -1
    for i in range(nn):
        k = np.int64(b_nbr[i])  # one specialisation of the star and validity helpers
        c = costs[i]
        if c > lim or not K.edge_count_ok_in(locked, boundary, b, k, b_tp, nt):
            continue
        if k == k0:
            d = d0  # (the state unchanged since: the same star)
        else:
            mt, mn, hub = _target_rows(head, cnext, talive, tv, vp, k, b_nbr, nn, kbuf)
            d = _HUB_DEGREE if hub else mn
        # the validity test costs most: only for a target that would win (k0 passed it already)
        if not (d > best_d or (d == best_d and c < best_c)):
            continue
        if k == k0 or K.valid_collapse_in(
            alive, locked, boundary, pts, min_area2, tv, pv, vstart, b, k, b_tris, b_tp, z, nt, b_nbr, z, nn,
            k_tp, z, mt, k_nbr, z, mn,
        ):  # fmt: skip
            best_d = d
            best_k = k
            best_c = c
    return best_k, best_c
