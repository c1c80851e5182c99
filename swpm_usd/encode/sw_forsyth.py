"""Forsyth's sliding-window builder: the quadric-error collapse order, one patch (the binned position's
star) per collapse, grouped into levels (Forsyth, "Comparison of VIPM Methods", Game Programming Gems 2,
sliding window). A collapse may not touch a triangle created in the current level; the best one that does
not is taken while its error is within a tolerance of the best one's, else a new level starts.

Collapses that touch the current level keep touching it until the level ends, so they wait in a deferred
heap instead of being popped and pushed back at every step. The patches are emitted with the helpers of
:mod:`.sw_collapse` and :mod:`.sw_fans`, as the topology-driven builder emits its own. :func:`_build_forsyth`
(at the end) runs it for :func:`.slidingwindow.build_sliding_window` and cuts its output into the levels
(:class:`.sw_layout.Level`) that :mod:`.sw_assemble` reads.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..mesh import Mesh
from ..simplify import collapse_sequence
from ..simplify import kernels as K
from . import sw_layout as swl
from .sw_centres import _grow_i64
from .sw_collapse import _emit_into, _grow_tris, _record_collapse
from .sw_fans import _chain_work, _chain_work_for, chain_order


@nb.njit(cache=True)
def _touches_level(st: K.CollapseState, b: int, tri_level: np.ndarray, level: int) -> bool:
    tris = K.gather_triangles(st, b)
    for j in range(tris.shape[0]):
        if tri_level[tris[j]] == level:
            return True
    return False


@nb.njit(cache=True)
def _valid_target(st: K.CollapseState, b: int, k: int) -> bool:
    """``k >= 0`` and the collapse of ``b`` onto ``k`` valid in the current state (b's star read afresh)."""
    tris_b = K.gather_triangles(st, b)
    tp_b = K.triangle_positions(st, tris_b)
    nbr_b = K.neighbours(b, tp_b)
    return k >= 0 and K.valid_collapse(st, b, k, tris_b, tp_b, nbr_b, None)


@nb.njit(cache=True)
def _refresh(st, q, keys, ids, stamps, size, stamp, target, validate, wait, grown):
    """Queue ``q`` with its best target: the best valid one (``validate``), or its cheapest, valid or not,
    which the pop checks (lazy evaluation: a check reads the target's whole star). A position with no valid
    target is not queued again until ``wait[q]`` more collapses next to it have refreshed it (as
    :func:`swpm_usd.simplify.kernels.run_sequence` does: a hub that no collapse suits, checked after every
    collapse of its ring, made a cone of 20,000 triangles take 66 s). ``grown``: (hub_grown,
    target_grown, hub_star) of :func:`forsyth_run`."""
    if not validate and target[q] < 0 and wait[q] > 0:
        wait[q] -= 1
        return keys, ids, stamps, size
    k2, c2, n_q = K.best_collapse_sized(st, q, validate, None)
    wait[q] = n_q // K.HUB_SIZE if validate and k2 < 0 else 0
    stamp[q] += 1
    target[q] = k2
    if k2 >= 0:
        grown[1][q] = grown[0][k2]
        keys, ids, stamps, size = K._heap_push(keys, ids, stamps, size, c2, q, stamp[q])
    return keys, ids, stamps, size


@nb.njit(cache=True)
def _stale(b: int, target: np.ndarray, grown: tuple) -> bool:
    """Whether ``b``'s queued target is a hub that took more than star // HUB_SIZE collapses since ``b``
    was queued (its ring is not refreshed after each: see forsyth_run)."""
    k = target[b]
    return k >= 0 and grown[0][k] - grown[1][b] > grown[2][k] // K.HUB_SIZE


#: the levels' starting triangles stored so far, in LOD 0's triangles, past which a level must remove at least
#: :data:`MIN_LEVEL_GAIN` of its triangles before another starts. The tolerance alone starts a level whenever
#: the best collapse touches the current one and no other is close enough: on a mesh where that happens after
#: a few collapses the pool grows with the square of the mesh (a hub of 20,000 random triangles: 168 levels,
#: lambda 94; its levels grow with the mesh, so a 1 M-triangle file asked for tens of GB). The ten shared
#: meshes stay below it (nefertiti stores the most: 34.8 times its triangles, lambda 36.3), so their pools
#: are unchanged.
POOL_BUDGET = 40.0
#: past :data:`POOL_BUDGET`: the fraction of its starting triangles a level removes, beyond the tolerance
#: if need be, before a new level starts (the topology-driven builder's ``_MIN_LEVEL_GAIN``)
MIN_LEVEL_GAIN = 0.05


@nb.njit(cache=True)
def forsyth_run(
    st: K.CollapseState,
    tolerance_abs: float,
    cur_gid: np.ndarray,
    gtris: np.ndarray,
    ng: int,
    pool_budget: float = POOL_BUDGET,
    min_level_gain: float = MIN_LEVEL_GAIN,
):
    """Quadric-error collapses, one patch (the star of the binned position) each, grouped into levels
    (Forsyth, "Comparison of VIPM Methods", sliding window): a collapse may not touch a triangle created
    in the current level. When the best collapse would, the best one that does not is taken if its error
    (a distance) exceeds the best one's by at most ``tolerance_abs``; otherwise a new level starts. Once the
    levels' starting triangles pass ``pool_budget`` times LOD 0's, a level removes at least
    ``min_level_gain`` of its triangles before another starts (the best collapse that touches no triangle of
    it, however far from the best one).

    Returns ``(gtris, ng, level_start, level_gids, patch_level, p_start, p_out, q_start, q_out, recs,
    step_info)``: per level the global ids of its starting triangles (CSR), per patch (= step) its level
    and its ``P``/``Q`` triangles, the vertex collapses and per step (error, binned, kept position).
    """
    P = st.pos_points.shape[0]
    T = st.tri_verts.shape[0]
    alive = st.tri_alive
    pos_alive = st.pos_alive
    tv = st.tri_verts
    tri_level = np.full(T, -1, np.int64)
    level = np.int64(0)
    level_start = np.zeros(2, np.int64)
    level_gids = np.empty(T, np.int64)
    nlg = np.int64(0)
    for t in range(T):
        if alive[t]:
            level_gids[nlg] = cur_gid[t]
            nlg += 1
    level_start[1] = nlg
    nlev = np.int64(1)
    budget = pool_budget * nlg
    level_alive = nlg  # the current level's starting triangles, and those it removed
    level_removed = np.int64(0)
    patch_level = np.empty(max(16, P), np.int64)
    p_start = np.zeros(max(16, P) + 1, np.int64)
    q_start = np.zeros(max(16, P) + 1, np.int64)
    p_out = np.empty(max(16, 3 * T), np.int64)
    q_out = np.empty(max(16, 3 * T), np.int64)
    npo = np.int64(0)
    nq = np.int64(0)
    recs = np.empty((max(16, st.vertex_pos.shape[0]), 3), np.int64)
    nrec = np.int64(0)
    step_info = np.empty((max(16, P), 3), np.float64)
    nstep = np.int64(0)
    stamp = np.zeros(P, np.int64)
    # int64 positions and triangle ids throughout: the callees shared with collapse_patches and
    # run_sequence are compiled once for both
    target = np.full(P, -1, np.int64)
    wait = np.zeros(P, np.int64)
    # per position: collapses onto it while a hub, the count when its target was queued, its star at the
    # last collapse onto it (a hub's ring is not refreshed after each collapse onto it, as in run_sequence)
    grown = (np.zeros(P, np.int64), np.zeros(P, np.int64), np.zeros(P, np.int64))
    keys = np.empty(max(16, P), np.float64)
    ids = np.empty(max(16, P), np.int64)
    stamps = np.empty(max(16, P), np.int64)
    size = np.int64(0)
    dk = np.empty(64, np.float64)  # deferred heap: collapses that touch the current level
    di = np.empty(64, np.int64)
    ds = np.empty(64, np.int64)
    dsize = np.int64(0)
    fw = _chain_work(np.int64(16))
    bbuf = K.star_buffers(st)
    for _ in range(3):
        progress = 0
        for p in range(P):
            # (validate as np.bool_ at every call: a literal True / False compiled _refresh twice)
            keys, ids, stamps, size = _refresh(
                st, p, keys, ids, stamps, size, stamp, target, np.bool_(True), wait, grown
            )
        while size > 0 or dsize > 0:
            # the best valid collapse: the deferred heap's top (it touches the level) or the main heap's
            while dsize > 0 and (ds[0] != stamp[di[0]] or not pos_alive[di[0]]):
                _, _, _, dsize = K._heap_pop(dk, di, ds, dsize)
            if dsize > 0 and (size == 0 or dk[0] <= keys[0]):
                cost, b, s, dsize = K._heap_pop(dk, di, ds, dsize)
                from_deferred = True
            elif size > 0:
                cost, b, s, size = K._heap_pop(keys, ids, stamps, size)
                if s != stamp[b] or not pos_alive[b]:
                    continue
                if _stale(b, target, grown):
                    keys, ids, stamps, size = _refresh(
                        st, b, keys, ids, stamps, size, stamp, target, np.bool_(False), wait, grown
                    )
                    continue
                from_deferred = False
            else:
                continue
            k = target[b]
            if not _valid_target(st, b, k):
                keys, ids, stamps, size = _refresh(
                    st, b, keys, ids, stamps, size, stamp, target, np.bool_(True), wait, grown
                )
                continue
            cost = K.collapse_cost(st, b, k)
            if from_deferred or _touches_level(st, b, tri_level, level):
                # Forsyth's reordering: the best collapse that starts no new level, if close enough. A
                # collapse that touches the level keeps touching it until the level ends (the level only
                # gains triangles), so it waits in the deferred heap instead of being popped and pushed
                # back at every step (quadratic on large meshes)
                dk, di, ds, dsize = K._heap_push(dk, di, ds, dsize, cost, b, s)
                limit = np.sqrt(cost) + tolerance_abs
                if nlg > budget and level_removed < min_level_gain * level_alive:
                    limit = np.inf
                found = -1
                while size > 0:
                    c2, b2, s2, size = K._heap_pop(keys, ids, stamps, size)
                    if s2 != stamp[b2] or not pos_alive[b2]:
                        continue
                    if _stale(b2, target, grown):
                        keys, ids, stamps, size = _refresh(
                            st, b2, keys, ids, stamps, size, stamp, target, np.bool_(False), wait, grown
                        )
                        continue
                    if np.sqrt(c2) > limit:
                        keys, ids, stamps, size = K._heap_push(keys, ids, stamps, size, c2, b2, s2)
                        break
                    if not _valid_target(st, b2, target[b2]):
                        keys, ids, stamps, size = _refresh(
                            st, b2, keys, ids, stamps, size, stamp, target, np.bool_(True), wait, grown
                        )
                        continue
                    if not _touches_level(st, b2, tri_level, level):
                        found = b2
                        break
                    dk, di, ds, dsize = K._heap_push(dk, di, ds, dsize, c2, b2, s2)
                if found < 0:
                    # new level: every current triangle may be changed again, every deferred collapse
                    # competes again
                    while dsize > 0:
                        c2, b2, s2, dsize = K._heap_pop(dk, di, ds, dsize)
                        keys, ids, stamps, size = K._heap_push(keys, ids, stamps, size, c2, b2, s2)
                    level += 1
                    level_start = _grow_i64(level_start, nlev + 2)
                    level_gids = _grow_i64(level_gids, nlg + T)
                    for t in range(T):
                        if alive[t]:
                            level_gids[nlg] = cur_gid[t]
                            nlg += 1
                    level_alive = nlg - level_start[nlev]
                    level_removed = 0
                    nlev += 1
                    level_start[nlev] = nlg
                    continue
                b = found
                k = target[b]
                cost = K.collapse_cost(st, b, k)
            # do the collapse b -> k as one patch
            tris_g = K.gather_triangles(st, b)
            tris_p = tris_g.astype(np.int64)  # int64 as collapse_patches' (_emit_into)
            # a hub's ring is most of the mesh: after a collapse onto it only b's ring (whose stars changed)
            # and the hub are refreshed (a non-manifold hub in 10,000 triangles: 86 s, quadratic)
            k_hub = K._alive_more_than(st, k, K.HUB_SIZE)
            if k_hub:
                # (the int32 ids every other caller passes: one compile of triangle_positions, not two)
                ring = K.neighbours(b, K.triangle_positions(st, tris_g))
            p_out = _grow_i64(p_out, npo + tris_p.shape[0])
            sub = np.empty((tris_p.shape[0], 3), np.int64)
            for j in range(tris_p.shape[0]):
                for i in range(3):
                    sub[j, i] = tv[tris_p[j], i]
            o = chain_order(sub)
            for j in range(tris_p.shape[0]):
                p_out[npo] = cur_gid[tris_p[o[j]]]
                npo += 1
            recs, nrec = _record_collapse(st, b, k, recs, nrec, nstep, bbuf)
            fw = _chain_work_for(fw, tris_p.shape[0])
            gtris = _grow_tris(gtris, ng + tris_p.shape[0])
            q_out = _grow_i64(q_out, nq + tris_p.shape[0])
            ng, nq = _emit_into(st, tris_p, cur_gid, gtris, ng, q_out, nq, fw)
            for j in range(tris_p.shape[0]):
                if alive[tris_p[j]]:
                    tri_level[tris_p[j]] = level
                else:
                    level_removed += 1
            if nstep + 1 >= patch_level.shape[0]:
                patch_level = _grow_i64(patch_level, nstep + 2)
                p_start = _grow_i64(p_start, nstep + 3)
                q_start = _grow_i64(q_start, nstep + 3)
                si = np.empty((2 * step_info.shape[0], 3), np.float64)
                for i in range(nstep):  # a loop: see _grow_tris
                    for j in range(3):
                        si[i, j] = step_info[i, j]
                step_info = si
            patch_level[nstep] = level
            step_info[nstep, 0] = np.sqrt(cost)
            step_info[nstep, 1] = b
            step_info[nstep, 2] = k
            nstep += 1
            p_start[nstep] = npo
            q_start[nstep] = nq
            progress += 1
            stamp[b] += 1
            if k_hub:
                grown[0][k] += 1
            else:
                ring = K.neighbours(k, K.triangle_positions(st, K.gather_triangles(st, k)))
            for i in range(ring.shape[0] + 1):
                q = k if i == ring.shape[0] else np.int64(ring[i])
                if q == k and i < ring.shape[0]:
                    continue
                if q == k and k_hub:
                    # the hub itself is refreshed every star // HUB_SIZE collapses onto it
                    if grown[0][k] % max(1, grown[2][k] // K.HUB_SIZE) != 0:
                        continue
                    grown[2][k] = K.gather_triangles(st, k).shape[0]
                if q == k:
                    wait[k] = 0  # its star grew by b's: checked now, as run_sequence checks it
                keys, ids, stamps, size = _refresh(
                    st, q, keys, ids, stamps, size, stamp, target, np.bool_(False), wait, grown
                )
        if progress == 0:
            break
    return (
        gtris,
        ng,
        level_start[: nlev + 1].copy(),
        level_gids[:nlg].copy(),
        patch_level[:nstep].copy(),
        p_start[: nstep + 1].copy(),
        p_out[:npo].copy(),
        q_start[: nstep + 1].copy(),
        q_out[:nq].copy(),
        recs[:nrec].copy(),
        step_info[:nstep].copy(),
    )


def _build_forsyth(mesh: Mesh, st, tolerance: float, boundary_weight: float, seam_weight: float):
    T = mesh.triangle_count
    # Forsyth's tolerance is relative to the average collapse error of the plain quadric sequence
    ref = collapse_sequence(
        mesh, boundary_weight=boundary_weight, seam_weight=seam_weight, geometric_error=False
    )
    mean_error = float(ref.step_error.mean()) if ref.step_count else 0.0
    gtris = np.empty((max(16, 2 * T), 3), np.int64)
    gtris[:T] = mesh.triangles
    cur_gid = np.arange(T, dtype=np.int64)
    (gtris, ng, level_start, level_gids, patch_level, p_start, p_out, q_start, q_out, recs, info) = (
        forsyth_run(
            st,
            float(tolerance) * mean_error,
            cur_gid,
            gtris,
            T,
            float(POOL_BUDGET),
            float(MIN_LEVEL_GAIN),
        )
    )
    levels = []
    bounds = np.searchsorted(patch_level, np.arange(level_start.shape[0]), side="left")
    for li in range(level_start.shape[0] - 1):
        a, b = int(bounds[li]), int(bounds[li + 1])
        if b == a:
            continue
        levels.append(
            swl.Level(
                level_gids[level_start[li] : level_start[li + 1]],
                p_start[a : b + 1] - p_start[a],
                p_out[p_start[a] : p_start[b]],
                q_start[a : b + 1] - q_start[a],
                q_out[q_start[a] : q_start[b]],
                np.ones(b - a, np.int64),
            )
        )
    return gtris[:ng], levels, recs, info
