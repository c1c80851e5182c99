"""The vanilla encoding's chunks, ``VREC``, ``RCNT`` and ``INDX`` (spec 3.6; the stages of spec 5).

:func:`_vanilla` checks the record counts and the triangle list's indices, that each record keeps a vertex
below the one it bins and removes no more triangles than there are, that ``LODS`` counts what the records
give, then replays the records over the list (:func:`.kernels.vanilla_replay`): a change must hit a slot
holding the binned vertex and each LOD must use only its own vertices (``SWPM_RECORD_BAD_CHANGE``,
``SWPM_PREFIX_VIOLATION``). Separate from the reader, as each encoding's checks are: one file per encoding.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import kernels_np
from . import layout as L
from .check_records import _common_records, _kept_below_binned, _lod_counts_check, _record_chunk
from .errors import Report
from .parsed import _frozen, _get, _index_check, _Parsed, _view


def vanilla_replay(*args: Any) -> tuple[int, int, int]:
    """:func:`.kernels.vanilla_replay` or :func:`.kernels_np.vanilla_replay_np`
    (:func:`.kernels_np.use_jitted`: a file's check in a process without numba loads none)."""
    if kernels_np.use_jitted(int(args[0].shape[0]) + int(args[4].shape[0])):  # (list elements and changes)
        from .kernels import vanilla_replay as jitted

        return jitted(*args)
    return kernels_np.vanilla_replay_np(*args)


def _vanilla(p: _Parsed, rep: Report) -> None:
    rc_c, idx_c = _get(p, L.RCNT), _get(p, L.INDX)
    rec = _record_chunk(
        p,
        rep,
        L.VREC,
        ["collapse_kept", "collapse_tris_removed", "collapse_change_count", "collapse_prev_change_count"],
    )
    if rc_c is None or idx_c is None or rec is None or p.lods is None or p.points is None:
        p.content_ok = False
        return
    it, ot = L.index_dtype(p.width), L.index_dtype(p.offset_width)
    ow = p.offset_width
    if rc_c.length % ow or idx_c.length % (3 * p.width):
        bad, unit = (rc_c, ow) if rc_c.length % ow else (idx_c, 3 * p.width)
        rep.add(
            "SWPM_CHUNK_BAD_LENGTH",
            bad.entry_offset + 16,
            type=bad.name,
            length=bad.length,
            need=bad.length // unit * unit,
        )
        p.content_ok = False
        return
    rc = _view(p.buf, rc_c.offset, rc_c.length // ow, ot)
    indices = _view(p.buf, idx_c.offset, idx_c.length // p.width, it)
    V, T0, Lc = p.vertex_count, idx_c.length // p.width // 3, p.lods.shape[0]  # (not the view: 4.2)
    ok = _common_records(p, rep, rec, rc, rc_c.offset, Lc)
    full = not p.indx_partial  # (ranges without all of INDX, spec 4.2: no LOD draws; its content waits)
    ok &= not full or _index_check(p, rep, idx_c, indices, "INDX", V, idx_c.offset)
    kept = rec["collapse_kept"].astype(np.int64)
    R = kept.shape[0]
    if R >= max(V, 1) and R:  # reported; the kept check of this stage still runs
        rep.add("SWPM_RECORD_BAD_COUNTS", int(rec["_base"][0]) - 8, reason=f"{R} records for {V} vertices")
        ok = False
    ok &= _kept_below_binned(p, rep, rec, V)
    removed = rec["collapse_tris_removed"].astype(np.int64)
    cum = np.r_[0, np.cumsum(removed)]
    if cum[-1] > T0:
        rep.add(
            "SWPM_RECORD_BAD_COUNTS",
            int(rec["_base"][0]) + ow,
            reason=f"records remove {int(cum[-1])} triangles of {T0}",
        )
        ok = False
    offs = rec["collapse_change_offsets"]
    ok &= _index_check(
        p, rep, p.chunks[L.VREC], offs, "collapse_change_offsets", 3 * T0, int(rec["_base"][1])
    )
    if ok:
        n = rc.astype(np.int64)
        ok &= _lod_counts_check(p, rep, V - n, T0 - cum[n])
    if ok and full:
        fields = (rec[f] for f in ("collapse_kept", "collapse_tris_removed", "collapse_change_count"))
        kind, r, s = vanilla_replay(*(_frozen(a) for a in (indices, *fields, offs)), V)
        if kind == 1:
            rep.add(
                "SWPM_RECORD_BAD_CHANGE",
                int(rec["_base"][0]) + int(r) * 4 * ow,
                record=int(r),
                slot=int(s),
            )
            ok = False
        elif kind == 2:
            k = int(np.searchsorted(rc, r + 1))
            rep.add(
                "SWPM_PREFIX_VIOLATION",
                int(rec["_base"][0]) + int(r) * 4 * ow,
                lod=k,
                vertex=int(s),
                limit=int(s),
            )
            ok = False
    if not ok:
        p.content_ok = False
        return
    rec.pop("_base")
    p.buffers = {"indices": indices, **rec, "lod_record_counts": rc}
