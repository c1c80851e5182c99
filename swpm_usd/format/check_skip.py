"""The skip-strip encoding's chunks, ``SKIP``, ``SREC``, ``RCNT`` and ``INDX`` (spec 3.7; stages of spec 5).

:func:`_skip` checks the level table (``SWPM_LEVEL_BAD_TABLE``), the restart index of ``META``, the indices
of the lists and records, and that each level's list uses only its first LOD's vertices;
:func:`_skip_records` then checks the records against the levels, ``RCNT`` and ``LODS`` and replays each
level's records (:func:`.kernels.skip_replay`): changes hit only the binned vertex, and the replay gives the
stored collapsed list. Separate from the reader, as each encoding's checks are: one file per encoding.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import kernels_np
from . import layout as L
from .check_records import _common_records, _kept_below_binned, _offsets_in_level, _record_chunk
from .errors import Report
from .kernels_np import segment_limits
from .parsed import _arrays, _Chunk, _frozen, _get, _index_check, _Parsed, _view


def skip_replay(*args: Any) -> tuple[int, int, int, np.ndarray]:
    """:func:`.kernels.skip_replay` or :func:`.kernels_np.skip_replay_np` (:func:`.kernels_np.use_jitted`)."""
    if kernels_np.use_jitted(int(args[0].shape[0]) + int(args[6].shape[0])):  # (list elements and changes)
        from .kernels import skip_replay as jitted

        return jitted(*args)
    return kernels_np.skip_replay_np(*args)


def _skip(p: _Parsed, rep: Report) -> None:
    rc_c, s_c, idx_c = _get(p, L.RCNT), _get(p, L.SKIP), _get(p, L.INDX)
    rec = _record_chunk(
        p,
        rep,
        L.SREC,
        ["collapse_kept", "collapse_binned", "collapse_change_count", "collapse_prev_change_count"],
    )
    if rc_c is None or s_c is None or idx_c is None or rec is None or p.lods is None or p.points is None:
        p.content_ok = False
        return
    # (the level table, records and RCNT are typed off, the lists idx: spec 3.7)
    it, ot, O = L.index_dtype(p.width), L.index_dtype(p.offset_width), p.offset_width
    if rc_c.length % O or idx_c.length % p.width or s_c.length < 8:
        bad, unit = (rc_c, O) if rc_c.length % O else (idx_c if idx_c.length % p.width else s_c, p.width)
        rep.add(
            "SWPM_CHUNK_BAD_LENGTH",
            bad.entry_offset + 16,
            type=bad.name,
            length=bad.length,
            need=max(bad.length // unit * unit, 8 if bad is s_c else 0),  # (SKIP: its two u32 counts)
        )
        p.content_ok = False
        return
    rc = _view(p.buf, rc_c.offset, rc_c.length // O, ot)
    lst = _view(p.buf, idx_c.offset, idx_c.length // p.width, it)
    h = _view(p.buf, s_c.offset, 1, L.SKIP_HEADER)[0]
    n, C = int(h["level_count"]), int(h["collapsed_count"])
    at: dict[str, int] = {}  # absolute offset of each SKIP array
    arrs = _arrays(
        p,
        rep,
        s_c,
        8,
        [
            ("level_first_lod", n, ot),
            ("level_index_start", n + 1, ot),
            ("level_collapsed_start", n + 1, ot),
            ("level_record_start", n + 1, ot),
            ("level_collapsed_indices", C, it),
        ],
        at=at,
    )
    if arrs is None:
        p.content_ok = False
        return
    V, Lc = p.vertex_count, p.lods.shape[0]
    ok = _common_records(p, rep, rec, rc, rc_c.offset, Lc)
    params = (p.meta or {}).get("params", {})
    restart = params.get("restart_index")
    exempt = (
        int(restart) if isinstance(restart, int) and params.get("primitive", "strip") == "strip" else None
    )
    if exempt is not None and exempt < V:
        meta_at = p.chunks[L.META].offset
        rep.add(
            "SWPM_META_BAD_FIELD", meta_at, field="params.restart_index", reason=f"{exempt} is below V ({V})"
        )
        p.content_ok = False
        return
    R = rec["collapse_kept"].shape[0]
    first = arrs["level_first_lod"].astype(np.int64)
    reason = None
    for name, total in (
        ("level_index_start", idx_c.length // p.width),  # (ranges: lst may stop at the last byte held)
        ("level_collapsed_start", C),
        ("level_record_start", R),
    ):
        s = arrs[name].astype(np.int64)
        if s[0] != 0 or s[-1] != total or np.any(np.diff(s) < 0):
            reason = f"{name} must run from 0 to {total} without decreasing"
    # the table among itself (spec 3.7, stage (a)); only its agreement with RCNT is a stage (c) check
    if not reason and not np.array_equal(arrs["level_collapsed_start"], arrs["level_index_start"]):
        reason = "level_collapsed_start must equal level_index_start"
    elif not reason and params.get("primitive", "strip") == "list":
        if np.any(np.diff(arrs["level_index_start"].astype(np.int64)) % 3):
            reason = "a level's triangle list must hold whole triangles (a multiple of 3 indices)"
    if n == 0 or first[0] != 0 or np.any(np.diff(first) <= 0) or first[-1] >= Lc:
        reason = "level_first_lod must start at 0, increase and stay below the LOD count"
    if reason:
        rep.add("SWPM_LEVEL_BAD_TABLE", s_c.offset, reason=reason)
        p.content_ok = False
        return
    full = not p.indx_partial  # (ranges without all of INDX, spec 4.2: .ranges checks the drawn lists)
    ok &= not full or _index_check(p, rep, idx_c, lst, "INDX", V, idx_c.offset, exempt)
    collapsed_at = at["level_collapsed_indices"]
    ok &= _index_check(
        p, rep, s_c, arrs["level_collapsed_indices"], "level_collapsed_indices", V, collapsed_at, exempt
    )
    for i, col in enumerate(("collapse_kept", "collapse_binned")):
        ok &= _index_check(p, rep, p.chunks[L.SREC], rec[col], col, V, int(rec["_base"][0]) + i * O)
    if ok:
        rstart = arrs["level_record_start"].astype(np.int64)
        lstart = arrs["level_index_start"].astype(np.int64)
        ok &= _offsets_in_level(p, rep, rec, rstart, lstart)
        # prefix property at each level's entry: its list uses only the level's first LOD's vertices
        vc = p.lods["vertex_count"].astype(np.int64)
        ex = -1 if exempt is None else exempt
        pos, lv = (int(x) for x in segment_limits(lst, lstart, vc[first], ex)) if full else (-1, -1)
        if pos >= 0:
            rep.add(
                "SWPM_PREFIX_VIOLATION",
                idx_c.offset + pos * p.width,
                lod=int(first[lv]),
                vertex=int(lst[pos]),
                limit=int(vc[first[lv]]),
            )
            ok = False
    if ok:
        ok = _skip_records(p, rep, rec, arrs, lst, rc, s_c, collapsed_at, exempt, replay=full)
    if not ok:
        p.content_ok = False
        return
    rec.pop("_base")
    p.buffers = {**{k: v for k, v in arrs.items()}, "level_indices": lst, **rec, "lod_record_counts": rc}


def _skip_records(
    p: _Parsed,
    rep: Report,
    rec: dict[str, np.ndarray],
    arrs: dict[str, np.ndarray],
    lst: np.ndarray,
    rc: np.ndarray,
    s_c: _Chunk,
    collapsed_at: int,
    restart: int | None,
    replay: bool = True,
) -> bool:
    """Skip-strip records against the lists and LODS (spec 3.7): record r bins V-1-r onto a kept vertex
    below it, the level table matches RCNT, replaying a level's records changes only slots holding the
    binned vertex, removes it from the list and gives the collapsed list, and LODS counts what is drawn.
    ``replay`` False (ranges without all of ``INDX``, spec 4.2): the checks up to LODS' vertex counts run,
    the replay and the collapsed lists' prefix wait for the whole file."""
    assert p.points is not None and p.lods is not None
    V, Lc, W, O = p.vertex_count, p.lods.shape[0], p.width, p.offset_width
    kept = rec["collapse_kept"].astype(np.int64)
    binned = rec["collapse_binned"].astype(np.int64)
    R = kept.shape[0]
    row0 = int(rec["_base"][0])
    ok = True
    if R >= max(V, 1) and R:  # reported; the other checks of this stage still run
        rep.add("SWPM_RECORD_BAD_COUNTS", row0 - 8, reason=f"{R} records for {V} vertices")
        ok = False
    bad = np.flatnonzero(binned != V - 1 - np.arange(R))
    for r in bad[:3]:
        rep.add("SWPM_RECORD_BAD_BINNED", row0 + (4 * int(r) + 1) * O, record=int(r), binned=int(binned[r]))
    ok &= bad.size == 0
    ok &= _kept_below_binned(p, rep, rec, V)
    first = arrs["level_first_lod"].astype(np.int64)
    rstart = arrs["level_record_start"].astype(np.int64)
    lstart = arrs["level_index_start"].astype(np.int64)
    nrc = rc.astype(np.int64)
    reason = None
    params = (p.meta or {}).get("params", {})
    strip = params.get("primitive", "strip") == "strip"
    if np.any(nrc[first] != rstart[:-1]):
        lv = int(np.flatnonzero(nrc[first] != rstart[:-1])[0])
        reason = f"level {lv} starts at record {int(rstart[lv])}, its first LOD applies {int(nrc[first[lv]])}"
    if reason:
        rep.add("SWPM_LEVEL_BAD_TABLE", s_c.offset, reason=reason)
        ok = False
    vc, tc = p.lods["vertex_count"].astype(np.int64), p.lods["triangle_count"].astype(np.int64)
    bad = np.flatnonzero(vc != V - nrc)
    if bad.size:
        k = int(bad[0])
        rep.add(
            "SWPM_LOD_VERTEX_COUNT",
            p.chunks[L.LODS].offset + 12 * k,
            lod=k,
            count=int(vc[k]),
            expected=int(V - nrc[k]),
        )
        ok = False
    if not ok or not replay:
        return ok
    kind, r, s, tris = skip_replay(
        lst,
        lstart,
        arrs["level_collapsed_indices"],
        rstart,
        kept,
        _frozen(rec["collapse_change_count"]),
        _frozen(rec["collapse_change_offsets"]),
        V,
        strip,
        -1 if restart is None else int(restart),
    )
    kind, r, s = int(kind), int(r), int(s)
    if kind == 1:
        rep.add("SWPM_RECORD_BAD_CHANGE", row0 + 4 * r * O, record=r, slot=s)
    elif kind == 3:
        lv = int(np.searchsorted(lstart, s, side="right")) - 1
        rep.add(
            "SWPM_LEVEL_BAD_TABLE",
            collapsed_at + s * W,
            reason=f"level {lv}'s collapsed list differs from its records at element {s}",
        )
    ok = kind == 0
    # a binned vertex left in the list after its record stays to the level's end: the collapsed list of
    # level l uses only vertices below V - level_record_start[l + 1]
    coll = arrs["level_collapsed_indices"]
    limits = V - rstart[1:]
    pos, lv = (int(x) for x in segment_limits(coll, lstart, limits, -1 if restart is None else int(restart)))
    if pos >= 0:
        rep.add(
            "SWPM_PREFIX_VIOLATION",
            collapsed_at + pos * W,
            lod=int(first[lv + 1]) if lv + 1 < first.shape[0] else Lc - 1,
            vertex=int(coll[pos]),
            limit=int(limits[lv]),
        )
        ok = False
    if not ok:
        return False
    # LODS triangle counts: the non-degenerate triangles of the level's list after RCNT[k] records
    lev = np.searchsorted(first, np.arange(Lc), side="right") - 1
    want = np.where(nrc > rstart[lev], tris[np.maximum(nrc - 1, 0)], tris[R + lev])
    bad = np.flatnonzero(tc != want)
    if bad.size:
        k = int(bad[0])
        rep.add(
            "SWPM_RECORD_BAD_COUNTS",
            p.chunks[L.LODS].offset + 12 * k,
            reason=f"LOD {k} has {int(tc[k])} triangles, the records give {int(want[k])}",
        )
        return False
    return True
