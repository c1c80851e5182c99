"""Fan deviation: how far the triangles a half-edge collapse creates lie from the input surface.

A collapse's quadric cost (Garland and Heckbert, :func:`.kernels.collapse_cost`) is the area-weighted *mean*
squared distance of the kept point from the planes its positions gathered. Its square root, the error every
LOD reported until 0.6, is blind to the new triangles' interiors: at 50/25/10 % of the triangles of the ten
shared meshes the Hausdorff error of a LOD (``metrics.surface_error``) was 0.88-7.93 times it (geometric mean
2.79) for the quadric order, 0.60-1.61 (1.18) for the sliding window. A renderer that picks LODs by that
error, or USD's LOD thresholds computed from it, then drew LODs with several times the error asked for,
and more so for the quadric order's encodings than for the sliding window's.

:func:`step_deviations` replays a collapse sequence and measures, before each step, the distance from the
input surface of its new fan's sample points (each fan triangle's centroid and new-edge midpoint: the
triangle ``(k, u, v)`` that replaces ``(b, u, v)``), exactly, in a bounding-volume hierarchy of the input's
triangles. A step's error is the larger of that and its quadric distance, a LOD's the largest over its steps
(:meth:`.sequence.CollapseSequence.lod_errors`). The topology-driven sliding-window builder ranks its patch
centres by the same samples (:mod:`swpm_usd.encode.sw_deviation`).
"""

from __future__ import annotations

from collections import namedtuple

import numba as nb
import numpy as np

from .. import metrics
from ..metrics import _STACK, _leaf_min2, _nearest2_from
from . import kernels as K

#: per fan triangle ``(k, u, v)`` (barycentric weights): its centroid and the midpoint of its new edge ``k u``
#: (``u v`` is an edge of the mesh already; ``v k`` is the next fan triangle's ``k u``, except at the end of a
#: boundary vertex's fan, whose last new edge goes unsampled: the boundary quadrics hold that edge)
SAMPLES = np.array([[1 / 3, 1 / 3, 1 / 3], [0.5, 0.5, 0.0]], dtype=np.float64)
#: distances below this fraction of the bounding-box diagonal count as 0 (rounding; a flat region's samples
#: then stop at their first triangle instead of searching for an exact zero)
DISTANCE_FLOOR = 1e-6
#: nodes a sample's search may open (where thousands of long triangles meet, at a cone's apex, every box
#: holds the point and the search would be linear in them; the search then keeps the nearest triangle it
#: found, an upper bound of the distance)
SEARCH_BUDGET = 4096

#: what a replay of the steps reads of a simplifier state (:func:`replay_deviations`): the positions, each
#: triangle's corner positions and the corner lists, without the vertices, quadrics and locks a collapse
#: also keeps (:func:`.kernels.apply_collapse`: its vertex map, hub edges and quadric sums were 40-60 % of
#: a replay's collapses)
ReplayState = namedtuple(
    "ReplayState",
    [
        "pos_points",  # (P,3) f64, as the CollapseState's (read only)
        "tri_pos",  # (T,3) i32 each triangle's corner positions (edited by the collapses)
        "corner_head",  # (P,) i32 as the CollapseState's
        "corner_next",  # (3T,) i32
        "tri_alive",  # (T,) bool
    ],
)


def surface_bvh(points: np.ndarray, triangles: np.ndarray) -> tuple:
    """The input surface for the deviation searches: its triangles sorted into a BVH (as metrics' own)."""
    return metrics.surface_bvh(metrics._triangle_vertices(points, triangles))


def surface_with_hints(points: np.ndarray, triangles: np.ndarray) -> tuple[tuple, np.ndarray]:
    """:func:`surface_bvh` of ``triangles`` (rows of indices into ``points``) and, per point, a BVH leaf
    holding one of its triangles (0, the root, for a point in none): a search for a point near it starts
    there and most stop at once."""
    tv = metrics._triangle_vertices(points, triangles)
    order, node_min, node_max, node_a, node_b = metrics._build_bvh(tv)
    leaf_of = np.zeros(tv.shape[0], np.int64)  # per BVH-order slot
    leaves = np.flatnonzero(node_b < 0)
    counts = -1 - node_b[leaves]
    leaf_of[np.repeat(node_a[leaves], counts) + _ranks(counts)] = np.repeat(leaves, counts)
    slot = np.empty(tv.shape[0], np.int64)
    slot[order] = np.arange(tv.shape[0])
    hint = np.zeros(points.shape[0], np.int64)
    tri = np.asarray(triangles, np.int64)
    for c in range(3):
        hint[tri[:, c]] = leaf_of[slot]
    return (np.ascontiguousarray(tv[order]), node_min, node_max, node_a, node_b), hint


def _ranks(counts: np.ndarray) -> np.ndarray:
    """0..c-1 for every ``c`` in ``counts``, concatenated."""
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    return np.arange(int(counts.sum())) - starts


@nb.njit(cache=True, inline="always")
def _fan_triangle(star_tp: np.ndarray, r: int, b: int, k: int) -> tuple[int, int, int]:
    """Star row ``r`` of ``b`` after ``b`` moves onto ``k``, turned to start at ``k`` with its winding kept:
    ``(k, u, v)``; ``(-1, -1, -1)`` if the row holds ``k`` (it collapses away)."""
    c0 = star_tp[r, 0]
    c1 = star_tp[r, 1]
    c2 = star_tp[r, 2]
    if c0 == k or c1 == k or c2 == k:
        return -1, -1, -1
    if c0 == b:
        return k, c1, c2
    if c1 == b:
        return k, c2, c0
    return k, c0, c1


@nb.njit(cache=True, inline="always")
def sample_point(pts: np.ndarray, c0: int, c1: int, c2: int, w: np.ndarray) -> tuple[float, float, float]:
    """The point of barycentric weights ``w`` (a row of :data:`SAMPLES`) in triangle ``(c0, c1, c2)``."""
    px = w[0] * pts[c0, 0] + w[1] * pts[c1, 0] + w[2] * pts[c2, 0]
    py = w[0] * pts[c0, 1] + w[1] * pts[c1, 1] + w[2] * pts[c2, 1]
    pz = w[0] * pts[c0, 2] + w[1] * pts[c1, 2] + w[2] * pts[c2, 2]
    return px, py, pz


@nb.njit(cache=True, inline="always")
def _fan_max2(
    pts: np.ndarray,
    tp_b: np.ndarray,
    n: int,
    b: int,
    k: int,
    m0: float,
    samples: np.ndarray,
    budget: int,
    hints: np.ndarray,
    tv: np.ndarray,
    node_min: np.ndarray,
    node_max: np.ndarray,
    node_a: np.ndarray,
    node_b: np.ndarray,
    stack: np.ndarray,
    stack_d: np.ndarray,
) -> float:
    """The larger of ``m0`` and the largest squared distance from the surface of the ``samples`` of the fan
    that binning ``b`` onto ``k`` makes of ``b``'s star rows ``tp_b[:n]`` (:func:`step_deviations`' search,
    each sample's stopping at the running value; the rows' order decides the hints a search out of its
    budget starts from)."""
    hint = hints[k]
    m = m0
    for r in range(n):
        c0, c1, c2 = _fan_triangle(tp_b, r, b, k)
        if c0 < 0:
            continue
        for q in range(samples.shape[0]):
            px, py, pz = sample_point(pts, c0, c1, c2, samples[q])
            # the corners are input points: the sample is no farther from the input than from the
            # nearest corner, so a sample that close to one cannot raise m (most, early in a sequence)
            ub = np.inf
            for c in (c0, c1, c2):
                ub = min(ub, (px - pts[c, 0]) ** 2 + (py - pts[c, 1]) ** 2 + (pz - pts[c, 2]) ** 2)
            if ub <= m:
                continue
            # then the input triangles around the corners (the BVH leaves that hold them): most samples
            # lie that close to one of them (bunny: 59 %), and need no search from the root. Each leaf's
            # own nearest kept (the same ub as one running minimum): a search starting from one of them
            # (the step's first, from k's) opens it again for that value
            h0 = hints[c0]
            l0 = _leaf_min2(px, py, pz, tv, node_a[h0], max(-1 - node_b[h0], 0), np.inf, m)
            ub = min(ub, l0)
            if ub <= m:
                continue
            h1 = hints[c1]
            l1 = _leaf_min2(px, py, pz, tv, node_a[h1], max(-1 - node_b[h1], 0), np.inf, m)
            ub = min(ub, l1)
            if ub <= m:
                continue
            h2 = hints[c2]
            l2 = _leaf_min2(px, py, pz, tv, node_a[h2], max(-1 - node_b[h2], 0), np.inf, m)
            ub = min(ub, l2)
            if ub <= m:
                continue
            # out of its budget the search keeps the nearest triangle it found, not m: an error may be
            # overestimated there, never underestimated (ub: the corners and their leaves, as near).
            # _nearest2's first leaf (the hint's) here, known where it is a corner's
            if hint == h0:
                d = l0
            elif hint == h1:
                d = l1
            elif hint == h2:
                d = l2
            else:
                d = _leaf_min2(px, py, pz, tv, node_a[hint], max(-1 - node_b[hint], 0), np.inf, m)
                if d <= m:
                    continue  # (min(d, ub) <= m: no change, the hint kept)
            # (np.bool_, not a literal True: the other callers' one compile of _nearest2_from)
            d, hint = _nearest2_from(
                px, py, pz, m, hint, d, tv, node_min, node_max, node_a, node_b, stack, budget, stack_d,
                np.bool_(True),
            )  # fmt: skip
            d = min(d, ub)
            if d > m:
                m = d
    return m


@nb.njit(cache=True, nogil=True)
def step_deviations(
    st: K.CollapseState,
    step_b: np.ndarray,
    step_k: np.ndarray,
    step_error: np.ndarray,
    samples: np.ndarray,
    budget: int,
    floor: float,
    hints: np.ndarray,
    tv: np.ndarray,
    node_min: np.ndarray,
    node_max: np.ndarray,
    node_a: np.ndarray,
    node_b: np.ndarray,
    start2: float = 0.0,
) -> np.ndarray:
    """Per step ``s`` (position ``step_b[s]`` onto ``step_k[s]``, applied to ``st`` in order): the larger of
    ``step_error[s]`` and the largest distance of the new fan's ``samples`` from the surface in the BVH
    (``tv`` and the nodes: :func:`surface_with_hints`, whose ``hints`` start each search near the binned
    position), where that distance exceeds every earlier step's value, else ``step_error[s]``: exact for
    the running maximum, which is all a LOD's error reads (:meth:`.sequence.CollapseSequence.lod_errors`).
    Distances up to ``floor`` count as 0. ``st`` must be the state the sequence started from; it ends
    collapsed. A sample's search stops at the first triangle within the running maximum (a closer sample
    changes nothing), so most stop in their first leaf; one out of its ``budget`` of nodes counts the
    nearest triangle it found (the value may then be above the distance, never below it). ``start2``: the
    squared running maximum of the steps before these (a sequence replayed in parts: the same values)."""
    pts = st.pos_points
    out = step_error.astype(np.float64).copy()
    bbuf = K.star_buffers(st)
    stack = np.empty(_STACK, np.int64)
    stack_d = np.empty(_STACK, np.float64)
    floor2 = floor * floor
    run2 = start2  # the running maximum, squared
    for s in range(step_b.shape[0]):
        b = step_b[s]
        k = step_k[s]
        n = K._positions_into(st, b, bbuf[0], bbuf[1])
        tris_b = bbuf[0][:n]
        tp_b = bbuf[1][:n]
        m0 = max(out[s] * out[s], floor2, run2)
        m = _fan_max2(pts, tp_b, n, b, k, m0, samples, budget, hints, tv, node_min, node_max, node_a, node_b,
                      stack, stack_d)  # fmt: skip
        if m > m0:
            out[s] = np.sqrt(m)
        run2 = max(run2, out[s] * out[s])
        K.apply_collapse(st, b, k, K.vertex_map(st, b, k, tris_b, tp_b))
    return out


def replay_state(st: K.CollapseState) -> ReplayState:
    """What :func:`replay_deviations` reads of ``st`` (a fresh state), in new arrays (``st`` may be collapsed
    afterwards; ``pos_points``, which no collapse changes, shared)."""
    tri_pos = np.ascontiguousarray(st.vertex_pos[st.tri_verts], np.int32)
    return ReplayState(
        st.pos_points, tri_pos, st.corner_head.copy(), st.corner_next.copy(), st.tri_alive.copy()
    )


@nb.njit(cache=True, nogil=True)
def replay_deviations(
    rs: ReplayState,
    step_b: np.ndarray,
    step_k: np.ndarray,
    step_error: np.ndarray,
    samples: np.ndarray,
    budget: int,
    floor: float,
    hints: np.ndarray,
    tv: np.ndarray,
    node_min: np.ndarray,
    node_max: np.ndarray,
    node_a: np.ndarray,
    node_b: np.ndarray,
    start2: float = 0.0,
) -> np.ndarray:
    """:func:`step_deviations` on a :class:`ReplayState` (:func:`replay_state` of the state the sequence
    started from; it ends collapsed): the same values, bit for bit. A collapse binning ``b`` onto ``k``
    moves every corner at ``b`` onto ``k`` whatever vertex at ``k`` it takes, so the corner positions, the
    corner lists (spliced as :func:`.kernels.apply_collapse` splices them) and hence every star's rows, in
    their order, are the full state's."""
    pts = rs.pos_points
    tri_pos = rs.tri_pos
    head = rs.corner_head
    cnext = rs.corner_next
    alive = rs.tri_alive
    out = step_error.astype(np.float64).copy()
    tris = np.empty(tri_pos.shape[0], np.int32)
    tp = np.empty((tri_pos.shape[0], 3), np.int32)
    stack = np.empty(_STACK, np.int64)
    stack_d = np.empty(_STACK, np.float64)
    floor2 = floor * floor
    run2 = start2  # the running maximum, squared
    for s in range(step_b.shape[0]):
        b = step_b[s]
        k = step_k[s]
        n = K._gather_rows(head, cnext, alive, b, tris, 0)
        for j in range(n):
            for i in range(3):
                tp[j, i] = tri_pos[tris[j], i]
        m0 = max(out[s] * out[s], floor2, run2)
        m = _fan_max2(pts, tp, n, b, k, m0, samples, budget, hints, tv, node_min, node_max, node_a, node_b,
                      stack, stack_d)  # fmt: skip
        if m > m0:
            out[s] = np.sqrt(m)
        run2 = max(run2, out[s] * out[s])
        # apply_collapse's edits of the corners and their lists: b's triangles on the edge die, its others
        # take k at its corner, its list goes in front of k's
        c = head[b]
        last = -1
        while c >= 0:
            t = c // 3
            if alive[t]:
                if tri_pos[t, 0] == k or tri_pos[t, 1] == k or tri_pos[t, 2] == k:
                    alive[t] = False
                else:
                    tri_pos[t, c - 3 * t] = k
            last = c
            c = cnext[c]
        if last >= 0:
            cnext[last] = head[k]
            head[k] = head[b]
        head[b] = -1
    return out
