"""SWPM section 3.1's connectivity optimisation: edge swaps that create low-degree vertices, so the
minimum-degree patch centres of the topology-driven builder have smaller patches and the index pool shrinks
(``optimize_connectivity=True``). :func:`optimize_mesh_connectivity` (at the end) is the entry point: the
guards (fold angle, the surface's deviation, the paper's degree floors, :func:`_swap_degree_floor`) and the
mesh in and out; the numba kernels before it do the swaps.

A swap may move the surface by at most a given distance: :func:`_swap_deviation` measures it exactly, along
the quad's two diagonals, where the two triangulations are farthest apart.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..encodings import SWAP_MAX_DEVIATION
from ..errors import BuildError
from ..mesh import Mesh
from ..metrics import _tri_dist2
from ..simplify import kernels as K
from ..simplify import mesh_topology


@nb.njit(cache=True, inline="always")
def _unit_normal(pts: np.ndarray, a: int, b: int, c: int) -> tuple[float, float, float]:
    nx, ny, nz = K.tri_normal(pts, a, b, c)
    ln = np.sqrt(nx * nx + ny * ny + nz * nz)
    if ln <= 0.0:
        return 0.0, 0.0, 0.0
    return nx / ln, ny / ln, nz / ln


@nb.njit(cache=True)
def _has_pos(tp: np.ndarray, t: int, p: int) -> bool:
    return tp[t, 0] == p or tp[t, 1] == p or tp[t, 2] == p


@nb.njit(cache=True)
def _dist_to_tri(pp: np.ndarray, x: float, y: float, z: float, t: tuple) -> float:
    """Distance from ``(x, y, z)`` to the triangle ``t`` (a position triple)."""
    p, q, r = t
    return np.sqrt(
        _tri_dist2(
            x, y, z,
            pp[p, 0], pp[p, 1], pp[p, 2],
            pp[q, 0], pp[q, 1], pp[q, 2],
            pp[r, 0], pp[r, 1], pp[r, 2],
        )
    )  # fmt: skip


@nb.njit(cache=True)
def _segment_to_pair(pp: np.ndarray, a: int, b: int, ta: tuple, tb: tuple) -> float:
    """Largest distance from the segment ``(a, b)`` to the nearer of the triangles ``ta`` (holding ``a``)
    and ``tb`` (holding ``b``). The distance to ``ta`` is convex along the segment and 0 at ``a``, so
    nondecreasing; that to ``tb`` nonincreasing: their minimum peaks where they cross, found by bisection
    (2^-30 of the segment)."""
    lo = 0.0
    hi = 1.0
    best = 0.0
    for _ in range(30):
        w = 0.5 * (lo + hi)
        x = pp[a, 0] + (pp[b, 0] - pp[a, 0]) * w
        y = pp[a, 1] + (pp[b, 1] - pp[a, 1]) * w
        z = pp[a, 2] + (pp[b, 2] - pp[a, 2]) * w
        da = _dist_to_tri(pp, x, y, z, ta)
        db = _dist_to_tri(pp, x, y, z, tb)
        best = max(best, min(da, db))
        if da < db:
            lo = w
        else:
            hi = w
    return best


@nb.njit(cache=True)
def _swap_deviation(pp: np.ndarray, v: int, j: int, k: int, l: int) -> float:
    """How far swapping the edge ``(v, j)`` of the triangles ``(v, j, k)``, ``(j, v, l)`` to ``(k, l)``
    moves the surface: the Hausdorff distance between the two triangulations of the quad. A point of an
    old triangle lies on a segment from its third corner (``k`` or ``l``, a corner of both new triangles,
    distance 0) to the diagonal ``(v, j)``, and the distance to each new triangle is convex along it, so
    the largest distance lies on the diagonal; likewise the other way (:func:`_segment_to_pair`)."""
    old = _segment_to_pair(pp, v, j, (v, l, k), (l, j, k))
    new = _segment_to_pair(pp, k, l, (v, j, k), (j, v, l))
    return max(old, new)


#: positions of a higher degree take no part in edge swaps (bounds the per-position work arrays)
_SWAP_MAX_DEGREE = 32


@nb.njit(cache=True)
def swap_edges(
    tris: np.ndarray,
    tri_pos: np.ndarray,
    pos_points: np.ndarray,
    free: np.ndarray,
    cos_max: float,
    min_degree: np.ndarray,
    max_deviation: float = np.inf,
) -> tuple[np.ndarray, int]:
    """Edge swaps that create low-degree vertices (SWPM section 3.1, procedure ``Optimize``).

    Positions are visited breadth first; a visited position ``v`` not yet marked ``Y`` joins ``X`` and
    each of its edges ``(v, j)`` with triangles ``(v, j, k)`` and ``(j, v, l)`` is swapped to ``(k, l)``
    when ``j`` is not in ``Y`` and ``k``, ``l`` are not in ``X``; then ``j`` joins ``X`` and ``k``, ``l``
    join ``Y``: the degrees of ``v`` and ``j`` drop by one, those of ``k`` and ``l`` grow by one.

    Guards: all four positions ``free`` (interior, manifold); the edge no attribute seam (the same
    vertices in both triangles); ``(k, l)`` not an edge yet; the normals of the two triangles and of the
    two new ones pairwise within ``acos(cos_max)`` (at 90 degrees: no triangle is flipped, the quad is
    never folded); the surface moves by at most ``max_deviation`` (:func:`_swap_deviation`); the degrees
    of ``v`` and ``j`` not below their ``min_degree`` (per position: the paper's floor, 4 in flat regions,
    3 elsewhere). Works on a copy of ``tris``; returns it and the
    number of swaps.
    """
    T = tris.shape[0]
    P = pos_points.shape[0]
    out = tris.copy()
    tp = tri_pos.astype(np.int64).copy()
    deg = np.zeros(P, np.int64)
    for t in range(T):
        for i in range(3):
            deg[tp[t, i]] += 1
    # incident triangles of every position, room for 8 more; positions of a higher degree than
    # _SWAP_MAX_DEGREE are never swapped (they keep only part of their list: it serves the visiting order)
    cap = 8
    for p in range(P):
        cap = max(cap, min(deg[p], _SWAP_MAX_DEGREE) + 8)
    free = free.copy()
    inc = np.full((P, cap), -1, np.int64)
    ninc = np.zeros(P, np.int64)
    for t in range(T):
        for i in range(3):
            p = tp[t, i]
            if ninc[p] < cap:
                inc[p, ninc[p]] = t
                ninc[p] += 1
    for p in range(P):
        if deg[p] > _SWAP_MAX_DEGREE:
            free[p] = False
    inX = np.zeros(P, np.bool_)
    inY = np.zeros(P, np.bool_)
    seen = np.zeros(P, np.bool_)
    queue = np.empty(P, np.int64)
    nswap = 0
    for root in range(P):
        if seen[root] or ninc[root] == 0:
            continue
        seen[root] = True
        qh = 0
        qt = 0
        queue[qt] = root
        qt += 1
        while qh < qt:
            v = queue[qh]
            qh += 1
            if free[v] and not inY[v]:
                inX[v] = True
                r = 0
                while r < ninc[v]:
                    t1 = inc[v, r]
                    r += 1
                    # the edge (v, j) that t1 holds in winding order, its third corner k
                    iv = 0
                    while tp[t1, iv] != v:
                        iv += 1
                    j = tp[t1, (iv + 1) % 3]
                    k = tp[t1, (iv + 2) % 3]
                    if inY[j] or inX[k] or not (free[j] and free[k]):
                        continue
                    if ninc[v] - 1 < min_degree[v] or ninc[j] - 1 < min_degree[j]:
                        continue
                    if ninc[k] + 1 > cap:
                        continue
                    # the other triangle (j, v, l)
                    t2 = -1
                    ncommon = 0
                    for s in range(ninc[v]):
                        u = inc[v, s]
                        if u != t1 and _has_pos(tp, u, j):
                            t2 = u
                            ncommon += 1
                    if ncommon != 1:
                        continue
                    i2 = 0
                    while tp[t2, i2] != j:
                        i2 += 1
                    if tp[t2, (i2 + 1) % 3] != v:
                        continue  # inconsistent winding
                    l = tp[t2, (i2 + 2) % 3]
                    if l == k or inX[l] or not free[l] or ninc[l] + 1 > cap:
                        continue
                    # no attribute seam on (v, j)
                    if out[t1, iv] != out[t2, (i2 + 1) % 3] or out[t1, (iv + 1) % 3] != out[t2, i2]:
                        continue
                    # (k, l) must not be an edge already
                    exists = False
                    for s in range(ninc[k]):
                        if _has_pos(tp, inc[k, s], l):
                            exists = True
                            break
                    if exists:
                        continue
                    # planarity: old and new normals close to each other
                    n1 = _unit_normal(pos_points, v, j, k)
                    n2 = _unit_normal(pos_points, j, v, l)
                    m1 = _unit_normal(pos_points, v, l, k)
                    m2 = _unit_normal(pos_points, l, j, k)
                    ok = True
                    ns = (n1, n2, m1, m2)
                    for x in range(4):
                        for y in range(x + 1, 4):
                            d = ns[x][0] * ns[y][0] + ns[x][1] * ns[y][1] + ns[x][2] * ns[y][2]
                            if d < cos_max:
                                ok = False
                    if not ok:
                        continue
                    if max_deviation < np.inf and _swap_deviation(pos_points, v, j, k, l) > max_deviation:
                        continue
                    # swap: t1 = (v, l, k), t2 = (l, j, k)
                    vv = out[t1, iv]
                    vj = out[t1, (iv + 1) % 3]
                    vk = out[t1, (iv + 2) % 3]
                    vl = out[t2, (i2 + 2) % 3]
                    out[t1, 0], out[t1, 1], out[t1, 2] = vv, vl, vk
                    out[t2, 0], out[t2, 1], out[t2, 2] = vl, vj, vk
                    tp[t1, 0], tp[t1, 1], tp[t1, 2] = v, l, k
                    tp[t2, 0], tp[t2, 1], tp[t2, 2] = l, j, k
                    # incidence: v loses t2, j loses t1, k gains t2, l gains t1
                    for s in range(ninc[v]):
                        if inc[v, s] == t2:
                            inc[v, s] = inc[v, ninc[v] - 1]
                            ninc[v] -= 1
                            break
                    for s in range(ninc[j]):
                        if inc[j, s] == t1:
                            inc[j, s] = inc[j, ninc[j] - 1]
                            ninc[j] -= 1
                            break
                    inc[k, ninc[k]] = t2
                    ninc[k] += 1
                    inc[l, ninc[l]] = t1
                    ninc[l] += 1
                    inX[j] = True
                    inY[k] = True
                    inY[l] = True
                    nswap += 1
                    r = 0  # v's fan changed: rescan it
            for s in range(ninc[v]):
                t = inc[v, s]
                for i in range(3):
                    w = tp[t, i]
                    if not seen[w]:
                        seen[w] = True
                        queue[qt] = w
                        qt += 1
    return out, nswap


#: fold guard of the edge swaps: the two triangles of a swapped edge and the two that replace them are all
#: within this angle (degrees) of each other (90: no triangle flips, the quad is never folded). How far the
#: surface may move is the ``swap_max_deviation`` parameter: a distance bounds what a viewer sees, an angle
#: does not (a 10-degree guard alone moved LOD 0 by 0.0003 of the diagonal on bunny, 0.0044 on suzanne)
_SWAP_MAX_ANGLE_DEG = 90.0
#: degree floors of the edge swaps (SWPM 3.1: "if a curvature in a vertex is below some threshold, then
#: degree of this vertex should not be decreased below four"; elsewhere the procedure goes down to three)
_SWAP_MIN_DEGREE_FLAT = 4
_SWAP_MIN_DEGREE_CURVED = 3
#: a vertex is flat when every incident triangle's normal is within this angle (degrees) of its
#: area-weighted vertex normal
_SWAP_FLAT_ANGLE_DEG = 2.0


def _swap_degree_floor(tri_pos: np.ndarray, pos_points: np.ndarray, flat_angle_deg: float) -> np.ndarray:
    """Per position: the degree an edge swap may not go below (4 where the surface is flat, else 3)."""
    P = pos_points.shape[0]
    p = pos_points[tri_pos]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])  # area-weighted face normals
    vn = np.zeros((P, 3))
    for i in range(3):
        np.add.at(vn, tri_pos[:, i], n)
    vn /= np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-300)
    un = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    min_cos = np.ones(P)
    for i in range(3):
        np.minimum.at(min_cos, tri_pos[:, i], np.sum(un * vn[tri_pos[:, i]], axis=1))
    flat = min_cos >= np.cos(np.radians(flat_angle_deg))
    return np.where(flat, _SWAP_MIN_DEGREE_FLAT, _SWAP_MIN_DEGREE_CURVED).astype(np.int64)


def optimize_mesh_connectivity(
    mesh: Mesh,
    max_angle_deg: float | None = None,
    min_degree: int | None = None,
    flat_angle_deg: float | None = None,
    max_deviation: float = SWAP_MAX_DEVIATION,
) -> Mesh:
    """``mesh`` with edges swapped to create low-degree vertices (SWPM 3.1, :func:`.sw_swaps.swap_edges`):
    same vertices and attributes, same triangle count, only interior manifold non-seam edges swapped whose
    quad is not folded (normals within ``max_angle_deg``) and whose swap moves the surface by at most
    ``max_deviation`` times the bounding-box diagonal; the topology (closed, manifold, Euler characteristic)
    is kept. Degree floor: ``min_degree`` everywhere if given, else the paper's 4 at flat vertices
    (``flat_angle_deg``) and 3 elsewhere."""
    angle = _SWAP_MAX_ANGLE_DEG if max_angle_deg is None else float(max_angle_deg)
    flat_angle = _SWAP_FLAT_ANGLE_DEG if flat_angle_deg is None else float(flat_angle_deg)
    if not float(max_deviation) >= 0.0:
        raise BuildError(f"swap_max_deviation must be >= 0, got {max_deviation}")
    if mesh.triangle_count == 0:
        return mesh
    topo = mesh_topology(mesh)
    free = ~(topo.pos_boundary | topo.pos_nonmanifold)
    tri_pos = np.ascontiguousarray(topo.tri_pos, np.int64)
    pos_points = np.ascontiguousarray(topo.pos_points, np.float64)
    if min_degree is None:
        floor = _swap_degree_floor(tri_pos, pos_points, flat_angle)
    else:
        floor = np.full(pos_points.shape[0], int(min_degree), np.int64)
    tris, _ = swap_edges(
        np.ascontiguousarray(mesh.triangles, np.int64),
        tri_pos,
        pos_points,
        np.ascontiguousarray(free),
        float(np.cos(np.radians(angle))),
        floor,
        float(max_deviation) * float(np.linalg.norm(pos_points.max(axis=0) - pos_points.min(axis=0))),
    )
    return Mesh(
        points=mesh.points,
        triangles=tris.astype(mesh.triangles.dtype),
        attributes=dict(mesh.attributes),
        source=mesh.source,
    )
