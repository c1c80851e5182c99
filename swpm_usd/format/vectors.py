"""Deterministic generator of the conformance vectors in ``spec/vectors/`` and the conformance runner.

``python -m swpm_usd.format.vectors spec/vectors`` rebuilds every vector byte for byte. The meshes are
hand-made (a five-vertex fan and a single triangle), so the vectors do not depend on the simplifier; the
sliding-window, skip-strip and mixed vectors are written from hand-made buffers through
:class:`RawProgressiveMesh`.
Invalid vectors are valid files with one defect patched in (two where a vector pins the order of the
checks); CRCs are recomputed unless the defect is a CRC.
"""

from __future__ import annotations

import hashlib
import json
import struct
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import layout as L
from .prefix import open_prefix, validate_prefix
from .ranges import open_ranges, validate_ranges
from .reader import _check
from .writer import encode_bytes, needed_index_ranges, smap_payload

GENERATOR = "swpm-usd conformance"


@dataclass
class RawProgressiveMesh:
    """The fields the writer reads, for writing buffers of any encoding without its implementation."""

    encoding: str
    points: np.ndarray
    vertex_counts: np.ndarray
    triangle_counts: np.ndarray
    lod_errors: np.ndarray
    raw_buffers: dict[str, np.ndarray]
    attributes: Mapping[str, np.ndarray] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def vertex_count(self) -> int:
        return int(np.asarray(self.points).reshape(-1, 3).shape[0])

    @property
    def lod_count(self) -> int:
        return int(len(self.vertex_counts))

    def buffers(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v, np.uint32) for k, v in self.raw_buffers.items()}


FAN_POINTS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0.25]], np.float32)


def _fan(
    encoding: str, bufs: dict[str, Any], params: dict[str, Any] | None = None, **over: Any
) -> RawProgressiveMesh:
    """The four-triangle fan's two LODs (5 -> 4 vertices, 4 -> 2 triangles) with an encoding's buffers;
    ``buffers=`` in ``over`` patches single buffers, any other key replaces that field (defect vectors)."""
    bufs = {**bufs, **over.pop("buffers", {})}
    args: dict[str, Any] = {
        "encoding": encoding,
        "points": FAN_POINTS,
        "vertex_counts": np.array([5, 4]),
        "triangle_counts": np.array([4, 2]),
        "lod_errors": np.array([0.0, 0.5], np.float32),
        "raw_buffers": bufs,
        "params": dict(params or {}),
    }
    args.update(over)
    return RawProgressiveMesh(**args)


def fan_vanilla(**over: Any) -> RawProgressiveMesh:
    """Four triangles around vertex 4; one collapse bins 4 onto 0 (2 triangles removed, 2 slots changed)."""
    bufs = {
        "indices": [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 0, 4],
        "collapse_kept": [0],
        "collapse_tris_removed": [2],
        "collapse_change_count": [2],
        "collapse_prev_change_count": [0],
        "collapse_change_offsets": [2, 5],
        "lod_record_counts": [0, 1],
    }
    return _fan("vanilla", bufs, **over)


def fan_sliding(**over: Any) -> RawProgressiveMesh:
    bufs = {
        "index_pool": [0, 1, 4, 3, 0, 4, 1, 2, 4, 2, 3, 4, 1, 2, 0, 2, 3, 0],
        "window_records": [[0, 4, 5], [12, 2, 4]],
    }
    return _fan("sliding-window", bufs, {"cache_size": 16}, **over)


def fan_sliding_strips(restart: int = 0xFFFF, **over: Any) -> RawProgressiveMesh:
    """:func:`fan_sliding`'s pool as strips (``SW_STRIPS``, format.md 3.5): window 0 is the fan as one strip
    with two swaps (8 indices, 4 triangles), then a restart index, then window 1 (4 indices, 2 triangles).
    ``restart`` 0xFFFFFFFF makes the file u32 (its idx's largest value, as a writer writes a u32 file's)."""
    R = restart
    bufs = {
        "index_pool": [1, 4, 0, 4, 3, 4, 2, 1, R, 1, 2, 0, 3],
        "window_records": [[0, 4, 5], [9, 2, 4]],
        "window_index_counts": [8, 4],
    }
    params = {"cache_size": 16, "primitive": "strip", "restart_index": R}
    return _fan("sliding-window", bufs, params, **over)


def fan_sliding_strip_prefix(**over: Any) -> RawProgressiveMesh:
    """A strip pool whose window 1 ends inside a strip (format.md 3.5): one strip ``1 2 0 3 0 4 1`` draws
    LOD 0's four triangles (0 1 2, 0 2 3, 0 3 4, 0 4 1), and LOD 1's two are its first four indices, a
    prefix decoding to exactly 0 1 2 and 0 2 3 (below vertex 4); no restart index at all."""
    bufs = {
        "index_pool": [1, 2, 0, 3, 0, 4, 1],
        "window_records": [[0, 4, 5], [0, 2, 4]],
        "window_index_counts": [7, 4],
    }
    params = {"cache_size": 16, "primitive": "strip", "restart_index": 0xFFFF}
    return _fan("sliding-window", bufs, params, **over)


def fan_sliding_strip_join(window1_count: int = 4, **over: Any) -> RawProgressiveMesh:
    """A strip pool whose strip goes on across window 1's end through degenerate triangles, as the writer
    joins a triangle that shares only a vertex (format.md 3.5): ``1 2 0 3 3 4 1 0`` draws 0 1 2 and 0 2 3
    (window 1, its first ``window1_count`` indices, all below vertex 4), the degenerate 0 3 3 and 3 3 4
    (counted for the parity only), then 3 4 1 at even parity and 1 4 0 at odd. ``window1_count`` 5 ends
    window 1 on the degenerate 0 3 3, which draws nothing: still its 2 triangles, still valid."""
    bufs = {
        "index_pool": [1, 2, 0, 3, 3, 4, 1, 0],
        "window_records": [[0, 4, 5], [0, 2, 4]],
        "window_index_counts": [8, window1_count],
    }
    params = {"cache_size": 16, "primitive": "strip", "restart_index": 0xFFFF}
    return _fan("sliding-window", bufs, params, **over)


def fan_skip(**over: Any) -> RawProgressiveMesh:
    bufs = {
        "level_first_lod": [0],
        "level_index_start": [0, 12],
        "level_indices": [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 0, 4],
        "level_collapsed_start": [0, 12],
        "level_collapsed_indices": [1, 2, 0, 2, 3, 0, 0, 1, 0, 3, 0, 0],
        "level_record_start": [0, 1],
        "collapse_kept": [0],
        "collapse_binned": [4],
        "collapse_change_count": [4],
        "collapse_prev_change_count": [0],
        "collapse_change_offsets": [2, 5, 8, 11],
        "lod_record_counts": [0, 1],
    }
    return _fan("skip-strip", bufs, {"primitive": "list"}, **over)


def _fan_strips(strip: list[int], restart: int = 0xFFFF) -> RawProgressiveMesh:
    """:func:`fan_skip`'s level as ``strip`` (restart index ``restart``), its record changing every slot of
    4."""
    slots = [i for i, v in enumerate(strip) if v == 4]
    bufs = dict(fan_skip().raw_buffers)
    bufs.update(
        level_index_start=[0, len(strip)],
        level_indices=strip,
        level_collapsed_start=[0, len(strip)],
        level_collapsed_indices=[0 if v == 4 else v for v in strip],
        collapse_change_count=[len(slots)],
        collapse_change_offsets=slots,
    )
    return _fan("skip-strip", bufs, {"primitive": "strip", "restart_index": restart})


def fan_skip_strip(restart: int = 0xFFFF) -> RawProgressiveMesh:
    """Skip-strip, strip variant: one single-triangle strip per triangle, joined by the restart index
    (0xFFFFFFFF: a u32 file, its idx's largest value)."""
    R = restart
    return _fan_strips([1, 2, 4, R, 2, 3, 4, R, 0, 1, 4, R, 3, 0, 4], R)


def fan_skip_swap() -> RawProgressiveMesh:
    """Skip-strip, strip variant: the whole fan as one strip with a swap (vertex 4 repeated), as
    :func:`swpm_usd.encode.strips.stripify` writes a fan: the degenerate triangle (4, 2, 4) before the
    collapse, and two more after it, are drawn but not counted."""
    return _fan_strips([0, 1, 4, 2, 4, 3, 0])


def fan_mixed(**over: Any) -> RawProgressiveMesh:
    """Mixed, one level: the two triangles the collapse bins are static, the two it changes dynamic."""
    bufs = {
        "level_first_lod": [0],
        "level_record_start": [0, 1],
        "level_static_start": [0, 6],
        "level_static_indices": [0, 1, 4, 3, 0, 4],
        "level_dynamic_start": [0, 6],
        "level_dynamic_indices": [1, 2, 4, 2, 3, 4],
        "level_dynamic_collapsed_indices": [1, 2, 0, 2, 3, 0],
        "collapse_kept": [0],
        "collapse_static_tris_removed": [2],
        "collapse_dynamic_tris_removed": [0],
        "collapse_change_count": [2],
        "collapse_prev_change_count": [0],
        "collapse_change_offsets": [2, 5],
        "lod_record_counts": [0, 1],
    }
    return _fan("mixed", bufs, {"cache_size": 16, "level_threshold": 0.25}, **over)


def fan_sliding_three_lods() -> RawProgressiveMesh:
    """:func:`fan_sliding` with a third LOD (3 vertices, the triangle 1 2 0) whose window follows the other
    two: three disjoint windows, so held ranges can draw LODs 0 and 2 but not 1 (format.md 4.2)."""
    bufs = {
        "index_pool": [0, 1, 4, 3, 0, 4, 1, 2, 4, 2, 3, 4, 1, 2, 0, 2, 3, 0, 1, 2, 0],
        "window_records": [[0, 4, 5], [12, 2, 4], [18, 1, 3]],
    }
    return _fan(
        "sliding-window",
        bufs,
        {"cache_size": 16},
        vertex_counts=np.array([5, 4, 3]),
        triangle_counts=np.array([4, 2, 1]),
        lod_errors=np.array([0.0, 0.5, 1.0], np.float32),
    )


def fan_skip_two_levels(
    level1: list[int] | None = None, collapsed0: list[int] | None = None
) -> RawProgressiveMesh:
    """Skip-strip list of two levels: level 0 (LODs 0 and 1) the fan, its records binning vertex 4, then 3,
    onto 0; level 1 (LOD 2, 3 vertices) ``level1``, the triangle 1 2 0 by default. A range reader holding
    level 0's list checks it against LOD 0's 5 vertices, not LOD 1's 4 (format.md 4.2)."""
    lst = [1, 2, 0] if level1 is None else level1
    bufs = {
        "level_first_lod": [0, 2],
        "level_index_start": [0, 12, 12 + len(lst)],
        "level_indices": [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 0, 4, *lst],
        "level_collapsed_start": [0, 12, 12 + len(lst)],
        "level_collapsed_indices": [*(collapsed0 or [1, 2, 0, 2, 0, 0, 0, 1, 0, 0, 0, 0]), 1, 2, 0],
        "level_record_start": [0, 2, 2],
        "collapse_kept": [0, 0],
        "collapse_binned": [4, 3],
        "collapse_change_count": [4, 2],
        "collapse_prev_change_count": [0, 4],
        "collapse_change_offsets": [2, 5, 8, 11, 4, 9],
        "lod_record_counts": [0, 1, 2],
    }
    return _fan(
        "skip-strip",
        bufs,
        {"primitive": "list"},
        vertex_counts=np.array([5, 4, 3]),
        triangle_counts=np.array([4, 2, 1]),
        lod_errors=np.array([0.0, 0.5, 1.0], np.float32),
    )


def fan_skip_level_of_two_lods(level1: list[int] | None = None) -> RawProgressiveMesh:
    """Skip-strip list of two levels whose second spans two LODs: level 0 (LOD 0) the fan, its record binning
    vertex 4 onto 0; level 1 (LODs 1 and 2, 4 then 3 vertices) ``level1``, by default the triangles 1 2 0 and
    2 3 0 that remain, its record binning 3 onto 0. Level 1's list names vertex 3, below its first LOD's 4
    vertices though not below LOD 2's 3: a range reader checks LOD 2's elements against LOD 1's count."""
    lst = [1, 2, 0, 2, 3, 0] if level1 is None else level1
    bufs = {
        "level_first_lod": [0, 1],
        "level_index_start": [0, 12, 12 + len(lst)],
        "level_indices": [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 0, 4, *lst],
        "level_collapsed_start": [0, 12, 12 + len(lst)],
        "level_collapsed_indices": [1, 2, 0, 2, 3, 0, 0, 1, 0, 3, 0, 0, 1, 2, 0, 2, 0, 0],
        "level_record_start": [0, 1, 2],
        "collapse_kept": [0, 0],
        "collapse_binned": [4, 3],
        "collapse_change_count": [4, 1],
        "collapse_prev_change_count": [0, 4],
        "collapse_change_offsets": [2, 5, 8, 11, 4],
        "lod_record_counts": [0, 1, 2],
    }
    return _fan(
        "skip-strip",
        bufs,
        {"primitive": "list"},
        vertex_counts=np.array([5, 4, 3]),
        triangle_counts=np.array([4, 2, 1]),
        lod_errors=np.array([0.0, 0.5, 1.0], np.float32),
    )


def fan_mixed_two_levels(static1: list[int] | None = None) -> RawProgressiveMesh:
    """Mixed, two levels: level 0 (LOD 0) :func:`fan_mixed`'s, its record binning vertex 4 onto 0; level 1
    (LODs 1 and 2, 4 then 3 vertices) the static triangle ``static1`` (2 3 0 by default), which its record,
    binning 3 onto 0, drops, and the dynamic triangle 1 2 0. The static list names vertex 3, below its
    level's first LOD's 4 vertices though not below LOD 2's 3."""
    st = [2, 3, 0] if static1 is None else static1
    bufs = {
        "level_first_lod": [0, 1],
        "level_record_start": [0, 1, 2],
        "level_static_start": [0, 6, 9],
        "level_static_indices": [0, 1, 4, 3, 0, 4, *st],
        "level_dynamic_start": [0, 6, 9],
        "level_dynamic_indices": [1, 2, 4, 2, 3, 4, 1, 2, 0],
        "level_dynamic_collapsed_indices": [1, 2, 0, 2, 3, 0, 1, 2, 0],
        "collapse_kept": [0, 0],
        "collapse_static_tris_removed": [2, 1],
        "collapse_dynamic_tris_removed": [0, 0],
        "collapse_change_count": [2, 0],
        "collapse_prev_change_count": [0, 2],
        "collapse_change_offsets": [2, 5],
        "lod_record_counts": [0, 1, 2],
    }
    return _fan(
        "mixed",
        bufs,
        {"cache_size": 16, "level_threshold": 0.25},
        vertex_counts=np.array([5, 4, 3]),
        triangle_counts=np.array([4, 2, 1]),
        lod_errors=np.array([0.0, 0.5, 1.0], np.float32),
    )


def quad_sliding_empty_windows() -> RawProgressiveMesh:
    """Sliding-window quad whose coarser LODs draw nothing: LOD 0 (4 vertices) draws pool [3, 9), LOD 1 (3
    vertices) an empty window at 0, LOD 2 (2 vertices, a band of its own) an empty window at 9, the pool's
    end. Pool elements [0, 3) belong to no window."""
    bufs = {"index_pool": [0, 1, 2, 0, 1, 2, 0, 2, 3], "window_records": [[3, 2, 4], [0, 0, 3], [9, 0, 2]]}
    return RawProgressiveMesh(
        "sliding-window",
        FAN_POINTS[:4],
        np.array([4, 3, 2]),
        np.array([2, 0, 0]),
        np.array([0.0, 0.5, 1.0], np.float32),
        bufs,
        params={"cache_size": 16},
    )


def single_triangle() -> RawProgressiveMesh:
    bufs = {
        "indices": [0, 1, 2],
        "collapse_kept": [],
        "collapse_tris_removed": [],
        "collapse_change_count": [],
        "collapse_prev_change_count": [],
        "collapse_change_offsets": [],
        "lod_record_counts": [0],
    }
    return RawProgressiveMesh(
        "vanilla", FAN_POINTS[:3], np.array([3]), np.array([1]), np.array([0.0], np.float32), bufs
    )


def _write(pm: RawProgressiveMesh, **kw: Any) -> bytes:
    return encode_bytes(pm, generator=GENERATOR, **kw)  # type: ignore[arg-type]


# -- patching helpers -----------------------------------------------------------------------------------
def _entries(data: bytes) -> list[tuple[bytes, int, int, int]]:
    """(type, entry offset, payload offset, length) of every chunk-table entry."""
    count = struct.unpack_from("<I", data, 24)[0]
    to = struct.unpack_from("<Q", data, 32)[0]
    out = []
    for i in range(count):
        eo = to + 32 * i
        t, _, off, ln = struct.unpack_from("<4sIQQ", data, eo)
        out.append((t, eo, off, ln))
    return out


def fix_crcs(data: bytes | bytearray) -> bytes:
    """Recompute every chunk CRC and the file CRC (for vectors whose defect is not a CRC)."""
    b = bytearray(data)
    ents = _entries(bytes(b))
    for t, eo, off, ln in ents:
        if off + ln <= len(b):
            struct.pack_into("<I", b, eo + 24, zlib.crc32(bytes(b[off : off + ln]), zlib.crc32(t)))
    table_end = struct.unpack_from("<Q", b, 32)[0] + 32 * len(ents)
    struct.pack_into("<I", b, L.FILE_CRC_OFFSET, 0)
    struct.pack_into("<I", b, L.FILE_CRC_OFFSET, zlib.crc32(bytes(b[:table_end])))
    return bytes(b)


def chunk(data: bytes, t: bytes) -> tuple[int, int, int]:
    """(entry offset, payload offset, length) of chunk ``t``."""
    for tt, eo, off, ln in _entries(data):
        if tt == t:
            return eo, off, ln
    raise KeyError(t)


def patch(data: bytes, offset: int, fmt: str, *values: Any, crc: bool = True) -> bytes:
    b = bytearray(data)
    struct.pack_into(fmt, b, offset, *values)
    return fix_crcs(b) if crc else bytes(b)


def reorder(data: bytes, order: list[int]) -> bytes:
    """The file with its chunks listed and laid out in ``order`` (indices into the chunk table), payloads
    packed from the table's end on 8-byte boundaries, CRCs recomputed. Permuting chunks that all precede an
    unmoved tail keeps the tail's offsets, so SMAP's ranges stay right."""
    ents = _entries(data)
    b = bytearray(data[: struct.unpack_from("<Q", data, 32)[0] + 32 * len(ents)])
    pos = L.align(len(b), L.CHUNK_ALIGN)
    body = bytearray(pos - len(b))
    for i, k in enumerate(order):
        _, eo, off, ln = ents[k]
        at = ents[i][1]
        b[at : at + 32] = data[eo : eo + 32]
        struct.pack_into("<Q", b, at + 8, pos)
        end = L.align(pos + ln, L.CHUNK_ALIGN) if i < len(order) - 1 else pos + ln
        body += data[off : off + ln] + bytes(end - pos - ln)
        pos = end
    out = b + body
    struct.pack_into("<Q", out, 40, len(out))
    return fix_crcs(out)


def with_smap(data: bytes, make: Callable[[dict[bytes, int] | None], Any]) -> bytes:
    """``data`` with SMAP's payload replaced by ``make(offsets)`` (the payload offset of every chunk once laid
    out again; ``make(None)`` gives the new payload's length), the chunks laid out again in table order,
    file_size and CRCs recomputed."""
    ents = _entries(data)
    table_end = struct.unpack_from("<Q", data, 32)[0] + 32 * len(ents)
    payload = {t: data[o : o + n] for t, _, o, n in ents}
    pos, offs = L.align(table_end, L.CHUNK_ALIGN), {}
    for t, *_ in ents:
        offs[t] = pos
        pos = L.align(pos + (make(None) if t == L.SMAP else len(payload[t])), L.CHUNK_ALIGN)
    payload[L.SMAP] = make(offs)
    out = bytearray(data[:table_end])
    for t, eo, _, _ in ents:
        out += bytes(offs[t] - len(out)) + payload[t]
        struct.pack_into("<QQ", out, eo + 8, offs[t], len(payload[t]))
    struct.pack_into("<Q", out, 40, len(out))
    return fix_crcs(out)


def smap_bytes(bands: list[tuple[int, int, int, int, int]], ranges: list[tuple[int, int]]) -> bytes:
    """An SMAP payload: bands (first_lod, lod_count, range_start, range_count, prefix_length), ranges
    (offset, length)."""
    head = np.array([(len(bands), len(ranges))], L.SMAP_HEADER).tobytes()
    return head + np.array(bands, L.SMAP_BAND).tobytes() + np.array(ranges, L.SMAP_RANGE).tobytes()


def fan_smap(extra: list[tuple[int, int]], range_count: int | None = None) -> bytes:
    """The minimal vanilla file whose one band lists its three hulls and then the ``extra`` ranges (offset
    -1: the end of the file); ``range_count``, if given, replaces the band's count of ranges."""

    def make(offs: dict[bytes, int] | None) -> int | bytes:
        if offs is None:
            return L.SMAP_HEADER.itemsize + L.SMAP_BAND.itemsize + L.SMAP_RANGE.itemsize * (3 + len(extra))
        indx, vert = offs[L.INDX], offs[L.VERT]
        end = vert + len(payload[L.VERT])
        more = [(end if o < 0 else o, n) for o, n in extra]
        ranges = [(0, indx), (indx, len(payload[L.INDX])), (vert, end - vert), *more]
        return smap_bytes([(0, 2, 0, range_count or len(ranges), end)], ranges)

    data = _write(fan_vanilla())
    payload = {t: data[o : o + n] for t, _, o, n in _entries(data)}
    return with_smap(data, make)


def restream(pm: RawProgressiveMesh, order: list[int]) -> bytes:
    """``pm``'s file with its chunks listed and laid out in ``order`` (see :func:`reorder`) and SMAP written
    again, as the writer would, for the new offsets of INDX and VERT."""
    return resmap(pm, reorder(_write(pm), order))


def resmap(pm: RawProgressiveMesh, data: bytes) -> bytes:
    """``data``, a file of ``pm`` laid out anew, with SMAP written again as the writer would."""
    _, vo, _ = chunk(data, L.VERT)
    _, _, stride, vert_data = struct.unpack_from("<4I", data, vo)
    width = L.read_widths(struct.unpack_from("<I", data, 20)[0])[0]
    bufs = pm.buffers()
    n_index = chunk(data, L.INDX)[2] // width
    need = needed_index_ranges(pm.encoding, bufs, pm.lod_count, n_index)
    vc = np.asarray(pm.vertex_counts, np.int64)
    size = len(smap_payload(vc, need, width, 0, 0, vert_data, stride))

    def make(offs: dict[bytes, int] | None) -> int | bytes:
        if offs is None:
            return size
        return smap_payload(vc, need, width, offs[L.INDX], offs[L.VERT], vert_data, stride)

    return with_smap(data, make)


def long_header(pm: RawProgressiveMesh, extra: int, fill: int = 0x5A) -> bytes:
    """``pm``'s file with ``extra`` (a multiple of 8) bytes of ``fill`` after byte 64, inside the header:
    header_size and table_offset 64 + ``extra`` (a reader skips bytes 64..header_size, format.md 2.1), every
    chunk moved by ``extra``, SMAP written again."""
    data = _write(pm)
    out = bytearray(data[:64]) + bytes([fill]) * extra + data[64:]
    struct.pack_into("<I", out, 12, 64 + extra)
    struct.pack_into("<Q", out, 32, 64 + extra)
    struct.pack_into("<Q", out, 40, len(out))
    for _, eo, off, _ in _entries(bytes(out)):
        struct.pack_into("<Q", out, eo + 8, off + extra)
    return resmap(pm, fix_crcs(out))


def grow_stride(data: bytes, extra: int) -> bytes:
    """The file with ``extra`` zero bytes appended to every VERT record (stride, length and file_size follow;
    VERT must be the last chunk)."""
    eo, vo, vl = chunk(data, L.VERT)
    V, _, stride, at = struct.unpack_from("<4I", data, vo)
    recs = np.frombuffer(data[vo + at : vo + vl], np.uint8).reshape(V, stride)
    grown = np.concatenate([recs, np.zeros((V, extra), np.uint8)], axis=1).tobytes()
    head = bytearray(data[vo : vo + at])
    struct.pack_into("<I", head, 8, stride + extra)
    out = bytearray(data[:vo]) + head + grown
    struct.pack_into("<Q", out, eo + 16, len(head) + len(grown))
    struct.pack_into("<Q", out, 40, len(out))
    return fix_crcs(out)


# -- the vectors ----------------------------------------------------------------------------------------
#: a u32 colour and an i32 attribute whose values need more than float32's 24 significant bits (usd.md,
#: "Attribute values"): the file keeps every bit, a USD stage does not
COLOR_U32 = np.array(
    [
        [0, 1, 2**24 - 1, 2**24],
        [2**32 - 1, 2**24 + 1, 2**25 + 1, 123_456_789],
        [2**31 - 1, 2**31, 2**31 + 1, 3_000_000_001],
        [2**32 - 2, 2**32 - 129, 0x89ABCDEF, 0x01234567],
        [16_843_009, 2**30 + 64, 2**30 + 128, 4_000_000_000],
    ],
    "<u4",
)
ID_I32 = np.array([[-(2**31)], [-(2**24) - 1], [2**24], [2**31 - 1], [7]], "<i4")


def _valid() -> dict[str, tuple[bytes, str]]:
    attrs = {
        "normal": np.tile(np.array([[0, 0, 1]], np.float32), (5, 1)),
        "uv": FAN_POINTS[:, :2].copy(),
        "color": np.array(
            [[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255], [9, 9, 9, 255], [1, 2, 3, 4]], np.uint8
        ),
    }
    return {
        "minimal-vanilla": (
            _write(fan_vanilla()),
            "the worked example of the spec: 4 triangles, one collapse",
        ),
        "vanilla-u32": (_write(fan_vanilla(), index_width=4), "the same mesh with u32 indices"),
        "sliding-window": (_write(fan_sliding()), "sliding window: two windows in one pool"),
        "skip-strip-list": (_write(fan_skip()), "skip-strip, list variant, one level"),
        "skip-strip-strip": (_write(fan_skip_strip()), "skip-strip, strips joined by restart index 0xFFFF"),
        "skip-strip-swap": (
            _write(fan_skip_swap()),
            "skip-strip, the fan as one strip with a swap: a repeated index draws a degenerate triangle,"
            " not counted",
        ),
        "attributes": (_write(fan_vanilla(attributes=attrs)), "normal f32x3, uv f32x2, color u8x4"),
        "attributes-32bit": (
            _write(fan_vanilla(attributes={"color": COLOR_U32, "id": ID_I32})),
            "color u32x4 and id i32 with values above 2^24: the file keeps every bit (a USD stage keeps 24"
            " significant bits, usd.md)",
        ),
        "single-triangle": (_write(single_triangle()), "one triangle, one LOD, no records"),
        "unknown-ancillary-chunk": (
            _write(fan_vanilla(), extra_chunks=[(b"zXTR", False, b"ignore me")]),
            "an unknown ancillary chunk a reader must skip",
        ),
        "newer-minor-version": (fix_crcs(_write(fan_vanilla(), minor=3)), "minor version 3: read as 1.0"),
        "mixed": (_write(fan_mixed()), "mixed, one level: static and dynamic list, one collapse"),
        "unknown-ancillary-before-smap": (
            # META zXTR LODS SMAP ...: unknown chunks are skipped by the stream-order check wherever they are
            reorder(
                _write(fan_vanilla(), extra_chunks=[(b"zXTR", False, b"ignore me")]), [0, 3, 1, 2, 4, 5, 6, 7]
            ),
            "an unknown ancillary chunk between META and LODS: no SWPM_STREAM_ORDER (format.md 2.3)",
        ),
        **_review_valid(),
        **_blind_valid(),
        "sliding-window-strips": (
            _write(fan_sliding_strips()),
            "sliding window, the pool as strips (SW_STRIPS): WREC rows of four fields, two windows each"
            " starting a strip, swaps not counted",
        ),
        "sliding-window-strips-u32": (
            # (since 0.9.0 the writer makes this pool u16, restart 0xFFFF: u32 is forced, INDEX32, as before)
            _write(fan_sliding_strips(0xFFFFFFFF), index_width=4),
            "the strip pool of sliding-window-strips in a u32 file with restart index 0xFFFFFFFF, all ones of"
            " idx: what a writer writes whenever the file is u32 (format.md 3.5), drawn as it is by an API"
            " whose restart value is all ones of the index type",
        ),
        "sliding-window-strips-u32-restart-ffff": (
            _write(fan_sliding_strips(), index_width=4, keep_restart_index=True),
            "the same pool in a u32 file with restart index 0xFFFF, as writers before 0.8.0 wrote a u32 file:"
            " still valid (a restart index is any value >= V), an engine rewrites its restarts or uploads it"
            " as u16 (format.md 3.5)",
        ),
        "skip-strip-strip-u32": (
            _write(fan_skip_strip(0xFFFFFFFF), index_width=4),
            "skip-strip-strip in a u32 file with restart index 0xFFFFFFFF, all ones of idx (format.md 3.7)",
        ),
        **_offset32_valid(),
        "sliding-window-strip-prefix": (
            _write(fan_sliding_strip_prefix()),
            "sliding window, a strip pool whose window 1 ends inside the strip window 0 draws: its 4 indices,"
            " a prefix of the strip, decode to its 2 triangles",
        ),
        "sliding-window-strip-join": (
            _write(fan_sliding_strip_join()),
            "sliding window, a strip pool whose strip goes on across window 1's end by a repeated index"
            " (3 3: two degenerate triangles, counted for the parity only) rather than a restart: window 1's"
            " 4 indices decode to its 2 triangles, window 0's 8 to its 4",
        ),
        "sliding-window-strip-end-degenerate": (
            _write(fan_sliding_strip_join(window1_count=5)),
            "sliding window, the same strip pool with window 1 ending on the degenerate triangle 0 3 3 (5"
            " indices): it draws nothing, so window 1 still decodes to its 2 triangles (a reader does not"
            " reject a window that ends on degenerate triangles)",
        ),
        **_prefix_valid(),
        **_ranges_valid(),
    }


#: what every forced OFFSET32 vector says of itself (format.md 1)
_FORCED = (
    ": a writer SHOULD NOT set OFFSET32 when every table value fits u16, as here (it is forced to keep the"
    " vector small, as a pool longer than 65,535 indices sets it); the file is still valid (format.md 1)"
)


def _offset32_valid() -> dict[str, tuple[bytes, str]]:
    """Valid files with the OFFSET32 bit (format.md 1): ``idx`` u16, the tables (``off``) u32, in each
    encoding; the strips keep restart index 0xFFFF, all ones of ``idx``."""
    return {
        "sliding-window-strips-offset32": (
            _write(fan_sliding_strips(), offset_width=4),
            "the strip pool of sliding-window-strips with OFFSET32: INDX u16 with restart index 0xFFFF, WREC"
            " u32 (its rows 16 bytes)" + _FORCED,
        ),
        "skip-strip-strip-offset32": (
            _write(fan_skip_strip(), offset_width=4),
            "skip-strip-strip with OFFSET32: INDX and level_collapsed_indices u16 with restart index 0xFFFF,"
            " the level table, SREC and RCNT u32" + _FORCED,
        ),
        "sliding-window-offset32": (
            _write(fan_sliding(), offset_width=4),
            "the list pool of sliding-window with OFFSET32: INDX u16, WREC u32 (rows of 12 bytes)" + _FORCED,
        ),
        "vanilla-offset32": (
            _write(fan_vanilla(), offset_width=4),
            "minimal-vanilla with OFFSET32: INDX u16, VREC's records and change offsets and RCNT u32"
            + _FORCED,
        ),
        "mixed-offset32": (
            _write(fan_mixed(), offset_width=4),
            "mixed with OFFSET32: INDX and MLVL's two dynamic lists u16, MLVL's level table, MREC and RCNT"
            " u32" + _FORCED,
        ),
    }


def _offset32_invalid(out: dict[str, tuple[bytes, str]]) -> None:
    """The OFFSET32 bit's rejections (format.md 1, 5)."""
    u32 = _write(fan_vanilla(), index_width=4)
    feats = struct.unpack_from("<I", u32, 20)[0]
    out["offset32-with-index32"] = (
        patch(u32, 20, "<I", feats | L.FEATURE_OFFSET32),
        "vanilla-u32 with the OFFSET32 bit beside INDEX32: SWPM_HEADER_OFFSET32_WITH_INDEX32, which does not"
        " stop the checks; the file reads as u32 (idx and off), so nothing else is wrong",
    )
    data = _write(fan_sliding(), offset_width=4)
    rows = np.asarray(fan_sliding().buffers()["window_records"], "<u2").tobytes()
    out["offset32-wrec-index-width"] = (
        relayout(data, {L.WREC: rows}),
        "sliding-window-offset32 with its WREC written in u16 (3 W L = 12 bytes), as a reader ignoring"
        " OFFSET32 would read it: WREC must be 3 O L = 24 bytes (SWPM_CHUNK_BAD_LENGTH)",
    )
    # (offsets into the tables step O = 4 bytes here, where W = 2: errors.md)
    out["offset32-window-count-mismatch"] = (
        _write(fan_sliding(buffers={"window_records": [[0, 4, 5], [12, 2, 3]]}), offset_width=4),
        "window-count-mismatch with OFFSET32: SWPM_WINDOW_COUNT_MISMATCH at window 1's vertex_count field,"
        " WREC payload + 3 O + 2 O (O = 4), not + 3 W + 2 W",
    )
    out["offset32-skip-binned-not-last"] = (
        _write(fan_skip(buffers={"collapse_binned": [3]}), offset_width=4),
        "skip-binned-not-last with OFFSET32: SWPM_RECORD_BAD_BINNED at record 0's binned field, table + O"
        " (O = 4)",
    )


def _review_valid() -> dict[str, tuple[bytes, str]]:
    """Valid files (a warning) that pin what reading the spec as a second implementer found (format.md 4)."""
    return {
        "smap-17-ranges": (
            fan_smap([(0, 8)] * 13 + [(-1, 8)]),
            "SMAP's band names 17 ranges and the last lies past the end of the file: the bands are checked"
            " first (SWPM_SMAP_INVALID at band 0, not at the range table)",
        ),
        "smap-empty-index-hull": (
            restream(quad_sliding_empty_windows(), [0, 1, 2, 3, 5, 4]),
            "sliding-window, VERT laid out before INDX (SWPM_STREAM_ORDER): an empty window adds nothing to"
            " its band's INDX hull (band 0: pool [3, 9), not [0, 9)), and a band of empty windows has no INDX"
            " hull (band 1: prefix_length ends at INDX's offset, not at its empty window's position 9)",
        ),
        "smap-range-in-trailing-bytes": (
            fan_smap([(-1, 8)]) + bytes(8),
            "an SMAP range ends in the 8 bytes after file_size: the file is read as its first file_size"
            " bytes, so the range lies outside it",
        ),
    }


def _invalid(base: bytes) -> dict[str, tuple[bytes, str]]:
    out: dict[str, tuple[bytes, str]] = {}
    out["truncated-header"] = (base[:40], "40 bytes: the header is cut")
    out["truncated-chunk-table"] = (base[:100], "the chunk table is cut (file_size also disagrees)")
    out["bad-magic"] = (b"SWPX" + base[4:], "wrong signature")
    out["unknown-major-version"] = (patch(base, 8, "<H", 2), "major version 2")
    _, voff, vlen = chunk(base, L.VERT)
    bad = bytearray(base)
    bad[voff + 20] ^= 0x40
    out["crc-mismatch"] = (bytes(bad), "one bit of a point flipped: VERT CRC no longer matches")
    out["file-checksum-mismatch"] = (
        patch(base, L.FILE_CRC_OFFSET, "<I", 0x12345678, crc=False),
        "the header's file CRC is wrong",
    )
    veo, _, _ = chunk(base, L.VERT)
    out["chunk-past-end"] = (patch(base, veo + 16, "<Q", vlen + 64), "VERT length runs past the end of file")
    _, moff, _ = chunk(base, L.META)
    leo, _, _ = chunk(base, L.LODS)
    out["overlapping-chunks"] = (patch(base, leo + 8, "<Q", moff), "LODS starts inside META")
    out["unknown-critical-chunk"] = (
        _write(fan_vanilla(), extra_chunks=[(b"zXTR", True, b"need me")]),
        "a critical chunk no v1 reader knows",
    )
    out["window-outside-pool"] = (
        _write(fan_sliding(buffers={"window_records": [[0, 4, 5], [15, 2, 4]]})),
        "the coarse window ends 3 indices past the pool",
    )
    out["index-above-vertex-count"] = (
        _write(fan_vanilla(buffers={"indices": [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 0, 9]})),
        "INDX holds 9 in a 5-vertex mesh",
    )
    out["window-prefix-violation"] = (
        _write(fan_sliding(buffers={"index_pool": [0, 1, 4, 3, 0, 4, 1, 2, 4, 2, 3, 4, 1, 2, 4, 2, 3, 0]})),
        "the coarse window (4 vertices) draws vertex 4",
    )
    out["non-monotone-records"] = (
        _write(
            fan_sliding(
                buffers={"window_records": [[12, 2, 5], [0, 4, 5]]},
                vertex_counts=np.array([5, 5]),
                triangle_counts=np.array([2, 4]),
            )
        ),
        "windows ordered coarse to fine: triangle counts grow",
    )
    _, roff, _ = chunk(base, L.VREC)
    out["huge-record-count"] = (
        patch(base, roff, "<I", 0xFFFFFFFF),
        "VREC declares 2^32-1 records: must be rejected before any allocation",
    )
    out["record-keeps-binned-vertex"] = (
        _write(fan_vanilla(buffers={"collapse_kept": [4]})),
        "the collapse keeps the vertex it bins",
    )
    out["record-changes-wrong-slot"] = (
        _write(fan_vanilla(buffers={"collapse_change_offsets": [0, 5]})),
        "a change offset points at a slot that does not hold the binned vertex",
    )
    _, mo, ml = chunk(base, L.META)
    b = bytearray(base)
    b[mo] = ord("[")
    out["meta-not-json"] = (fix_crcs(b), "META is not a JSON object")
    out["unknown-required-feature"] = (
        patch(base, 20, "<I", L.FEATURE_VANILLA | (1 << 20)),
        "required-feature bit 20 is unknown",
    )
    out["mixed-change-offset-out-of-range"] = (
        _write(fan_mixed(buffers={"collapse_change_offsets": [2, 6]})),
        "a mixed change offset points past its level's dynamic list (6 slots)",
    )
    out["mixed-level-outside-list"] = (
        _write(fan_mixed(buffers={"level_static_start": [0, 9]})),
        "the mixed level's static range ends 3 indices past INDX",
    )
    out["skip-binned-not-last"] = (
        _write(fan_skip(buffers={"collapse_binned": [3]})),
        "the skip-strip record bins vertex 3; record 0 must bin V - 1 = 4",
    )
    out["skip-collapsed-list-differs"] = (
        _write(fan_skip(buffers={"level_collapsed_indices": [1, 2, 0, 2, 3, 0, 0, 1, 0, 3, 1, 0]})),
        "the skip-strip level's collapsed list is not its list with the record applied",
    )
    out["skip-triangle-count"] = (
        _write(fan_skip(triangle_counts=np.array([4, 3]))),
        "LODS says 3 triangles after the collapse; the list holds 2 non-degenerate ones",
    )
    partial = [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 0, 4, 4]
    out["skip-list-partial-triangle"] = (
        _write(
            fan_skip(
                buffers={
                    "level_index_start": [0, 13],
                    "level_indices": partial,
                    "level_collapsed_start": [0, 13],
                    "level_collapsed_indices": [0 if v == 4 else v for v in partial],
                    "collapse_change_count": [5],
                    "collapse_change_offsets": [2, 5, 8, 11, 12],
                }
            )
        ),
        "a skip-strip triangle list of 13 indices: the last triangle is cut",
    )
    restart_vertex = fan_skip_strip()
    restart_vertex.params["restart_index"] = 3
    out["skip-restart-is-a-vertex"] = (
        _write(restart_vertex),
        "the strips' restart index 3 is a vertex of the 5-vertex mesh",
    )
    bad_primitive = fan_skip()
    bad_primitive.params["primitive"] = "fan"
    out["skip-bad-primitive"] = (_write(bad_primitive), "skip-strip params.primitive is not strip or list")
    dup = base.replace(b'"source_digest":null', b'"encoding":"vanilla"')
    out["meta-duplicate-key"] = (fix_crcs(dup), "META repeats the key encoding (not valid JSON: RFC 8259)")
    _new_invalid(base, out)
    _strips_invalid(base, out)
    _offset32_invalid(out)
    return out


def _strips_invalid(base: bytes, out: dict[str, tuple[bytes, str]]) -> None:
    """A sliding window's strip pool (format.md 3.5, ``SW_STRIPS``): each rejection with its code."""
    feats = struct.unpack_from("<I", base, 20)[0]
    out["strips-bit-without-sliding"] = (
        patch(base, 20, "<I", feats | L.FEATURE_SW_STRIPS),
        "a vanilla file with the SW_STRIPS feature bit: SWPM_HEADER_STRIPS_NOT_SLIDING",
    )
    out["sliding-strips-window-mid-strip"] = (
        _write(
            fan_sliding_strips(
                buffers={"window_records": [[0, 4, 5], [10, 2, 4]], "window_index_counts": [8, 3]}
            )
        ),
        "window 1 starts one index after the restart index, inside its strip: SWPM_WINDOW_MID_STRIP",
    )
    out["sliding-strips-triangle-count"] = (
        _write(fan_sliding_strips(buffers={"window_index_counts": [7, 4]})),
        "window 0's index_count 7 leaves its last triangle out: it decodes to 3 triangles, not 4"
        " (SWPM_WINDOW_STRIP_TRIANGLES at its index_count field)",
    )
    out["sliding-strips-window-outside-pool"] = (
        _write(fan_sliding_strips(buffers={"window_index_counts": [8, 5]})),
        "window 1 (index_count 5) ends one index past the pool: SWPM_WINDOW_OUT_OF_POOL",
    )
    listed = fan_sliding_strips()
    listed.params["primitive"] = "list"
    out["sliding-strips-primitive-list"] = (
        _write(listed),
        'the SW_STRIPS bit with params.primitive "list": SWPM_META_BAD_FIELD, the encoding\'s checks do not'
        " run",
    )
    no_restart = fan_sliding_strips()
    no_restart.params["restart_index"] = None
    out["sliding-strips-restart-null"] = (
        _write(no_restart),
        "the SW_STRIPS bit with params.restart_index null: SWPM_META_BAD_FIELD",
    )
    low = fan_sliding_strips()
    low.params["restart_index"] = 3
    out["sliding-strips-restart-below-vertex-count"] = (
        _write(low),
        "params.restart_index 3, a vertex of the 5: SWPM_META_BAD_FIELD in stage (a), the checks end",
    )
    stripped = fan_sliding()
    stripped.params.update(primitive="strip", restart_index=0xFFFF)
    out["sliding-list-primitive-strip"] = (
        _write(stripped),
        'a list pool (no SW_STRIPS bit) whose params.primitive is "strip": SWPM_META_BAD_FIELD',
    )
    three = _write(fan_sliding_strips())
    _, woff, wlen = chunk(three, L.WREC)
    out["sliding-strips-wrec-three-fields"] = (
        relayout(three, {L.WREC: three[woff : woff + wlen][: 3 * 2 * 2]}),
        "the SW_STRIPS bit with WREC rows of three fields (12 bytes for 2 LODs, u16): SWPM_CHUNK_BAD_LENGTH",
    )


def _new_invalid(base: bytes, out: dict[str, tuple[bytes, str]]) -> None:
    """The vectors that pin what the audit of a second reader found open (format.md 2.3, 3.3, 3.4, 5)."""
    out["rcnt-count-and-change-counts"] = (
        _write(fan_vanilla(buffers={"lod_record_counts": [0, 1, 1], "collapse_change_count": [3]})),
        "RCNT holds 3 counts for 2 LODs and the change counts sum to 3, not 2: both stage (a) counts, the"
        " change counts first (RCNT's count is not a stage 0 length)",
    )
    out["vanilla-lods-row0-not-index-count"] = (
        _write(fan_vanilla(buffers={"indices": [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 0, 4, 0, 1, 2]})),
        "INDX holds 5 triangles, LODS row 0 says 4: T0 is INDX count / 3, so LODS row 0 is wrong (stage b)",
    )
    attr = {"w": np.zeros((5, 1), "<f8")}
    out["vert-stride-not-element-multiple"] = (
        grow_stride(_write(fan_vanilla(attributes=attr)), 4),
        "an f64 attribute in a stride-28 vertex record: stride must be a multiple of every element size",
    )
    out["vert-attribute-count-too-large"] = (
        patch(base, chunk(base, L.VERT)[1] + 4, "<I", 256),
        "VERT declares 256 attributes in a 76-byte chunk: the descriptors' count is checked before A <= 255",
    )
    data = bytearray(_write(fan_vanilla(), extra_chunks=[(b"zXTR", False, b"{}")]))
    eo, _, _ = chunk(bytes(data), b"zXTR")
    data[eo : eo + 8] = L.META + L.CHUNK_CRITICAL.to_bytes(4, "little")
    out["duplicate-meta-misplaced"] = (
        fix_crcs(data),
        "a second META after SMAP: a duplicate, and the stream-order warning names it, not the first META",
    )
    out["bad-chunk-type"] = (
        _write(fan_vanilla(), extra_chunks=[(b"zX!R", False, b"ignore me")]),
        "an ancillary chunk typed zX!R: a bad type, and so also an unknown ancillary chunk",
    )
    out["skip-kept-above-vertex-count"] = (
        _write(fan_skip(buffers={"collapse_kept": [9], "collapse_binned": [3]})),
        "a skip-strip record keeps vertex 9 of 5 (stage a); its binned 3, not V-1 = 4, is a stage (c) check"
        " that then does not run",
    )
    out["skip-index-past-level-table"] = (
        _write(fan_skip(buffers={"level_indices": [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 0, 4, 0, 1, 2]})),
        "INDX holds 15 indices, level_index_start ends at 12: its last element must be the INDX count",
    )
    _settled_invalid(base, out)


def _settled_invalid(base: bytes, out: dict[str, tuple[bytes, str]]) -> None:
    """The vectors that pin the points a later audit left open (format.md 2.2, 2.3, 3.6)."""
    veo, voff, vlen = chunk(base, L.VERT)
    size = len(base)
    out["chunk-moved-past-end"] = (
        patch(base, veo + 8, "<Q", L.align(size, L.CHUNK_ALIGN)),
        "VERT's offset moved past the end of file: SWPM_CHUNK_OUT_OF_BOUNDS, then its padding gap, checked up"
        " to the end of file, holds VERT's old payload (SWPM_PADDING_NONZERO)",
    )
    out["record-changes-slot-twice"] = (
        _write(fan_vanilla(buffers={"collapse_change_count": [3], "collapse_change_offsets": [2, 2, 5]})),
        "one record lists slot 2 twice: its changes are made in order, so the second time slot 2 no longer"
        " holds the binned vertex",
    )
    # META LODS SMAP zXTR RCNT VREC INDX VERT -> META LODS SMAP RCNT VREC INDX VERT VERT (a copy of VERT)
    data = bytearray(
        reorder(
            _write(fan_vanilla(), extra_chunks=[(b"zXTR", True, base[voff : voff + vlen])]),
            [0, 1, 2, 4, 5, 6, 7, 3],
        )
    )
    eo, _, _ = chunk(bytes(data), b"zXTR")
    data[eo : eo + 4] = L.VERT
    out["duplicate-vert-trailing"] = (
        fix_crcs(data),
        "a second VERT listed after the first: a duplicate, and the stream-order warning names it (a position"
        " past the end of the order differs)",
    )
    _review_invalid(out)
    _blind_invalid(out)
    _ranges_invalid(base, out)
    out["skip-strip-two-levels-collapsed-prefix"] = (
        _write(fan_skip_two_levels(collapsed0=[1, 2, 0, 2, 3, 0, 0, 1, 0, 0, 0, 0])),
        "skip-strip-two-levels with level 0's collapsed list keeping vertex 3, which its records bin: the"
        " replay's list differs (SWPM_LEVEL_BAD_TABLE) and the collapsed lists' prefix is broken"
        " (SWPM_PREFIX_VIOLATION), both at that element; without all of INDX both wait (range case"
        " skip-strip-two-levels-collapsed-prefix-no-indx)",
    )
    out["skip-strip-two-levels-prefix-violation"] = (
        _write(fan_skip_two_levels([1, 2, 3])),
        "skip-strip-two-levels with level 1's list 1 2 3 (its collapsed list 1 2 0): vertex 3 is not below"
        " its first LOD's 3 vertices, SWPM_PREFIX_VIOLATION at that element (range case"
        " skip-strip-two-levels-prefix-violation-level-1: found at once from that list's range)",
    )


def _review_invalid(out: dict[str, tuple[bytes, str]]) -> None:
    """The vectors that pin what reading the spec as a second implementer found (format.md 1, 4, 5)."""
    base = _write(fan_vanilla())
    _, voff, _ = chunk(base, L.VERT)
    out["truncated-inside-vert"] = (
        base[: voff + 40],
        "the file ends 40 bytes into VERT (file_size says 620): the end of the file is its length, so VERT is"
        " out of bounds (and not a CRC mismatch)",
    )
    out["header-size-past-file-size"] = (
        patch(base, 12, "<I", len(base) + 8) + bytes(8),
        "header_size 628, file_size 620, 628 bytes: header_size is compared with the file's length, not cut"
        " at file_size (no SWPM_HEADER_BAD_SIZE); the table then starts inside the header",
    )
    _, moff, mlen = chunk(base, L.META)
    _, loff, _ = chunk(base, L.LODS)
    gap = bytearray(base)
    gap[moff + mlen + 1] = 7  # the padding after META
    gap = bytearray(fix_crcs(gap))
    gap[loff] ^= 1  # LODS no longer matches its CRC
    out["gap-nonzero-and-crc-mismatch"] = (
        bytes(gap),
        "a non-zero byte in the gap before LODS and a flipped bit in LODS: the gap's SWPM_PADDING_NONZERO"
        " does not stop LODS's CRC check (SWPM_CHUNK_CRC_MISMATCH follows)",
    )
    out["skip-collapsed-start-not-index-start"] = (
        _write(
            fan_skip(
                buffers={
                    "level_indices": [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 0, 9],
                    "level_collapsed_start": [0, 15],
                    "level_collapsed_indices": [1, 2, 0, 2, 3, 0, 0, 1, 0, 3, 0, 0, 0, 1, 2],
                }
            )
        ),
        "level_collapsed_start differs from level_index_start and INDX holds 9: the level table by itself is"
        " a stage (a) check before the values < V and ends the checks",
    )


def relayout(data: bytes, payloads: dict[bytes, bytes]) -> bytes:
    """``data`` with the payloads of the chunks named in ``payloads`` replaced, every chunk laid out again in
    table order (8-byte aligned), file_size and CRCs recomputed (SMAP's ranges are not rewritten)."""
    ents = _entries(data)
    out = bytearray(data[: struct.unpack_from("<Q", data, 32)[0] + 32 * len(ents)])
    for t, eo, off, ln in ents:
        body = payloads.get(t, data[off : off + ln])
        out += bytes(L.align(len(out), L.CHUNK_ALIGN) - len(out))
        struct.pack_into("<QQ", out, eo + 8, len(out), len(body))
        out += body
    struct.pack_into("<Q", out, 40, len(out))
    return fix_crcs(out)


def _blind_valid() -> dict[str, tuple[bytes, str]]:
    """Valid files (warnings) that pin what a blind reader of the spec had to guess (format.md 2.1, 3.3, 3.7,
    4)."""
    base = _write(fan_vanilla())
    eo, _, _ = chunk(base, L.INDX)
    reserved = patch(base, 28, "<I", 1, crc=False)
    reserved = patch(reserved, 56, "<I", 2, crc=False)
    reserved = patch(reserved, eo + 28, "<I", 3)
    nan = FAN_POINTS.copy()
    nan[3, 1] = np.nan
    list_restart = fan_skip()
    list_restart.params["restart_index"] = 2
    _, _, vlen = chunk(base, L.VERT)

    def split_hull(offs: dict[bytes, int] | None) -> int | bytes:
        # the (a) hull [0, INDX) given as two ranges that abut at 64: no one range holds it
        if offs is None:
            return L.SMAP_HEADER.itemsize + L.SMAP_BAND.itemsize + L.SMAP_RANGE.itemsize * 4
        indx, vert = offs[L.INDX], offs[L.VERT]
        ranges = [(0, 64), (64, indx - 64), (indx, 24), (vert, vlen)]
        return smap_bytes([(0, 2, 0, 4, vert + vlen)], ranges)

    return {
        "reserved-fields-nonzero": (
            reserved,
            "header reserved0 = 1, reserved1's second word = 2, INDX's entry reserved = 3: three"
            " SWPM_HEADER_RESERVED_NONZERO warnings (one for the three words at 52), the file stays valid",
        ),
        "vert-nonfinite-point": (
            _write(fan_vanilla(points=nan)),
            "vertex 3's y is NaN: SWPM_VERT_NONFINITE, a warning at the first vertex record, not at vertex 3",
        ),
        "skip-list-restart-below-vertex-count": (
            _write(list_restart),
            "skip-strip lists with params.restart_index 2, a vertex: lists ignore it (only a strips' restart"
            " index below V is rejected) and LODS counts the triangles that hold vertex 2",
        ),
        "smap-hull-split-across-ranges": (
            with_smap(base, split_hull),
            "SMAP's band covers the bytes before INDX with two ranges that abut: each hull must lie inside"
            " one range (SWPM_SMAP_INVALID at band 0)",
        ),
    }


def _blind_invalid(out: dict[str, tuple[bytes, str]]) -> None:
    """The vectors that pin what a blind reader of the spec had to guess, and rules no vector checked
    (format.md 2.1-2.3, 3.1, 3.2, 3.5, 3.6, 3.8, 5)."""
    base = _write(fan_vanilla())
    ents = {t: (eo, off, ln) for t, eo, off, ln in _entries(base)}
    out["table-too-large"] = (
        patch(base, 24, "<I", 1025, crc=False),
        "chunk_count 1025: SWPM_TABLE_TOO_LARGE (the limit is 1024) ends the checks, before the table's end"
        " and the file CRC (left as it was) are checked",
    )
    out["header-size-below-64"] = (
        patch(base, 12, "<I", 60),
        "header_size 60: SWPM_HEADER_BAD_SIZE ends the checks",
    )
    dup = bytearray(out["duplicate-meta-misplaced"][0])
    struct.pack_into("<I", dup, 20, L.FEATURE_VANILLA | L.FEATURE_SLIDING_WINDOW)
    out["two-encodings-and-duplicate"] = (
        fix_crcs(dup),
        "two encoding bits and a second META: the duplicate is still reported, but with no encoding neither"
        " SWPM_CHUNK_MISSING nor SWPM_STREAM_ORDER is checked",
    )
    leo, loff, _ = ents[L.LODS]
    out["chunk-misaligned"] = (
        patch(base, leo + 8, "<Q", loff - 4),
        "LODS's offset moved 4 bytes back, into META's padding: misaligned (its CRC is then not checked), and"
        " the gap after it holds LODS's last 4 bytes",
    )
    swapped = bytearray(base)
    (reo, _, _), (veo, _, _) = ents[L.RCNT], ents[L.VREC]
    swapped[reo : reo + 32], swapped[veo : veo + 32] = base[veo : veo + 32], base[reo : reo + 32]
    out["chunks-out-of-order"] = (
        fix_crcs(swapped),
        "the RCNT and VREC entries swapped in the table, payloads unmoved: RCNT's entry is out of order, and"
        " VREC listed before RCNT is out of streaming order",
    )
    missing = bytearray(base)
    missing[reo : reo + 8] = b"zXTR" + bytes(4)
    out["chunk-missing"] = (
        fix_crcs(missing),
        "RCNT's entry renamed zXTR, ancillary: an unknown ancillary chunk, and RCNT is missing (offset null)",
    )
    out["chunk-not-allowed"] = (
        _write(fan_vanilla(), extra_chunks=[(L.WREC, True, bytes(12))]),
        "a sliding-window WREC chunk in a vanilla file",
    )
    seo, _, _ = ents[L.SMAP]
    out["chunk-bad-flags"] = (
        patch(base, seo + 4, "<I", L.CHUNK_CRITICAL),
        "SMAP marked critical: SWPM_CHUNK_BAD_FLAGS at its flags field",
    )
    out["lods-empty"] = (
        relayout(base, {L.LODS: b""}),
        "LODS of 0 bytes: SWPM_LOD_EMPTY; no encoding check runs",
    )
    out["lods-row0-not-vertex-count"] = (
        _write(fan_vanilla(vertex_counts=np.array([6, 4]))),
        "LODS row 0 says 6 vertices, VERT holds 5: reported in step 3 and again, at the same offset, by the"
        " vanilla check of LODS against RCNT (stage b)",
    )
    out["window-count-mismatch"] = (
        _write(fan_sliding(buffers={"window_records": [[0, 4, 5], [12, 2, 3]]})),
        "the coarse window says 3 vertices, LODS 4: SWPM_WINDOW_COUNT_MISMATCH at its vertex_count field (its"
        " prefix violation, vertex 3, is a stage (b) check that then does not run)",
    )
    out["vanilla-binned-vertex-left"] = (
        _write(fan_vanilla(buffers={"collapse_change_count": [1], "collapse_change_offsets": [2]})),
        "the collapse changes slot 2 only: vertex 4 stays in slot 5 of a live triangle, found by the replay"
        " (SWPM_PREFIX_VIOLATION at the record's row)",
    )
    enc = _write(fan_vanilla(buffers={"collapse_kept": [4]}))
    enc = enc.replace(b'"encoding":"vanilla",', b'"encoding":"mixed"  ,')
    out["meta-encoding-differs"] = (
        fix_crcs(enc),
        "META's encoding is mixed in a vanilla file and the record keeps its binned vertex: the field is"
        " reported and the encoding's checks still run",
    )
    params = _write(fan_vanilla(buffers={"collapse_kept": [4]})).replace(b'"params":{}', b'"params":[]')
    out["meta-params-not-object"] = (
        fix_crcs(params),
        "META's params is an array and the record keeps its binned vertex: SWPM_META_BAD_FIELD ends the"
        " checks of META and the encoding's checks do not run (no SWPM_RECORD_BAD_KEPT)",
    )
    out["skip-counts-and-level-table"] = (
        _write(fan_skip(buffers={"collapse_prev_change_count": [1], "level_first_lod": [1]})),
        "a wrong prev_change_count and level_first_lod not 0: a problem of the counts of 3.6 does not end"
        " skip-strip stage (a), the level table is still checked",
    )
    out["mixed-two-bad-level-arrays"] = (
        _write(fan_mixed(buffers={"level_static_start": [0, 9], "level_record_start": [0, 2]})),
        "level_static_start and level_record_start both bad: one SWPM_MIXED_BAD_LEVELS, at the last bad array"
        " in the order static, dynamic, record",
    )
    out["mixed-removes-too-many"] = (
        _write(fan_mixed(buffers={"collapse_static_tris_removed": [3]}, triangle_counts=np.array([4, 1]))),
        "the mixed record removes 3 static triangles from a static list of 2: SWPM_RECORD_BAD_COUNTS at"
        " record 0's static_tris_removed",
    )


def _ranges_invalid(base: bytes, out: dict[str, tuple[bytes, str]]) -> None:
    """Invalid files that range cases need (format.md 4.2): a file_size below the header, a two-LOD level
    whose list breaks its first LOD's vertex count."""
    out["file-size-below-header"] = (
        patch(base, 40, "<Q", 40),
        "minimal-vanilla with file_size 40, below the 64-byte header: SWPM_FILE_TRAILING_BYTES (a warning)"
        " and the chunk table past the end of the file, SWPM_TABLE_TRUNCATED; a range reader holding the"
        " header reports the same (range case file-size-below-header-header-only), not the caller's error",
    )
    out["skip-strip-level-of-two-lods-prefix-violation"] = (
        _write(fan_skip_level_of_two_lods([1, 2, 0, 2, 4, 0])),
        "skip-strip-level-of-two-lods with level 1's list 1 2 0 2 4 0: vertex 4 is not below its first LOD's"
        " 4 vertices, SWPM_PREFIX_VIOLATION at that element (range case"
        " skip-strip-level-of-two-lods-prefix-violation-level-1: found at once from that list's range)",
    )
    out["mixed-two-levels-prefix-violation"] = (
        _write(fan_mixed_two_levels([2, 4, 0])),
        "mixed-two-levels with level 1's static triangle 2 4 0: vertex 4 is not below its level's first"
        " LOD's 4 vertices, SWPM_PREFIX_VIOLATION at that element (range case"
        " mixed-two-levels-prefix-violation-level-1: found at once from that list's range)",
    )


def _prefix_valid() -> dict[str, tuple[bytes, str]]:
    """Valid files that prefix cases need (format.md 4.1): a long header, an SMAP of two bands."""
    return {
        "long-header": (
            long_header(fan_vanilla(), 64),
            "header_size 128 (bytes 64..128 are 0x5A, skipped by a reader), table_offset 128: a prefix"
            " reader waits for header_size bytes (prefix case long-header-at-100)",
        ),
        "smap-two-bands": (
            _write(quad_sliding_empty_windows()),
            "sliding window, LODs of 4, 3 and 2 vertices in two SMAP bands (LODs 0-1, LOD 2) whose"
            " prefix_length is the prefix the band's finest LOD needs (format.md 4.1)",
        ),
    }


def _ranges_valid() -> dict[str, tuple[bytes, str]]:
    """Valid files that range cases need (format.md 4.2): LODs whose INDX elements lie apart."""
    return {
        "sliding-window-three-lods": (
            _write(fan_sliding_three_lods()),
            "sliding window of three LODs (5, 4 and 3 vertices) with disjoint windows: held ranges can draw"
            " LODs 0 and 2 and not LOD 1 (range case sliding-window-three-lods-not-lod-1)",
        ),
        "vanilla-tables-after-indx": (
            reorder(_write(fan_vanilla()), [0, 1, 5, 4, 3, 2, 6]),
            "minimal-vanilla laid out META LODS INDX VREC RCNT SMAP VERT (valid, SWPM_STREAM_ORDER): VREC,"
            " RCNT and SMAP lie after INDX, outside (a) of format.md 4 (range cases"
            " vanilla-tables-after-indx-tables-not-held, vanilla-tables-after-indx-smap-not-held)",
        ),
        "skip-strip-two-levels": (
            _write(fan_skip_two_levels()),
            "skip-strip list of two levels (LODs 0-1, LOD 2): a range reader checks level 0's list, held"
            " alone, against LOD 0's vertex count for LOD 1 too (range case skip-strip-two-levels-level-0)",
        ),
        "skip-strip-level-of-two-lods": (
            _write(fan_skip_level_of_two_lods()),
            "skip-strip list of two levels (LOD 0, LODs 1-2): level 1's list names vertex 3, below LOD 1's 4"
            " vertices, not LOD 2's 3: a range reader checks LOD 2's elements against LOD 1's count (range"
            " case skip-strip-level-of-two-lods-level-1)",
        ),
        "mixed-two-levels": (
            _write(fan_mixed_two_levels()),
            "mixed, two levels (LOD 0, LODs 1-2): level 1's static list names vertex 3, below LOD 1's 4"
            " vertices, not LOD 2's 3 (range cases mixed-two-levels-*)",
        ),
    }


def _prefix_cases(files: Mapping[str, bytes]) -> dict[str, list[tuple[str, int, str]]]:
    """Per vector, its prefix cases (format.md 4.1): (name, prefix length n, description), one or more per
    rule of 4.1."""

    def at(name: str, t: bytes) -> tuple[int, int, int]:
        eo, off, ln = chunk(files[name], t)
        return eo, off, ln

    def records(name: str) -> int:  # the offset of VERT's first vertex record
        _, vo, _ = at(name, L.VERT)
        return vo + struct.unpack_from("<I", files[name], vo + 12)[0]

    def needed(name: str, lod: int) -> int:
        data = files[name]
        _, vo, _ = at(name, L.VERT)
        _, lo, _ = at(name, L.LODS)
        return (
            records(name)
            + struct.unpack_from("<I", data, lo + 12 * lod)[0] * struct.unpack_from("<I", data, vo + 8)[0]
        )

    mv, table_end = "minimal-vanilla", 64 + 32 * struct.unpack_from("<I", files["minimal-vanilla"], 24)[0]
    _, moff, mlen = at("gap-nonzero-and-crc-mismatch", L.META)
    return {
        "bad-magic": [
            (
                "bad-magic-at-7",
                7,
                "7 bytes: the magic cannot be checked yet, SWPM_PREFIX_TOO_SHORT needing 64",
            ),
            ("bad-magic-at-8", 8, "8 bytes of another magic: SWPM_HEADER_BAD_MAGIC, an error of the file"),
        ],
        mv: [
            ("minimal-vanilla-at-63", 63, "n < 64: SWPM_PREFIX_TOO_SHORT at 63 needing 64"),
            (
                "minimal-vanilla-at-table-end-minus-1",
                table_end - 1,
                "the chunk table ends one byte past n: SWPM_PREFIX_TOO_SHORT needing the table's end",
            ),
            (
                "minimal-vanilla-at-table-end",
                table_end,
                "the header and the table only: every payload CRC and padding byte waits, the prefix needs"
                " every byte before VERT's records",
            ),
            (
                "minimal-vanilla-at-records-minus-1",
                records(mv) - 1,
                "one byte before VERT's first vertex record: SWPM_PREFIX_TOO_SHORT needing that byte",
            ),
            (
                "minimal-vanilla-at-records",
                records(mv),
                "exactly every byte before VERT's records: opens, no LOD drawable yet",
            ),
            (
                "minimal-vanilla-mid-record",
                needed(mv, 1) + 2,
                "two bytes into vertex 4's record: LOD 1 (4 vertices) drawable, LOD 0 not",
            ),
            ("minimal-vanilla-whole", len(files[mv]), "n = file_size: the whole file, every LOD drawable"),
        ],
        "attributes": [
            (
                "attributes-at-vert-header",
                at("attributes", L.VERT)[1] + 8,
                "VERT's 16-byte header is cut: SWPM_PREFIX_TOO_SHORT needing the header (data_offset is in"
                " it)",
            ),
            (
                "attributes-mid-record",
                needed("attributes", 1) + 1,
                "LOD 1 drawable with its points and attributes (normal, uv, color)",
            ),
        ],
        "long-header": [
            ("long-header-at-100", 100, "header_size 128 past n = 100: SWPM_PREFIX_TOO_SHORT needing 128"),
        ],
        "smap-empty-index-hull": [
            (
                "smap-empty-index-hull-not-streamable",
                at("smap-empty-index-hull", L.VERT)[1] + 16,
                "INDX is the last table entry: SWPM_PREFIX_NOT_STREAMABLE at that entry (the whole file is"
                " valid, with SWPM_STREAM_ORDER)",
            ),
        ],
        "smap-two-bands": [
            (
                "smap-two-bands-band-1",
                needed("smap-two-bands", 2),
                "band 1's prefix_length = needed(2): LOD 2 drawable",
            ),
            (
                "smap-two-bands-band-1-minus-1",
                needed("smap-two-bands", 2) - 1,
                "one byte short of band 1's prefix_length: opens, no LOD drawable",
            ),
            ("smap-two-bands-lod-1", needed("smap-two-bands", 1), "needed(1), inside band 0: LOD 1 drawable"),
        ],
        "gap-nonzero-and-crc-mismatch": [
            (
                "gap-nonzero-and-crc-mismatch-at-records",
                records("gap-nonzero-and-crc-mismatch"),
                "the padding and LODS's CRC lie before n: both errors found at once, as in the whole file",
            ),
            (
                "gap-nonzero-and-crc-mismatch-deferred",
                moff + mlen + 1,
                "n ends just before the non-zero padding byte, LODS past n: both wait for the file, the"
                " prefix needs every byte before VERT's records",
            ),
        ],
        "crc-mismatch": [
            (
                "crc-mismatch-vert-deferred",
                len(files["crc-mismatch"]) - 1,
                "VERT's CRC waits for the file: the prefix opens (LOD 1 drawable) and finishing rejects it",
            ),
        ],
        "vert-nonfinite-point": [
            (
                "vert-nonfinite-point-deferred",
                needed("vert-nonfinite-point", 1),
                "LOD 1 drawable, its vertex 3 NaN: SWPM_VERT_NONFINITE waits for the file",
            ),
        ],
        "truncated-inside-vert": [
            (
                "truncated-inside-vert-whole",
                len(files["truncated-inside-vert"]),
                "every byte there is, fewer than file_size: the prefix opens, finishing reports"
                " SWPM_FILE_SIZE_MISMATCH",
            ),
        ],
        "index-above-vertex-count": [
            (
                "index-above-vertex-count-at-records",
                records("index-above-vertex-count"),
                "steps 3-5 of format.md 5 run on the prefix: the encoding's error is found at once",
            ),
        ],
    }


def _smap_band_ranges(data: bytes, band: int) -> list[tuple[int, int]]:
    """The (offset, length) ranges SMAP names for band ``band`` (format.md 4), empty ones included."""
    _, off, _ = chunk(data, L.SMAP)
    B = struct.unpack_from("<I", data, off)[0]
    _, _, rs, rn, _ = struct.unpack_from("<IIIIQ", data, off + 8 + 24 * band)
    return [struct.unpack_from("<QQ", data, off + 8 + 24 * B + 16 * i) for i in range(rs, rs + rn)]


def _ranges_cases(files: Mapping[str, bytes]) -> dict[str, list[tuple[str, list[tuple[int, int]], str]]]:
    """Per vector, its range cases (format.md 4.2): (name, held ranges (offset, length), description), one
    or more per rule of 4.2."""

    def at(name: str, t: bytes) -> tuple[int, int]:
        _, off, ln = chunk(files[name], t)
        return off, ln

    def rec(name: str, count: int) -> tuple[int, int]:  # VERT's header and its first ``count`` records
        vo, _ = at(name, L.VERT)
        data_offset, stride = (struct.unpack_from("<I", files[name], vo + x)[0] for x in (12, 8))
        return vo, data_offset + count * stride

    mv, data = "minimal-vanilla", files["minimal-vanilla"]
    table_end = 64 + 32 * struct.unpack_from("<I", data, 24)[0]
    io, il = at(mv, L.INDX)
    vo, vl = at(mv, L.VERT)
    gap = "gap-nonzero-and-crc-mismatch"
    g = at(gap, L.META)[0] + at(gap, L.META)[1] + 1  # the non-zero padding byte
    wp, wio = "window-prefix-violation", at("window-prefix-violation", L.INDX)[0]
    s3, s3io = "sliding-window-three-lods", at("sliding-window-three-lods", L.INDX)[0]
    k2, k2io = "skip-strip-two-levels", at("skip-strip-two-levels", L.INDX)[0]
    k2v, k2vio = (
        "skip-strip-two-levels-prefix-violation",
        at("skip-strip-two-levels-prefix-violation", L.INDX)[0],
    )
    tb = "smap-two-bands"
    band0 = _smap_band_ranges(files[tb], 0)
    long_len = len(files["long-header"])
    long_table = 128 + 32 * struct.unpack_from("<I", files["long-header"], 24)[0]
    crc_bad = 564  # (the byte crc-mismatch flips: vertex 0's record)
    late = "vanilla-tables-after-indx"
    k2c = "skip-strip-two-levels-collapsed-prefix"
    sk, skio = "skip-strip-level-of-two-lods", at("skip-strip-level-of-two-lods", L.INDX)[0]
    mx, mxio = "mixed-two-levels", at("mixed-two-levels", L.INDX)[0]
    skv = "skip-strip-level-of-two-lods-prefix-violation"
    skvio = at(skv, L.INDX)[0]
    mxv, mxvio = "mixed-two-levels-prefix-violation", at("mixed-two-levels-prefix-violation", L.INDX)[0]
    return {
        mv: [
            (
                "minimal-vanilla-header-part",
                [(0, 40)],
                "40 header bytes: SWPM_RANGES_NOT_HELD at 40, [0, 64)",
            ),
            (
                "minimal-vanilla-header-only",
                [(0, 64)],
                "the header alone: the chunk table is needed, SWPM_RANGES_NOT_HELD at 64 with [0, table end)",
            ),
            (
                "minimal-vanilla-table-only",
                [(0, table_end)],
                "the header and the chunk table: every CRC and padding byte waits, then every byte before"
                " INDX is needed",
            ),
            (
                "minimal-vanilla-before-indx",
                [(0, io)],
                "every byte before INDX: VERT's 16-byte header is needed ([o, o + 16): data_offset is in it)",
            ),
            (
                "minimal-vanilla-no-indx",
                [(0, io), (vo, vl)],
                "all but INDX: opens (INDX's CRC and content wait); vanilla draws from all of INDX, so no"
                " LOD",
            ),
            (
                "minimal-vanilla-smap-band-0",
                _smap_band_ranges(data, 0),
                "SMAP's band 0 ranges, abutting: every byte is held, the file is read as format.md 5 reads"
                " it",
            ),
            (
                "minimal-vanilla-unsorted-overlapping",
                [(vo, 16 + 4 * 12), (300, io + il - 300), (0, 400)],
                "ranges unsorted, overlapping and abutting (held(a, b) asks only whether every byte is held):"
                " LOD 1 drawable, not LOD 0 (vertex 4's record is not held)",
            ),
        ],
        "bad-magic": [
            (
                "bad-magic-first-8",
                [(0, 8)],
                "the first 8 bytes held and another magic: SWPM_HEADER_BAD_MAGIC",
            ),
        ],
        "long-header": [
            (
                "long-header-first-64",
                [(0, 64)],
                "header_size 128 past the last byte held: SWPM_RANGES_NOT_HELD at 64 needing [0, 128)",
            ),
            (
                "long-header-skipped-bytes-not-held",
                [(0, 64), (128, long_len - 128)],
                "all but header bytes 64..128: the chunk table's check needs [0, table end), which file_crc"
                f" covers (SWPM_RANGES_NOT_HELD at 64 with [0, {long_table}))",
            ),
        ],
        gap: [
            (
                "gap-nonzero-and-crc-mismatch-padding-held",
                [(0, table_end), (g, 1)],
                "the non-zero padding byte held: SWPM_PADDING_NONZERO at once; LODS not held, its CRC waits",
            ),
            (
                "gap-nonzero-and-crc-mismatch-crc-held",
                [(0, g), (g + 1, len(files[gap]) - g - 1)],
                "all but the non-zero padding byte: LODS wholly held, SWPM_CHUNK_CRC_MISMATCH at once; the"
                " padding byte waits",
            ),
            (
                "gap-nonzero-and-crc-mismatch-deferred",
                [(0, g)],
                "up to the padding byte: both faults wait, and every byte before INDX is needed",
            ),
        ],
        "crc-mismatch": [
            (
                "crc-mismatch-vert-held",
                [(0, io), (vo, vl)],
                "VERT wholly held with its flipped bit: SWPM_CHUNK_CRC_MISMATCH at once",
            ),
            (
                "crc-mismatch-vert-part",
                [(0, crc_bad + 8)],
                "VERT held up to just past its flipped bit: its CRC waits, the ranges open (no LOD drawable)"
                " and finishing rejects the file",
            ),
        ],
        "index-above-vertex-count": [
            (
                "index-above-vertex-count-indx-held",
                [(0, io + il), rec("index-above-vertex-count", 0)],
                "INDX wholly held: the encoding's checks read it, SWPM_INDEX_OUT_OF_RANGE at once",
            ),
            (
                "index-above-vertex-count-indx-not-held",
                [(0, io), (vo, vl)],
                "INDX not held: its values wait for the whole file (finishing: SWPM_INDEX_OUT_OF_RANGE)",
            ),
        ],
        wp: [
            (
                "window-prefix-violation-window-1",
                [(0, wio), (wio + 24, 12), rec(wp, 4)],
                "window 1 held (INDX partly): its vertex 4 is not below LOD 1's 4 vertices,"
                " SWPM_PREFIX_VIOLATION at once",
            ),
            (
                "window-prefix-violation-window-0",
                [(0, wio), (wio, 24), rec(wp, 5)],
                "window 0 held, not window 1: LOD 0 drawable; the violation waits (finishing rejects)",
            ),
        ],
        tb: [
            ("smap-two-bands-ranges-band-0", band0, "SMAP's band 0 ranges: LODs 0-2 drawable"),
            (
                "smap-two-bands-ranges-band-1",
                _smap_band_ranges(files[tb], 1),
                "SMAP's band 1 ranges (its INDX range empty): LOD 2 drawable, not LOD 1 (3 vertices)",
            ),
            (
                "smap-two-bands-band-0-last-dropped",
                band0[:-1],
                "band 0's ranges but VERT's: SWPM_RANGES_NOT_HELD at VERT's offset, [o, o + 16)",
            ),
            (
                "smap-two-bands-band-0-window-dropped",
                [band0[0], band0[2]],
                "band 0's ranges but its INDX range: LOD 0 not drawable, LODs 1 and 2 (empty windows) are",
            ),
        ],
        s3: [
            (
                "sliding-window-three-lods-not-lod-1",
                [(0, s3io), (s3io, 24), (s3io + 36, 6), rec(s3, 5)],
                "windows 0 and 2 held, not window 1: LODs 0 and 2 drawable, not LOD 1 (not consecutive)",
            ),
        ],
        k2: [
            (
                "skip-strip-two-levels-level-0",
                [(0, k2io), (k2io, 24), rec(k2, 5)],
                "level 0's list held, not level 1's: LODs 0 and 1 drawable; LOD 1's elements are checked"
                " against LOD 0's 5 vertices (its level's first LOD), so vertex 4 there is no violation",
            ),
        ],
        k2c: [
            (
                "skip-strip-two-levels-collapsed-prefix-no-indx",
                [(0, at(k2c, L.INDX)[0]), rec(k2c, 5)],
                "all but INDX: the replay and the collapsed lists' prefix (stage (d), though the prefix"
                " check reads SKIP only) wait; the ranges open and finishing rejects the file",
            ),
        ],
        k2v: [
            (
                "skip-strip-two-levels-prefix-violation-level-1",
                [(0, k2vio), (k2vio + 24, 6), rec(k2v, 3)],
                "level 1's list held: its vertex 3 is not below LOD 2's 3 vertices, SWPM_PREFIX_VIOLATION"
                " at once",
            ),
            (
                "skip-strip-two-levels-prefix-violation-level-0",
                [(0, k2vio), (k2vio, 24), rec(k2v, 5)],
                "level 0's list held, not level 1's: LODs 0 and 1 drawable; finishing rejects the file",
            ),
        ],
        "vanilla-tables-after-indx": [
            (
                "vanilla-tables-after-indx-tables-not-held",
                [(0, at(late, L.INDX)[0]), at(late, L.VERT)],
                "VREC and RCNT, after INDX, not held: the encoding's checks decode them, SWPM_RANGES_NOT_HELD"
                " with RCNT's payload range (the first in format.md 2.3's order, though listed after VREC)",
            ),
            (
                "vanilla-tables-after-indx-smap-not-held",
                [(0, at(late, L.INDX)[0]), at(late, L.VREC), at(late, L.RCNT), at(late, L.VERT)],
                "SMAP, after INDX, not held: ancillary, it is not checked (no SWPM_SMAP_INVALID); the ranges"
                " open, no LOD drawable (INDX not held)",
            ),
        ],
        "mixed": [
            (
                "mixed-no-indx",
                [(0, at("mixed", L.INDX)[0]), at("mixed", L.VERT)],
                "all but INDX (the static lists): opens; the dynamic lists' checks run, no LOD drawable",
            ),
        ],
        "file-size-below-header": [
            (
                "file-size-below-header-header-part",
                [(0, 40)],
                "file_size 40 and 40 header bytes held: the header is needed, SWPM_RANGES_NOT_HELD at 40 with"
                " [0, 64)",
            ),
            (
                "file-size-below-header-header-only",
                [(0, 64)],
                "the header, past its file_size 40: the file's error as format.md 5 reports it"
                " (SWPM_FILE_TRAILING_BYTES, SWPM_TABLE_TRUNCATED), not the caller's",
            ),
            (
                "file-size-below-header-header-and-table",
                [(0, table_end), (io, il)],
                "the header, the chunk table and INDX: the same two problems (nothing past the header is"
                " read)",
            ),
        ],
        sk: [
            (
                "skip-strip-level-of-two-lods-level-1",
                [(0, skio), (skio + 24, 12), rec(sk, 4)],
                "level 1's list held (LODs 1-2), not level 0's: LODs 1 and 2 drawable; LOD 2's elements are"
                " checked against LOD 1's 4 vertices (its level's first LOD), so vertex 3 is no violation",
            ),
            (
                "skip-strip-level-of-two-lods-level-0",
                [(0, skio), (skio, 24), rec(sk, 5)],
                "level 0's list held, not level 1's: LOD 0 drawable only",
            ),
        ],
        mx: [
            (
                "mixed-two-levels-level-1",
                [(0, mxio), (mxio + 12, 6), rec(mx, 4)],
                "level 1's static list held, not level 0's: LODs 1 and 2 drawable (their dynamic lists are in"
                " MLVL, before INDX); vertex 3 is checked against LOD 1's 4 vertices, no violation",
            ),
            (
                "mixed-two-levels-level-0",
                [(0, mxio), (mxio, 12), rec(mx, 5)],
                "level 0's static list held, not level 1's: LOD 0 drawable only",
            ),
            (
                "mixed-two-levels-no-indx",
                [(0, mxio), at(mx, L.VERT)],
                "all but INDX: opens (the dynamic lists and the level table are checked at once), no LOD"
                " drawable",
            ),
            (
                "mixed-two-levels-smap-band-0",
                _smap_band_ranges(files[mx], 0),
                "SMAP's one band: every byte is held, read as format.md 5 reads the file, every LOD drawable",
            ),
        ],
        skv: [
            (
                "skip-strip-level-of-two-lods-prefix-violation-level-1",
                [(0, skvio), (skvio + 24, 12), rec(skv, 4)],
                "level 1's list held (LODs 1-2): its vertex 4 is not below LOD 1's 4 vertices,"
                " SWPM_PREFIX_VIOLATION at once (the whole file's error too)",
            ),
            (
                "skip-strip-level-of-two-lods-prefix-violation-level-0",
                [(0, skvio), (skvio, 24), rec(skv, 5)],
                "level 0's list held, not level 1's: LOD 0 drawable; finishing rejects the file",
            ),
        ],
        mxv: [
            (
                "mixed-two-levels-prefix-violation-level-1",
                [(0, mxvio), (mxvio + 12, 6), rec(mxv, 4)],
                "level 1's static list held: its vertex 4 is not below LOD 1's 4 vertices,"
                " SWPM_PREFIX_VIOLATION at once (the whole file's error too)",
            ),
            (
                "mixed-two-levels-prefix-violation-level-0",
                [(0, mxvio), (mxvio, 12), rec(mxv, 5)],
                "level 0's static list held, not level 1's: LOD 0 drawable; finishing rejects the file",
            ),
        ],
        "truncated-inside-vert": [
            (
                "truncated-inside-vert-all-there-is",
                [(0, len(files["truncated-inside-vert"]))],
                "every byte there is, fewer than file_size: opens; finishing reports SWPM_FILE_SIZE_MISMATCH",
            ),
        ],
        "vert-nonfinite-point": [
            (
                "vert-nonfinite-point-deferred",
                [(0, vo + 16 + 4 * 12)],
                "LOD 1 drawable, its vertex 3 NaN: SWPM_VERT_NONFINITE waits for the file",
            ),
            (
                "vert-nonfinite-point-every-byte",
                [(0, len(files["vert-nonfinite-point"]))],
                "every byte: read as format.md 5 reads the file, SWPM_VERT_NONFINITE (a warning) at once",
            ),
        ],
    }


def prefix_result(data: bytes) -> dict[str, Any]:
    """The verdict of a prefix reader on ``data``, a file's first n bytes (format.md 4.1): its problems (a
    SWPM_PREFIX_TOO_SHORT with ``need``, the prefix length its check needs) and, once opened, needed(k) per
    LOD, the finest drawable LOD and the SHA-256 of its points and attributes."""
    rep = validate_prefix(data)
    problems: list[dict[str, Any]] = []
    for q in rep.problems:
        problems.append({"code": q.code, "severity": q.severity, "offset": q.offset})
        if q.code == "SWPM_PREFIX_TOO_SHORT":
            problems[-1]["need"] = int(rep.summary["prefix_need"])
    out: dict[str, Any] = {"length": len(data), "opened": rep.valid, "problems": problems}
    if rep.valid:
        fp = open_prefix(data)
        out["needed"] = [fp.needed_bytes(k) for k in range(fp.lod_count)]
        k = fp.finest_drawable
        out["finest_drawable"] = k
        if k is not None:
            arrays = {
                "points": fp.lod_points(k),
                **{f"attribute:{a}": v for a, v in fp.lod_attributes(k).items()},
            }
            out["drawable"] = {
                a: {
                    "shape": list(v.shape),
                    "sha256": hashlib.sha256(np.ascontiguousarray(v).tobytes()).hexdigest(),
                }
                for a, v in sorted(arrays.items())
            }
    return out


def _digest(v: np.ndarray) -> dict[str, Any]:
    return {"shape": list(v.shape), "sha256": hashlib.sha256(np.ascontiguousarray(v).tobytes()).hexdigest()}


def ranges_result(data: bytes, ranges: list[tuple[int, int]]) -> dict[str, Any]:
    """The verdict of a range reader holding ``ranges`` ((offset, length) each) of the file ``data``
    (format.md 4.2): its problems (a SWPM_RANGES_NOT_HELD with ``need_start`` and ``need``, the range its
    check needs) and, once opened, the ranges (a), (b) and (c) each LOD needs, the drawable LODs and, per
    drawable LOD, the SHA-256 of its vertices' points and attributes and of its INDX elements
    (``indices``)."""
    held: dict[int, bytes] = {}
    for o, n in ranges:  # (two ranges at one offset: the longer holds the other)
        if n and n > len(held.get(o, b"")):
            held[o] = data[o : o + n]
    rep = validate_ranges(held)
    problems: list[dict[str, Any]] = []
    for q in rep.problems:
        problems.append({"code": q.code, "severity": q.severity, "offset": q.offset})
        if q.code == "SWPM_RANGES_NOT_HELD":
            problems[-1]["need_start"], problems[-1]["need"] = (int(x) for x in rep.summary["range_need"])
    out: dict[str, Any] = {"ranges": [list(r) for r in ranges], "opened": rep.valid, "problems": problems}
    if rep.valid:
        fr = open_ranges(held)
        out["needed"] = [[[o, o + n] for o, n in fr.needed_ranges(k)] for k in range(fr.lod_count)]
        lods = [int(k) for k in fr.drawable_lods]
        out["drawable_lods"] = lods
        out["drawable"] = {
            str(k): {
                a: _digest(v)
                for a, v in sorted(
                    {
                        "points": fr.lod_points(k),
                        **{f"attribute:{a}": v for a, v in fr.lod_attributes(k).items()},
                        "indices": fr.lod_index_elements(k),
                    }.items()
                )
            }
            for k in lods
        }
    return out


def buffer_digests(data: bytes) -> dict[str, Any]:
    """Decoded summary of a valid file: counts and the SHA-256 of each array as stored (little-endian)."""
    rep, p = _check(np.frombuffer(data, np.uint8), None)
    if not rep.valid or p is None or p.points is None or p.lods is None:
        raise ValueError(rep.format())
    arrays = {"points": p.points, **{f"attribute:{k}": v for k, v in p.attributes.items()}, **p.buffers}
    arrays["vertex_counts"] = p.lods["vertex_count"]
    arrays["triangle_counts"] = p.lods["triangle_count"]
    arrays["lod_errors"] = p.lods["error"]
    return {
        "encoding": p.encoding,
        "index_width": p.width,
        "offset_width": p.offset_width,
        "lod_count": int(p.lods.shape[0]),
        "vertex_count": int(p.points.shape[0]),
        "triangle_count": int(p.lods["triangle_count"][0]),
        "params": (p.meta or {}).get("params", {}),
        "buffers": {
            k: {
                "shape": list(v.shape),
                "sha256": hashlib.sha256(np.ascontiguousarray(v).tobytes()).hexdigest(),
            }
            for k, v in sorted(arrays.items())
        },
    }


def expected_result(data: bytes) -> dict[str, Any]:
    rep, _ = _check(np.frombuffer(data, np.uint8), None)
    out: dict[str, Any] = {
        "valid": rep.valid,
        "problems": [{"code": q.code, "severity": q.severity, "offset": q.offset} for q in rep.problems],
    }
    if rep.valid:
        out["summary"] = buffer_digests(data)
    return out


def build_all() -> dict[str, bytes]:
    """Every file of ``spec/vectors`` by name (vectors, expected results, manifest), deterministically."""
    files: dict[str, bytes] = {}
    manifest: list[dict[str, Any]] = []
    valid = _valid()
    invalid = _invalid(valid["minimal-vanilla"][0])
    for group, items in (("valid", valid), ("invalid", invalid)):
        for name, (data, desc) in items.items():
            exp = expected_result(data)
            if exp["valid"] != (group == "valid"):
                raise AssertionError(f"vector {name}: expected {group}, validator says {exp}")
            files[f"{group}/{name}.swpm"] = data
            files[f"{group}/{name}.json"] = (json.dumps(exp, indent=2, sort_keys=True) + "\n").encode()
            manifest.append(
                {
                    "name": name,
                    "file": f"{group}/{name}.swpm",
                    "expected": f"{group}/{name}.json",
                    "valid": group == "valid",
                    "description": desc,
                    "sha256": hashlib.sha256(data).hexdigest(),
                }
            )
    by_name = {**{k: v[0] for k, v in valid.items()}, **{k: v[0] for k, v in invalid.items()}}
    cases = _prefix_cases(by_name)
    for entry in manifest:
        prefixes = []
        for case, n, desc in cases.pop(entry["name"], []):
            if n > len(by_name[entry["name"]]):
                raise AssertionError(f"prefix case {case}: {n} bytes, more than the file")
            rel = f"prefix/{case}.json"
            files[rel] = (
                json.dumps(prefix_result(by_name[entry["name"]][:n]), indent=2, sort_keys=True) + "\n"
            ).encode()
            prefixes.append({"name": case, "length": n, "expected": rel, "description": desc})
        if prefixes:
            entry["prefixes"] = prefixes
    if cases:
        raise AssertionError(f"prefix cases of no vector: {sorted(cases)}")
    rcases = _ranges_cases(by_name)
    for entry in manifest:
        ranges = []
        for case, held, desc in rcases.pop(entry["name"], []):
            rel = f"ranges/{case}.json"
            files[rel] = (
                json.dumps(ranges_result(by_name[entry["name"]], held), indent=2, sort_keys=True) + "\n"
            ).encode()
            ranges.append(
                {"name": case, "ranges": [list(r) for r in held], "expected": rel, "description": desc}
            )
        if ranges:
            entry["ranges"] = ranges
    if rcases:
        raise AssertionError(f"range cases of no vector: {sorted(rcases)}")
    doc = {"format": "SWPM", "version": "1.0", "vectors": manifest}
    files["manifest.json"] = (json.dumps(doc, indent=2) + "\n").encode()
    files["minimal-vanilla.hex"] = hexdump(valid["minimal-vanilla"][0]).encode()
    return files


def hexdump(data: bytes) -> str:
    """``xxd``-style dump: offset, 16 bytes in hex, ASCII."""
    lines = []
    for i in range(0, len(data), 16):
        row = data[i : i + 16]
        hx = " ".join(row[j : j + 2].hex() for j in range(0, len(row), 2))
        asc = "".join(chr(c) if 32 <= c < 127 else "." for c in row)
        lines.append(f"{i:08x}: {hx:<39}  {asc}")
    return "\n".join(lines) + "\n"


def write_all(outdir: str | Path) -> list[Path]:
    """Write :func:`build_all` under ``outdir``."""
    outdir = Path(outdir)
    written = []
    for rel, data in build_all().items():
        path = outdir / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        written.append(path)
    return written


@dataclass
class Outcome:
    name: str
    passed: bool
    detail: str


class ConformanceManifestError(ValueError):
    """``manifest.json`` of a vector folder cannot be read or is not ``{"vectors": [...]}``."""


def run_conformance(vector_dir: str | Path) -> list[Outcome]:
    """Validate every vector of ``manifest.json`` and compare with its expected result.

    A manifest that cannot be read raises :class:`ConformanceManifestError` naming it; a vector whose entry
    or expected file is unusable (an expected result without ``valid`` and ``problems``) fails, with the
    reason, and so does one whose file's SHA-256 or validity differs from its manifest entry's."""
    from .reader import validate

    vector_dir = Path(vector_dir)
    where = vector_dir / "manifest.json"
    try:
        manifest = json.loads(where.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ConformanceManifestError(f"{where}: cannot read it: {exc}") from None
    if not isinstance(manifest, dict) or not isinstance(manifest.get("vectors"), list):
        raise ConformanceManifestError(f'{where}: not a JSON object with a "vectors" list')
    out = []
    for i, v in enumerate(manifest["vectors"]):
        name = v.get("name", f"vectors[{i}]") if isinstance(v, dict) else f"vectors[{i}]"
        try:
            exp = json.loads((vector_dir / v["expected"]).read_text(encoding="utf-8"))
            path = vector_dir / v["file"]
            if not isinstance(exp, dict):
                raise ValueError("the expected result is not a JSON object")
            for key in ("valid", "problems"):  # (spec/format.md: every expected result holds both)
                if key not in exp:
                    raise ValueError(f"the expected result has no {key!r}")
        except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError) as exc:
            what = f"no {exc} key" if isinstance(exc, KeyError) else str(exc)
            out.append(Outcome(str(name), False, f"unusable manifest entry: {what}"))
            continue
        if "valid" in v and v["valid"] != exp["valid"]:
            said, expected = json.dumps(v["valid"]), json.dumps(exp["valid"])
            detail = f"the manifest says valid {said}, the expected result {expected}"
            out.append(Outcome(str(name), False, detail))
            continue
        if "sha256" in v and path.is_file():
            digest = hashlib.sha256(path.read_bytes()).hexdigest()
            if digest != v["sha256"]:
                detail = f"sha256 of {v['file']} is {digest}, the manifest says {v['sha256']}"
                out.append(Outcome(str(name), False, detail))
                continue
        rep = validate(path)
        got = {
            "valid": rep.valid,
            "problems": [{"code": q.code, "severity": q.severity, "offset": q.offset} for q in rep.problems],
        }
        if rep.valid:
            got["summary"] = buffer_digests(path.read_bytes())
        diff = sorted(k for k in exp.keys() | got.keys() if exp.get(k) != got.get(k))  # (a key missing too)
        out.append(Outcome(v["name"], not diff, "ok" if not diff else f"differs in {', '.join(diff)}"))
        out += _run_prefixes(vector_dir, v, path)
        out += _run_ranges(vector_dir, v, path)
    return out


def _run_cases(
    vector_dir: Path,
    v: dict[str, Any],
    path: Path,
    key: str,
    kind: str,
    result: Callable[[bytes, dict], dict],
) -> list[Outcome]:
    """The cases ``v[key]`` of vector ``v``: ``result(file bytes, case)``, the reader's verdict on the part of
    the file the case holds, against the case's expected result (finishing is the vector's own verdict)."""
    out = []
    for j, case in enumerate(v.get(key, [])):
        name = f"{v['name']}/{case.get('name', f'{key}[{j}]') if isinstance(case, dict) else j}"
        try:
            exp = json.loads((vector_dir / case["expected"]).read_text(encoding="utf-8"))
            got = result(path.read_bytes(), case)
        except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError) as exc:
            what = f"no {exc} key" if isinstance(exc, KeyError) else str(exc)
            out.append(Outcome(name, False, f"unusable {kind} case: {what}"))
            continue
        diff = (
            sorted(k for k in exp.keys() | got.keys() if exp.get(k) != got.get(k))
            if isinstance(exp, dict)
            else ["all"]
        )
        out.append(Outcome(name, not diff, "ok" if not diff else f"differs in {', '.join(diff)}"))
    return out


def _run_ranges(vector_dir: Path, v: dict[str, Any], path: Path) -> list[Outcome]:
    """The range cases of vector ``v`` (format.md 4.2): the range reader's verdict on the file's held
    ranges."""
    return _run_cases(
        vector_dir,
        v,
        path,
        "ranges",
        "range",
        lambda d, c: ranges_result(d, [(int(o), int(n)) for o, n in c["ranges"]]),
    )


def _run_prefixes(vector_dir: Path, v: dict[str, Any], path: Path) -> list[Outcome]:
    """The prefix cases of vector ``v`` (format.md 4.1): the prefix reader's verdict on the file's first
    ``length`` bytes."""
    return _run_cases(
        vector_dir, v, path, "prefixes", "prefix", lambda d, c: prefix_result(d[: int(c["length"])])
    )


if __name__ == "__main__":  # pragma: no cover
    import sys

    for p in write_all(sys.argv[1] if len(sys.argv) > 1 else "spec/vectors"):
        print(p)
