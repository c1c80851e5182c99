"""The triangles of a level's patches (TD-VIPM section 3; the static middle of Forsyth's sliding window).

Both builders describe each level-of-detail step as a *patch*: the triangles it replaces (``P``, the star of
its inner vertices) and the triangles that replace them (``Q``, :mod:`.sw_collapse`).

* :func:`patch_triangles` - the triangles of every patch, ordered as fans (:mod:`.sw_fans`).
* :func:`absorb_middle` - grows the patches by the triangles of no patch (the static middle ``M``), each
  into the patch it shares most corners with, so a window draws it with its neighbours rather than in a
  scattered block; :func:`.sw_order.reassign_middle` moves them again once the patch order is known.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..simplify import kernels as K
from .sw_fans import _chain_order_into, _chain_work


@nb.njit(cache=True, nogil=True)
def patch_triangles(
    st: K.CollapseState, inner_start: np.ndarray, inner: np.ndarray, stars: K.Stars
) -> tuple[np.ndarray, np.ndarray]:
    """CSR of the (state) triangles of every patch: the union of its inner positions' stars, as a fan
    (``stars``: a snapshot of ``st``)."""
    tv = st.tri_verts
    T = tv.shape[0]
    n = inner_start.shape[0] - 1
    mark = np.full(T, -1, np.int64)
    start = np.zeros(n + 1, np.int64)
    # a patch has at most the sum of its inner positions' star sizes: sized once, so that the loops below
    # reassign no array (numba's reference counting per reassignment)
    cap = np.int64(16)
    max_ns = np.int64(16)
    for p in range(n):
        ns = np.int64(0)
        for r in range(inner_start[p], inner_start[p + 1]):
            ns += stars.start[inner[r] + 1] - stars.start[inner[r]]
        cap += ns
        max_ns = max(max_ns, ns)
    out = np.empty(cap, np.int64)
    w = _chain_work(max_ns)
    m = np.int64(0)
    for p in range(n):
        for r in range(inner_start[p], inner_start[p + 1]):
            for j in range(stars.start[inner[r]], stars.start[inner[r] + 1]):
                t = stars.tris[j]
                if mark[t] != p:
                    mark[t] = p
                    out[m] = t
                    m += 1
        ns = m - start[p]
        seg = w[4]
        sub = w[5]
        for j in range(ns):
            seg[j] = out[start[p] + j]
            for i in range(3):
                sub[j, i] = tv[seg[j], i]
        o = _chain_order_into(sub, ns, w)
        for j in range(ns):
            out[start[p] + j] = seg[o[j]]
        start[p + 1] = m
    return start, out[:m].copy()


@nb.njit(cache=True, nogil=True)
def absorb_middle(
    st: K.CollapseState,
    pt_start: np.ndarray,
    pt: np.ndarray,
    alive_t: np.ndarray,
    min_shared: int,
    stars: K.Stars,
) -> tuple[np.ndarray, np.ndarray]:
    """Patches grown by the level's untouched triangles (those in no patch, the static middle ``M``).

    A middle triangle joins the patch with which it shares most (per corner of one of the patch's triangles:
    2 for the same vertex, 1 for the same position with another vertex, i.e. across an attribute seam,
    where the cache gains nothing; ties: the smaller patch), if that is at least ``min_shared``. It touches
    no inner vertex, so its ``Q`` copy is the same triangle: it is stored twice (in ``P_i`` and ``Q_i``)
    instead of once in ``M``, but is drawn with its neighbours instead of in a separate, scattered block.
    Returns the grown CSR (each patch's own triangles first, then the absorbed ones); ``stars``: a
    snapshot of ``st``."""
    star_start = stars.start
    star_tris = stars.tris
    tv = st.tri_verts
    vpos = st.vertex_pos
    T = tv.shape[0]
    n = pt_start.shape[0] - 1
    tri_patch = np.full(T, -1, np.int64)
    size = np.zeros(n, np.int64)
    for p in range(n):
        size[p] = pt_start[p + 1] - pt_start[p]
        for j in range(pt_start[p], pt_start[p + 1]):
            tri_patch[pt[j]] = p
    extra_of = np.full(alive_t.shape[0], -1, np.int64)
    cnt = np.zeros(n + 1, np.int64)
    cand = np.empty(64, np.int64)
    score = np.empty(64, np.int64)
    for i in range(alive_t.shape[0]):
        t = alive_t[i]
        if tri_patch[t] >= 0:
            continue
        a = vpos[tv[t, 0]]
        b = vpos[tv[t, 1]]
        c = vpos[tv[t, 2]]
        nc = 0
        for r in range(3):
            q = a if r == 0 else (b if r == 1 else c)
            if K.is_hub(star_start, q):
                continue  # a hub's star holds patches all over the mesh: linear per triangle
            for j in range(star_start[q], star_start[q + 1]):
                u = star_tris[j]
                p = tri_patch[u]
                # shared corners; a shared vertex (not only its position: an attribute seam splits
                # the cache entries) counts double
                sh = 0
                for k in range(3):
                    x = tv[u, k]
                    w = vpos[x]
                    if x == tv[t, 0] or x == tv[t, 1] or x == tv[t, 2]:
                        sh += 2
                    elif w == a or w == b or w == c:
                        sh += 1
                if p < 0:
                    continue
                found = -1
                for m in range(nc):
                    if cand[m] == p:
                        found = m
                        break
                if found < 0:
                    if nc == cand.shape[0]:
                        continue
                    cand[nc] = p
                    score[nc] = sh
                    nc += 1
                elif sh > score[found]:
                    score[found] = sh
        best = -1
        for m in range(nc):
            if score[m] < min_shared:
                continue
            if (
                best < 0
                or score[m] > score[best]
                or (score[m] == score[best] and size[cand[m]] < size[cand[best]])
            ):
                best = m
        if best >= 0:
            p = cand[best]
            extra_of[i] = p
            size[p] += 1
            cnt[p + 1] += 1
    new_start = np.zeros(n + 1, np.int64)
    for p in range(n):
        new_start[p + 1] = new_start[p] + (pt_start[p + 1] - pt_start[p]) + cnt[p + 1]
    out = np.empty(new_start[n], np.int64)
    fill = np.empty(n, np.int64)
    for p in range(n):
        m = new_start[p]
        for j in range(pt_start[p], pt_start[p + 1]):
            out[m] = pt[j]
            m += 1
        fill[p] = m
    for i in range(alive_t.shape[0]):
        p = extra_of[i]
        if p >= 0:
            out[fill[p]] = alive_t[i]
            fill[p] += 1
    return new_start, out
