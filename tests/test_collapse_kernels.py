"""The collapse kernels' fast paths against their plain counterparts: the per-level star snapshot
(:func:`star_snapshot`, read by ``level_costs``, ``patch_triangles`` and ``absorb_middle``) and the
sliding-window target choice (``_shaped_collapse``), on meshes with attribute seams, boundaries, fixed
and complex (non-manifold) positions, degenerate triangles and dead corners left by earlier collapses."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import shared_mesh

from swpm_usd.encode import sw_collapse, sw_fans, sw_levels
from swpm_usd.mesh import Mesh
from swpm_usd.simplify import kernels as K
from swpm_usd.simplify import make_state, mesh_topology


def _awkward_grid(n: int = 9) -> Mesh:
    """An open, bumpy n x n grid with a UV seam half way down column 4 (from the border to an interior
    end), a non-manifold fin and a degenerate triangle (two seam vertices at one position)."""
    ii, jj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    pts = np.stack([ii, jj, 0.3 * np.sin(ii * 1.3) * np.cos(jj * 0.9)], -1).reshape(-1, 3).astype(float)
    vid = (ii * n + jj).astype(np.int64)
    dup = np.full((n, n), -1, np.int64)
    dup[4, :5] = pts.shape[0] + np.arange(5)  # column 4 again, for the triangles right of the seam
    pts = np.vstack([pts, pts[vid[4, :5]]])
    uv = np.vstack([pts[: n * n, :2], pts[vid[4, :5], :2] + 100.0])
    tris = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = (i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)
            q = [int(dup[p] if i >= 4 and dup[p] >= 0 else vid[p]) for p in (a, b, c, d)]
            tris += [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    fin = pts.shape[0]
    pts = np.vstack([pts, [[1.5, 1.5, 2.0]]])
    uv = np.vstack([uv, [[0.0, 0.0]]])
    tris.append([int(vid[1, 1]), int(vid[2, 2]), fin])  # a third triangle on an interior edge
    tris.append([int(vid[4, 2]), int(dup[4, 2]), int(vid[5, 3])])  # two corners at one position
    return Mesh(points=pts, triangles=np.array(tris), attributes={"uv": uv})


def _collapsed_state(mesh: Mesh, frac: float, seed: int = 0):
    """A state after ``frac`` of the positions were collapsed in random order (best valid targets)."""
    st = make_state(mesh, mesh_topology(mesh))
    P = st.pos_points.shape[0]
    recs = np.empty((16, 3), np.int64)
    bbuf = K.star_buffers(st)
    nrec, done = 0, 0
    for b in np.random.default_rng(seed).permutation(P):
        if done >= frac * P:
            break
        k, _ = K.best_collapse(st, int(b))
        if k >= 0:
            recs, nrec = sw_collapse._record_collapse(st, int(b), int(k), recs, nrec, 0, bbuf)
            done += 1
    return st


def _dead_linked_corners(st) -> int:
    n = 0
    for p in range(st.corner_head.shape[0]):
        c = st.corner_head[p]
        while c >= 0:
            n += not st.tri_alive[c // 3]
            c = st.corner_next[c]
    return n


def _valid_reference(st, b, k, tris_b, tp_b, nbr_b) -> bool:
    """:func:`valid_collapse` without its shortcuts: the duplicate-face scan over every surviving
    triangle and the full :func:`vertex_map` for every position."""
    if not st.pos_alive[b] or not st.pos_alive[k] or b == k:
        return False
    edge = [j for j in range(tp_b.shape[0]) if k in tp_b[j]]
    opp_list = [int(q) for j in edge for q in tp_b[j] if q != b and q != k]
    opp = set(opp_list)
    if st.pos_locked[b] == K.LOCK_COMPLEX:
        # onto a complex position, along an edge of three or more triangles with distinct third corners
        if not st.pos_locked[k] & K.LOCK_COMPLEX or len(edge) < 3 or len(opp) != len(opp_list):
            return False
    elif st.pos_locked[b] or not edge or len(edge) > 2 or len(edge) != (1 if st.pos_boundary[b] else 2):
        return False
    _, tp_k, nbr_k = _plain_star(st, k)
    common = (set(nbr_b.tolist()) - {k}) & set(nbr_k.tolist())
    if not common <= opp or len(common) != len(edge):
        return False
    pts = st.pos_points
    for j in range(tp_b.shape[0]):
        if j in edge:
            continue
        i = int(np.flatnonzero(tp_b[j] == b)[0])
        x, y = int(tp_b[j, (i + 1) % 3]), int(tp_b[j, (i + 2) % 3])
        n0 = K.tri_normal(pts, b, x, y)
        n1 = K.tri_normal(pts, k, x, y)
        l0 = n0[0] * n0[0] + n0[1] * n0[1] + n0[2] * n0[2]
        l1 = n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]
        if l1 <= st.min_area2[0] or n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2] <= 0.1 * np.sqrt(l0 * l1):
            return False
        if any(x in t and y in t for t in tp_k.tolist()):
            return False
    return K.vertex_map(st, b, k, tris_b, tp_b)[0] >= 0


def _plain_star(st, p):
    tris = K.gather_triangles(st, p)
    tp = K.triangle_positions(st, tris)
    return tris, tp, K.neighbours(p, tp)


@pytest.mark.parametrize(
    ("name", "frac"), [("grid", 0.0), ("grid", 0.4), ("beetle.obj", 0.3), ("spot.obj", 0.5)]
)
def test_star_snapshot_matches_the_corner_lists(name: str, frac: float) -> None:
    mesh = _awkward_grid() if name == "grid" else shared_mesh(name)
    st = _collapsed_state(mesh, frac)
    P = st.pos_points.shape[0]
    if frac > 0:
        assert _dead_linked_corners(st) > 0  # the snapshot walks (and unlinks) dead corners
    alive_tp = st.vertex_pos[st.tri_verts]
    alive_tp[~st.tri_alive] = -1
    # the snapshot of the positions with a live triangle (as a sliding-window level reads it) first: the
    # same arrays as the whole one's
    live = np.flatnonzero(np.bincount(alive_tp[st.tri_alive].ravel(), minlength=P))
    some = K.star_snapshot(st, live)
    stars = K.star_snapshot(st)
    assert _dead_linked_corners(st) == 0
    assert np.array_equal(some.start, stars.start) and np.array_equal(some.nbr_start, stars.nbr_start)
    m, mn = stars.start[-1], stars.nbr_start[-1]  # (the rows past these are room, not snapshot)
    assert np.array_equal(some.tris[:m], stars.tris[:m]) and np.array_equal(some.tp[:m], stars.tp[:m])
    assert np.array_equal(some.nbr[:mn], stars.nbr[:mn])
    seams = boundary = locked = degenerate = 0
    for p in range(P):
        r = slice(stars.start[p], stars.start[p + 1])
        rn = slice(stars.nbr_start[p], stars.nbr_start[p + 1])
        # independent of the corner lists: every alive triangle once per corner at p
        ref = np.repeat(np.arange(alive_tp.shape[0]), (alive_tp == p).sum(1))
        assert np.array_equal(np.sort(stars.tris[r]), ref), p
        assert np.array_equal(stars.tp[r], alive_tp[stars.tris[r]])
        ref_nbr = np.setdiff1d(alive_tp[ref], [p])
        assert np.array_equal(np.sort(stars.nbr[rn]), ref_nbr), p
        # and exactly (order too: it decides best_collapse's ties) what the plain kernels return
        tris, tp, nbr = _plain_star(st, p)
        assert np.array_equal(tris, stars.tris[r]) and np.array_equal(nbr, stars.nbr[rn]), p
        if ref.size and st.pos_alive[p]:
            seams += st.pos_vstart[p + 1] - st.pos_vstart[p] > 1
            boundary += bool(st.pos_boundary[p])
            locked += bool(st.pos_locked[p])
            degenerate += ref.size > np.unique(ref).size
    assert seams
    if name == "grid":
        assert boundary and locked and degenerate

    # level_costs through the snapshot == best_collapse through the corner lists
    positions = np.arange(P, dtype=np.int64)
    ks, cs = sw_levels.level_costs(st, positions, stars)
    n_valid = 0
    kbuf = K.star_buffers(st)
    for p in range(P):
        k, c = K.best_collapse(st, p)
        assert (ks[p], cs[p]) == (k, c) or (ks[p] == k == -1), p
        n_valid += k >= 0
        tris, tp, nbr = _plain_star(st, p)
        for q in nbr:
            plain = K.valid_collapse(st, p, int(q), tris, tp, nbr, None)
            assert K.valid_collapse(st, p, int(q), tris, tp, nbr, stars) == plain, (p, q)
            # k's star read by the caller into reused buffers (the sliding-window target choice)
            _, tp_k, nbr_k = K.star_into(st, int(q), *kbuf)
            assert K.valid_collapse(st, p, int(q), tris, tp, nbr, None, tp_k, nbr_k) == plain, (p, q)
            assert _valid_reference(st, p, int(q), tris, tp, nbr) == plain, (p, q)
    assert 0 < n_valid < P


def test_complex_collapses_match_the_reference() -> None:
    # a fin standing on a path of the grid: its inner feet may slide along it, onto each other and onto its
    # two ends (complex and on the boundary, so fixed themselves)
    from test_simplify import _finned_grid

    mesh, _ = _finned_grid()
    st = make_state(mesh, mesh_topology(mesh))
    onto_fixed = 0
    n_valid = 0
    for p in range(st.pos_points.shape[0]):
        tris, tp, nbr = _plain_star(st, p)
        for q in nbr:
            plain = K.valid_collapse(st, p, int(q), tris, tp, nbr, None)
            assert _valid_reference(st, p, int(q), tris, tp, nbr) == plain, (p, q)
            n_valid += plain and st.pos_locked[p] == K.LOCK_COMPLEX
            onto_fixed += plain and st.pos_locked[q] == K.LOCK_COMPLEX | K.LOCK_FIXED
    assert n_valid > 0 and onto_fixed > 0


@pytest.mark.parametrize(("name", "frac"), [("grid", 0.2), ("spot.obj", 0.3)])
def test_shaped_collapse_is_the_highest_degree_valid_target_within_the_slack(name: str, frac: float) -> None:
    mesh = _awkward_grid() if name == "grid" else shared_mesh(name)
    st = _collapsed_state(mesh, frac)
    P = st.pos_points.shape[0]
    costs = np.array([K.best_collapse(st, p)[1] for p in range(P)])
    max_cost = float(np.quantile(costs[np.isfinite(costs)], 0.9))
    moved = 0
    bbuf = K.star_buffers(st)
    kbuf = K.star_buffers(st)
    cbuf = np.empty(bbuf[2].shape[0])
    for slack in (0.05, 0.5):
        for b in range(P):
            k0, c0 = K.best_collapse(st, b)
            got = sw_collapse._shaped_collapse(st, b, slack, max_cost, bbuf, kbuf, cbuf)
            if k0 < 0:
                assert got[0] == -1
                continue
            # every valid target within the slack, scanned in neighbour order (the plain loop)
            tris, tp, nbr = _plain_star(st, b)
            lim = min(c0 + slack * max_cost, max_cost)
            best = (k0, c0, -1)
            for k in nbr:
                c = K.collapse_cost(st, b, int(k))
                if c > lim or not K.valid_collapse(st, b, int(k), tris, tp, nbr, None):
                    continue
                d = _plain_star(st, int(k))[2].shape[0]
                if d > best[2] or (d == best[2] and c < best[1]):
                    best = (int(k), c, d)
            assert got == best[:2], (b, slack)
            moved += got[0] != k0
    assert moved > 0  # the slack changes some targets


def test_chain_order_in_reused_buffers_matches_fresh_ones() -> None:
    # the patch kernels reuse one work set for every patch: a larger earlier patch must leave no
    # adjacency behind (closed fans of every size, parts of them, then random sets)
    rng = np.random.default_rng(5)
    w = sw_fans._chain_work(4)
    cases = []
    for k in (12, 3, 7, 1, 9, 2):
        ring = np.arange(1, k + 1)
        fan = np.stack([np.zeros(k, np.int64), ring, np.roll(ring, -1)], 1)
        cases += [(fan[rng.permutation(k)], k >= 3), (fan[rng.permutation(k)][: max(1, k - 2)], False)]
    cases += [(rng.integers(0, 6, (n, 3)), False) for n in (10, 4, 8, 0, 5)]
    for tv, closed in cases:
        tv = np.ascontiguousarray(tv, np.int64)
        n = tv.shape[0]
        w = sw_fans._chain_work_for(w, n)
        sub = w[5]
        sub[:n] = tv
        got = sw_fans._chain_order_into(sub, n, w).copy()
        assert np.array_equal(got, sw_fans.chain_order(tv))
        assert np.array_equal(np.sort(got), np.arange(n))
        if closed:  # a closed fan comes out as a fan: consecutive triangles share an edge
            assert all(len(set(tv[a]) & set(tv[b])) == 2 for a, b in zip(got[:-1], got[1:], strict=True))


def test_the_validity_test_asks_for_no_literal_specialisation() -> None:
    # every numba specialisation is a whole compile (seconds each on a fresh machine): valid_collapse passed
    # literal 0s, and valid_collapse_in and three of its callees compiled again apart from the sliding
    # window's int64s. A copy of valid_collapse compiled here (not loaded from the cache, which does not
    # type its callees) asks valid_collapse_in for the specialisation its arguments' types need
    import numba as nb
    from numba.core import types

    mesh = shared_mesh("cow.obj")
    st = make_state(mesh, mesh_topology(mesh))
    fresh = nb.njit(K.valid_collapse.py_func)
    tris, tp, nbr = _plain_star(st, 0)
    fresh(st, 0, int(nbr[0]), tris, tp, nbr, None)
    literal = [s for s in K.valid_collapse_in.signatures if any(isinstance(t, types.Literal) for t in s)]
    assert K.valid_collapse_in.signatures and not literal, literal
