"""SWPM v1 reader and validator.

:func:`validate` returns a :class:`Report` of every problem (never raises for file content); :func:`load`
memory-maps the file, runs the same checks and returns a :class:`ProgressiveMesh` whose arrays are views of
the mapping (read-only, no copy; integer buffers keep the file's u16/u32 dtype). Every count is checked
against the bytes that remain before an array is viewed, and arrays are only ever views, so a hostile file
cannot make the reader allocate much more than its own size.

This module is the structure pass (header, chunk table, chunk order: spec 2 and 5) and the public API; the
content checks, run in the order of spec 5 by :func:`_check`, each live in a module of their own:
:mod:`.meta` (``META``, spec 3.1), :mod:`.check_lods_vert` (``LODS`` and ``VERT``, 3.2-3.3), one module per
encoding (:mod:`.check_sliding` 3.5, :mod:`.check_vanilla` 3.6, :mod:`.check_skip` 3.7, :mod:`.check_mixed`
3.8, with the record checks they share in :mod:`.check_records`) and :mod:`.check_smap` (``SMAP``, 4).
:mod:`.parsed` holds the parsed state they fill in and the checked views they take of the mapping. With
``prefix`` (:mod:`.prefix`, spec 4.1) the same checks read the first bytes of a file still arriving: the end
of the file is the header's file_size and what lies past the bytes given waits for the whole file.
"""

from __future__ import annotations

import errno
import mmap
import os
import re
import stat
import zlib
from typing import TYPE_CHECKING, Any

import numpy as np

from . import layout as L
from .check_lods_vert import _lods, _vert
from .check_mixed import _mixed
from .check_skip import _skip
from .check_sliding import _sliding
from .check_smap import _smap
from .check_vanilla import _vanilla
from .errors import Report, SwpmFormatError
from .meta import _meta, parse_meta_json  # noqa: F401 - (re-exported: public, its home before the split)
from .parsed import _Chunk, _Parsed, _Spans

if TYPE_CHECKING:  # (the encoders, numba's among them, are imported by load() alone: validate and inspect
    # start without them, 0.3-0.5 s of each command's start)
    from ..encode.base import ProgressiveMesh

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


def _io_reason(exc: OSError) -> str:
    """Why a file could not be read, without its name: the report names it (``str(exc)`` named it twice,
    "x.swpm: INVALID ... [Errno 2] No such file or directory: 'x.swpm'")."""
    return exc.strerror or str(exc)


# -- structure ------------------------------------------------------------------------------------------
def _structure(
    buf: np.ndarray, rep: Report, check_crc: bool, prefix: bool = False, held: _Spans | None = None
) -> _Parsed | None:
    """Steps 1-2 of spec 5. ``prefix``: ``buf`` may be a prefix of the file (spec 4.1): when it is shorter
    than file_size the end of the file is file_size, the bytes it lacks (a CRC over them, padding there,
    the length) are left to the whole file, and a header or table it cuts is SWPM_PREFIX_TOO_SHORT.
    ``held`` (byte ranges, spec 4.2): ``buf`` runs to the last byte held, the end of the file is file_size,
    and only the ``held`` bytes are the file's (the rest zero, so padding there reads clean until the whole
    file); a CRC over bytes not all held waits for the whole file, and a header or table not held is
    SWPM_RANGES_NOT_HELD."""
    size = int(buf.shape[0])
    p = _Parsed(buf, held=held, prefix=held is not None)
    if size < L.HEADER_SIZE:
        if size >= 8 and bytes(buf[:8]) != L.MAGIC:
            rep.add("SWPM_HEADER_BAD_MAGIC", 0, found=bytes(buf[:8]).hex(), expected=L.MAGIC.hex())
        elif prefix:  # the header's file_size is not there yet: wait for it
            rep.add("SWPM_PREFIX_TOO_SHORT", size, size=size, need=L.HEADER_SIZE)
            rep.summary["prefix_need"] = L.HEADER_SIZE
        else:
            rep.add("SWPM_HEADER_TRUNCATED", 0, size=size, need=L.HEADER_SIZE)
        return None
    if not p.holds(0, L.HEADER_SIZE):
        _not_held(p, rep, 0, L.HEADER_SIZE)
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
    declared = int(h["file_size"])
    # a prefix of a longer file, or ranges (held up to the last byte held, spec 4.2): it ends at file_size
    streaming = (prefix or held is not None) and declared > size
    if held is not None and L.HEADER_SIZE <= hs <= declared and hs > size:
        _not_held(p, rep, 0, hs)
        return None
    if streaming and L.HEADER_SIZE <= hs <= declared and hs > size:
        rep.add("SWPM_PREFIX_TOO_SHORT", size, size=size, need=hs)
        rep.summary["prefix_need"] = hs
        return None
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
    p.features = feats
    if feats & L.FEATURE_SW_STRIPS and not feats & L.FEATURE_SLIDING_WINDOW:
        rep.add("SWPM_HEADER_STRIPS_NOT_SLIDING", 20, bits=feats)
    if feats & L.FEATURE_OFFSET32 and feats & L.FEATURE_INDEX32:  # (read on with idx = off = u32)
        rep.add("SWPM_HEADER_OFFSET32_WITH_INDEX32", 20, bits=feats)
    p.width, p.offset_width = L.read_widths(feats)
    if p.minor == L.VERSION_MINOR:  # newer minors may use reserved fields
        for name, off in (("reserved0", 28), ("reserved1", 52)):
            val = h[name]
            if np.any(val):
                rep.add("SWPM_HEADER_RESERVED_NONZERO", off, field=name, value=np.asarray(val).tolist())
    end = size
    if streaming:
        end, p.prefix = declared, True
    elif declared > size:
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
    if table_end > size and held is not None:
        _not_held(p, rep, 0, table_end)
        return None
    if table_end > size:  # (a prefix only: else the end of the file is at most its length)
        rep.add("SWPM_PREFIX_TOO_SHORT", size, size=size, need=table_end)
        rep.summary["prefix_need"] = table_end
        return None
    if not p.holds(0, table_end):  # (ranges: before the table's end, all of which is in buf)
        _not_held(p, rep, 0, table_end)
        return None
    if check_crc:
        found = int(h["file_crc"])
        crc = zlib.crc32(buf[: L.FILE_CRC_OFFSET])
        crc = zlib.crc32(b"\0\0\0\0", crc)
        crc = zlib.crc32(buf[L.FILE_CRC_OFFSET + 4 : table_end], crc)
        if crc != found:
            rep.add("SWPM_CHECKSUM_MISMATCH", L.FILE_CRC_OFFSET, found=found, computed=crc)
    if p.nonzero(hs, to):
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
        elif p.nonzero(prev_end, min(off, end)):  # a gap running past the end of file: up to the end
            rep.add("SWPM_PADDING_NONZERO", prev_end, start=prev_end)
        if int(e["reserved"]) and p.minor == L.VERSION_MINOR:
            rep.add(
                "SWPM_HEADER_RESERVED_NONZERO",
                eo + 28,
                field=f"chunk {name} reserved",
                value=int(e["reserved"]),
            )
        if c.ok and check_crc and p.holds(off, off + ln):  # (a prefix or ranges: else it waits for the rest)
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
    if prev_end < end and p.nonzero(prev_end, end):
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


# -- content: each chunk's checks in their own module (see above), run in the order of spec 5 -----------
_DECODERS = {"vanilla": _vanilla, "sliding-window": _sliding, "skip-strip": _skip, "mixed": _mixed}


def _prefix_skeleton(p: _Parsed, rep: Report) -> None:
    """What a prefix must hold to be opened (spec 4.1), once steps 1-2 passed: VERT the last table entry
    (else SWPM_PREFIX_NOT_STREAMABLE), and every byte before VERT's vertex records: its header, then its
    first data_offset bytes (else SWPM_PREFIX_TOO_SHORT, with the bytes needed)."""
    size, last = int(p.buf.shape[0]), p.order[-1]
    if last.type != L.VERT:
        rep.add("SWPM_PREFIX_NOT_STREAMABLE", last.entry_offset, type=last.name)
        return
    need = _vert_head_end(p, p.chunks[L.VERT])  # the last entry (a second VERT was SWPM_CHUNK_DUPLICATE)
    if need > size:
        rep.add("SWPM_PREFIX_TOO_SHORT", size, size=size, need=need)
        rep.summary["prefix_need"] = need


def _vert_head_end(p: _Parsed, v: _Chunk) -> int:
    """The end of ``VERT``'s bytes before its vertex records (spec 4.1 step 3): o + max(16, min(data_offset,
    length)), o + length when length < 16, and o + 16 while its header, where data_offset is, is not held."""
    end = v.offset + min(v.length, L.VERT_HEADER.itemsize)
    if p.holds(v.offset, end) and v.length >= L.VERT_HEADER.itemsize:
        data = int(p.buf[v.offset + 12 : v.offset + 16].view("<u4")[0])
        end = v.offset + max(L.VERT_HEADER.itemsize, min(data, v.length))
    return end


def _not_held(p: _Parsed, rep: Report, start: int, end: int) -> None:
    """SWPM_RANGES_NOT_HELD (spec 4.2): bytes [start, end) are needed, not all held; at the first missing."""
    assert p.held is not None
    rep.add("SWPM_RANGES_NOT_HELD", p.first_missing(start, end), start=start, end=end)
    rep.summary["range_need"] = [start, end]


def _ranges_skeleton(p: _Parsed, rep: Report) -> None:
    """What byte ranges must hold to be opened (spec 4.2), once steps 1-2 passed: every byte before ``INDX``
    and ``VERT``'s bytes before its vertex records (as 4.1 reads them), then every table steps 3-5 decode
    (``META``, ``LODS``, the encoding's, in the order of 2.3: one after ``INDX`` in a file not in streaming
    order), else SWPM_RANGES_NOT_HELD. INDX not all held: its content is checked per drawn LOD
    (:mod:`.ranges`), not by the encoding's checks."""
    indx, v = p.chunks.get(L.INDX), p.chunks.get(L.VERT)
    if indx is None or v is None:
        return  # (SWPM_CHUNK_MISSING was reported)
    if not p.holds(0, indx.offset):
        _not_held(p, rep, 0, indx.offset)
        return
    end = _vert_head_end(p, v)
    if not p.holds(v.offset, end):
        _not_held(p, rep, v.offset, end)
        return
    for t in L.REQUIRED_CHUNKS[p.encoding or "vanilla"]:
        c = p.chunks.get(t)
        # (a table's bytes not held are not zeros: decoding them would report errors the file does not have)
        if c is not None and t not in (L.SMAP, L.INDX, L.VERT) and not p.holds(c.offset, c.offset + c.length):
            _not_held(p, rep, c.offset, c.offset + c.length)
            return
    p.indx_partial = not p.holds(indx.offset, indx.offset + indx.length)


def _check(
    buf: np.ndarray,
    path: str | None,
    check_crc: bool = True,
    prefix: bool = False,
    held: _Spans | None = None,
) -> tuple[Report, _Parsed | None]:
    rep = _Report(path=path)
    p = _structure(buf, rep, check_crc, prefix, held)
    if p is not None and held is not None and not rep.errors:
        _ranges_skeleton(p, rep)
    elif p is not None and p.prefix and not rep.errors:
        _prefix_skeleton(p, rep)
    if p is not None and not rep.errors:
        _meta(p, rep)
        _lods(p, rep)
        _vert(p, rep)
        if p.lods is not None and p.points is not None:
            vc0 = int(p.lods["vertex_count"][0])
            if vc0 != p.vertex_count:
                rep.add(
                    "SWPM_LOD_VERTEX_COUNT",
                    p.chunks[L.LODS].offset,
                    lod=0,
                    count=vc0,
                    expected=p.vertex_count,
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


def _stored_indices(p: _Parsed) -> int:
    """Indices the file stores for every instance, as ``run``'s manifest and report count them for lambda
    (:func:`..encode.base.stored_index_count`: skip-strip's collapsed lists in ``SKIP``, mixed's dynamic ones
    in ``MLVL``, not ``INDX`` alone: a skip-strip file read 2.61 here, 5.23 in its run's report)."""
    return L.stored_index_count(p.buffers) or int(p.chunks[L.INDX].length // p.width)


#: the index lists an engine uploads to draw from, per encoding (skip-strip's and mixed's collapsed lists are
#: the ones an instance copies at a level boundary)
_DRAWN_LISTS = {
    "vanilla": ("indices",),
    "sliding-window": ("index_pool",),
    "skip-strip": ("level_indices", "level_collapsed_indices"),
    "mixed": ("level_static_indices", "level_dynamic_indices", "level_dynamic_collapsed_indices"),
}


def _index_values_width(p: _Parsed) -> int:
    """The smallest width (2 or 4) an engine can upload the lists it draws from at, beside the file's ``idx``
    (``index_width``), which a file of a writer before 0.9.0 widened for its offsets and counts (a list pool
    longer than 65,535 indices; since OFFSET32 they widen ``off``, ``offset_width``, alone): every
    vertex id in them fits it, and a strips' restart index by :func:`.layout.draw_index_width` (0xFFFFFFFF,
    all ones of a u32 file's ``idx``, copies to u16 as 0xFFFF while no vertex id is 0xFFFF). 4 from 65,536
    vertices on, also for an older writer's u16 file of them: vertex 65,535 is u16's restart (spec 1)."""
    names = _DRAWN_LISTS.get(p.encoding or "", ())
    if p.indx_partial:  # (ranges without all of INDX, the first list: its values wait for the file, spec 4.2)
        names = names[1:]
    lists = [np.asarray(p.buffers[n]) for n in names if n in p.buffers]
    if not lists:
        return p.width
    ri = L.strips_restart_index(p.encoding, (p.meta or {}).get("params"))
    V = int(p.vertex_count) if p.points is not None else 0
    values = L.choose_index_width({str(i): a for i, a in enumerate(lists)}, restart=ri)
    return max(values, L.draw_index_width(V, ri))


def _summarise(p: _Parsed, rep: Report) -> None:
    assert p.lods is not None and p.points is not None
    t0 = int(p.lods["triangle_count"][0])
    rep.summary.update(
        {
            "encoding": p.encoding,
            "version": f"1.{p.minor}",
            "index_width": p.width,
            "offset_width": p.offset_width,
            "index_values_width": _index_values_width(p),
            "lod_count": int(p.lods.shape[0]),
            "vertex_count": int(p.vertex_count),
            "triangle_count": int(p.lods["triangle_count"][0]),
            "index_count": int(p.chunks[L.INDX].length // p.width),
            "lambda": (_stored_indices(p) / (3 * t0)) if t0 else None,
            "file_size": p.size if p.prefix else int(p.buf.shape[0]),
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
    """Every problem of the SWPM file at ``path`` (``report.valid`` is True when none is an error). A USD
    stage (a ``.usd`` ``.usda`` ``.usdc`` ``.usdz`` path, picked by the suffix as ``swpm-pipeline validate``
    picks) is checked by :func:`swpm_usd.usd.validate.validate_stage`, our validators and usd-core's built-in
    ones, its findings the report's problems (:func:`swpm_usd.usd.validate.stage_report`)."""
    from ..usd import USD_SUFFIXES

    if os.fspath(path).lower().endswith(USD_SUFFIXES):
        from ..usd.validate import stage_report

        return stage_report(path)
    try:
        buf = _map(path)
    except OSError as exc:
        rep = Report(path=str(path))
        rep.add("SWPM_IO_ERROR", None, reason=_io_reason(exc))
        return rep
    return _check(buf, str(path))[0]


def _build(p: _Parsed, rep: Report) -> ProgressiveMesh:
    from ..encode.base import ENCODINGS, from_buffers

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
    A USD stage (picked by its suffix, as :func:`validate` picks) is read by
    :func:`swpm_usd.usd.read_file`: its only encoded prim, else :class:`~swpm_usd.usd.reader.UsdReadError`.
    """
    from ..usd import USD_SUFFIXES

    if os.fspath(path).lower().endswith(USD_SUFFIXES):
        from ..usd.reader import read_file

        return read_file(path)
    try:
        buf = _map(path)
    except OSError as exc:
        rep = Report(path=str(path))
        rep.add("SWPM_IO_ERROR", None, reason=_io_reason(exc))
        err = SwpmFormatError(rep)
        # (a missing or unreadable file was INPUT_MALFORMED, as a corrupt one: the codes a mesh gets)
        err.code = "INPUT_NOT_FOUND" if exc.errno == errno.ENOENT else "INPUT_UNREADABLE"
        raise err from exc
    rep, p = _check(buf, str(path))
    if not rep.valid or p is None:
        err = SwpmFormatError(rep)
        hint = _mesh_given_hint(path, rep)
        if hint:  # (``load("spot.obj")`` said "SWPM_HEADER_BAD_MAGIC: magic is 7620302e33343837, ...")
            err.args = (f"{err.args[0]}; {hint}",)
        raise err
    return _build(p, rep)


def _mesh_given_hint(path: str | os.PathLike[str], rep: Report) -> str:
    """What to call instead when ``path``, refused for its first bytes, is named as a mesh file: "" else."""
    from ..io import SUPPORTED_SUFFIXES

    suffix = os.path.splitext(os.fspath(path))[1].lower()
    first = rep.errors[0].code if rep.errors else ""
    if suffix not in SUPPORTED_SUFFIXES or first not in ("SWPM_HEADER_BAD_MAGIC", "SWPM_HEADER_TRUNCATED"):
        return ""
    return (
        f"it is a mesh file ({suffix}), not an SWPM file: swpm_usd.build reads it (swpm_usd.save writes one)"
    )
