"""SWPM v1 reader and validator.

:func:`validate` returns a :class:`Report` of every problem (never raises for file content); :func:`load`
memory-maps the file, runs the same checks and returns a :class:`ProgressiveMesh` whose arrays are views of
the mapping (read-only, no copy; integer buffers keep the file's u16/u32 dtype). Every count is checked
against the bytes that remain before an array is viewed, and arrays are only ever views, so a hostile file
cannot make the reader allocate much more than its own size.
"""

from __future__ import annotations

import errno
import mmap
import os
import re
import stat
import zlib
from typing import Any

import numpy as np

from ..encode.base import ENCODINGS, ProgressiveMesh, from_buffers
from . import layout as L
from .check_lods_vert import _lods, _vert
from .check_records import (
    _common_records,
    _kept_below_binned,
    _lod_counts_check,
    _offsets_in_level,
    _record_chunk,
)
from .errors import Report, SwpmFormatError
from .kernels import (
    first_violation,
    mixed_replay,
    monotone_windows,
    segment_limits,
    skip_replay,
    vanilla_replay,
    window_limits,
)
from .meta import _meta, parse_meta_json  # noqa: F401 - (re-exported: the writer, swpm_usd.usd import it)
from .parsed import _arrays, _Chunk, _frozen, _get, _index_check, _Parsed, _view
from .writer import MIXED_RECORD_COLUMNS, index_hulls, needed_index_ranges

_TYPE_RE = re.compile(rb"^[A-Za-z0-9]{4}$")
#: problems of one code beyond this many are counted in ``summary["suppressed"]``, not listed
MAX_PER_CODE = 20


class _Report(Report):
    def add(self, code: str, offset: int | None, **args: Any) -> None:  # noqa: D401 - capped add
        n = self.summary.setdefault("_counts", {}).get(code, 0)
        self.summary["_counts"][code] = n + 1
        if n < MAX_PER_CODE:
            super().add(code, offset, **args)
        else:
            self.summary["suppressed"] = self.summary.get("suppressed", 0) + 1


def _map(path: str | os.PathLike[str]) -> np.ndarray:
    """The file at ``path`` mapped read-only. An :class:`OSError` naming ``path`` when it cannot be read or
    is not a regular file: a FIFO is opened without waiting for a writer (``open`` waited for ever) and
    refused, as a device is."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    try:  # (checked on the descriptor: ``open(fd)`` of a folder named the error by the number, kept it open)
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), os.fspath(path))
        if not stat.S_ISREG(mode):
            raise OSError(errno.EINVAL, "not a regular file", os.fspath(path))
    except OSError:
        os.close(fd)
        raise
    with open(fd, "rb") as f:
        size = os.fstat(f.fileno()).st_size
        if size == 0:
            return np.zeros(0, np.uint8)
        flags = mmap.MAP_SHARED | getattr(mmap, "MAP_POPULATE", 0)
        mm = mmap.mmap(f.fileno(), 0, flags=flags, prot=mmap.PROT_READ)
    return np.frombuffer(mm, np.uint8)


# -- structure ------------------------------------------------------------------------------------------
def _structure(buf: np.ndarray, rep: Report, check_crc: bool) -> _Parsed | None:
    size = int(buf.shape[0])
    p = _Parsed(buf)
    if size < L.HEADER_SIZE:
        if size >= 8 and bytes(buf[:8]) != L.MAGIC:
            rep.add("SWPM_HEADER_BAD_MAGIC", 0, found=bytes(buf[:8]).hex(), expected=L.MAGIC.hex())
        else:
            rep.add("SWPM_HEADER_TRUNCATED", 0, size=size, need=L.HEADER_SIZE)
        return None
    h = buf[: L.HEADER_SIZE].view(L.HEADER)[0]
    if bytes(buf[:8]) != L.MAGIC:
        rep.add("SWPM_HEADER_BAD_MAGIC", 0, found=bytes(buf[:8]).hex(), expected=L.MAGIC.hex())
        return None
    if int(h["major"]) != L.VERSION_MAJOR:
        rep.add("SWPM_HEADER_UNSUPPORTED_MAJOR", 8, major=int(h["major"]))
        return None
    p.minor = int(h["minor"])
    if p.minor > L.VERSION_MINOR:
        rep.add("SWPM_HEADER_NEWER_MINOR", 10, minor=p.minor)
    hs = int(h["header_size"])
    if hs < L.HEADER_SIZE or hs > size:
        rep.add("SWPM_HEADER_BAD_SIZE", 12, value=hs)
        return None
    feats = int(h["features"])
    if feats & ~L.KNOWN_FEATURES:
        rep.add("SWPM_HEADER_UNKNOWN_FEATURE", 20, bits=feats & ~L.KNOWN_FEATURES)
    encs = [e for e, bit in L.ENCODING_FEATURES.items() if feats & bit]
    if len(encs) != 1:
        rep.add("SWPM_HEADER_BAD_ENCODING", 20, bits=feats)
    else:
        p.encoding = encs[0]
    p.width = 4 if feats & L.FEATURE_INDEX32 else 2
    if p.minor == L.VERSION_MINOR:  # newer minors may use reserved fields
        for name, off in (("reserved0", 28), ("reserved1", 52)):
            val = h[name]
            if np.any(val):
                rep.add("SWPM_HEADER_RESERVED_NONZERO", off, field=name, value=np.asarray(val).tolist())
    declared = int(h["file_size"])
    end = size
    if declared > size:
        rep.add("SWPM_FILE_SIZE_MISMATCH", 40, declared=declared, actual=size)
    elif declared < size:
        rep.add("SWPM_FILE_TRAILING_BYTES", declared, extra=size - declared)
        end = declared
    p.size = end
    to, count = int(h["table_offset"]), int(h["chunk_count"])
    if to < hs or to % L.CHUNK_ALIGN:
        rep.add("SWPM_TABLE_BAD_OFFSET", 32, value=to)
        return None
    need = count * L.CHUNK_ENTRY.itemsize
    if count > L.MAX_CHUNKS:
        rep.add("SWPM_TABLE_TOO_LARGE", 24, count=count, limit=L.MAX_CHUNKS)
        return None
    if to + need > end:
        rep.add("SWPM_TABLE_TRUNCATED", 24, count=count, need=need, at=to, size=end)
        return None
    table_end = to + need
    if check_crc:
        found = int(h["file_crc"])
        crc = zlib.crc32(buf[: L.FILE_CRC_OFFSET])
        crc = zlib.crc32(b"\0\0\0\0", crc)
        crc = zlib.crc32(buf[L.FILE_CRC_OFFSET + 4 : table_end], crc)
        if crc != found:
            rep.add("SWPM_CHECKSUM_MISMATCH", L.FILE_CRC_OFFSET, found=found, computed=crc)
    if np.any(buf[hs:to]):
        rep.add("SWPM_PADDING_NONZERO", hs, start=hs)
    entries = buf[to:table_end].view(L.CHUNK_ENTRY)
    prev_end, prev_off, prev_name = table_end, -1, "header/chunk table"
    for i in range(count):
        e = entries[i]
        eo = to + i * L.CHUNK_ENTRY.itemsize
        t = bytes(e["type"]).ljust(4, b"\0")
        flags, off, ln = int(e["flags"]), int(e["offset"]), int(e["length"])
        c = _Chunk(t, flags, off, ln, eo)
        name = t.decode("latin-1")
        if not _TYPE_RE.match(t):
            rep.add("SWPM_CHUNK_BAD_TYPE", eo, type=repr(t)[1:])
            c.ok = False
        if off + ln > end:
            rep.add("SWPM_CHUNK_OUT_OF_BOUNDS", eo + 8, type=name, start=off, end=off + ln, size=end)
            c.ok = False
        if off % L.CHUNK_ALIGN:
            rep.add("SWPM_CHUNK_MISALIGNED", eo + 8, type=name, start=off)
            c.ok = False
        if off < prev_off:
            rep.add("SWPM_CHUNK_OUT_OF_ORDER", eo + 8, type=name, start=off)
            c.ok = False
        elif off < prev_end:
            rep.add("SWPM_CHUNK_OVERLAP", eo + 8, type=name, start=off, end=off + ln, other=prev_name)
            c.ok = False
        elif np.any(buf[prev_end : min(off, end)]):  # a gap running past the end of file: up to the end
            rep.add("SWPM_PADDING_NONZERO", prev_end, start=prev_end)
        if int(e["reserved"]) and p.minor == L.VERSION_MINOR:
            rep.add(
                "SWPM_HEADER_RESERVED_NONZERO",
                eo + 28,
                field=f"chunk {name} reserved",
                value=int(e["reserved"]),
            )
        if c.ok and check_crc:
            crc = zlib.crc32(buf[off : off + ln], zlib.crc32(t))
            if crc != int(e["crc"]):
                rep.add("SWPM_CHUNK_CRC_MISMATCH", eo + 24, type=name, found=int(e["crc"]), computed=crc)
                c.ok = False
        critical = bool(flags & L.CHUNK_CRITICAL)
        known = L.CHUNK_TYPES.get(t)
        if known is None:
            if critical:
                rep.add("SWPM_CHUNK_UNKNOWN_CRITICAL", eo, type=name)
            else:
                rep.add("SWPM_CHUNK_UNKNOWN_ANCILLARY", eo, type=name)
        else:
            if critical != known[0]:
                rep.add("SWPM_CHUNK_BAD_FLAGS", eo + 4, type=name, flags=flags, critical=int(known[0]))
            if p.encoding is not None and p.encoding not in known[1]:
                rep.add("SWPM_CHUNK_NOT_ALLOWED", eo, type=name, encoding=p.encoding)
            elif t in p.chunks:
                rep.add("SWPM_CHUNK_DUPLICATE", eo, type=name)
            else:
                p.chunks[t] = c
        p.order.append(c)
        if off >= prev_off:
            prev_off, prev_end, prev_name = off, max(prev_end, off + ln), name
    if prev_end < end and np.any(buf[prev_end:end]):
        rep.add("SWPM_PADDING_NONZERO", prev_end, start=prev_end)
    if p.encoding is None:
        return None
    for t in L.REQUIRED_CHUNKS[p.encoding]:
        if t not in p.chunks and L.CHUNK_TYPES[t][0]:
            rep.add("SWPM_CHUNK_MISSING", None, type=t.decode())
    _stream_order(p, rep)
    return p


def _stream_order(p: _Parsed, rep: Report) -> None:
    """Known chunk types in table order (duplicates counted, unknown chunks skipped) against the order of
    spec 2.3 restricted to the types present: the entry at the first position where they differ (a position
    past the end of the order, i.e. a trailing duplicate, differs), else VERT when it is not the last entry.
    """
    want = [t for t in L.REQUIRED_CHUNKS[p.encoding or "vanilla"] if t in p.chunks]
    have = [c for c in p.order if c.type in want]  # every type of ``want`` at least once: never shorter
    for i, c in enumerate(have):
        if i >= len(want):  # a duplicate after the whole order
            rep.add("SWPM_STREAM_ORDER", c.entry_offset, type=c.name, reason="a duplicate after the order")
            return
        if c.type != want[i]:  # this entry (not the first chunk of its type) is where another is expected
            b = want[i].decode()
            rep.add("SWPM_STREAM_ORDER", c.entry_offset, type=c.name, reason=f"expected {b} here")
            return
    if p.order and p.order[-1].type != L.VERT and L.VERT in p.chunks:
        c = p.chunks[L.VERT]
        rep.add("SWPM_STREAM_ORDER", c.entry_offset, type="VERT", reason="VERT must be the last chunk")


# -- content --------------------------------------------------------------------------------------------


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
    it = L.index_dtype(p.width)
    if rc_c.length % p.width or idx_c.length % (3 * p.width):
        bad = rc_c if rc_c.length % p.width else idx_c
        rep.add(
            "SWPM_CHUNK_BAD_LENGTH",
            bad.entry_offset + 16,
            type=bad.name,
            length=bad.length,
            need=bad.length // (3 * p.width) * 3 * p.width,
        )
        p.content_ok = False
        return
    rc = _view(p.buf, rc_c.offset, rc_c.length // p.width, it)
    indices = _view(p.buf, idx_c.offset, idx_c.length // p.width, it)
    V, T0, Lc = p.points.shape[0], indices.shape[0] // 3, p.lods.shape[0]
    ok = _common_records(p, rep, rec, rc, rc_c.offset, Lc)
    ok &= _index_check(p, rep, idx_c, indices, "INDX", V, idx_c.offset)
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
            int(rec["_base"][0]) + p.width,
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
    if ok:
        fields = (rec[f] for f in ("collapse_kept", "collapse_tris_removed", "collapse_change_count"))
        kind, r, s = vanilla_replay(*(_frozen(a) for a in (indices, *fields, offs)), V)
        if kind == 1:
            rep.add(
                "SWPM_RECORD_BAD_CHANGE",
                int(rec["_base"][0]) + int(r) * 4 * p.width,
                record=int(r),
                slot=int(s),
            )
            ok = False
        elif kind == 2:
            k = int(np.searchsorted(rc, r + 1))
            rep.add(
                "SWPM_PREFIX_VIOLATION",
                int(rec["_base"][0]) + int(r) * 4 * p.width,
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


def _sliding(p: _Parsed, rep: Report) -> None:
    w_c, idx_c = _get(p, L.WREC), _get(p, L.INDX)
    if w_c is None or idx_c is None or p.lods is None or p.points is None:
        p.content_ok = False
        return
    it = L.index_dtype(p.width)
    Lc = p.lods.shape[0]
    if w_c.length != 3 * p.width * Lc or idx_c.length % p.width:
        bad = w_c if w_c.length != 3 * p.width * Lc else idx_c
        need = 3 * p.width * Lc if bad is w_c else bad.length // p.width * p.width
        rep.add("SWPM_CHUNK_BAD_LENGTH", bad.entry_offset + 16, type=bad.name, length=bad.length, need=need)
        p.content_ok = False
        return
    win = _view(p.buf, w_c.offset, 3 * Lc, it).reshape(Lc, 3)
    pool = _view(p.buf, idx_c.offset, idx_c.length // p.width, it)
    V = p.points.shape[0]
    first, tc, vc = (win[:, i].astype(np.int64) for i in range(3))
    ok = True
    row = 3 * p.width
    for i, (what, col) in enumerate((("triangle_count", "triangle_count"), ("vertex_count", "vertex_count"))):
        got = (tc, vc)[i]
        bad = np.flatnonzero(got != p.lods[col])
        if bad.size:
            k = int(bad[0])
            rep.add(
                "SWPM_WINDOW_COUNT_MISMATCH",
                w_c.offset + k * row + (1 + i) * p.width,
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
            w_c.offset + k * row + p.width,
            lod=k,
            what="triangle count grows from the previous (finer) window",
        )
        ok = False
    end = first + 3 * tc
    bad = np.flatnonzero(end > pool.shape[0])
    for k in bad[:3]:
        rep.add(
            "SWPM_WINDOW_OUT_OF_POOL",
            w_c.offset + int(k) * row,
            lod=int(k),
            start=int(first[k]),
            end=int(end[k]),
            pool=int(pool.shape[0]),
        )
    ok &= bad.size == 0
    ok &= _index_check(p, rep, idx_c, pool, "INDX", V, idx_c.offset)
    if ok and pool.size:
        if np.all(np.diff(first) >= 0) and np.all(np.diff(end) >= 0) and np.all(np.diff(vc) <= 0):
            pos, k = (int(x) for x in monotone_windows(pool, first, end, vc))
        else:
            lim, owner = window_limits(first, end, vc, pool.shape[0])
            pos = int(first_violation(pool, lim))
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
    if not ok:
        p.content_ok = False
        return
    p.buffers = {"index_pool": pool, "window_records": win}


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
    it = L.index_dtype(p.width)
    if rc_c.length % p.width or idx_c.length % p.width or s_c.length < 8:
        bad = rc_c if rc_c.length % p.width else idx_c if idx_c.length % p.width else s_c
        rep.add(
            "SWPM_CHUNK_BAD_LENGTH",
            bad.entry_offset + 16,
            type=bad.name,
            length=bad.length,
            need=bad.length // p.width * p.width,
        )
        p.content_ok = False
        return
    rc = _view(p.buf, rc_c.offset, rc_c.length // p.width, it)
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
            ("level_first_lod", n, it),
            ("level_index_start", n + 1, it),
            ("level_collapsed_start", n + 1, it),
            ("level_record_start", n + 1, it),
            ("level_collapsed_indices", C, it),
        ],
        at=at,
    )
    if arrs is None:
        p.content_ok = False
        return
    V, Lc = p.points.shape[0], p.lods.shape[0]
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
        ("level_index_start", lst.shape[0]),
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
    ok &= _index_check(p, rep, idx_c, lst, "INDX", V, idx_c.offset, exempt)
    collapsed_at = at["level_collapsed_indices"]
    ok &= _index_check(
        p, rep, s_c, arrs["level_collapsed_indices"], "level_collapsed_indices", V, collapsed_at, exempt
    )
    for i, col in enumerate(("collapse_kept", "collapse_binned")):
        ok &= _index_check(p, rep, p.chunks[L.SREC], rec[col], col, V, int(rec["_base"][0]) + i * p.width)
    if ok:
        rstart = arrs["level_record_start"].astype(np.int64)
        lstart = arrs["level_index_start"].astype(np.int64)
        ok &= _offsets_in_level(p, rep, rec, rstart, lstart)
        # prefix property at each level's entry: its list uses only the level's first LOD's vertices
        vc = p.lods["vertex_count"].astype(np.int64)
        pos, lv = (int(x) for x in segment_limits(lst, lstart, vc[first], -1 if exempt is None else exempt))
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
        ok = _skip_records(p, rep, rec, arrs, lst, rc, s_c, collapsed_at, exempt)
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
) -> bool:
    """Skip-strip records against the lists and LODS (spec 3.7): record r bins V-1-r onto a kept vertex
    below it, the level table matches RCNT, replaying a level's records changes only slots holding the
    binned vertex, removes it from the list and gives the collapsed list, and LODS counts what is drawn."""
    assert p.points is not None and p.lods is not None
    V, Lc, W = p.points.shape[0], p.lods.shape[0], p.width
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
        rep.add("SWPM_RECORD_BAD_BINNED", row0 + (4 * int(r) + 1) * W, record=int(r), binned=int(binned[r]))
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
    if not ok:
        return False
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
        rep.add("SWPM_RECORD_BAD_CHANGE", row0 + 4 * r * W, record=r, slot=s)
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


def _mixed(p: _Parsed, rep: Report) -> None:
    rc_c, m_c, idx_c = _get(p, L.RCNT), _get(p, L.MLVL), _get(p, L.INDX)
    rec = _record_chunk(p, rep, L.MREC, list(MIXED_RECORD_COLUMNS))
    if rc_c is None or m_c is None or idx_c is None or rec is None or p.lods is None or p.points is None:
        p.content_ok = False
        return
    it = L.index_dtype(p.width)
    if rc_c.length % p.width or idx_c.length % p.width or m_c.length < 8:
        bad = rc_c if rc_c.length % p.width else idx_c if idx_c.length % p.width else m_c
        rep.add(
            "SWPM_CHUNK_BAD_LENGTH",
            bad.entry_offset + 16,
            type=bad.name,
            length=bad.length,
            need=max(bad.length // p.width * p.width, 8 if bad is m_c else 0),
        )
        p.content_ok = False
        return
    rc = _view(p.buf, rc_c.offset, rc_c.length // p.width, it)
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
        [(names[0], n, it), *((k, n + 1, it) for k in names[1:])]
        + [("level_dynamic_indices", D, it), ("level_dynamic_collapsed_indices", D, it)],
        at=at,
    )
    if arrs is None:
        p.content_ok = False
        return
    V, Lc = p.points.shape[0], p.lods.shape[0]
    ok = _common_records(p, rep, rec, rc, rc_c.offset, Lc)
    R = rec["collapse_kept"].shape[0]
    first = arrs["level_first_lod"].astype(np.int64)
    reason, where = None, m_c.offset
    for name, total, step in (
        ("level_static_start", static.shape[0], 3),
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
            where = at["level_record_start"] + lv * p.width
    if reason:
        rep.add("SWPM_MIXED_BAD_LEVELS", where, reason=reason)
        p.content_ok = False
        return
    ok &= _index_check(p, rep, idx_c, static, "INDX", V, idx_c.offset)
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
                int(rec["_base"][0]) + (1 if col == "static" else 2) * p.width,
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
    for arr, starts, base, limits in (
        (static, sstart, idx_c.offset, lim),
        (arrs["level_dynamic_indices"], dstart, at["level_dynamic_indices"], lim),
    ):
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
    if ok:
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
        row = int(rec["_base"][0]) + r * 5 * p.width
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


_DECODERS = {"vanilla": _vanilla, "sliding-window": _sliding, "skip-strip": _skip, "mixed": _mixed}


def _smap(p: _Parsed, rep: Report) -> None:
    c = p.chunks.get(L.SMAP)
    if c is None or not c.ok or not p.content_ok or p.lods is None:
        return
    if c.length < 8:
        rep.add("SWPM_SMAP_INVALID", c.offset, reason="shorter than its header")
        return
    h = _view(p.buf, c.offset, 1, L.SMAP_HEADER)[0]
    B, N = int(h["band_count"]), int(h["range_count"])
    if 8 + 24 * B + 16 * N != c.length:
        rep.add(
            "SWPM_SMAP_INVALID",
            c.offset,
            reason=f"{B} bands and {N} ranges need {8 + 24 * B + 16 * N} bytes, the chunk has {c.length}",
        )
        return
    bands = _view(p.buf, c.offset + 8, B, L.SMAP_BAND)
    ranges = _view(p.buf, c.offset + 8 + 24 * B, N, L.SMAP_RANGE)
    Lc = p.lods.shape[0]
    fl, lc = bands["first_lod"].astype(np.int64), bands["lod_count"].astype(np.int64)
    if (
        B == 0
        or fl[0] != 0
        or np.any(lc == 0)
        or np.any(fl[1:] != (fl + lc)[:-1])
        or int((fl + lc)[-1]) != Lc
    ):
        rep.add("SWPM_SMAP_INVALID", c.offset + 8, reason="bands do not cover the LODs in order")
        return
    rs, rn = bands["range_start"].astype(np.int64), bands["range_count"].astype(np.int64)
    if np.any(rs + rn > N):
        rep.add("SWPM_SMAP_INVALID", c.offset + 8, reason="a band's ranges lie outside the range table")
        return
    if int(rn.max()) > L.MAX_BAND_RANGES:  # a band check too: before the ranges against the file
        rep.add(
            "SWPM_SMAP_INVALID", c.offset + 8, reason=f"a band names more than {L.MAX_BAND_RANGES} ranges"
        )
        return
    ro, rl = ranges["offset"].astype(np.uint64), ranges["length"].astype(np.uint64)
    fsz = np.uint64(p.size)  # the file as read: bytes after file_size are not part of it
    if np.any(ro > fsz) or np.any(rl > fsz - np.minimum(ro, fsz)):
        rep.add("SWPM_SMAP_INVALID", c.offset + 8 + 24 * B, reason="a range lies outside the file")
        return
    indx, vert = p.chunks[L.INDX], p.chunks[L.VERT]
    need = needed_index_ranges(p.encoding or "", p.buffers, Lc, indx.length // p.width)
    ro, rl = ro.astype(np.int64), rl.astype(np.int64)
    vc = p.lods["vertex_count"].astype(np.int64)
    # hulls of (a) prefix before INDX, (b) INDX elements, (c) VERT prefix, per band (vectorised over bands);
    # (b) ignores LODs that need no INDX element and is empty (lo = hi) when none of the band's LODs needs one
    lo, hi = (indx.offset + h * p.width for h in index_hulls(need, fl))
    vend = vert.offset + p.vert_data + np.maximum.reduceat(vc, fl) * p.vert_stride
    want_a = np.stack([np.zeros(B, np.int64), lo, np.full(B, vert.offset, np.int64)], axis=1)
    want_e = np.stack([np.full(B, indx.offset, np.int64), hi, vend], axis=1)
    slot = rs[:, None] + np.arange(L.MAX_BAND_RANGES)[None, :]  # (B, 16) range ids, masked past rn
    used = np.arange(L.MAX_BAND_RANGES)[None, :] < rn[:, None]
    slot = np.where(used, slot, 0) if N else np.zeros_like(slot)
    r_lo = ro[slot] if N else np.zeros(slot.shape, np.int64)
    r_hi = r_lo + (rl[slot] if N else 0)
    inside = (
        used[:, None, :] & (r_lo[:, None, :] <= want_a[:, :, None]) & (r_hi[:, None, :] >= want_e[:, :, None])
    ).any(axis=2) | (want_e <= want_a)
    if not inside.all():
        b, j = (int(x) for x in np.argwhere(~inside)[0])
        rep.add(
            "SWPM_SMAP_INVALID",
            c.offset + 8 + 24 * b,
            reason=f"band {b} (LODs {int(fl[b])}..{int(fl[b] + lc[b] - 1)}) does not cover bytes "
            f"[{int(want_a[b, j])}, {int(want_e[b, j])})",
        )
        return
    prefix = np.where(want_e > want_a, want_e, 0).max(axis=1)  # the largest end of the non-empty hulls
    bad = np.flatnonzero(bands["prefix_length"].astype(np.int64) != prefix)
    if bad.size:
        b = int(bad[0])
        rep.add(
            "SWPM_SMAP_INVALID",
            c.offset + 8 + 24 * b + 16,
            reason=f"band {b} prefix_length is {int(bands['prefix_length'][b])}, LODs need {int(prefix[b])}",
        )


def _check(buf: np.ndarray, path: str | None, check_crc: bool = True) -> tuple[Report, _Parsed | None]:
    rep = _Report(path=path)
    p = _structure(buf, rep, check_crc)
    if p is not None and not rep.errors:
        _meta(p, rep)
        _lods(p, rep)
        _vert(p, rep)
        if p.lods is not None and p.points is not None:
            vc0 = int(p.lods["vertex_count"][0])
            if vc0 != p.points.shape[0]:
                rep.add(
                    "SWPM_LOD_VERTEX_COUNT",
                    p.chunks[L.LODS].offset,
                    lod=0,
                    count=vc0,
                    expected=p.points.shape[0],
                )
                p.content_ok = False
        if p.lods is not None and p.points is not None and p.meta is not None:
            _DECODERS[p.encoding or ""](p, rep)
        if not rep.errors:
            _smap(p, rep)
        if not rep.errors:
            _summarise(p, rep)
    counts = rep.summary.pop("_counts", None)
    if rep.summary.get("suppressed"):
        rep.summary["suppressed_by_code"] = {
            k: v - MAX_PER_CODE for k, v in counts.items() if v > MAX_PER_CODE
        }
    return rep, p


def _summarise(p: _Parsed, rep: Report) -> None:
    assert p.lods is not None and p.points is not None
    t0 = int(p.lods["triangle_count"][0])
    rep.summary.update(
        {
            "encoding": p.encoding,
            "version": f"1.{p.minor}",
            "index_width": p.width,
            "lod_count": int(p.lods.shape[0]),
            "vertex_count": int(p.points.shape[0]),
            "triangle_count": int(p.lods["triangle_count"][0]),
            "index_count": int(p.chunks[L.INDX].length // p.width),
            "lambda": (p.chunks[L.INDX].length / p.width / (3 * t0)) if t0 else None,
            "file_size": int(p.buf.shape[0]),
            "attributes": {n: f"{a.dtype}x{a.shape[1]}" for n, a in p.attributes.items()},
            "chunks": [
                {"type": c.name, "critical": bool(c.flags & 1), "offset": c.offset, "length": c.length}
                for c in p.order
            ],
        }
    )


# -- public API -----------------------------------------------------------------------------------------
def validate_bytes(data: bytes | bytearray | memoryview | np.ndarray, path: str | None = None) -> Report:
    """Validate an in-memory file (see :func:`validate`)."""
    buf = (
        np.frombuffer(data, np.uint8) if not isinstance(data, np.ndarray) else data.view(np.uint8).reshape(-1)
    )
    return _check(buf, path)[0]


def validate(path: str | os.PathLike[str]) -> Report:
    """Every problem of the file at ``path`` (``report.valid`` is True when none is an error)."""
    try:
        buf = _map(path)
    except OSError as exc:
        rep = Report(path=str(path))
        rep.add("SWPM_IO_ERROR", None, reason=str(exc))
        return rep
    return _check(buf, str(path))[0]


def _build(p: _Parsed, rep: Report) -> ProgressiveMesh:
    assert p.lods is not None and p.meta is not None and p.points is not None
    if p.encoding not in ENCODINGS:
        rep.add("SWPM_ENCODING_UNAVAILABLE", None, encoding=p.encoding)
        raise SwpmFormatError(rep)
    try:
        return from_buffers(
            p.encoding or "",
            p.points,
            p.attributes,
            p.lods["vertex_count"],
            p.lods["triangle_count"],
            p.lods["error"],
            p.buffers,
            p.meta.get("params", {}),
        )
    except Exception as exc:  # noqa: BLE001 - an implementation's complaint becomes a coded problem
        rep.add("SWPM_BUFFERS_REJECTED", None, encoding=p.encoding, reason=f"{type(exc).__name__}: {exc}")
        raise SwpmFormatError(rep) from exc


def load_bytes(data: bytes | bytearray | memoryview | np.ndarray, path: str | None = None) -> ProgressiveMesh:
    """Decode an in-memory file (see :func:`load`); arrays are views of ``data``."""
    buf = (
        np.frombuffer(data, np.uint8) if not isinstance(data, np.ndarray) else data.view(np.uint8).reshape(-1)
    )
    rep, p = _check(buf, path)
    if not rep.valid or p is None:
        raise SwpmFormatError(rep)
    return _build(p, rep)


def load(path: str | os.PathLike[str]) -> ProgressiveMesh:
    """Memory-map and decode ``path``; raises :class:`SwpmFormatError` (with the full report) if invalid.

    The returned mesh's ``points``, ``attributes`` and encoding buffers are read-only views of the mapping;
    integer buffers are u16 when the file stores u16 (values equal ``pm.buffers()`` of the saved mesh).
    """
    try:
        buf = _map(path)
    except OSError as exc:
        rep = Report(path=str(path))
        rep.add("SWPM_IO_ERROR", None, reason=str(exc))
        raise SwpmFormatError(rep) from exc
    rep, p = _check(buf, str(path))
    if not rep.valid or p is None:
        raise SwpmFormatError(rep)
    return _build(p, rep)
