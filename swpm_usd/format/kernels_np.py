"""numpy versions of the validator's kernels for skip-strip and vanilla files
(:func:`.kernels.segment_limits`, :func:`.kernels.skip_replay` as :func:`skip_replay_np`,
:func:`.kernels.vanilla_replay` as :func:`vanilla_replay_np`): the same results, without numba.

``validate`` and ``inspect`` of one file spent 1.5 s starting: numba's import and its cached kernels' load
(0.7 s for the skip-strip check's two on cow) for a check that takes milliseconds once loaded. These replay
a file's records vectorised (each change's slot value before it, each affected triangle's corners at its
time, by sorting the changes by slot), so a skip-strip or vanilla file's check loads no numba; callers check
every index, offset and range first, as for the jitted kernels.
"""

from __future__ import annotations

import sys

import numpy as np

#: list elements and changes above which a jitted replay pays for loading numba in a process that has not
#: (the numpy one takes ~0.2 us an element, 113 ms for a 4.2 MB skip-strip bunny; numba's import and kernel
#: load ~0.8 s; its memory, a few hundred bytes a change, stays bounded)
NUMPY_REPLAY_MAX = 4_000_000


def use_jitted(elements: int) -> bool:
    """A replay of ``elements`` (list elements and changes) jitted where numba is loaded already (a pipeline
    worker, a process validating many files: ~10x faster a file) or the file is large; else numpy, so that
    ``validate``/``inspect`` of one file start without numba. Both give the same results
    (tests/test_cli_warts_h248.py)."""
    return "numba" in sys.modules or elements > NUMPY_REPLAY_MAX


def segment_limits(arr: np.ndarray, starts: np.ndarray, limits: np.ndarray, exempt: int) -> tuple[int, int]:
    """First position p, segment by segment, in segment s = ``[starts[s], starts[s+1])`` with
    ``arr[p] >= limits[s]`` and ``arr[p] != exempt``, as ``(p, s)``; ``(-1, -1)`` when none."""
    starts = np.asarray(starts, np.int64)
    n = int(limits.shape[0])
    lens = np.maximum(starts[1 : n + 1] - starts[:n], 0)
    seg = np.repeat(np.arange(n, dtype=np.int64), lens)
    first = np.cumsum(lens) - lens
    pos = np.arange(seg.shape[0], dtype=np.int64) - np.repeat(first, lens) + np.repeat(starts[:n], lens)
    values = np.asarray(arr)[pos].astype(np.int64)
    hit = np.flatnonzero((values >= np.asarray(limits, np.int64)[seg]) & (values != exempt))
    if not hit.size:
        return -1, -1
    return int(pos[hit[0]]), int(seg[hit[0]])


def _ok(x: np.ndarray, y: np.ndarray, z: np.ndarray, restart: int) -> np.ndarray:
    """A triangle of corners x, y, z draws: no restart index, three distinct vertices (as an int64 0 or 1)."""
    return ((x != restart) & (y != restart) & (z != restart) & (x != y) & (y != z) & (x != z)).astype(
        np.int64
    )


def _by_slot(
    g: np.ndarray, k: np.ndarray, base: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The changes (slot ``g``, kept vertex ``k``) by slot, in order: ``(order, gs, ks, same, before)``, each
    change's slot value before it (``before``) the previous change's kept vertex of that slot, else the
    list's (``base``); ``same``: a sorted change whose slot the one before it changed too."""
    J = int(g.shape[0])
    order = np.lexsort((np.arange(J), g))
    gs, ks = g[order], k[order]
    same = np.zeros(J, bool)
    same[1:] = gs[1:] == gs[:-1]
    before = np.empty(J, np.int64)
    before[order] = np.where(same, np.roll(ks, 1), base[gs])
    return order, gs, ks, same, before


def skip_replay_np(
    lst: np.ndarray,
    lstart: np.ndarray,
    coll: np.ndarray,
    rstart: np.ndarray,
    kept: np.ndarray,
    change_count: np.ndarray,
    offsets: np.ndarray,
    nv: int,
    strip: bool,
    restart: int,
) -> tuple[int, int, int, np.ndarray]:
    """:func:`.kernels.skip_replay`'s ``(kind, record, slot, tris)`` (``tris`` only when kind is 0: the caller
    reads it then alone). The levels' records must be ``0..rstart[-1]`` in order (as :func:`.check_skip._skip`
    has checked)."""
    R = int(kept.shape[0])
    n = int(lstart.shape[0]) - 1
    lstart = np.asarray(lstart, np.int64)
    rstart = np.asarray(rstart, np.int64)
    if n < 1 or rstart[0] != 0 or (np.diff(rstart) < 0).any() or (np.diff(lstart) < 0).any():
        from .kernels import skip_replay as jitted  # (a table the caller has not ordered: as it was)

        return jitted(lst, lstart, coll, rstart, kept, change_count, offsets, nv, strip, restart)
    base = np.asarray(lst).astype(np.int64)
    rn = int(rstart[n])
    cc = np.asarray(change_count[:rn], np.int64)
    cstart = np.concatenate(([0], np.cumsum(cc)))  # (change index of each record's first change)
    J = int(cstart[-1])
    rec = np.repeat(np.arange(rn, dtype=np.int64), cc)  # each change's record
    level_of_rec = np.repeat(np.arange(n, dtype=np.int64), np.diff(rstart))
    lv = level_of_rec[rec]
    a = lstart[lv]
    m = lstart[lv + 1] - a
    s = np.asarray(offsets[:J], np.int64)
    g = a + s  # each change's element of lst
    b = nv - 1 - rec
    k = np.asarray(kept, np.int64)[rec]
    order, gs, ks, same, before = _by_slot(g, k, base)
    bad = np.flatnonzero(before != b)
    final = base.copy()
    last = np.ones(J, bool)
    last[:-1] = gs[1:] != gs[:-1]
    final[gs[last]] = ks[last]
    lo_all, hi_all = int(lstart[0]), int(lstart[n])
    differs = (
        np.flatnonzero(np.asarray(coll[lo_all:hi_all]).astype(np.int64) != final[lo_all:hi_all]) + lo_all
    )
    tris = np.zeros(R + n, np.int64)
    # (the first level whose collapsed list differs, unless a change fails in a level before it)
    if differs.size:
        i3 = int(differs[0])
        l3 = int(np.searchsorted(lstart, i3, side="right")) - 1
        if not bad.size or l3 < int(lv[bad[0]]):
            return 3, int(rstart[l3 + 1]) - 1, i3, tris
    if bad.size:
        j1 = int(bad[0])
        return 1, int(rec[j1]), int(g[j1]), tris
    # the non-degenerate triangles of each level's list before its records (strip: every window of 3; list:
    # every third), then each change's difference over the triangles it touches, at its time
    p0, lens = int(lstart[0]), np.diff(lstart)
    lv_p = np.repeat(np.arange(n, dtype=np.int64), lens)  # each element's level
    local = np.arange(lv_p.shape[0], dtype=np.int64) - np.repeat(lstart[:-1] - p0, lens)
    first = p0 + np.flatnonzero((local <= lens[lv_p] - 3) & ((local % 3 == 0) | bool(strip)))
    drawn = _ok(base[first], base[first + 1], base[first + 2], restart)
    init = np.bincount(lv_p[first - p0], weights=drawn, minlength=n).astype(np.int64)
    tris[R : R + n] = init
    if J:
        key = gs * (J + 1) + order  # (the changes by slot, then index: ascending)
        js = np.arange(J, dtype=np.int64)
        # the elements 2 either side of each change's, as they are before it (after every earlier change):
        # the last change of that element before it, else the list's value; the change's own before and after
        near_before = np.empty((5, J), np.int64)
        for e in (-2, -1, 1, 2):
            q = np.where((s + e >= 0) & (s + e < m), g + e, 0)
            pos = np.searchsorted(key, q * (J + 1) + js, side="left") - 1
            posc = np.maximum(pos, 0)
            near_before[e + 2] = np.where((pos >= 0) & (gs[posc] == q), ks[posc], base[q])
        near_before[2] = before
        near_after = near_before.copy()
        near_after[2] = k
        # the triangles the change touches: strip, those starting 2, 1 and 0 elements before it; list, its own
        firsts = [np.full(J, d, np.int64) for d in (-2, -1, 0)] if strip else [-(s % 3)]
        delta = np.zeros(J, np.int64)
        for d in firsts:
            use = (s + d >= 0) & (s + d <= m - 3)
            rows = [np.clip(d + c + 2, 0, 4) for c in range(3)]
            was = _ok(*(near_before[r, js] for r in rows), restart)
            now = _ok(*(near_after[r, js] for r in rows), restart)
            delta += use * (now - was)
        dsum = np.concatenate(([0], np.cumsum(delta)))
        r_all = np.arange(rn, dtype=np.int64)
        lv_r = level_of_rec
        tris[:rn] = init[lv_r] + dsum[cstart[r_all + 1]] - dsum[cstart[rstart[lv_r]]]
    elif rn:
        tris[:rn] = init[level_of_rec]
    return 0, 0, 0, tris


def vanilla_replay_np(
    indices: np.ndarray,
    kept: np.ndarray,
    removed: np.ndarray,
    change_count: np.ndarray,
    offsets: np.ndarray,
    vertex_count: int,
) -> tuple[int, int, int]:
    """:func:`.kernels.vanilla_replay`'s ``(kind, record, slot)``, vectorised: each slot's values over the
    replay as segments (a value, the change that wrote it, the change that replaces it), so the binned vertex
    of record r is still referenced after it when a segment of that value is alive then, in the live
    triangles' slots (or the list's tail past its last whole triangle, which no record removes)."""
    n = int(indices.shape[0])
    R = int(kept.shape[0])
    cc = np.asarray(change_count, np.int64)
    cstart = np.concatenate(([0], np.cumsum(cc)))
    J = int(cstart[-1])
    live0 = n // 3
    after = live0 - np.cumsum(np.asarray(removed, np.int64))  # live triangles after each record
    if int(offsets.shape[0]) < J or (R and int(after[-1]) < 0) or (np.asarray(removed) < 0).any():
        from .kernels import vanilla_replay as jitted  # (records the caller has not bounded: as it was)

        return jitted(indices, kept, removed, change_count, offsets, vertex_count)
    base = np.asarray(indices).astype(np.int64)
    rec = np.repeat(np.arange(R, dtype=np.int64), cc)
    g = np.asarray(offsets[:J], np.int64)
    b = vertex_count - 1 - rec
    k = np.asarray(kept, np.int64)[rec]
    order, gs, ks, same, before = _by_slot(g, k, base)
    bad = np.flatnonzero((g >= 3 * after[rec]) | (before != b))
    r1 = int(rec[bad[0]]) if bad.size else R
    # segments: each slot's first value (from before the replay) and each change's, until the next change
    # of the slot (J + 1: never)
    never = J + 1
    nxt = np.full(J, never, np.int64)
    nxt[:-1] = np.where(gs[1:] == gs[:-1], order[1:], never)
    first_change = np.full(n, never, np.int64)
    first_change[gs[~same]] = order[~same]
    slot = np.concatenate((np.arange(n, dtype=np.int64), gs))
    value = np.concatenate((base, ks))
    start = np.concatenate((np.full(n, -1, np.int64), order))
    end = np.concatenate((first_change, nxt))
    r_of = vertex_count - 1 - value  # the record that bins the segment's vertex
    has = (r_of >= 0) & (r_of < R)
    slot, start, end, r_of = slot[has], start[has], end[has], r_of[has]
    t = cstart[r_of + 1]  # the changes done once that record is
    alive = (start < t) & (end >= t) & ((slot < 3 * after[r_of]) | (slot >= 3 * live0))
    r2 = int(r_of[alive].min()) if alive.any() else R
    if r1 < R and r1 <= r2:
        return 1, r1, int(g[bad[0]])
    if r2 < R:
        return 2, r2, vertex_count - 1 - r2
    return 0, 0, 0
