"""The mixed encoding's chunks, ``MLVL``, ``MREC``, ``RCNT`` and ``INDX`` (spec 3.8; the stages of spec 5).

:func:`_mixed` checks the level table against the lists and ``RCNT`` (``SWPM_MIXED_BAD_LEVELS``), the
indices and records, that no level's records remove more static or dynamic triangles than it holds, that
``LODS`` counts what the records give, the prefix property of the static, dynamic and collapsed dynamic
lists, then replays the records (:func:`.kernels.mixed_replay`). Separate from the reader, as each
encoding's checks are: one file per encoding.
"""

from __future__ import annotations

import numpy as np

from . import layout as L
from .check_records import (
    _common_records,
    _kept_below_binned,
    _lod_counts_check,
    _offsets_in_level,
    _record_chunk,
)
from .errors import Report
from .kernels_np import segment_limits
from .parsed import _arrays, _frozen, _get, _index_check, _Parsed, _view


def _mixed(p: _Parsed, rep: Report) -> None:
    rc_c, m_c, idx_c = _get(p, L.RCNT), _get(p, L.MLVL), _get(p, L.INDX)
    rec = _record_chunk(p, rep, L.MREC, list(L.MIXED_RECORD_COLUMNS))
    if rc_c is None or m_c is None or idx_c is None or rec is None or p.lods is None or p.points is None:
        p.content_ok = False
        return
    # (the level table, records and RCNT are typed off, the lists idx: spec 3.8)
    it, ot, O = L.index_dtype(p.width), L.index_dtype(p.offset_width), p.offset_width
    if rc_c.length % O or idx_c.length % p.width or m_c.length < 8:
        bad, unit = (rc_c, O) if rc_c.length % O else (idx_c if idx_c.length % p.width else m_c, p.width)
        rep.add(
            "SWPM_CHUNK_BAD_LENGTH",
            bad.entry_offset + 16,
            type=bad.name,
            length=bad.length,
            need=max(bad.length // unit * unit, 8 if bad is m_c else 0),
        )
        p.content_ok = False
        return
    rc = _view(p.buf, rc_c.offset, rc_c.length // O, ot)
    static = _view(p.buf, idx_c.offset, idx_c.length // p.width, it)
    h = _view(p.buf, m_c.offset, 1, L.MLVL_HEADER)[0]
    n, D = int(h["level_count"]), int(h["dynamic_count"])
    names = ["level_first_lod", "level_static_start", "level_dynamic_start", "level_record_start"]
    at: dict[str, int] = {}  # absolute offset of each MLVL array
    arrs = _arrays(
        p,
        rep,
        m_c,
        8,
        [(names[0], n, ot), *((k, n + 1, ot) for k in names[1:])]
        + [("level_dynamic_indices", D, it), ("level_dynamic_collapsed_indices", D, it)],
        at=at,
    )
    if arrs is None:
        p.content_ok = False
        return
    V, Lc = p.vertex_count, p.lods.shape[0]
    ok = _common_records(p, rep, rec, rc, rc_c.offset, Lc)
    R = rec["collapse_kept"].shape[0]
    first = arrs["level_first_lod"].astype(np.int64)
    reason, where = None, m_c.offset
    for name, total, step in (
        ("level_static_start", idx_c.length // p.width, 3),  # (ranges: the view may stop early)
        ("level_dynamic_start", D, 3),
        ("level_record_start", R, 1),
    ):
        s = arrs[name].astype(np.int64)
        d = np.diff(s)
        if s[0] != 0 or s[-1] != total or np.any(d < 0) or np.any(d % step):
            reason, where = f"{name} must run from 0 to {total} in non-decreasing steps of {step}", at[name]
    if n == 0 or first[0] != 0 or np.any(np.diff(first) <= 0) or first[-1] >= Lc:
        reason = "level_first_lod must start at 0, increase and stay below the LOD count"
        where = at["level_first_lod"]
    elif ok and not reason:
        rstart = arrs["level_record_start"].astype(np.int64)
        bad = np.flatnonzero(rc.astype(np.int64)[first] != rstart[:-1])
        if bad.size:
            lv = int(bad[0])
            applied = int(rc[first[lv]])
            reason = f"level {lv} starts at record {int(rstart[lv])}, its first LOD applies {applied}"
            where = at["level_record_start"] + lv * O
    if reason:
        rep.add("SWPM_MIXED_BAD_LEVELS", where, reason=reason)
        p.content_ok = False
        return
    whole_indx = not p.indx_partial  # (ranges without all of INDX, spec 4.2: .ranges checks the drawn lists)
    ok &= not whole_indx or _index_check(p, rep, idx_c, static, "INDX", V, idx_c.offset)
    for k in ("level_dynamic_indices", "level_dynamic_collapsed_indices"):
        ok &= _index_check(p, rep, m_c, arrs[k], k, V, at[k])
    if R >= max(V, 1) and R:  # reported; the kept check of this stage still runs
        rep.add("SWPM_RECORD_BAD_COUNTS", int(rec["_base"][0]) - 8, reason=f"{R} records for {V} vertices")
        ok = False
    ok &= _kept_below_binned(p, rep, rec, V)
    if not ok:
        p.content_ok = False
        return
    rstart = arrs["level_record_start"].astype(np.int64)
    sstart = arrs["level_static_start"].astype(np.int64)
    dstart = arrs["level_dynamic_start"].astype(np.int64)
    ok &= _offsets_in_level(p, rep, rec, rstart, dstart)  # offsets index the level's dynamic list
    # live triangles of each list after r records (per level): never negative
    live = {}
    for col, lst_start in (("static", sstart), ("dynamic", dstart)):
        cum = np.r_[0, np.cumsum(rec[f"collapse_{col}_tris_removed"].astype(np.int64))]
        full = np.diff(lst_start) // 3
        ends = full - (cum[rstart[1:]] - cum[rstart[:-1]])  # live triangles after all of a level's records
        if np.any(ends < 0):
            lv = int(np.flatnonzero(ends < 0)[0])
            rep.add(
                "SWPM_RECORD_BAD_COUNTS",
                int(rec["_base"][0]) + (1 if col == "static" else 2) * O,
                reason=f"level {lv}'s records remove {int(full[lv] - ends[lv])} {col} triangles "
                f"of {int(full[lv])}",
            )
            ok = False
        live[col] = ends
    if not ok:
        p.content_ok = False
        return
    # LODS agrees with the records: vertex_count = V - RCNT, triangle_count = live static + live dynamic
    vc = p.lods["vertex_count"].astype(np.int64)
    nrc = rc.astype(np.int64)
    lev = np.searchsorted(first, np.arange(Lc), side="right") - 1
    tri = np.zeros(Lc, np.int64)
    for col, lst_start in (("static", sstart), ("dynamic", dstart)):
        removed = rec[f"collapse_{col}_tris_removed"].astype(np.int64)
        cum = np.r_[0, np.cumsum(removed)]
        tri += np.diff(lst_start)[lev] // 3 - (cum[nrc] - cum[rstart[lev]])
    ok &= _lod_counts_check(p, rep, V - nrc, tri)
    # prefix property: a level's static and dynamic lists use only its first LOD's vertices, the live part
    # of its collapsed dynamic list only the vertices left after its records
    lim = vc[first]
    lists = [(arrs["level_dynamic_indices"], dstart, at["level_dynamic_indices"], lim)]
    if whole_indx:
        lists.insert(0, (static, sstart, idx_c.offset, lim))
    for arr, starts, base, limits in lists:
        pos, lv = (int(x) for x in segment_limits(arr, starts, limits, -1))
        if pos >= 0:
            rep.add(
                "SWPM_PREFIX_VIOLATION",
                base + pos * p.width,
                lod=int(first[lv]),
                vertex=int(arr[pos]),
                limit=int(limits[lv]),
            )
            ok = False
    col = arrs["level_dynamic_collapsed_indices"]
    live_end = dstart[:-1] + 3 * live["dynamic"]
    for lv in range(n):
        seg = col[int(dstart[lv]) : int(live_end[lv])]
        if seg.size and int(seg.max()) >= V - int(rstart[lv + 1]):
            j = int(np.flatnonzero(seg >= V - int(rstart[lv + 1]))[0])
            rep.add(
                "SWPM_PREFIX_VIOLATION",
                at["level_dynamic_collapsed_indices"] + (int(dstart[lv]) + j) * p.width,
                lod=int(first[lv + 1]) if lv + 1 < n else Lc - 1,
                vertex=int(seg[j]),
                limit=V - int(rstart[lv + 1]),
            )
            ok = False
            break
    if ok and whole_indx:
        from .kernels import mixed_replay  # (numba: loaded by the check that replays, not by the import)

        kind, r, s = (
            int(x)
            for x in mixed_replay(
                static,
                sstart,
                arrs["level_dynamic_indices"],
                col,
                dstart,
                rstart,
                _frozen(rec["collapse_kept"]),
                _frozen(rec["collapse_static_tris_removed"]),
                _frozen(rec["collapse_dynamic_tris_removed"]),
                _frozen(rec["collapse_change_count"]),
                _frozen(rec["collapse_change_offsets"]),
                V,
            )
        )
        row = int(rec["_base"][0]) + r * 5 * O
        if kind == 1:
            rep.add("SWPM_RECORD_BAD_CHANGE", row, record=r, slot=s)
        elif kind == 2:
            rep.add("SWPM_PREFIX_VIOLATION", row, lod=int(np.searchsorted(rc, r + 1)), vertex=s, limit=s)
        elif kind == 3:
            lv = int(np.searchsorted(dstart, s, side="right")) - 1
            rep.add(
                "SWPM_MIXED_BAD_LEVELS",
                at["level_dynamic_collapsed_indices"] + s * p.width,
                reason=f"level {lv}'s collapsed dynamic list differs from its records at element {s}",
            )
        ok &= kind == 0
    if not ok:
        p.content_ok = False
        return
    rec.pop("_base")
    p.buffers = {**arrs, "level_static_indices": static, **rec, "lod_record_counts": rc}
