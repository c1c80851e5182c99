"""Quality metrics: post-transform vertex-cache efficiency, index-dataset ratio, and geometric error.

Vertex cache (:func:`cache_misses`, :func:`acmr`, :func:`atvr`)
    A FIFO cache of ``cache_size`` entries. Every index goes through the cache in order: a miss fetches
    (transforms) the vertex and pushes it, evicting the oldest entry when full; a hit does not reorder the
    cache. This is the model of ``meshopt_analyzeVertexCache(..., warp_size=0, primgroup_size=0)``, and for
    triangle lists the miss counts are identical to it.

    * ``kind="triangles"``: the indices are a list of triangles (``(T, 3)`` or flat with a length that is a
      multiple of 3); the three indices of each triangle are looked up in order.
    * ``kind="strip"``: the indices are a triangle strip; triangle ``i`` of a strip uses ``s[i], s[i+1],
      s[i+2]`` (the alternating winding does not matter to the cache). ``restart_index`` (when not ``None``)
      ends the current strip and starts a new one; it is never fetched and never forms triangles. Each
      strip index goes through the cache exactly *once*, in order (that is how hardware sees a strip: one
      new index per triangle), not three times per triangle. Indices of a strip shorter than 3 are still
      fetched (they were submitted) but make no triangle.

    Degenerate triangles (two equal indices) cost their misses, since their vertices are still fetched, but
    are not counted as triangles. ``ACMR = misses / non-degenerate triangles`` and ``ATVR = misses / distinct
    vertices referenced``. Empty input (or no triangle / no vertex in the denominator) gives ``0.0``.
    Note that meshoptimizer divides by *all* triangles including degenerate ones, so ACMR values differ from
    it when degenerate triangles are present; the miss counts never do.

Index-dataset ratio (:func:`lambda_ratio`)
    The size of an encoding's index dataset over the index count of LOD 0.

Geometric error (:func:`surface_error`, :func:`point_triangle_distances`)
    Symmetric sampled surface distance. ``samples`` points are drawn area-uniformly on each mesh with a
    seeded generator, and for every sample the *exact* unsigned distance to the other mesh's triangles is
    computed (closest point on a triangle after Ericson, *Real-Time Collision Detection* 5.1.5) through a
    bounding-volume hierarchy with exact branch-and-bound pruning: never a distance to samples of the other
    mesh, which would have a noise floor larger than the errors being measured. Results are normalised by
    the bounding-box diagonal of the reference (first) mesh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from . import numba_cache  # noqa: F401 (before the kernels: it stamps them)

__all__ = [
    "SurfaceError",
    "acmr",
    "atvr",
    "cache_misses",
    "lambda_ratio",
    "point_triangle_distances",
    "surface_error",
]

_KINDS = ("triangles", "strip")


# --------------------------------------------------------------------------------------------------------
# Vertex cache
# --------------------------------------------------------------------------------------------------------


@njit(cache=True)
def _fifo_kernel(seq: np.ndarray, cache_size: int, vertex_count: int) -> tuple[int, int]:
    """Misses and distinct vertices of a fetch sequence through a FIFO cache (timestamp formulation).

    A vertex is in the cache iff it was pushed fewer than ``cache_size`` pushes ago, which is exactly a
    FIFO of ``cache_size`` entries that pushes on a miss and does not reorder on a hit.
    """
    stamp = np.zeros(vertex_count, dtype=np.int64)  # 0 = never pushed; else push number (1-based)
    pushes = 0
    for i in range(seq.shape[0]):
        v = seq[i]
        s = stamp[v]
        if s == 0 or pushes - s + 1 > cache_size:
            pushes += 1
            stamp[v] = pushes
    distinct = 0
    for v in range(vertex_count):
        if stamp[v] != 0:
            distinct += 1
    return pushes, distinct


@njit(cache=True)
def _count_list_triangles(tris: np.ndarray) -> int:
    n = 0
    for t in range(tris.shape[0]):
        a = tris[t, 0]
        b = tris[t, 1]
        c = tris[t, 2]
        if a != b and b != c and a != c:
            n += 1
    return n


@njit(cache=True)
def _count_strip_triangles(strip: np.ndarray, restart: int, has_restart: bool) -> int:
    n = 0
    run = 0  # indices seen since the last restart
    a = -1
    b = -1
    for i in range(strip.shape[0]):
        c = strip[i]
        if has_restart and c == restart:
            run = 0
            continue
        if run >= 2 and a != b and b != c and a != c:
            n += 1
        a = b
        b = c
        run += 1
    return n


def _analyze(
    indices: np.ndarray,
    cache_size: int,
    kind: str,
    restart_index: int | None,
    vertex_count: int | None,
) -> tuple[int, int, int]:
    """(misses, non-degenerate triangles, distinct vertices referenced)."""
    if kind not in _KINDS:
        raise ValueError(f"kind must be one of {_KINDS}, got {kind!r}")
    if int(cache_size) < 0:
        raise ValueError(f"cache_size must be >= 0, got {cache_size}")
    idx = np.asarray(indices)
    if idx.size and not np.issubdtype(idx.dtype, np.integer):
        raise ValueError(f"indices must be integers, got {idx.dtype}")
    idx = idx.astype(np.int64, copy=False).reshape(-1)

    if kind == "triangles":
        if restart_index is not None:
            raise ValueError("restart_index only applies to kind='strip'")
        if idx.size % 3:
            raise ValueError(f"a triangle list needs a multiple of 3 indices, got {idx.size}")
        fetch = np.ascontiguousarray(idx)
    else:
        fetch = np.ascontiguousarray(idx if restart_index is None else idx[idx != int(restart_index)])

    if fetch.size == 0:
        return 0, 0, 0
    lo = int(fetch.min())
    hi = int(fetch.max())
    if lo < 0:
        raise ValueError(f"negative vertex index {lo}")
    if vertex_count is None:
        vertex_count = hi + 1
    elif hi >= int(vertex_count):
        raise ValueError(f"vertex index {hi} out of range for vertex_count={vertex_count}")

    misses, distinct = _fifo_kernel(fetch, int(cache_size), int(vertex_count))
    if kind == "triangles":
        ntri = _count_list_triangles(fetch.reshape(-1, 3))
    else:
        has_restart = restart_index is not None
        ntri = _count_strip_triangles(
            np.ascontiguousarray(idx), int(restart_index) if has_restart else -1, has_restart
        )
    return int(misses), int(ntri), int(distinct)


def cache_misses(
    indices: np.ndarray,
    cache_size: int = 16,
    kind: str = "triangles",
    restart_index: int | None = None,
) -> tuple[int, int]:
    """``(misses, drawn_triangles)`` of ``indices`` through a FIFO vertex cache of ``cache_size`` entries.

    ``drawn_triangles`` counts the non-degenerate triangles only. See the module docstring for the cache
    model, strips and restart indices.
    """
    misses, ntri, _ = _analyze(indices, cache_size, kind, restart_index, None)
    return misses, ntri


def acmr(
    indices: np.ndarray,
    cache_size: int = 16,
    kind: str = "triangles",
    restart_index: int | None = None,
) -> float:
    """Average cache miss ratio: misses per non-degenerate triangle (0.0 for empty input)."""
    misses, ntri, _ = _analyze(indices, cache_size, kind, restart_index, None)
    return misses / ntri if ntri else 0.0


def atvr(
    indices: np.ndarray,
    vertex_count: int,
    cache_size: int = 16,
    kind: str = "triangles",
    restart_index: int | None = None,
) -> float:
    """Average transform to vertex ratio: misses per distinct vertex referenced (0.0 for empty input).

    ``vertex_count`` is the size of the vertex buffer: every index must be below it. The denominator is the
    number of distinct vertices the indices reference (as meshoptimizer does), not ``vertex_count``.
    """
    misses, _, distinct = _analyze(indices, cache_size, kind, restart_index, int(vertex_count))
    return misses / distinct if distinct else 0.0


def lambda_ratio(index_dataset_size: int, lod0_index_count: int) -> float:
    """Index-dataset size over the LOD-0 index count.

    ``index_dataset_size`` is the number of indices an encoding stores for all its levels (e.g. the
    sliding-window index buffer), ``lod0_index_count`` the index count of the full-resolution mesh
    (3 x its triangles). A value of 1 means no index overhead over storing LOD 0 alone.
    """
    if lod0_index_count <= 0:
        raise ValueError(f"lod0_index_count must be positive, got {lod0_index_count}")
    return float(index_dataset_size) / float(lod0_index_count)


# --------------------------------------------------------------------------------------------------------
# Exact point-to-triangle distance
# --------------------------------------------------------------------------------------------------------


@njit(cache=True, inline="always")
def _seg_dist2(
    px: float, py: float, pz: float, ax: float, ay: float, az: float, bx: float, by: float, bz: float
) -> float:
    dx = bx - ax
    dy = by - ay
    dz = bz - az
    wx = px - ax
    wy = py - ay
    wz = pz - az
    dd = dx * dx + dy * dy + dz * dz
    t = 0.0
    if dd > 0.0:
        t = (wx * dx + wy * dy + wz * dz) / dd
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
    ex = wx - t * dx
    ey = wy - t * dy
    ez = wz - t * dz
    return ex * ex + ey * ey + ez * ez


@njit(cache=True)
def _tri_dist2(
    px: float,
    py: float,
    pz: float,
    ax: float,
    ay: float,
    az: float,
    bx: float,
    by: float,
    bz: float,
    cx: float,
    cy: float,
    cz: float,
) -> float:
    """Squared distance from p to triangle abc (Ericson, closest point by Voronoi regions)."""
    abx = bx - ax
    aby = by - ay
    abz = bz - az
    acx = cx - ax
    acy = cy - ay
    acz = cz - az
    apx = px - ax
    apy = py - ay
    apz = pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:  # vertex a
        return apx * apx + apy * apy + apz * apz
    bpx = px - bx
    bpy = py - by
    bpz = pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:  # vertex b
        return bpx * bpx + bpy * bpy + bpz * bpz
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0 and d1 - d3 > 0.0:  # edge ab
        v = d1 / (d1 - d3)
        ex = apx - v * abx
        ey = apy - v * aby
        ez = apz - v * abz
        return ex * ex + ey * ey + ez * ez
    cpx = px - cx
    cpy = py - cy
    cpz = pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:  # vertex c
        return cpx * cpx + cpy * cpy + cpz * cpz
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0 and d2 - d6 > 0.0:  # edge ac
        w = d2 / (d2 - d6)
        ex = apx - w * acx
        ey = apy - w * acy
        ez = apz - w * acz
        return ex * ex + ey * ey + ez * ez
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0 and (d4 - d3) + (d5 - d6) > 0.0:  # edge bc
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        ex = px - (bx + w * (cx - bx))
        ey = py - (by + w * (cy - by))
        ez = pz - (bz + w * (cz - bz))
        return ex * ex + ey * ey + ez * ez
    denom = va + vb + vc
    if not denom > 0.0:
        # Degenerate (zero-area) triangle that fell through the region tests: it is its edges.
        d = _seg_dist2(px, py, pz, ax, ay, az, bx, by, bz)
        e = _seg_dist2(px, py, pz, bx, by, bz, cx, cy, cz)
        f = _seg_dist2(px, py, pz, ax, ay, az, cx, cy, cz)
        return min(d, min(e, f))
    inv = 1.0 / denom
    v = vb * inv
    w = vc * inv
    ex = apx - v * abx - w * acx
    ey = apy - v * aby - w * acy
    ez = apz - v * abz - w * acz
    return ex * ex + ey * ey + ez * ez


# --------------------------------------------------------------------------------------------------------
# Bounding-volume hierarchy over triangles (median split, leaves of up to _LEAF triangles)
# --------------------------------------------------------------------------------------------------------

_LEAF = 4
_STACK = 128


@njit(cache=True)
def _select(order: np.ndarray, keys: np.ndarray, lo: int, hi: int, k: int) -> None:
    """Reorder ``order[lo..hi]`` (inclusive) so that ``keys[order[k]]`` is the k-th smallest key there."""
    while hi > lo:
        mid = (lo + hi) // 2
        x = keys[order[lo]]
        y = keys[order[mid]]
        z = keys[order[hi]]
        pivot = max(min(x, y), min(max(x, y), z))  # median of three
        i = lo
        j = hi
        while i <= j:
            while keys[order[i]] < pivot:
                i += 1
            while keys[order[j]] > pivot:
                j -= 1
            if i <= j:
                t = order[i]
                order[i] = order[j]
                order[j] = t
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return


@njit(cache=True, nogil=True)
def _build_bvh(
    tv: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """BVH over triangles ``tv`` (T, 3, 3) float64.

    Returns (order, node_min, node_max, node_a, node_b): for an inner node ``node_a``/``node_b``
    are its children and ``node_b >= 0``; for a leaf ``node_b = -1 - count`` and ``node_a`` is the first
    position in ``order`` of its triangles.
    """
    nt = tv.shape[0]
    cen = np.empty((nt, 3), dtype=np.float64)
    for t in range(nt):
        for k in range(3):
            cen[t, k] = (tv[t, 0, k] + tv[t, 1, k] + tv[t, 2, k]) / 3.0
    keys = np.empty(nt, dtype=np.float64)
    order = np.arange(nt)
    cap = 2 * nt + 1
    node_min = np.empty((cap, 3), dtype=np.float64)
    node_max = np.empty((cap, 3), dtype=np.float64)
    node_a = np.zeros(cap, dtype=np.int64)
    node_b = np.zeros(cap, dtype=np.int64)
    st_node = np.empty(_STACK, dtype=np.int64)
    st_lo = np.empty(_STACK, dtype=np.int64)
    st_hi = np.empty(_STACK, dtype=np.int64)
    sp = 0
    st_node[0] = 0
    st_lo[0] = 0
    st_hi[0] = nt
    sp = 1
    n_nodes = 1
    while sp > 0:
        sp -= 1
        node = st_node[sp]
        lo = st_lo[sp]
        hi = st_hi[sp]
        bmin0 = np.inf
        bmin1 = np.inf
        bmin2 = np.inf
        bmax0 = -np.inf
        bmax1 = -np.inf
        bmax2 = -np.inf
        cmin = np.full(3, np.inf)
        cmax = np.full(3, -np.inf)
        for i in range(lo, hi):
            t = order[i]
            for j in range(3):
                bmin0 = min(bmin0, tv[t, j, 0])
                bmin1 = min(bmin1, tv[t, j, 1])
                bmin2 = min(bmin2, tv[t, j, 2])
                bmax0 = max(bmax0, tv[t, j, 0])
                bmax1 = max(bmax1, tv[t, j, 1])
                bmax2 = max(bmax2, tv[t, j, 2])
            for k in range(3):
                cmin[k] = min(cmin[k], cen[t, k])
                cmax[k] = max(cmax[k], cen[t, k])
        node_min[node, 0] = bmin0
        node_min[node, 1] = bmin1
        node_min[node, 2] = bmin2
        node_max[node, 0] = bmax0
        node_max[node, 1] = bmax1
        node_max[node, 2] = bmax2
        if hi - lo <= _LEAF:
            node_a[node] = lo
            node_b[node] = -1 - (hi - lo)
            continue
        axis = 0
        ext = cmax[0] - cmin[0]
        for k in range(1, 3):
            if cmax[k] - cmin[k] > ext:
                ext = cmax[k] - cmin[k]
                axis = k
        for i in range(lo, hi):
            keys[order[i]] = cen[order[i], axis]
        mid = (lo + hi) // 2
        _select(order, keys, lo, hi - 1, mid)
        left = n_nodes
        right = n_nodes + 1
        n_nodes += 2
        node_a[node] = left
        node_b[node] = right
        st_node[sp] = right
        st_lo[sp] = mid
        st_hi[sp] = hi
        sp += 1
        st_node[sp] = left
        st_lo[sp] = lo
        st_hi[sp] = mid
        sp += 1
    return order, node_min[:n_nodes].copy(), node_max[:n_nodes].copy(), node_a[:n_nodes], node_b[:n_nodes]


@njit(cache=True, inline="always")
def _box_dist2(px: float, py: float, pz: float, node_min: np.ndarray, node_max: np.ndarray, n: int) -> float:
    # per axis the larger of the gaps below and above the box, or 0 inside it, without a branch (a point
    # lies on either side of a node's box unpredictably; the fan-deviation searches -13 %, 238 captured
    # calls: 175.9 -> 153.1 ms). For a finite point the same sum, bit for bit, as the branches' "the gap
    # below if positive, else the one above if positive": at most one is positive (both +inf for the empty
    # BVH's box), and adding 0.0 leaves d as it was. (Selects written out as conditional expressions
    # compiled back to branches: no faster)
    d = 0.0
    e = max(node_min[n, 0] - px, px - node_max[n, 0], 0.0)
    d += e * e
    e = max(node_min[n, 1] - py, py - node_max[n, 1], 0.0)
    d += e * e
    e = max(node_min[n, 2] - pz, pz - node_max[n, 2], 0.0)
    d += e * e
    return d


@njit(cache=True, inline="always")
def _leaf_min2(
    px: float, py: float, pz: float, tv_sorted: np.ndarray, first: int, count: int, best: float, bound: float
) -> float:
    """The smaller of ``best`` and the squared distance to the triangles ``first .. first + count - 1``, or
    the first of those distances below ``best`` that is at most ``bound`` (the bounded search stops there)."""
    for t in range(first, first + count):
        d = _tri_dist2(
            px, py, pz,
            tv_sorted[t, 0, 0], tv_sorted[t, 0, 1], tv_sorted[t, 0, 2],
            tv_sorted[t, 1, 0], tv_sorted[t, 1, 1], tv_sorted[t, 1, 2],
            tv_sorted[t, 2, 0], tv_sorted[t, 2, 1], tv_sorted[t, 2, 2],
        )  # fmt: skip
        if d < best:
            best = d
            if best <= bound:
                return best
    return best


@njit(cache=True)
def _nearest2_from(
    px: float,
    py: float,
    pz: float,
    bound: float,
    hint: int,
    best: float,
    tv_sorted: np.ndarray,
    node_min: np.ndarray,
    node_max: np.ndarray,
    node_a: np.ndarray,
    node_b: np.ndarray,
    stack: np.ndarray,
    budget: int,
    stack_d: np.ndarray,
    upper: bool,
) -> tuple[float, int]:
    """:func:`_nearest2` after its first leaf, bit for bit: ``best`` the squared distance to
    the triangles of the ``hint`` leaf, above ``bound`` (the caller tried that leaf inline, and most
    searches stop there without a call: numba's reference counting of the call's arrays)."""
    stack[0] = 0
    stack_d[0] = _box_dist2(px, py, pz, node_min, node_max, 0)
    sp = 1
    while sp > 0:
        budget -= 1
        if budget < 0:
            return (best if upper else bound), hint
        sp -= 1
        n = stack[sp]
        if stack_d[sp] >= best:
            continue
        b = node_b[n]
        if b < 0:
            d = _leaf_min2(px, py, pz, tv_sorted, node_a[n], -1 - b, best, bound)
            if d < best:
                best = d
                hint = n
            if best <= bound:
                return best, hint
            continue
        a = node_a[n]
        da = _box_dist2(px, py, pz, node_min, node_max, a)
        db = _box_dist2(px, py, pz, node_min, node_max, b)
        # (the farther child pushed first, so the nearer one is searched first)
        if da <= db:
            if db < best:
                stack[sp] = b
                stack_d[sp] = db
                sp += 1
            if da < best:
                stack[sp] = a
                stack_d[sp] = da
                sp += 1
        else:
            if da < best:
                stack[sp] = a
                stack_d[sp] = da
                sp += 1
            if db < best:
                stack[sp] = b
                stack_d[sp] = db
                sp += 1
    return best, hint


@njit(cache=True)
def _nearest2(
    px: float,
    py: float,
    pz: float,
    bound: float,
    hint: int,
    tv_sorted: np.ndarray,
    node_min: np.ndarray,
    node_max: np.ndarray,
    node_a: np.ndarray,
    node_b: np.ndarray,
    stack: np.ndarray,
    budget: int,
    stack_d: np.ndarray,
    upper: bool = False,
) -> tuple[float, int]:
    """Squared distance from the point to the nearest triangle (branch and bound), and the leaf that held it,
    the ``hint`` of the next, nearby query (its triangles seed the bound: coherent queries are cheap).

    With ``bound >= 0`` the search may stop at the first triangle at most that close and return its distance
    (the exact distance is returned whenever it is above ``bound``); after opening ``budget`` nodes it stops
    and returns ``bound`` (where thousands of long triangles meet, at a cone's apex or a disc's centre,
    every box holds the point and the search would be linear in them), or with ``upper`` the nearest
    triangle's distance found so far (an upper bound: a search for a distance that must not be
    underestimated). ``bound = -1`` and an unreachable ``budget``: the exact distance always. ``stack_d``:
    scratch beside ``stack`` (the box distance of every node on it, computed when it was pushed)."""
    best = _leaf_min2(px, py, pz, tv_sorted, node_a[hint], max(-1 - node_b[hint], 0), np.inf, bound)
    if best <= bound:
        return best, hint
    return _nearest2_from(
        px,
        py,
        pz,
        bound,
        hint,
        best,
        tv_sorted,
        node_min,
        node_max,
        node_a,
        node_b,
        stack,
        budget,
        stack_d,
        upper,
    )


@njit(cache=True)
def _query_bvh(
    q: np.ndarray,
    tv_sorted: np.ndarray,
    node_min: np.ndarray,
    node_max: np.ndarray,
    node_a: np.ndarray,
    node_b: np.ndarray,
) -> np.ndarray:
    """Exact unsigned distance from every row of ``q`` to the nearest triangle (branch and bound)."""
    nq = q.shape[0]
    out = np.empty(nq, dtype=np.float64)
    stack = np.empty(_STACK, dtype=np.int64)
    stack_d = np.empty(_STACK, dtype=np.float64)
    hint = 0  # leaf that held the previous answer: a cheap first upper bound for coherent queries
    for i in range(nq):
        best, hint = _nearest2(
            q[i, 0],
            q[i, 1],
            q[i, 2],
            -1.0,
            hint,
            tv_sorted,
            node_min,
            node_max,
            node_a,
            node_b,
            stack,
            1 << 62,
            stack_d,
            np.bool_(False),  # (not omitted, nor a literal: the other callers' one compile of _nearest2)
        )
        out[i] = np.sqrt(best)
    return out


def _triangle_vertices(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    tri = np.asarray(tris)
    if tri.size and not np.issubdtype(tri.dtype, np.integer):
        raise ValueError(f"triangle indices must be integers, got {tri.dtype}")
    tri = tri.astype(np.int64, copy=False).reshape(-1, 3)
    if tri.shape[0] == 0:
        raise ValueError("the mesh has no triangles")
    if tri.min() < 0 or tri.max() >= pts.shape[0]:
        raise ValueError(f"triangle index out of range for {pts.shape[0]} points")
    return np.ascontiguousarray(pts[tri])  # (T, 3, 3)


def surface_bvh(tv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The triangles ``tv`` (T, 3, 3) in BVH order, and the BVH's nodes: (tv_sorted, node_min, node_max,
    node_a, node_b), the arguments of :func:`_query_bvh` and :func:`_nearest2` after the query."""
    order, node_min, node_max, node_a, node_b = _build_bvh(tv)
    return np.ascontiguousarray(tv[order]), node_min, node_max, node_a, node_b


def _distances_to(query: np.ndarray, tv: np.ndarray) -> np.ndarray:
    bvh = surface_bvh(tv)
    q = np.ascontiguousarray(np.asarray(query, dtype=np.float64).reshape(-1, 3))
    if q.shape[0] == 0:
        return np.zeros(0, dtype=np.float64)
    return _query_bvh(q, *bvh)


def point_triangle_distances(query_points: np.ndarray, points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Exact unsigned distance (float64, shape ``(Q,)``) from each query point to the nearest triangle.

    ``points`` (V, 3) and ``tris`` (T, 3) describe the target mesh; it must have at least one triangle.
    Degenerate (zero-area) triangles are handled as their edges.
    """
    return _distances_to(query_points, _triangle_vertices(points, tris))


# --------------------------------------------------------------------------------------------------------
# Symmetric surface error
# --------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SurfaceError:
    """Symmetric sampled surface distance, every distance divided by ``diagonal``.

    ``hausdorff``: the largest sample-to-surface distance in either direction; ``rms`` and ``mean``: over
    the samples of both directions together; ``diagonal``: the bounding-box diagonal of the reference mesh.
    """

    hausdorff: float
    rms: float
    mean: float
    diagonal: float


def _sample_surface(tv: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` area-uniform points on the triangles ``tv`` (T, 3, 3)."""
    a = tv[:, 0]
    ab = tv[:, 1] - a
    ac = tv[:, 2] - a
    area = 0.5 * np.linalg.norm(np.cross(ab, ac), axis=1)
    cum = np.cumsum(area)
    total = cum[-1]
    if total > 0.0:
        pick = np.searchsorted(cum, rng.random(n) * total, side="right")
        pick = np.minimum(pick, tv.shape[0] - 1)
    else:  # all triangles degenerate: fall back to uniform over triangles
        pick = rng.integers(0, tv.shape[0], n)
    r1 = np.sqrt(rng.random(n))
    r2 = rng.random(n)
    u = (r1 * (1.0 - r2))[:, None]
    v = (r1 * r2)[:, None]
    return a[pick] + u * ab[pick] + v * ac[pick]


def surface_error(
    points_a: np.ndarray,
    tris_a: np.ndarray,
    points_b: np.ndarray,
    tris_b: np.ndarray,
    samples: int = 200_000,
    seed: int = 0,
) -> SurfaceError:
    """Symmetric surface distance between mesh A (the reference) and mesh B.

    ``samples`` points are drawn area-uniformly on A and on B (deterministic for a given ``seed``); each
    sample's exact distance to the other mesh's triangles is computed. ``hausdorff`` is the maximum over
    both directions, ``rms = sqrt(mean(d**2))`` and ``mean = mean(d)`` over both sample sets together, all
    divided by the bounding-box diagonal of ``points_a``.
    """
    if samples <= 0:
        raise ValueError(f"samples must be positive, got {samples}")
    tva = _triangle_vertices(points_a, tris_a)
    tvb = _triangle_vertices(points_b, tris_b)
    pa = np.asarray(points_a, dtype=np.float64).reshape(-1, 3)
    diag = float(np.linalg.norm(pa.max(axis=0) - pa.min(axis=0)))
    if not diag > 0.0:
        raise ValueError("the reference mesh has a zero bounding-box diagonal")
    rng = np.random.default_rng(seed)
    sa = _sample_surface(tva, int(samples), rng)
    sb = _sample_surface(tvb, int(samples), rng)
    d_ab = _distances_to(sa, tvb)
    d_ba = _distances_to(sb, tva)
    d = np.concatenate([d_ab, d_ba])
    return SurfaceError(
        hausdorff=float(d.max()) / diag,
        rms=float(np.sqrt(np.mean(d * d))) / diag,
        mean=float(d.mean()) / diag,
        diagonal=diag,
    )
