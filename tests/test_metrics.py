"""Tests of swpm_usd.metrics: FIFO vertex-cache statistics, lambda ratio and exact surface distances."""

from __future__ import annotations

import ctypes
from collections import deque
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swpm_usd.metrics import (
    SurfaceError,
    acmr,
    atvr,
    cache_misses,
    lambda_ratio,
    point_triangle_distances,
    surface_error,
)

MESHES = Path(__file__).resolve().parents[1].parent / "shared" / "meshes"


# --------------------------------------------------------------------------------------------------------
# FIFO vertex cache
# --------------------------------------------------------------------------------------------------------


def _fifo_reference(seq: list[int], cache_size: int) -> int:
    """Plain-Python FIFO: push on a miss (evicting the oldest), no reordering on a hit."""
    cache: deque[int] = deque()
    misses = 0
    for v in seq:
        if v in cache:
            continue
        misses += 1
        cache.append(v)
        if len(cache) > cache_size:
            cache.popleft()
    return misses


def test_fifo_hand_computed_cache3() -> None:
    # 0 1 2 | 2 1 3 | 3 1 0 with a 3-entry FIFO:
    # 0,1,2 miss -> [0 1 2]; 2,1 hit; 3 miss -> [1 2 3]; 3,1 hit; 0 miss -> [2 3 0].  5 misses, 3 triangles.
    tris = np.array([[0, 1, 2], [2, 1, 3], [3, 1, 0]])
    assert cache_misses(tris, cache_size=3) == (5, 3)
    assert acmr(tris, cache_size=3) == pytest.approx(5 / 3)
    assert atvr(tris, 4, cache_size=3) == pytest.approx(5 / 4)


def test_fifo_hit_does_not_reorder() -> None:
    # 0 1 2 | 0 3 4 with cache 3: 0 is a hit (no refresh), 3 evicts 0 (oldest), 4 evicts 1.
    # Then 0 1 2 again: 0 miss (evicts 2), 1 miss (evicts 3), 2 miss (evicts 4).  An LRU would hit on 0.
    tris = np.array([[0, 1, 2], [0, 3, 4], [0, 1, 2]])
    assert cache_misses(tris, cache_size=3) == (8, 3)
    assert cache_misses(tris, cache_size=5) == (5, 3)
    assert cache_misses(tris.ravel(), cache_size=3) == (8, 3)  # flat input


def test_degenerate_triangles_cost_misses_but_do_not_count() -> None:
    tris = np.array([[0, 1, 2], [3, 3, 4], [5, 6, 5]])
    assert cache_misses(tris, cache_size=3) == (7, 1)
    assert acmr(tris, cache_size=3) == pytest.approx(7.0)
    assert atvr(tris, 7, cache_size=3) == pytest.approx(1.0)
    # only degenerate triangles: misses but no triangles -> ACMR 0 by convention
    assert cache_misses(np.array([[1, 1, 2]]), cache_size=3) == (2, 0)
    assert acmr(np.array([[1, 1, 2]]), cache_size=3) == 0.0


def test_strip_each_index_fetched_once() -> None:
    strip = np.array([0, 1, 2, 3, 4, 5])  # 4 triangles, 6 fetches
    assert cache_misses(strip, cache_size=3, kind="strip") == (6, 4)
    assert acmr(strip, cache_size=3, kind="strip") == pytest.approx(1.5)
    # a swap (degenerate) inside a strip: 0 1 2 2 3 -> (0 1 2) (1 2 2)x (2 2 3)x -> 1 triangle; 2 hits once
    assert cache_misses(np.array([0, 1, 2, 2, 3]), cache_size=3, kind="strip") == (4, 1)


def test_strip_restart_index() -> None:
    r = 0xFFFFFFFF
    strip = np.array([0, 1, 2, 3, r, 4, 5, 0, 6, r, 7, 8], dtype=np.uint32)
    # strips: [0 1 2 3] -> 2 tris, [4 5 0 6] -> 2 tris, [7 8] -> 0 tris.
    # cache 3: 0 1 2 miss [0 1 2]; 3 miss [1 2 3]; 4 miss [2 3 4]; 5 miss [3 4 5]; 0 miss [4 5 0]; 6 miss
    # [5 0 6]; 7, 8 miss.  10 fetches, all misses; the restart index is never fetched.
    assert cache_misses(strip, cache_size=3, kind="strip", restart_index=r) == (10, 4)
    assert cache_misses(strip, cache_size=16, kind="strip", restart_index=r) == (9, 4)
    assert atvr(strip, 9, cache_size=16, kind="strip", restart_index=r) == pytest.approx(1.0)
    # a restart at the start, at the end and twice in a row makes no triangle across it
    s2 = np.array([-1, 0, 1, -1, -1, 2, 3, 4, -1])
    assert cache_misses(s2, cache_size=16, kind="strip", restart_index=-1) == (5, 1)


def test_empty_and_invalid_inputs() -> None:
    empty = np.zeros((0, 3), dtype=np.int32)
    assert acmr(empty) == 0.0
    assert atvr(empty, 0) == 0.0
    assert cache_misses(empty) == (0, 0)
    assert acmr(np.zeros(0, dtype=np.uint32), kind="strip") == 0.0
    with pytest.raises(ValueError):
        acmr(np.array([0, 1]))  # not a multiple of 3
    with pytest.raises(ValueError):
        acmr(np.array([[0, 1, 2]]), kind="fan")
    with pytest.raises(ValueError):
        atvr(np.array([[0, 1, 5]]), 3)  # index out of range
    with pytest.raises(ValueError):
        acmr(np.array([[0, -1, 2]]))
    with pytest.raises(ValueError):
        acmr(np.array([[0, 1, 2]]), restart_index=7)  # restart only for strips
    assert lambda_ratio(150, 100) == pytest.approx(1.5)
    with pytest.raises(ValueError):
        lambda_ratio(10, 0)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.integers(0, 12), min_size=0, max_size=90).map(lambda x: x[: len(x) // 3 * 3]),
    st.integers(1, 8),
)
def test_fifo_matches_python_reference(seq: list[int], cache_size: int) -> None:
    misses, ntri = cache_misses(np.array(seq, dtype=np.int64), cache_size=cache_size)
    assert misses == _fifo_reference(seq, cache_size)
    tris = np.array(seq).reshape(-1, 3)
    expected_tris = int(
        np.sum((tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2]))
    )
    assert ntri == expected_tris


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(0, 9), min_size=0, max_size=60), st.integers(1, 6))
def test_strip_matches_python_reference(seq: list[int], cache_size: int) -> None:
    restart = 9  # value 9 acts as the restart index
    misses, ntri = cache_misses(
        np.array(seq, dtype=np.int64), cache_size, kind="strip", restart_index=restart
    )
    assert misses == _fifo_reference([v for v in seq if v != restart], cache_size)
    expected = 0
    run: list[int] = []
    for v in seq:
        if v == restart:
            run = []
            continue
        run.append(v)
        if len(run) >= 3 and len(set(run[-3:])) == 3:
            expected += 1
    assert ntri == expected


class _VertexCacheStatistics(ctypes.Structure):
    _fields_ = [
        ("vertices_transformed", ctypes.c_uint),
        ("warps_executed", ctypes.c_uint),
        ("acmr", ctypes.c_float),
        ("atvr", ctypes.c_float),
    ]


def _meshopt_analyze(indices: np.ndarray, vertex_count: int, cache_size: int) -> _VertexCacheStatistics:
    import meshoptimizer._loader as loader

    lib = ctypes.CDLL(loader.lib._name)  # own handle: do not touch the wrapper's function prototypes
    fn = lib.meshopt_analyzeVertexCache
    fn.restype = _VertexCacheStatistics
    fn.argtypes = [
        ctypes.POINTER(ctypes.c_uint),
        ctypes.c_size_t,
        ctypes.c_size_t,
        ctypes.c_uint,
        ctypes.c_uint,
        ctypes.c_uint,
    ]
    idx = np.ascontiguousarray(indices, dtype=np.uint32).ravel()
    return fn(idx.ctypes.data_as(ctypes.POINTER(ctypes.c_uint)), idx.size, vertex_count, cache_size, 0, 0)


def _load(name: str) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    path = MESHES / name
    assert path.exists(), f"{path} missing: CI runs with ../shared beside the project"
    m = trimesh.load(path, process=False)
    return np.asarray(m.vertices, dtype=np.float32), np.asarray(m.faces, dtype=np.uint32)


def test_cache_misses_equal_meshoptimizer_on_cow() -> None:
    import meshoptimizer as meshopt

    points, tris = _load("cow.obj")
    nv = points.shape[0]
    optimized = np.zeros(tris.size, dtype=np.uint32)
    meshopt.optimize_vertex_cache(optimized, tris.ravel(), tris.size, nv)
    shuffled = tris[np.random.default_rng(1).permutation(tris.shape[0])]
    for ib in (tris.ravel(), optimized, shuffled.ravel()):
        for cache_size in (16, 32):
            ref = _meshopt_analyze(ib, nv, cache_size)
            misses, ntri = cache_misses(ib, cache_size=cache_size)
            assert misses == ref.vertices_transformed
            assert ntri == tris.shape[0]  # cow has no degenerate triangle
            assert acmr(ib, cache_size) == pytest.approx(ref.acmr, rel=1e-6)
            assert atvr(ib, nv, cache_size) == pytest.approx(ref.atvr, rel=1e-6)
    assert acmr(optimized, 16) < acmr(tris, 16)


# --------------------------------------------------------------------------------------------------------
# Exact point-triangle distance
# --------------------------------------------------------------------------------------------------------


def _brute_distances(q: np.ndarray, tv: np.ndarray) -> np.ndarray:
    """Independent reference: inside-face projection or the nearest of the three edges, all pairs."""
    q = np.asarray(q, dtype=np.float64)[:, None, :]  # (Q, 1, 3)
    a, b, c = (tv[None, :, k, :] for k in range(3))  # (1, T, 3)

    def seg(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        d = v - u
        dd = np.einsum("...k,...k->...", d, d)
        t = np.einsum("...k,...k->...", q - u, d) / np.where(dd > 0, dd, 1.0)
        t = np.clip(t, 0.0, 1.0)
        return np.linalg.norm(q - (u + t[..., None] * d), axis=-1)

    n = np.cross(b - a, c - a)
    nn = np.linalg.norm(n, axis=-1)
    nh = n / np.where(nn > 0, nn, 1.0)[..., None]
    h = np.einsum("...k,...k->...", q - a, nh)
    proj = q - h[..., None] * nh
    inside = np.broadcast_to(nn > 0, h.shape).copy()
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("...k,...k->...", np.cross(v - u, proj - u), n) >= 0
    edge = np.minimum(np.minimum(seg(a, b), seg(b, c)), seg(c, a))
    return np.where(inside, np.abs(h), edge).min(axis=1)


def test_point_triangle_single_triangle_regions() -> None:
    pts = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    tri = np.array([[0, 1, 2]])
    q = np.array(
        [
            [0.25, 0.25, 2.0],  # face: distance 2
            [-1.0, -1.0, 0.0],  # vertex a
            [3.0, -1.0, 0.0],  # vertex b
            [-0.5, 2.0, 1.0],  # vertex c
            [0.5, -2.0, 0.0],  # edge ab
            [1.0, 1.0, 0.0],  # edge bc
            [-3.0, 0.5, 4.0],  # edge ca
            [0.2, 0.3, 0.0],  # on the face
        ]
    )
    expected = [2.0, np.sqrt(2.0), np.sqrt(5.0), np.sqrt(0.25 + 1.0 + 1.0), 2.0, np.sqrt(0.5), 5.0, 0.0]
    np.testing.assert_allclose(point_triangle_distances(q, pts, tri), expected, atol=1e-12)


def test_point_triangle_distances_match_brute_force() -> None:
    rng = np.random.default_rng(7)
    pts = rng.normal(size=(60, 3))
    tris = rng.integers(0, 60, size=(40, 3))
    tris[0] = [3, 3, 5]  # degenerate: a segment
    pts[10:13] = [[0, 0, 0], [1, 1, 1], [2, 2, 2]]  # collinear: a zero-area triangle
    tris[1] = [10, 11, 12]
    tv = pts[tris]
    q = rng.normal(scale=1.5, size=(400, 3))
    # points that project exactly onto vertices, edge midpoints, and face interiors, lifted off the plane
    n = np.cross(tv[:, 1] - tv[:, 0], tv[:, 2] - tv[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    lift = rng.uniform(0.0, 0.5, size=(40, 1)) * n
    special = np.concatenate(
        [tv[:, 0], tv[:, 1] + lift, 0.5 * (tv[:, 1] + tv[:, 2]) + lift, tv.mean(axis=1) + lift]
    )
    q = np.concatenate([q, special])
    got = point_triangle_distances(q, pts, tris)
    np.testing.assert_allclose(got, _brute_distances(q, tv), rtol=1e-10, atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 300))
def test_point_triangle_distances_property(seed: int, ntri: int) -> None:
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-1, 1, size=(ntri + 2, 3))
    tris = np.stack([np.arange(ntri), np.arange(ntri) + 1, np.arange(ntri) + 2], axis=1)
    tris = tris[rng.permutation(ntri)]
    q = rng.uniform(-2, 2, size=(50, 3))
    np.testing.assert_allclose(
        point_triangle_distances(q, pts, tris), _brute_distances(q, pts[tris]), rtol=1e-10, atol=1e-12
    )


def test_point_triangle_distances_bunny_subset() -> None:
    points, tris = _load("stanford-bunny.obj")
    rng = np.random.default_rng(3)
    sub = tris[rng.choice(tris.shape[0], 3000, replace=False)]
    lo, hi = points.min(axis=0), points.max(axis=0)
    q = rng.uniform(lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo), size=(150, 3))
    got = point_triangle_distances(q, points, sub)
    np.testing.assert_allclose(
        got, _brute_distances(q, points.astype(np.float64)[sub]), rtol=1e-9, atol=1e-12
    )


# --------------------------------------------------------------------------------------------------------
# Surface error
# --------------------------------------------------------------------------------------------------------


def _unit_cube() -> tuple[np.ndarray, np.ndarray]:
    pts = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
    tris = np.array(
        [
            [0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
            [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3],
        ]
    )  # fmt: skip
    return pts, tris


def test_surface_error_of_mesh_with_itself_is_zero() -> None:
    points, tris = _load("cow.obj")
    e = surface_error(points, tris, points, tris, samples=20_000)
    assert isinstance(e, SurfaceError)
    assert e.hausdorff < 1e-6 and e.rms < 1e-6 and e.mean < 1e-6
    assert e.diagonal == pytest.approx(
        float(np.linalg.norm(points.max(axis=0).astype(np.float64) - points.min(axis=0)))
    )


def test_surface_error_translated_cube() -> None:
    pts, tris = _unit_cube()
    diag = np.sqrt(3.0)
    e = surface_error(pts, tris, pts + [0.01, 0.0, 0.0], tris, samples=50_000, seed=3)
    assert e.diagonal == pytest.approx(diag)
    # the x = 0 and x = 1 faces are 0.01 apart; samples on the other faces are within 0.01 too
    assert e.hausdorff == pytest.approx(0.01 / diag, rel=0.02)
    assert e.hausdorff <= 0.01 / diag + 1e-12
    assert 0 < e.mean < e.rms <= e.hausdorff


def test_surface_error_is_deterministic_and_symmetric_in_samples() -> None:
    pts, tris = _unit_cube()
    other = pts * [1.0, 1.0, 1.05]
    e1 = surface_error(pts, tris, other, tris, samples=5_000, seed=11)
    e2 = surface_error(pts, tris, other, tris, samples=5_000, seed=11)
    assert e1 == e2
    assert e1.hausdorff == pytest.approx(
        0.05 / np.sqrt(3.0), rel=1e-9
    )  # every sample on the top face of B is 0.05 away
    with pytest.raises(ValueError):
        surface_error(pts, tris, other, np.zeros((0, 3), dtype=int))


def test_surface_error_simplified_bunny_is_small_and_monotone() -> None:
    import meshoptimizer as meshopt

    points, tris = _load("stanford-bunny.obj")
    results = []
    for frac in (0.5, 0.1):
        dst = np.zeros(tris.size, dtype=np.uint32)
        target = int(tris.size * frac) // 3 * 3
        n = meshopt.simplify(dst, tris.ravel(), points, tris.size, points.shape[0], 12, target, 1e3)
        results.append(surface_error(points, tris, points, dst[:n].reshape(-1, 3), samples=50_000))
    assert 1e-4 < results[0].hausdorff < results[1].hausdorff < 1e-2
    assert results[0].rms < results[1].rms


def test_point_distances_match_trimesh_closest_point() -> None:
    """An independent implementation: trimesh's per-triangle closest point, over every (point, triangle)."""
    import trimesh

    points, tris = _load("cow.obj")
    q = np.random.default_rng(0).uniform(points.min(axis=0), points.max(axis=0), size=(60, 3))
    corners = points.astype(np.float64)[tris]  # (T,3,3)
    pairs_tri = np.repeat(corners[None], q.shape[0], axis=0).reshape(-1, 3, 3)
    pairs_q = np.repeat(q, tris.shape[0], axis=0)
    closest = trimesh.triangles.closest_point(pairs_tri, pairs_q)
    ref = np.linalg.norm(closest - pairs_q, axis=1).reshape(q.shape[0], -1).min(axis=1)
    np.testing.assert_allclose(point_triangle_distances(q, points, tris), ref, rtol=1e-6, atol=1e-9)


def test_box_distance_is_the_per_axis_gap_sum_bit_for_bit() -> None:
    """``_box_dist2`` (computed without branches) adds, axis by axis, the square of the gap below the box or
    else the gap above it, nothing inside: the BVH searches' pruning (and so the fan deviation and the
    reported errors) depends on the exact value. Finite points (the queries: samples of checked meshes)
    inside, outside, on faces and corners, next to them; boxes of zero extent and an empty box (+inf / -inf,
    a BVH of no triangles). A guard for the branch-free form: main's branches pass it too."""
    from swpm_usd.metrics import _box_dist2

    def reference(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
        d = 0.0
        for a in range(3):
            if lo[a] - p[a] > 0.0:
                d += (lo[a] - p[a]) * (lo[a] - p[a])
            elif p[a] - hi[a] > 0.0:
                d += (p[a] - hi[a]) * (p[a] - hi[a])
        return d

    rng = np.random.default_rng(11)
    lo = rng.normal(size=(300, 3)) * 10.0 ** rng.integers(-6, 4, size=(300, 1))
    hi = lo + np.abs(rng.normal(size=(300, 3))) * 10.0 ** rng.integers(-8, 3, size=(300, 1))
    hi[:20] = lo[:20]  # zero extent
    lo = np.vstack([lo, np.full((1, 3), np.inf)])
    hi = np.vstack([hi, np.full((1, 3), -np.inf)])
    for n in range(lo.shape[0]):
        if not np.isfinite(lo[n]).all():
            points = [np.zeros(3), rng.normal(size=3) * 1e3]
        else:
            centre = (lo[n] + hi[n]) / 2.0
            points = [centre, lo[n], hi[n], np.where(rng.random(3) < 0.5, lo[n], hi[n])]
            points += [np.nextafter(lo[n], -np.inf), np.nextafter(hi[n], np.inf)]
            points += [centre + rng.normal(size=3) * 3.0 * (hi[n] - lo[n] + 1e-3) for _ in range(4)]
        for p in points:
            got = _box_dist2(p[0], p[1], p[2], lo, hi, n)
            want = reference(p, lo[n], hi[n])
            assert got == want, (n, p, got, want)
