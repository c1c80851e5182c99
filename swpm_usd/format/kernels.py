"""Numba kernels of the validator: checks that need a loop but must stay linear in the file size.

Callers check every bound first (indices below the vertex count, offsets inside the index buffer), so the
kernels never index out of range even on hostile input.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .. import numba_cache  # noqa: F401 (before the kernels: it stamps them)


@nb.njit(cache=True)
def vanilla_replay(indices, kept, removed, change_count, offsets, vertex_count):  # pragma: no cover - jitted
    """Replay vanilla records; return ``(kind, record, slot)`` of the first problem, kind 0 when none.

    kind 1: record ``record`` changes ``slot``, which does not hold its binned vertex (or is not live);
    kind 2: after record ``record`` its binned vertex is still referenced by a live triangle.
    """
    n = indices.shape[0]
    buf = np.empty(n, np.int32)
    ref = np.zeros(vertex_count, np.int32)
    for i in range(n):
        v = np.int32(indices[i])
        buf[i] = v
        ref[v] += 1
    live = n // 3
    j = 0
    for r in range(kept.shape[0]):
        b = np.int32(vertex_count - 1 - r)
        k = np.int32(kept[r])
        after = live - np.int64(removed[r])
        for _ in range(np.int64(change_count[r])):
            s = np.int64(offsets[j])
            j += 1
            if s >= 3 * after or buf[s] != b:
                return 1, r, s
            buf[s] = k
            ref[b] -= 1
            ref[k] += 1
        for s in range(3 * after, 3 * live):
            ref[buf[s]] -= 1
        live = after
        if ref[b] != 0:
            return 2, r, np.int64(b)
    return 0, 0, 0


@nb.njit(cache=True)
def window_limits(starts, ends, limits, n):  # pragma: no cover - jitted
    """For each pool position, the smallest ``limits[w]`` of the windows ``[starts[w], ends[w])`` covering it
    and that window (``-1`` where none covers). Linear: windows are painted tightest first, skipping painted
    positions with a path-compressed next-unpainted pointer."""
    order = np.argsort(limits, kind="mergesort")
    lim = np.full(n, -1, np.int64)
    owner = np.full(n, -1, np.int64)
    nxt = np.arange(n + 1)
    for oi in range(order.shape[0]):
        w = order[oi]
        p = starts[w]
        e = ends[w]
        # find first unpainted >= p
        while p < e:
            q = p
            while nxt[q] != q:
                q = nxt[q]
            # path compression
            r = p
            while nxt[r] != q:
                t = nxt[r]
                nxt[r] = q
                r = t
            p = q
            if p >= e:
                break
            lim[p] = limits[w]
            owner[p] = w
            nxt[p] = p + 1
            p += 1
    return lim, owner


@nb.njit(cache=True)
def first_violation(values, lim):  # pragma: no cover - jitted
    """First position whose value is at or above its limit (limit -1: unconstrained), or -1."""
    for p in range(values.shape[0]):
        if lim[p] >= 0 and values[p] >= lim[p]:
            return p
    return -1


@nb.njit(cache=True)
def monotone_windows(pool, starts, ends, limits):  # pragma: no cover - jitted
    """Prefix check for windows whose starts and ends do not decrease and whose limits do not increase:
    the tightest window covering position p is the last one starting at or before p. Returns
    ``(position, window)`` of the first index at or above its limit, ``(-1, -1)`` when none. O(pool + L)."""
    n_w = starts.shape[0]
    for k in range(n_w):
        s = starts[k]
        nxt = starts[k + 1] if k + 1 < n_w else pool.shape[0]
        e = min(nxt, ends[k])
        lim = limits[k]
        for p in range(s, e):
            if pool[p] >= lim:
                return p, k
    return -1, -1


@nb.njit(cache=True)
def segment_limits(arr, starts, limits, exempt):  # pragma: no cover - jitted
    """First position p in segment [starts[s], starts[s+1]) with ``arr[p] >= limits[s]`` (not ``exempt``)."""
    for s in range(limits.shape[0]):
        lim = limits[s]
        for p in range(starts[s], starts[s + 1]):
            v = arr[p]
            if v >= lim and v != exempt:
                return p, s
    return -1, -1


@nb.njit(cache=True)
def mixed_replay(
    static, sstart, dyn, coll, dstart, rstart, kept, st_removed, dy_removed, change_count, offsets, nv
):  # pragma: no cover - jitted
    """Replay each mixed level's records on a copy of its dynamic list; ``(kind, record, slot)`` of the first
    problem, kind 0 when none. Callers have checked every index, offset and per-level range.

    kind 1: record ``record`` changes dynamic slot ``slot``, which does not hold its binned vertex (or is
    not live after the record); kind 2: after record ``record`` its binned vertex (``slot``) is still
    referenced by a live triangle of either list; kind 3: the collapsed dynamic list differs from the replay
    at ``slot``. ``nv`` is the vertex count.
    """
    ref = np.zeros(nv, np.int32)
    n = sstart.shape[0] - 1
    j = 0
    for lv in range(n):
        s0, s1, d0, d1 = sstart[lv], sstart[lv + 1], dstart[lv], dstart[lv + 1]
        buf = np.empty(d1 - d0, np.int64)
        for i in range(d1 - d0):
            buf[i] = dyn[d0 + i]
            ref[buf[i]] += 1
        for i in range(s0, s1):
            ref[static[i]] += 1
        live_s = (s1 - s0) // 3
        live_d = (d1 - d0) // 3
        for r in range(rstart[lv], rstart[lv + 1]):
            b = nv - 1 - r
            k = kept[r]
            after_s = live_s - np.int64(st_removed[r])
            after_d = live_d - np.int64(dy_removed[r])
            for _ in range(np.int64(change_count[r])):
                s = np.int64(offsets[j])
                j += 1
                if s >= 3 * after_d or buf[s] != b:
                    return 1, r, s
                buf[s] = k
                ref[b] -= 1
                ref[k] += 1
            for s in range(3 * after_d, 3 * live_d):
                ref[buf[s]] -= 1
            for s in range(s0 + 3 * after_s, s0 + 3 * live_s):
                ref[static[s]] -= 1
            live_s, live_d = after_s, after_d
            if ref[b] != 0:
                return 2, r, np.int64(b)
        for i in range(d1 - d0):
            if coll[d0 + i] != buf[i]:
                return 3, rstart[lv + 1] - 1, np.int64(d0 + i)
        # forget this level's live references (linear, no O(V) reset per level)
        for s in range(3 * live_d):
            ref[buf[s]] -= 1
        for s in range(s0, s0 + 3 * live_s):
            ref[static[s]] -= 1
    return 0, 0, 0


@nb.njit(cache=True, inline="always")
def _skip_tri_ok(buf, j, restart):  # pragma: no cover - jitted
    a, b, c = buf[j], buf[j + 1], buf[j + 2]
    if a == restart or b == restart or c == restart:
        return 0
    return 1 if (a != b and b != c and a != c) else 0


@nb.njit(cache=True)
def skip_replay(
    lst, lstart, coll, rstart, kept, change_count, offsets, nv, strip, restart
):  # pragma: no cover - jitted
    """Replay each skip-strip level's records on a copy of its list; returns ``(kind, record, slot, tris)``.

    ``tris[r]`` is the number of non-degenerate triangles of record r's level list after records up to r
    (``tris[R + l]``: level l's list before any record). kind 1: record ``record`` changes ``slot`` (an
    element of ``lst``), which does not hold its binned vertex; kind 3: the collapsed list differs from the
    replay at element ``slot`` of ``coll``. (A binned vertex left in the list after its record stays there
    to the level's end, so the caller finds it in the collapsed list: vertices >= V - the level's last
    record.) ``restart`` is the strip restart index (-1: none; never a vertex). Callers have checked every
    index (< nv or the restart index), offset (inside its level's list) and range.
    """
    R = kept.shape[0]
    n = lstart.shape[0] - 1
    tris = np.zeros(R + n, np.int64)
    j = 0
    step = 1 if strip else 3
    for lv in range(n):
        a, e = lstart[lv], lstart[lv + 1]
        m = e - a
        buf = lst[a:e].astype(np.int64)
        count = 0
        if strip:
            for t in range(m - 2):
                count += _skip_tri_ok(buf, t, restart)
        else:
            for t in range(0, m - 2, 3):
                count += _skip_tri_ok(buf, t, restart)
        tris[R + lv] = count
        for r in range(rstart[lv], rstart[lv + 1]):
            b = nv - 1 - r
            k = kept[r]
            for _ in range(np.int64(change_count[r])):
                s = np.int64(offsets[j])
                j += 1
                if buf[s] != b:
                    return 1, r, a + s, tris
                lo = max(0, s - 2) if strip else s - s % 3
                hi = min(s, m - 3) if strip else min(s - s % 3, m - 3)  # never past the list's end
                for t in range(lo, hi + 1, step):
                    count -= _skip_tri_ok(buf, t, restart)
                buf[s] = k
                for t in range(lo, hi + 1, step):
                    count += _skip_tri_ok(buf, t, restart)
            tris[r] = count
        for i in range(m):
            if coll[a + i] != buf[i]:
                return 3, rstart[lv + 1] - 1, a + i, tris
    return 0, 0, 0, tris
