"""The sliding-window encoding's chunks, ``WREC`` and the ``INDX`` pool (spec 3.5; the stages of spec 5).

:func:`_sliding` checks each LOD's window against ``LODS`` (``SWPM_WINDOW_COUNT_MISMATCH``), that windows
do not grow and stay inside the pool (``SWPM_WINDOW_NOT_MONOTONE``, ``SWPM_WINDOW_OUT_OF_POOL``), and that
each window uses only its LOD's vertices (``SWPM_PREFIX_VIOLATION``; one pass over the pool when the
windows move monotonically, :func:`.kernels.monotone_windows`, else per-position limits). A strip pool
(the ``SW_STRIPS`` feature bit): ``WREC`` rows of four fields (``index_count`` last), the restart index
exempt from the index checks, every window starting at the pool's start or after a restart index
(``SWPM_WINDOW_MID_STRIP``) and decoding to its triangle count (``SWPM_WINDOW_STRIP_TRIANGLES``). Separate
from the reader, as each encoding's checks are: one file per encoding.
"""

from __future__ import annotations

import numpy as np

from . import layout as L
from .errors import Report
from .parsed import _get, _index_check, _Parsed, _view


def _sliding(p: _Parsed, rep: Report) -> None:
    w_c, idx_c = _get(p, L.WREC), _get(p, L.INDX)
    if w_c is None or idx_c is None or p.lods is None or p.points is None:
        p.content_ok = False
        return
    it, O = L.index_dtype(p.width), p.offset_width  # (WREC is typed off, the pool idx: spec 3.5)
    Lc = p.lods.shape[0]
    strips = bool(p.features & L.FEATURE_SW_STRIPS)
    cols = 4 if strips else 3
    if w_c.length != cols * O * Lc or idx_c.length % p.width:
        bad = w_c if w_c.length != cols * O * Lc else idx_c
        need = cols * O * Lc if bad is w_c else bad.length // p.width * p.width
        rep.add("SWPM_CHUNK_BAD_LENGTH", bad.entry_offset + 16, type=bad.name, length=bad.length, need=need)
        p.content_ok = False
        return
    win = _view(p.buf, w_c.offset, cols * Lc, L.index_dtype(O)).reshape(Lc, cols)
    pool = _view(p.buf, idx_c.offset, idx_c.length // p.width, it)
    V = p.vertex_count
    first, tc, vc = (win[:, i].astype(np.int64) for i in range(3))
    rv = None
    if strips:  # (META checked it is an integer)
        rv = int(p.meta["params"]["restart_index"]) if p.meta is not None else None
        if rv is None or rv < V:
            c = p.chunks[L.META]
            rep.add("SWPM_META_BAD_FIELD", c.offset, field="params.restart_index", reason=f"below V = {V}")
            p.content_ok = False
            return
    ok = True
    row = cols * O
    for i, (what, col) in enumerate((("triangle_count", "triangle_count"), ("vertex_count", "vertex_count"))):
        got = (tc, vc)[i]
        bad = np.flatnonzero(got != p.lods[col])
        if bad.size:
            k = int(bad[0])
            rep.add(
                "SWPM_WINDOW_COUNT_MISMATCH",
                w_c.offset + k * row + (1 + i) * O,
                lod=k,
                what=what,
                value=int(got[k]),
                expected=int(p.lods[col][k]),
            )
            ok = False
    bad = np.flatnonzero(np.diff(tc) > 0)
    if bad.size:
        k = int(bad[0]) + 1
        rep.add(
            "SWPM_WINDOW_NOT_MONOTONE",
            w_c.offset + k * row + O,
            lod=k,
            what="triangle count grows from the previous (finer) window",
        )
        ok = False
    count = win[:, 3].astype(np.int64) if strips else 3 * tc
    end = first + count
    n_pool = idx_c.length // p.width  # (ranges, spec 4.2: the view may stop at the last byte held)
    bad = np.flatnonzero(end > n_pool)
    for k in bad[:3]:
        rep.add(
            "SWPM_WINDOW_OUT_OF_POOL",
            w_c.offset + int(k) * row,
            lod=int(k),
            start=int(first[k]),
            end=int(end[k]),
            pool=n_pool,
        )
    ok &= bad.size == 0
    # (ranges without all of INDX, spec 4.2: its content is checked per drawn LOD by .ranges, the rest waits)
    full = not p.indx_partial
    ok &= not full or _index_check(p, rep, idx_c, pool, "INDX", V, idx_c.offset, exempt=rv)
    if strips and bad.size == 0 and full:
        # a window starts a strip (the pool's start or right after a restart index); it may end inside one
        live = np.flatnonzero(count > 0)
        mid = live[(first[live] > 0) & (pool[np.maximum(first[live] - 1, 0)] != rv)]
        if mid.size:
            k = int(mid[0])
            rep.add("SWPM_WINDOW_MID_STRIP", w_c.offset + k * row, lod=k, start=int(first[k]))
            ok = False
    stage_a = ok and full
    if stage_a and pool.size:
        from .kernels import first_violation, monotone_windows, window_limits  # (numba: loaded when used)

        # (a strip pool's restart index is exempt: read as vertex 0 here)
        checked = np.where(pool == rv, 0, pool).astype(pool.dtype) if strips else pool
        if np.all(np.diff(first) >= 0) and np.all(np.diff(end) >= 0) and np.all(np.diff(vc) <= 0):
            pos, k = (int(x) for x in monotone_windows(checked, first, end, vc))
        else:
            lim, owner = window_limits(first, end, vc, pool.shape[0])
            pos = int(first_violation(checked, lim))
            k = int(owner[pos]) if pos >= 0 else -1
        if pos >= 0:
            rep.add(
                "SWPM_PREFIX_VIOLATION",
                idx_c.offset + pos * p.width,
                lod=k,
                vertex=int(pool[pos]),
                limit=int(vc[k]),
            )
            ok = False
    if stage_a and strips:  # (after a prefix problem too: both are stage (b))
        # triangle_count = the non-degenerate triangles the window's strip decodes to (spec 3.7's rule); a
        # window starts a strip, so those are the triangles of the pool's decoding that end inside it
        s = pool.astype(np.int64)
        a, b, c = s[:-2], s[1:-1], s[2:]
        tri = (a != rv) & (b != rv) & (c != rv) & (a != b) & (b != c) & (a != c)
        ends = np.zeros(s.shape[0] + 1, np.int64)
        np.cumsum(tri, out=ends[3:])
        decoded = ends[end] - ends[first]
        bad = np.flatnonzero(decoded != tc)
        if bad.size:
            k = int(bad[0])
            rep.add(
                "SWPM_WINDOW_STRIP_TRIANGLES",
                w_c.offset + k * row + 3 * O,
                lod=k,
                decoded=int(decoded[k]),
                expected=int(tc[k]),
            )
            ok = False
    if not ok:
        p.content_ok = False
        return
    p.buffers = {"index_pool": pool, "window_records": win[:, :3]}
    if strips:
        p.buffers["window_index_counts"] = win[:, 3]
