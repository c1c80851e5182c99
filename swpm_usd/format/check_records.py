"""Checks of the collapse records that the vanilla, skip-strip and mixed encodings share (spec 3.6-3.8).

:func:`_record_chunk` views a record chunk (``VREC``, ``SREC``, ``MREC``: a header, the record table and the
change offsets, every count checked against the chunk first); :func:`_common_records` checks the change
counts and ``RCNT``; :func:`_kept_below_binned`, :func:`_lod_counts_check` and :func:`_offsets_in_level`
are the record checks two or three encodings run. Separate so that each encoding's module holds only what
is its own.
"""

from __future__ import annotations

import numpy as np

from . import layout as L
from .errors import Report
from .parsed import _arrays, _get, _Parsed, _view


def _record_chunk(p: _Parsed, rep: Report, t: bytes, cols: list[str]) -> dict[str, np.ndarray] | None:
    c = _get(p, t)
    if c is None:
        return None
    if c.length < 8:
        rep.add("SWPM_CHUNK_BAD_LENGTH", c.entry_offset + 16, type=c.name, length=c.length, need=8)
        p.content_ok = False
        return None
    h = _view(p.buf, c.offset, 1, L.REC_HEADER)[0]
    R, M = int(h["record_count"]), int(h["offset_count"])
    it = L.index_dtype(p.offset_width)  # (records and change offsets are typed off, spec 3.6)
    nc = len(cols)
    at: dict[str, int] = {}
    arrs = _arrays(p, rep, c, 8, [("record_count", nc * R, it), ("offset_count", M, it)], at=at)
    if arrs is None:
        p.content_ok = False
        return None
    table = arrs["record_count"].reshape(R, nc)
    out = {name: table[:, i] for i, name in enumerate(cols)}
    out["collapse_change_offsets"] = arrs["offset_count"]
    # (record table start, change offsets start, columns per record)
    out["_base"] = np.array([at["record_count"], at["offset_count"], nc], np.int64)
    return out


def _kept_below_binned(p: _Parsed, rep: Report, rec: dict[str, np.ndarray], V: int) -> bool:
    """Record r bins vertex V-1-r and must keep a vertex below it (``SWPM_RECORD_BAD_KEPT`` at the row's
    ``kept`` field, the first three)."""
    kept = rec["collapse_kept"].astype(np.int64)
    binned = V - 1 - np.arange(kept.shape[0])
    bad = np.flatnonzero(kept >= binned)
    row, ncols = int(rec["_base"][0]), int(rec["_base"][2])
    for r in bad[:3]:
        rep.add(
            "SWPM_RECORD_BAD_KEPT",
            row + int(r) * ncols * p.offset_width,
            record=int(r),
            kept=int(kept[r]),
            binned=int(binned[r]),
        )
    return bad.size == 0


def _lod_counts_check(p: _Parsed, rep: Report, vertex_want: np.ndarray, triangle_want: np.ndarray) -> bool:
    """LODS's vertex and triangle counts equal what the records give (first bad LOD of each reported at its
    LODS row: ``SWPM_LOD_VERTEX_COUNT`` / ``SWPM_RECORD_BAD_COUNTS``)."""
    ok = True
    for what, col, want in (
        ("vertex", "vertex_count", vertex_want),
        ("triangle", "triangle_count", triangle_want),
    ):
        got = p.lods[col].astype(np.int64)
        bad = np.flatnonzero(got != want)
        if bad.size:
            k = int(bad[0])
            rep.add(
                "SWPM_LOD_VERTEX_COUNT" if what == "vertex" else "SWPM_RECORD_BAD_COUNTS",
                p.chunks[L.LODS].offset + 12 * k,
                lod=k,
                count=int(got[k]),
                expected=int(want[k]),
                reason=f"LOD {k} has {int(got[k])} {what}s, the records give {int(want[k])}",
            )
            ok = False
    return ok


def _common_records(
    p: _Parsed, rep: Report, rec: dict[str, np.ndarray], rc: np.ndarray, rc_off: int, lods: int
) -> bool:
    cc = rec["collapse_change_count"].astype(np.int64)
    R = cc.shape[0]
    ok = True
    if int(cc.sum()) != rec["collapse_change_offsets"].shape[0]:
        rep.add(
            "SWPM_RECORD_BAD_COUNTS",
            int(rec["_base"][0]),
            reason=f"change counts sum to {int(cc.sum())}, {rec['collapse_change_offsets'].shape[0]} offsets",
        )
        ok = False
    prev = rec["collapse_prev_change_count"].astype(np.int64)
    if R and (prev[0] != 0 or np.any(prev[1:] != cc[:-1])):
        bad = 0 if prev[0] != 0 else int(np.flatnonzero(prev[1:] != cc[:-1])[0]) + 1
        rep.add(
            "SWPM_RECORD_BAD_COUNTS",
            # prev_change_count is the last column of every record table (4 columns, 5 in MREC)
            int(rec["_base"][0]) + (bad * int(rec["_base"][2]) + int(rec["_base"][2]) - 1) * p.offset_width,
            reason=f"record {bad}: previous change count {int(prev[bad])} is wrong",
        )
        ok = False
    rc64 = rc.astype(np.int64)
    if rc64.shape[0] != lods:
        rep.add("SWPM_CHUNK_BAD_LENGTH", rc_off, type="RCNT", length=rc.nbytes, need=lods * p.offset_width)
        return False
    if rc64[0] != 0 or np.any(np.diff(rc64) < 0) or rc64[-1] > R:
        rep.add(
            "SWPM_RECORD_BAD_COUNTS",
            rc_off,
            reason="per-LOD record counts must start at 0, not decrease and not exceed the record count",
        )
        ok = False
    return ok


def _offsets_in_level(
    p: _Parsed, rep: Report, rec: dict[str, np.ndarray], rstart: np.ndarray, list_start: np.ndarray
) -> bool:
    """Change offsets of record r must index inside the list of the level that holds r."""
    R = rec["collapse_change_count"].shape[0]
    lev_of_rec = np.searchsorted(rstart, np.arange(R), side="right") - 1
    per_off = np.repeat(lev_of_rec, rec["collapse_change_count"].astype(np.int64))
    limit = (list_start[per_off + 1] - list_start[per_off]) if per_off.size else per_off
    bad = np.flatnonzero(rec["collapse_change_offsets"].astype(np.int64) >= limit)
    for j in bad[:3]:
        rep.add(
            "SWPM_INDEX_OUT_OF_RANGE",
            int(rec["_base"][1]) + int(j) * p.offset_width,
            what="collapse_change_offsets",
            value=int(rec["collapse_change_offsets"][j]),
            index=int(j),
            limit=int(limit[j]),
        )
    return bad.size == 0
