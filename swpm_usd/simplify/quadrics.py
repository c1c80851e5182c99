"""Garland-Heckbert quadrics: seeding them from faces and constraint edges, and a collapse's cost.

``quadric[p, 0:10]`` is the upper triangle of position ``p``'s 4x4 matrix and ``quadric_weight[p]`` the
face area it sums; :func:`collapse_cost` is the merged quadric's mean squared plane distance at the kept
point (a half-edge collapse: Svarovsky's VIPM, references/001). Also the triangle normal and smallest area
that the validity test shares.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .state import CollapseState


@nb.njit(cache=True, inline="always")
def _add_plane(q: np.ndarray, p: int, nx: float, ny: float, nz: float, d: float, w: float) -> None:
    q[p, 0] += w * nx * nx
    q[p, 1] += w * nx * ny
    q[p, 2] += w * nx * nz
    q[p, 3] += w * nx * d
    q[p, 4] += w * ny * ny
    q[p, 5] += w * ny * nz
    q[p, 6] += w * ny * d
    q[p, 7] += w * nz * nz
    q[p, 8] += w * nz * d
    q[p, 9] += w * d * d


@nb.njit(cache=True, inline="always")
def _eval_quadric2(q: np.ndarray, a: int, b: int, x: float, y: float, z: float) -> float:
    """(Q_a + Q_b)(x, y, z)."""
    s = 0.0
    s += (q[a, 0] + q[b, 0]) * x * x
    s += 2.0 * (q[a, 1] + q[b, 1]) * x * y
    s += 2.0 * (q[a, 2] + q[b, 2]) * x * z
    s += 2.0 * (q[a, 3] + q[b, 3]) * x
    s += (q[a, 4] + q[b, 4]) * y * y
    s += 2.0 * (q[a, 5] + q[b, 5]) * y * z
    s += 2.0 * (q[a, 6] + q[b, 6]) * y
    s += (q[a, 7] + q[b, 7]) * z * z
    s += 2.0 * (q[a, 8] + q[b, 8]) * z
    s += q[a, 9] + q[b, 9]
    return s


@nb.njit(cache=True, nogil=True)
def init_quadrics(
    pos_points: np.ndarray,
    tri_pos: np.ndarray,
    constraint_edges: np.ndarray,
    constraint_faces: np.ndarray,
    constraint_weights: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Area-weighted face quadrics, plus planes through each constraint edge (boundary or attribute seam)
    perpendicular to its face, weighted by ``constraint_weights[i] * length^2`` (so they keep area units)."""
    P = pos_points.shape[0]
    q = np.zeros((P, 10))
    w = np.zeros(P)
    # cross products written out (the same products and differences as np.cross): numba's np.cross
    # compiles and links the string formatting of its shape error, seconds of compile time
    for t in range(tri_pos.shape[0]):
        a, b, c = tri_pos[t, 0], tri_pos[t, 1], tri_pos[t, 2]
        n0, n1, n2 = tri_normal(pos_points, a, b, c)
        ln = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if ln <= 0.0:
            continue
        area = 0.5 * ln
        nx, ny, nz = n0 / ln, n1 / ln, n2 / ln
        d = -(nx * pos_points[a, 0] + ny * pos_points[a, 1] + nz * pos_points[a, 2])
        for p in (a, b, c):
            _add_plane(q, p, nx, ny, nz, d, area)
            w[p] += area
    for i in range(constraint_edges.shape[0]):
        a, b = constraint_edges[i, 0], constraint_edges[i, 1]
        t = constraint_faces[i]
        f0, f1, f2 = tri_normal(pos_points, tri_pos[t, 0], tri_pos[t, 1], tri_pos[t, 2])
        ex = pos_points[b, 0] - pos_points[a, 0]
        ey = pos_points[b, 1] - pos_points[a, 1]
        ez = pos_points[b, 2] - pos_points[a, 2]
        n0 = ey * f2 - ez * f1
        n1 = ez * f0 - ex * f2
        n2 = ex * f1 - ey * f0
        ln = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if ln <= 0.0:
            continue
        nx, ny, nz = n0 / ln, n1 / ln, n2 / ln
        d = -(nx * pos_points[a, 0] + ny * pos_points[a, 1] + nz * pos_points[a, 2])
        wt = constraint_weights[i] * (ex * ex + ey * ey + ez * ez)
        _add_plane(q, a, nx, ny, nz, d, wt)
        _add_plane(q, b, nx, ny, nz, d, wt)
    return q, w


@nb.njit(cache=True, inline="always")
def tri_normal(pts: np.ndarray, a: int, b: int, c: int) -> tuple[float, float, float]:
    """Unnormalised normal of triangle (a, b, c): (b - a) x (c - a), twice its area long."""
    ux = pts[b, 0] - pts[a, 0]
    uy = pts[b, 1] - pts[a, 1]
    uz = pts[b, 2] - pts[a, 2]
    vx = pts[c, 0] - pts[a, 0]
    vy = pts[c, 1] - pts[a, 1]
    vz = pts[c, 2] - pts[a, 2]
    return uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx


@nb.njit(cache=True, nogil=True)
def min_doubled_area2(pts: np.ndarray, tri_pos: np.ndarray) -> float:
    """The smallest non-zero squared doubled area (:func:`tri_normal`'s length squared) of the triangles
    ``tri_pos`` (rows of ``pts``); inf if none has an area."""
    best = np.inf
    for t in range(tri_pos.shape[0]):
        n0, n1, n2 = tri_normal(pts, tri_pos[t, 0], tri_pos[t, 1], tri_pos[t, 2])
        a2 = n0 * n0 + n1 * n1 + n2 * n2
        if 0.0 < a2 < best:
            best = a2
    return best


@nb.njit(cache=True, nogil=True)
def collapse_cost(st: CollapseState, b: int, k: int) -> float:
    """Mean squared plane distance of the merged quadric at the kept point (>= 0)."""
    return _cost_of(st.pos_points, st.quadric, st.quadric_weight, b, k)


@nb.njit(cache=True, inline="always")
def _cost_of(pts: np.ndarray, quadric: np.ndarray, qw: np.ndarray, b: int, k: int) -> float:
    """:func:`collapse_cost` on the state's arrays (a hot loop reads them once: each namedtuple field read
    costs numba's reference counting)."""
    x, y, z = pts[k, 0], pts[k, 1], pts[k, 2]
    e = _eval_quadric2(quadric, b, k, x, y, z)
    w = qw[b] + qw[k]
    if w > 0.0:
        e /= w
    return e if e > 0.0 else 0.0
