"""Fan deviation: how far the new triangles of a collapse lie from the input surface.

The topology-driven builder bars a fraction ``mu`` of each level's costliest vertices from being patch
centres (SWPM section 3) and ranks the rest by cost. The quadric cost of a half-edge collapse (Garland and
Heckbert, :func:`swpm_usd.simplify.kernels.collapse_cost`) is the area-weighted *mean* squared distance of the
kept point from the planes gathered by the binned one: it measures the kept vertex, not the interiors of the
new fan's triangles, and on a later level a large region's mean dilutes one fold of it. A window's Hausdorff
error is the *largest* distance of any of its triangles from the input, so :func:`deviation_costs` ranks a
position's best collapse by the larger of its quadric cost, the squared distance from the input surface of
the new fan's sample points (each fan triangle's centroid and new-edge midpoint) and the squared distance of
the binned point (an input vertex) from the new fan.

Most samples lie closer to the input than that larger value: a query stops at the first input triangle within
it (the bounded search of :func:`swpm_usd.metrics._nearest2`, in the bounding-volume hierarchy of the input's
triangles), so a sample needs an exact nearest-triangle search only where it raises the position's cost, and
each search opens at most ``budget`` nodes.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..metrics import _STACK, _leaf_min2, _nearest2_from, _tri_dist2
from ..simplify.fan_deviation import SAMPLES, _fan_triangle, sample_point, surface_bvh

__all__ = ["SAMPLES", "deviation_costs", "surface_bvh"]


@nb.njit(cache=True, inline="always")
def _point_tri2(pts: np.ndarray, p: int, a: int, b: int, c: int) -> float:
    return _tri_dist2(
        pts[p, 0], pts[p, 1], pts[p, 2],
        pts[a, 0], pts[a, 1], pts[a, 2],
        pts[b, 0], pts[b, 1], pts[b, 2],
        pts[c, 0], pts[c, 1], pts[c, 2],
    )  # fmt: skip


@nb.njit(cache=True, nogil=True)
def deviation_costs(
    pts: np.ndarray,
    positions: np.ndarray,
    ks: np.ndarray,
    costs: np.ndarray,
    star_start: np.ndarray,
    star_tp: np.ndarray,
    floor2: float,
    samples: np.ndarray,
    budget: int,
    tv: np.ndarray,
    node_min: np.ndarray,
    node_max: np.ndarray,
    node_a: np.ndarray,
    node_b: np.ndarray,
) -> np.ndarray:
    """``max(costs[i], D)`` for the collapse of ``positions[i]`` onto ``ks[i]``, where ``D`` is the largest
    squared distance of the new fan's ``samples`` (barycentric rows over each fan triangle ``(k, u, v)``)
    from the input and of the binned point from the fan; ``costs[i]`` where ``D <= floor2`` (rounding, far
    below any error that matters) or ``ks[i] < 0`` (no valid collapse). ``star_start``, ``star_tp``: a star
    snapshot's rows (:func:`swpm_usd.simplify.kernels.star_snapshot`); ``tv`` and the node arrays:
    :func:`surface_bvh`. :func:`deviation_rows` and :func:`deviation_join` give the same on several
    threads."""
    out = np.empty_like(costs)
    hint_at = np.empty(positions.shape[0], np.int64)
    # (np.int64, not a literal 0: deviation_rows and _nearest2 compiled once more for it)
    deviation_rows(
        pts, positions, ks, costs, star_start, star_tp, floor2, samples, budget, tv, node_min, node_max,
        node_a, node_b, np.int64(0), positions.shape[0], np.int64(0), out, hint_at,
    )  # fmt: skip
    return out


@nb.njit(cache=True, nogil=True)
def deviation_rows(
    pts: np.ndarray,
    positions: np.ndarray,
    ks: np.ndarray,
    costs: np.ndarray,
    star_start: np.ndarray,
    star_tp: np.ndarray,
    floor2: float,
    samples: np.ndarray,
    budget: int,
    tv: np.ndarray,
    node_min: np.ndarray,
    node_max: np.ndarray,
    node_a: np.ndarray,
    node_b: np.ndarray,
    lo: int,
    hi: int,
    hint: int,
    out: np.ndarray,
    hint_at: np.ndarray,
) -> int:
    """Rows ``lo .. hi - 1`` of :func:`deviation_costs` into ``out``, the searches started from the BVH leaf
    ``hint`` (0: none). ``hint_at[i]``: the hint row ``i`` started from. Returns the hint after row
    ``hi - 1``. A row depends on the rows before it only through that hint, which decides where a search
    that runs out of its ``budget`` stops (:func:`swpm_usd.metrics._nearest2`)."""
    stack = np.empty(_STACK, np.int64)
    stack_d = np.empty(_STACK, np.float64)
    for i in range(lo, hi):
        hint_at[i] = hint
        out[i] = costs[i]
        k = ks[i]
        if k < 0:
            continue
        b = positions[i]
        # the other way first, cheap: the binned point (an input vertex) to its nearest fan triangle; a
        # larger bound lets more of the samples' searches stop early
        dev = np.inf
        for r in range(star_start[b], star_start[b + 1]):
            c0, c1, c2 = _fan_triangle(star_tp, r, b, k)
            if c0 >= 0:
                dev = min(dev, _point_tri2(pts, b, c0, c1, c2))
        if not np.isfinite(dev):
            continue  # no fan: the collapse removes the whole star
        m = max(costs[i], floor2, dev)
        for r in range(star_start[b], star_start[b + 1]):
            c0, c1, c2 = _fan_triangle(star_tp, r, b, k)
            if c0 < 0:
                continue
            for s in range(samples.shape[0]):
                px, py, pz = sample_point(pts, c0, c1, c2, samples[s])
                # _nearest2's first leaf here: 40 % of the searches stop in it (bunny, nefertiti)
                d = _leaf_min2(px, py, pz, tv, node_a[hint], max(-1 - node_b[hint], 0), np.inf, m)
                if d <= m:
                    continue
                d, hint = _nearest2_from(
                    px, py, pz, m, hint, d, tv, node_min, node_max, node_a, node_b, stack, budget, stack_d,
                    np.bool_(False),
                )  # fmt: skip
                if d > m:
                    m = d
                    dev = d
        if dev > floor2:
            out[i] = max(dev, costs[i])
    return hint


@nb.njit(cache=True, nogil=True)
def deviation_join(
    pts: np.ndarray,
    positions: np.ndarray,
    ks: np.ndarray,
    costs: np.ndarray,
    star_start: np.ndarray,
    star_tp: np.ndarray,
    floor2: float,
    samples: np.ndarray,
    budget: int,
    tv: np.ndarray,
    node_min: np.ndarray,
    node_max: np.ndarray,
    node_a: np.ndarray,
    node_b: np.ndarray,
    block: int,
    end_hint: np.ndarray,
    out: np.ndarray,
    hint_at: np.ndarray,
) -> None:
    """:func:`deviation_costs`' output, bit for bit, in ``out``, from blocks of ``block`` rows computed by
    :func:`deviation_rows` in any order (on several threads), each started from hint 0 (``end_hint[j]``:
    block ``j``'s hint after its last row). Block 0 started from the sequential run's hint; each later block's
    rows are computed again, in order from the hint the sequential run would hold there, until that hint is
    the one the block's row started from: from there on the block is the sequential run's (a search that
    opens nodes leaves the leaf it ended in as the hint, whatever hint it started from, so the hints meet
    within a row or two)."""
    n = positions.shape[0]
    hint = end_hint[0]
    for j in range(1, end_hint.shape[0]):
        i = j * block
        end = min(n, i + block)
        while i < end and hint_at[i] != hint:
            hint = deviation_rows(
                pts, positions, ks, costs, star_start, star_tp, floor2, samples, budget, tv, node_min,
                node_max, node_a, node_b, i, i + 1, hint, out, hint_at,
            )  # fmt: skip
            i += 1
        if i < end:
            hint = end_hint[j]
