"""An engine integrator's model of loading and drawing a `.swpm` file, written from `spec/format.md` alone.

It does what a C++ renderer (Vulkan / D3D12, OpenGL ES fallback) does with the file: parse the header and
chunk table, reject what a loader must reject before it trusts offsets and indices, "upload" the index pool
as the GPU takes it (u16 or u32, 4-byte aligned, primitive restart at all ones of the uploaded type), then
draw LOD k by the spec's runtime procedure: a sliding-window record look-up and one contiguous draw (Forsyth,
"Sliding Window Progressive Meshes"), or a per-instance index buffer edited by applying and undoing collapse
records (Hoppe's VIPM as Forsyth stores it; skip-strip and mixed levels of §3.7-3.8). A draw is rasterised
as the GPU would: degenerate triangles dropped, strip parity by Vulkan's rule (triangle i of a strip is
(i, i+1, i+2) for even i and (i, i+2, i+1) for odd i). It is a test model, not the product's reader: it
never imports `swpm_usd`.

Two integer types (§1): the arrays the GPU takes (`INDX`, skip-strip's collapsed lists, mixed's dynamic lists)
are `idx` (W bytes) and uploaded as they are; every table the CPU walks (windows, records, change offsets,
`RCNT`, level tables) is `off` (O bytes), u32 with `INDEX32` or `OFFSET32` (bit 6), so an `OFFSET32` file's
long pool of fewer than 65,536 vertices is a u16 buffer with restart 0xFFFF, read from the file as it is.
"""

from __future__ import annotations

import json
import math
import struct
import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

MAGIC = b"SWPM\r\n\x1a\n"
INDEX32, VANILLA, SLIDING, SKIP, MIXED, SW_STRIPS, OFFSET32 = 1, 2, 4, 8, 16, 32, 64
ENCODING_BITS = {VANILLA: "vanilla", SLIDING: "sliding-window", SKIP: "skip-strip", MIXED: "mixed"}
KNOWN_CHUNKS = {
    "META": (True, None),
    "LODS": (True, None),
    "SMAP": (False, None),
    "RCNT": (True, {"vanilla", "skip-strip", "mixed"}),
    "WREC": (True, {"sliding-window"}),
    "VREC": (True, {"vanilla"}),
    "SKIP": (True, {"skip-strip"}),
    "SREC": (True, {"skip-strip"}),
    "MLVL": (True, {"mixed"}),
    "MREC": (True, {"mixed"}),
    "INDX": (True, None),
    "VERT": (True, None),
}
STREAM_ORDER = {
    "vanilla": ["META", "LODS", "SMAP", "RCNT", "VREC", "INDX", "VERT"],
    "sliding-window": ["META", "LODS", "SMAP", "WREC", "INDX", "VERT"],
    "skip-strip": ["META", "LODS", "SMAP", "RCNT", "SKIP", "SREC", "INDX", "VERT"],
    "mixed": ["META", "LODS", "SMAP", "RCNT", "MLVL", "MREC", "INDX", "VERT"],
}
ELEM_SIZE = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 2, 8: 4, 9: 8}


class EngineLoadError(Exception):
    """The loader refused the file; ``code`` is the errors.md code of the first problem it met."""

    def __init__(self, code: str, detail: str = "") -> None:
        super().__init__(f"{code}: {detail}")
        self.code = code


class NotStreamedYet(Exception):
    """A streaming reader does not hold the bytes a draw needs yet."""


def _fail(code: str, detail: str = "") -> None:
    raise EngineLoadError("SWPM_" + code, detail)


def _align4(n: int) -> int:
    return (n + 3) & ~3


# ---------------------------------------------------------------- META JSON (§3.1)
def _json_object_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    keys = [k for k, _ in pairs]
    if len(set(keys)) != len(keys):
        raise ValueError("duplicate key")
    return dict(pairs)


def _json_float(s: str) -> float:
    v = float(s)
    if not math.isfinite(v):
        raise ValueError("number rounds to infinity")
    return v


def _json_int(s: str) -> int:
    v = int(s)
    if abs(v) >= 2**1024 - 2**970:
        raise ValueError("integer rounds to infinity")
    return v


def _depth(v: Any) -> int:
    if isinstance(v, dict):
        return 1 + max((_depth(x) for x in v.values()), default=0)
    if isinstance(v, list):
        return 1 + max((_depth(x) for x in v), default=0)
    return 0


def parse_meta(payload: bytes) -> dict[str, Any]:
    try:
        if payload.startswith(b"\xef\xbb\xbf"):
            raise ValueError("byte-order mark")
        text = payload.decode("utf-8")
        obj = json.loads(
            text,
            object_pairs_hook=_json_object_pairs,
            parse_float=_json_float,
            parse_int=_json_int,
            parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)),
        )
        if _depth(obj) > 128:
            raise ValueError("nested deeper than 128")
    except (ValueError, RecursionError) as exc:
        _fail("META_BAD_JSON", str(exc))
    if not isinstance(obj, dict):
        _fail("META_BAD_JSON", "not an object")
    return obj


def _is_u32_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and 0 <= v < 2**32


# ---------------------------------------------------------------- the file as a loader sees it
@dataclass
class Chunk:
    type: str
    flags: int
    offset: int
    length: int
    crc: int


@dataclass
class SwpmFile:
    """A parsed file: views into ``data`` (no copy), checked as far as an engine loader must.

    ``streaming=True`` accepts a prefix of the file (fewer bytes than ``file_size``): the header, table and
    every chunk but ``VERT`` must be whole (their CRCs are checked), ``VERT`` may be cut; ``vertices_present``
    says how many vertex records arrived.
    """

    data: bytes
    streaming: bool = False
    encoding: str = ""
    features: int = 0
    W: int = 2
    idx: Any = np.uint16
    O: int = 2
    off: Any = np.uint16
    chunks: dict[str, Chunk] = field(default_factory=dict)
    table: list[Chunk] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    vertex_counts: Any = None
    triangle_counts: Any = None
    lod_errors: Any = None
    V: int = 0
    stride: int = 0
    data_offset: int = 0
    vertices_present: int = 0
    points: Any = None
    arrays: dict[str, Any] = field(default_factory=dict)
    file_size: int = 0

    def __post_init__(self) -> None:
        self._parse()

    # -- helpers
    def payload(self, t: str) -> memoryview:
        c = self.chunks[t]
        return memoryview(self.data)[c.offset : c.offset + c.length]

    def _idx_array(self, t: str, start: int, count: int, table: bool = False) -> np.ndarray:
        """idx[count] (``table``: off[count]) at ``start`` in chunk ``t``'s payload, a view of the file."""
        c = self.chunks[t]
        dt = self.off if table else self.idx
        return np.frombuffer(
            self.data, dtype=np.dtype(dt).newbyteorder("<"), count=count, offset=c.offset + start
        )

    def _off_array(self, t: str, start: int, count: int) -> np.ndarray:
        return self._idx_array(t, start, count, table=True)

    @property
    def L(self) -> int:
        return len(self.vertex_counts)

    # -- §2, §5 steps 1-2
    def _parse(self) -> None:
        d = self.data
        n = len(d)
        if n < 64:
            _fail("HEADER_BAD_MAGIC" if n >= 8 and d[:8] != MAGIC else "HEADER_TRUNCATED")
        if d[:8] != MAGIC:
            _fail("HEADER_BAD_MAGIC")
        major, _minor, header_size, _flags, features, chunk_count = struct.unpack_from("<HHIIII", d, 8)
        table_offset, file_size, file_crc = struct.unpack_from("<QQI", d, 32)
        if major != 1:
            _fail("HEADER_UNSUPPORTED_MAJOR")
        if header_size < 64 or header_size > n:
            _fail("HEADER_BAD_SIZE")
        if features & ~0x7F:
            _fail("HEADER_UNKNOWN_FEATURE")
        enc = [b for b in ENCODING_BITS if features & b]
        if len(enc) != 1:
            _fail("HEADER_BAD_ENCODING")
        if features & SW_STRIPS and not features & SLIDING:
            _fail("HEADER_STRIPS_NOT_SLIDING")
        if features & OFFSET32 and features & INDEX32:
            _fail("HEADER_OFFSET32_WITH_INDEX32")
        if n < file_size and not self.streaming:
            _fail("FILE_SIZE_MISMATCH", f"file has {n} bytes, header says {file_size}")
        end = min(n, file_size) if not self.streaming else file_size
        have = min(n, file_size)
        self.file_size = file_size
        if table_offset < header_size or table_offset % 8:
            _fail("TABLE_BAD_OFFSET")
        if chunk_count > 1024:
            _fail("TABLE_TOO_LARGE")
        table_end = table_offset + 32 * chunk_count
        if table_end > have:
            _fail("TABLE_TRUNCATED")
        head = bytearray(d[:table_end])
        head[48:52] = b"\0\0\0\0"
        if zlib.crc32(head) != file_crc:
            _fail("CHECKSUM_MISMATCH")
        self.features = features
        self.encoding = ENCODING_BITS[enc[0]]
        self.W = 4 if features & INDEX32 else 2
        self.idx = np.uint32 if self.W == 4 else np.uint16
        self.O = 4 if features & (INDEX32 | OFFSET32) else 2
        self.off = np.uint32 if self.O == 4 else np.uint16
        last, stop = -1, table_end
        for i in range(chunk_count):
            t, flags, off, length, crc = struct.unpack_from("<4sIQQI", d, table_offset + 32 * i)
            if not all(chr(c).isalnum() and c < 128 for c in t):
                _fail("CHUNK_BAD_TYPE")
            ts = t.decode("ascii")
            if off + length > end:
                _fail("CHUNK_OUT_OF_BOUNDS", ts)
            if off % 8:
                _fail("CHUNK_MISALIGNED", ts)
            if off < last:
                _fail("CHUNK_OUT_OF_ORDER", ts)
            if off < stop:
                _fail("CHUNK_OVERLAP", ts)
            last, stop = off, max(stop, off + length)
            c = Chunk(ts, flags, off, length, crc)
            self.table.append(c)
            whole = off + length <= have
            if whole and zlib.crc32(d[off : off + length], zlib.crc32(t)) != crc:
                _fail("CHUNK_CRC_MISMATCH", ts)
            if not whole and ts != "VERT":
                raise NotStreamedYet(ts)
            if ts not in KNOWN_CHUNKS:
                if flags & 1:
                    _fail("CHUNK_UNKNOWN_CRITICAL", ts)
                continue
            critical, allowed = KNOWN_CHUNKS[ts]
            if bool(flags & 1) != critical:
                _fail("CHUNK_BAD_FLAGS", ts)
            if allowed is not None and self.encoding not in allowed:
                _fail("CHUNK_NOT_ALLOWED", ts)
            if ts in self.chunks:
                _fail("CHUNK_DUPLICATE", ts)
            self.chunks[ts] = c
        for ts in STREAM_ORDER[self.encoding]:
            if ts != "SMAP" and ts not in self.chunks:
                _fail("CHUNK_MISSING", ts)
        self._parse_meta_lods_vert(have)
        getattr(self, "_parse_" + self.encoding.replace("-", "_"))()

    # -- §3.1-3.3
    def _parse_meta_lods_vert(self, have: int) -> None:
        self.meta = parse_meta(bytes(self.payload("META")))
        params = self.meta.get("params", {})
        if not isinstance(params, dict):
            _fail("META_BAD_FIELD", "params")
        if "encoding" in self.meta and self.meta["encoding"] != self.encoding:
            _fail("META_BAD_FIELD", "encoding")
        self.params = params
        if self.encoding == "sliding-window":
            strips = bool(self.features & SW_STRIPS)
            prim = params.get("primitive", "list")
            ri = params.get("restart_index")
            if prim != ("strip" if strips else "list"):
                _fail("META_BAD_FIELD", "primitive")
            if not (_is_u32_int(ri) or (ri is None and not strips)):
                _fail("META_BAD_FIELD", "restart_index")
        if self.encoding == "skip-strip":
            prim = params.get("primitive", "strip")
            ri = params.get("restart_index")
            if prim not in ("strip", "list"):
                _fail("META_BAD_FIELD", "primitive")
            if not (ri is None or _is_u32_int(ri)):
                _fail("META_BAD_FIELD", "restart_index")
        lods = self.chunks["LODS"]
        if lods.length % 12:
            _fail("CHUNK_BAD_LENGTH", "LODS")
        if lods.length == 0:
            _fail("LOD_EMPTY")
        rows = np.frombuffer(self.data, dtype="<u4", count=lods.length // 4, offset=lods.offset).reshape(
            -1, 3
        )
        self.vertex_counts = rows[:, 0]
        self.triangle_counts = rows[:, 1]
        self.lod_errors = rows[:, 2].view("<f4")
        if np.any(np.diff(self.vertex_counts.astype(np.int64)) > 0) or np.any(
            np.diff(self.triangle_counts.astype(np.int64)) > 0
        ):
            _fail("LOD_NOT_MONOTONE", "counts")
        e = self.lod_errors
        if not np.all(np.isfinite(e)) or np.any(np.diff(e) < 0):
            _fail("LOD_NOT_MONOTONE", "errors")
        # VERT: its header must be here even when streaming (it is the first bytes of VERT)
        c = self.chunks["VERT"]
        avail = max(0, min(have, c.offset + c.length) - c.offset)
        if c.length < 16:
            _fail("CHUNK_BAD_LENGTH", "VERT")
        if avail < 16:
            raise NotStreamedYet("VERT header")
        V, A, stride, data_offset = struct.unpack_from("<IIII", self.data, c.offset)
        if 16 + 16 * A > c.length:
            _fail("COUNT_EXCEEDS_CHUNK", "VERT descriptors")
        if A > 255 or stride < 12 or stride % 4 or data_offset % 8 or data_offset < 16 + 16 * A:
            _fail("VERT_BAD_LAYOUT")
        if data_offset > c.length:
            _fail("VERT_BAD_LAYOUT", "data_offset past the chunk")
        if data_offset + V * stride > c.length:
            _fail("COUNT_EXCEEDS_CHUNK", "VERT records")
        if data_offset + V * stride != c.length:
            _fail("CHUNK_BAD_LENGTH", "VERT")
        if avail < data_offset:
            raise NotStreamedYet("VERT descriptors")
        spans = [(0, 12)]
        names = set()
        for a in range(A):
            no, nl, et, comp, ao, _r = struct.unpack_from("<IHBBII", self.data, c.offset + 16 + 16 * a)
            if et not in ELEM_SIZE or comp < 1 or nl < 1:
                _fail("VERT_BAD_LAYOUT", "descriptor")
            if no < 16 + 16 * A or no + nl > data_offset:
                _fail("VERT_BAD_LAYOUT", "name")
            try:
                name = bytes(self.data[c.offset + no : c.offset + no + nl]).decode("utf-8")
            except UnicodeDecodeError:
                _fail("VERT_BAD_LAYOUT", "name")
            if name in names:
                _fail("VERT_BAD_LAYOUT", "duplicate name")
            names.add(name)
            size = ELEM_SIZE[et]
            if stride % size or ao % size or ao + size * comp > stride:
                _fail("VERT_BAD_LAYOUT", "attribute offset")
            spans.append((ao, ao + size * comp))
        spans.sort()
        if any(b[0] < a[1] for a, b in zip(spans, spans[1:], strict=False)):
            _fail("VERT_BAD_LAYOUT", "overlap")
        if self.vertex_counts[0] != V:
            _fail("LOD_VERTEX_COUNT", "row 0")
        self.V, self.stride, self.data_offset = V, stride, data_offset
        self.vertices_present = min(V, (avail - data_offset) // stride)
        self.vertex_base = c.offset + data_offset
        # what the engine uploads as its vertex buffer: the records present, bound up to vertex_count(k)
        self.vertex_bytes = memoryview(self.data)[
            self.vertex_base : self.vertex_base + self.vertices_present * stride
        ]

    # -- shared record parsing (§3.6)
    def _records(self, t: str, cols: int) -> tuple[np.ndarray, np.ndarray]:
        c = self.chunks[t]
        if c.length < 8:
            _fail("CHUNK_BAD_LENGTH", t)
        R, M = struct.unpack_from("<II", self.data, c.offset)
        if 8 + cols * self.O * R > c.length:
            _fail("COUNT_EXCEEDS_CHUNK", t + " records")
        off = 8 + _align4(cols * self.O * R)
        if off + self.O * M > c.length:
            _fail("COUNT_EXCEEDS_CHUNK", t + " offsets")
        if off + self.O * M != c.length:
            _fail("CHUNK_BAD_LENGTH", t)
        rec = self._off_array(t, 8, cols * R).reshape(R, cols).astype(np.int64)
        offs = self._off_array(t, off, M).astype(np.int64)
        return rec, offs

    def _rcnt(self, R: int, cc: np.ndarray, M: int) -> np.ndarray:
        if int(cc.sum()) != M:
            _fail("RECORD_BAD_COUNTS", "change counts")
        c = self.chunks["RCNT"]
        if c.length % self.O:
            _fail("CHUNK_BAD_LENGTH", "RCNT")
        if c.length // self.O != self.L:
            _fail("CHUNK_BAD_LENGTH", "RCNT count")
        rc = self._off_array("RCNT", 0, self.L).astype(np.int64)
        if rc[0] != 0 or np.any(np.diff(rc) < 0) or rc[-1] > R:
            _fail("RECORD_BAD_COUNTS", "RCNT")
        if R and R >= self.V:
            _fail("RECORD_BAD_COUNTS", "R >= V")
        if np.any(self.vertex_counts.astype(np.int64) != self.V - rc):
            _fail("LOD_VERTEX_COUNT", "against RCNT")
        return rc

    def _indx(self, mult: int = 1) -> np.ndarray:
        c = self.chunks["INDX"]
        if c.length % (self.W * mult):
            _fail("CHUNK_BAD_LENGTH", "INDX")
        return self._idx_array("INDX", 0, c.length // self.W)

    @staticmethod
    def _check_prev(rec: np.ndarray, cc_col: int) -> None:
        cc = rec[:, cc_col]
        prev = rec[:, cc_col + 1]
        if len(rec) and (prev[0] != 0 or np.any(prev[1:] != cc[:-1])):
            _fail("RECORD_BAD_COUNTS", "prev_change_count")

    # -- §3.6 vanilla
    def _parse_vanilla(self) -> None:
        rec, offs = self._records("VREC", 4)
        indx = self._indx(3)
        self._check_prev(rec, 2)
        rc = self._rcnt(len(rec), rec[:, 2], len(offs))
        V, R, T0 = self.V, len(rec), len(indx) // 3
        if len(indx) and int(indx.max()) >= V:
            _fail("INDEX_OUT_OF_RANGE", "INDX")
        if R and np.any(rec[:, 0] >= V - 1 - np.arange(R)):
            _fail("RECORD_BAD_KEPT")
        if int(rec[:, 1].sum()) > T0 or (len(offs) and offs.max() >= 3 * T0):
            _fail("INDEX_OUT_OF_RANGE" if len(offs) and offs.max() >= 3 * T0 else "RECORD_BAD_COUNTS")
        removed = np.concatenate([[0], np.cumsum(rec[:, 1])])
        if self.triangle_counts[0] != T0 or np.any(self.triangle_counts != T0 - removed[rc]):
            _fail("RECORD_BAD_COUNTS", "LODS triangle counts")
        # replay once at load, so that no later draw reads a vertex the LOD does not bind
        _replay(indx.astype(np.int64), rec[:, 0], rec[:, 1], offs, starts_of(rec[:, 2]), V, 0, R)
        self.arrays.update(indices=indx, records=rec, change_offsets=offs, record_counts=rc)

    # -- §3.5 sliding window
    def _parse_sliding_window(self) -> None:
        strips = bool(self.features & SW_STRIPS)
        cols = 4 if strips else 3
        c = self.chunks["WREC"]
        if c.length != cols * self.O * self.L:
            _fail("CHUNK_BAD_LENGTH", "WREC")
        pool = self._indx()
        win = self._off_array("WREC", 0, cols * self.L).reshape(self.L, cols).astype(np.int64)
        restart = self.params.get("restart_index") if strips else None
        if strips and restart < self.V:
            _fail("META_BAD_FIELD", "restart index below V")
        if np.any(win[:, 1] != self.triangle_counts) or np.any(win[:, 2] != self.vertex_counts):
            _fail("WINDOW_COUNT_MISMATCH")
        if np.any(np.diff(win[:, 1]) > 0):
            _fail("WINDOW_NOT_MONOTONE")
        n_idx = win[:, 3] if strips else 3 * win[:, 1]
        if np.any(win[:, 0] + n_idx > len(pool)):
            _fail("WINDOW_OUT_OF_POOL")
        p = pool.astype(np.int64)
        is_restart = p == restart if strips else np.zeros(len(p), bool)
        if np.any((p >= self.V) & ~is_restart):
            _fail("INDEX_OUT_OF_RANGE", "INDX")
        if strips:
            f0 = win[:, 0]
            mid = (n_idx > 0) & (f0 > 0) & ~is_restart[np.maximum(f0 - 1, 0)]
            if np.any(mid):
                _fail("WINDOW_MID_STRIP", f"window {int(np.argmax(mid))}")
        wmax = range_max(np.where(is_restart, -1, p), win[:, 0], win[:, 0] + n_idx)
        if np.any(wmax >= win[:, 2]):
            _fail("PREFIX_VIOLATION", f"window {int(np.argmax(wmax >= win[:, 2]))}")
        if strips:
            # a window starts a strip: its triangles are the pool's whose last index lies inside it
            ok = np.zeros(len(p) + 1, np.int64)
            if len(p) >= 3:
                a, b, c3 = p[:-2], p[1:-1], p[2:]
                nd = (a != b) & (b != c3) & (a != c3) & ~is_restart[:-2] & ~is_restart[1:-1] & ~is_restart[2:]
                ok[3:] = np.cumsum(nd)
            lo = np.minimum(win[:, 0] + 2, win[:, 0] + n_idx)
            if np.any(ok[win[:, 0] + n_idx] - ok[lo] != win[:, 1]):
                _fail("WINDOW_STRIP_TRIANGLES")
        self.arrays.update(index_pool=pool, windows=win, window_index_counts=n_idx, restart_index=restart)

    # -- §3.7 skip-strip
    def _level_table(self, t: str, names: list[str], tail: list[str], code: str) -> tuple[dict, int]:
        c = self.chunks[t]
        if c.length < 8:
            _fail("CHUNK_BAD_LENGTH", t)
        n, C = struct.unpack_from("<II", self.data, c.offset)
        if n == 0:
            _fail(code, "no level")
        off = 8
        out: dict[str, np.ndarray] = {}
        for name in names + tail:
            count = n if name == "level_first_lod" else (n + 1 if name not in tail else C)
            # the level tables are off; the lists after them are uploaded, idx (§3.7, §3.8)
            table = name not in tail
            width = self.O if table else self.W
            if off + count * width > c.length:
                _fail("COUNT_EXCEEDS_CHUNK", f"{t} {name}")
            arr = self._idx_array(t, off, count, table)
            # tables are walked on the CPU (int64); the lists stay views of the file, uploaded as they are
            out[name] = arr.astype(np.int64) if table else arr
            end = off + count * width
            off = _align4(end)
        if c.length != end:
            _fail("CHUNK_BAD_LENGTH", t)
        return out, C

    def _parse_skip_strip(self) -> None:
        rec, offs = self._records("SREC", 4)
        lv, C = self._level_table(
            "SKIP",
            ["level_first_lod", "level_index_start", "level_collapsed_start", "level_record_start"],
            ["level_collapsed_indices"],
            "LEVEL_BAD_TABLE",
        )
        indx = self._indx()
        self._check_prev(rec, 2)
        rc = self._rcnt(len(rec), rec[:, 2], len(offs))
        V, R = self.V, len(rec)
        prim = self.params.get("primitive", "strip")
        restart = self.params.get("restart_index") if prim == "strip" else None
        if restart is not None and restart < V:
            _fail("META_BAD_FIELD", "restart index below V")
        first, ist, cst, rst = (
            lv[k]
            for k in ["level_first_lod", "level_index_start", "level_collapsed_start", "level_record_start"]
        )
        coll = lv["level_collapsed_indices"]
        n = len(first)
        if first[0] != 0 or np.any(np.diff(first) <= 0) or first[-1] >= self.L:
            _fail("LEVEL_BAD_TABLE", "level_first_lod")
        for arr, total in ((ist, len(indx)), (cst, C), (rst, R)):
            if arr[0] != 0 or np.any(np.diff(arr) < 0) or arr[-1] != total:
                _fail("LEVEL_BAD_TABLE", "start arrays")
        if np.any(cst != ist):
            _fail("LEVEL_BAD_TABLE", "collapsed start")
        if prim == "list" and np.any(np.diff(ist) % 3):
            _fail("LEVEL_BAD_TABLE", "partial triangle")
        pi, pc = indx.astype(np.int64), coll.astype(np.int64)
        for arr in (pi, pc):
            if np.any((arr >= V) & (arr != (restart if restart is not None else -1))):
                _fail("INDEX_OUT_OF_RANGE")
        if np.any(rec[:, 0] >= V) or np.any(rec[:, 1] >= V):
            _fail("INDEX_OUT_OF_RANGE", "SREC")
        if R and np.any(rec[:, 1] != V - 1 - np.arange(R)):
            _fail("RECORD_BAD_BINNED")
        if R and np.any(rec[:, 0] >= V - 1 - np.arange(R)):
            _fail("RECORD_BAD_KEPT")
        if np.any(rst[:-1] != rc[first]):
            _fail("LEVEL_BAD_TABLE", "record start vs RCNT")
        level_of_lod = np.searchsorted(first, np.arange(self.L), side="right") - 1
        starts = np.concatenate([[0], np.cumsum(rec[:, 2])])
        for l in range(n):
            lst = pi[ist[l] : ist[l + 1]].copy()
            vc = self.vertex_counts[first[l]]
            live = lst[lst != restart] if restart is not None else lst
            if len(live) and live.max() >= vc:
                _fail("PREFIX_VIOLATION", f"level {l}")
            lods = np.flatnonzero(level_of_lod == l)
            want = {}
            for k in lods:
                want.setdefault(int(rc[k]), []).append(int(k))
            tris = count_triangles(lst, restart, prim)
            for r in range(rst[l], rst[l + 1] + 1):
                for k in want.get(r, []):
                    if tris != self.triangle_counts[k]:
                        _fail("RECORD_BAD_COUNTS", f"LOD {k}")
                if r == rst[l + 1]:
                    break
                slots = offs[starts[r] : starts[r + 1]]
                if np.any(slots >= len(lst)):
                    _fail("RECORD_BAD_CHANGE", f"record {r}")
                js = _touched(slots, len(lst), prim)
                tris -= _nondegenerate_at(lst, js, restart, prim)
                for sl in slots:
                    if lst[sl] != V - 1 - r:
                        _fail("RECORD_BAD_CHANGE", f"record {r}")
                    lst[sl] = rec[r, 0]
                tris += _nondegenerate_at(lst, js, restart, prim)
            if np.any(lst != pc[cst[l] : cst[l + 1]]):
                _fail("LEVEL_BAD_TABLE", f"collapsed list of level {l}")
            live = lst[lst != restart] if restart is not None else lst
            if len(live) and live.max() >= V - rst[l + 1]:
                _fail("PREFIX_VIOLATION", f"collapsed level {l}")
        self.arrays.update(
            level_indices=indx,
            levels=lv,
            records=rec,
            change_offsets=offs,
            record_counts=rc,
            restart_index=restart,
            primitive=prim,
            level_of_lod=level_of_lod,
            record_starts=starts,
        )

    # -- §3.8 mixed
    def _parse_mixed(self) -> None:
        rec, offs = self._records("MREC", 5)
        lv, D = self._level_table(
            "MLVL",
            ["level_first_lod", "level_static_start", "level_dynamic_start", "level_record_start"],
            ["level_dynamic_indices", "level_dynamic_collapsed_indices"],
            "MIXED_BAD_LEVELS",
        )
        indx = self._indx()
        self._check_prev(rec, 3)
        rc = self._rcnt(len(rec), rec[:, 3], len(offs))
        V, R = self.V, len(rec)
        first, sst, dst, rst = (
            lv[k]
            for k in ["level_first_lod", "level_static_start", "level_dynamic_start", "level_record_start"]
        )
        dyn, dcol = lv["level_dynamic_indices"], lv["level_dynamic_collapsed_indices"]
        n = len(first)
        ok = first[0] == 0 and np.all(np.diff(first) > 0) and first[-1] < self.L
        for arr, total, m3 in ((sst, len(indx), True), (dst, D, True), (rst, R, False)):
            ok = ok and arr[0] == 0 and np.all(np.diff(arr) >= 0) and arr[-1] == total
            ok = ok and (not m3 or np.all(np.diff(arr) % 3 == 0))
        if not ok or np.any(rst[:-1] != rc[first]):
            _fail("MIXED_BAD_LEVELS")
        for arr in (indx, dyn, dcol):
            if len(arr) and int(arr.max()) >= V:
                _fail("INDEX_OUT_OF_RANGE")
        if R and np.any(rec[:, 0] >= V - 1 - np.arange(R)):
            _fail("RECORD_BAD_KEPT")
        level_of_lod = np.searchsorted(first, np.arange(self.L), side="right") - 1
        starts = np.concatenate([[0], np.cumsum(rec[:, 3])])
        for l in range(n):
            d_len, s_len = dst[l + 1] - dst[l], sst[l + 1] - sst[l]
            r0, r1 = rst[l], rst[l + 1]
            if rec[r0:r1, 1].sum() * 3 > s_len or rec[r0:r1, 2].sum() * 3 > d_len:
                _fail("RECORD_BAD_COUNTS", f"level {l} removals")
            if np.any(offs[starts[r0] : starts[r1]] >= d_len):
                _fail("INDEX_OUT_OF_RANGE", "change offsets")
        for k in range(self.L):
            l = level_of_lod[k]
            r0, r = rst[l], rc[k]
            live = (
                (sst[l + 1] - sst[l]) // 3
                + (dst[l + 1] - dst[l]) // 3
                - rec[r0:r, 1].sum()
                - rec[r0:r, 2].sum()
            )
            if live != self.triangle_counts[k]:
                _fail("RECORD_BAD_COUNTS", f"LOD {k}")
        for l in range(n):
            vc = self.vertex_counts[first[l]]
            st, dl = indx[sst[l] : sst[l + 1]], dyn[dst[l] : dst[l + 1]].astype(np.int64)
            if (len(st) and st.max() >= vc) or (len(dl) and dl.max() >= vc):
                _fail("PREFIX_VIOLATION", f"level {l}")
            r0, r1 = rst[l], rst[l + 1]
            d_live = _replay(dl, rec[:, 0], rec[:, 2], offs, starts, V, r0, r1)
            # the static list only shortens: a slot holding v must be dead once v's record is applied
            s_after = len(st) // 3 - np.cumsum(rec[r0:r1, 1])
            rv = V - 1 - st.astype(np.int64)
            inl = (rv >= r0) & (rv < r1)
            if np.any(np.flatnonzero(inl) < 3 * s_after[rv[inl] - r0]):
                _fail("PREFIX_VIOLATION", f"static list of level {l}")
            del d_live
            if np.any(dl != dcol[dst[l] : dst[l + 1]]):
                _fail("MIXED_BAD_LEVELS", f"collapsed list of level {l}")
        self.arrays.update(
            level_static_indices=indx,
            levels=lv,
            records=rec,
            change_offsets=offs,
            record_counts=rc,
            level_of_lod=level_of_lod,
            record_starts=starts,
        )

    # -- §4: what drawing LOD k needs, as file byte ranges
    def needed_ranges(self, k: int) -> tuple[tuple[int, int], tuple[int, int] | None, tuple[int, int]]:
        """Byte ranges [start, end) LOD k needs: (a) all before INDX, (b) its INDX elements (None: none),
        (c) VERT up to its vertex records."""
        ic, vc = self.chunks["INDX"], self.chunks["VERT"]
        a = self.arrays
        if self.encoding == "vanilla":
            b = (0, ic.length)
        elif self.encoding == "sliding-window":
            first = int(a["windows"][k, 0])
            b = (first * self.W, (first + int(a["window_index_counts"][k])) * self.W)
        else:
            lv = a["levels"]
            st = lv["level_index_start" if self.encoding == "skip-strip" else "level_static_start"]
            lvl = a["level_of_lod"][k]
            b = (int(st[lvl]) * self.W, int(st[lvl + 1]) * self.W)
        vert = (vc.offset, vc.offset + self.data_offset + int(self.vertex_counts[k]) * self.stride)
        return (0, ic.offset), (ic.offset + b[0], ic.offset + b[1]) if b[1] > b[0] else None, vert

    def streaming_bytes(self, k: int) -> tuple[int, int]:
        """Bytes a streaming reader needs before drawing LOD k: as a file prefix, and as byte ranges (§4)."""
        parts = [r for r in self.needed_ranges(k) if r is not None]
        return max(r[1] for r in parts), sum(r[1] - r[0] for r in parts)

    def smap(self) -> list[tuple[int, int, list[tuple[int, int]], int]]:
        """The streaming map's bands: (first_lod, lod_count, ranges, prefix_length)."""
        if "SMAP" not in self.chunks:
            return []
        p = self.chunks["SMAP"].offset
        B, N = struct.unpack_from("<II", self.data, p)
        ranges = [struct.unpack_from("<QQ", self.data, p + 8 + 24 * B + 16 * i) for i in range(N)]
        bands = []
        for b in range(B):
            f, n, rs, rn, pl = struct.unpack_from("<IIIIQ", self.data, p + 8 + 24 * b)
            bands.append((f, n, [(o, o + ln) for o, ln in ranges[rs : rs + rn]], pl))
        return bands


# ---------------------------------------------------------------- replay helpers
def starts_of(change_counts: np.ndarray) -> np.ndarray:
    return np.concatenate([[0], np.cumsum(change_counts)]).astype(np.int64)


def _replay(
    buf: np.ndarray,
    kept: np.ndarray,
    removed: np.ndarray,
    offs: np.ndarray,
    starts: np.ndarray,
    V: int,
    r0: int,
    r1: int,
) -> int:
    """Apply records [r0, r1) to the list ``buf`` in place, as §3.6 checks them; return live triangles.

    A slot changed by record r must hold V-1-r and stay live; after r no live slot holds V-1-r. The slots that
    hold a vertex are tracked per value (a slot gets value v only initially or as a record's kept), so the
    check costs O(slots + changes), not O(slots) per record.
    """
    live = len(buf) // 3
    order = np.argsort(buf, kind="stable")
    vals = buf[order]
    added: dict[int, list[int]] = {}
    for r in range(r0, r1):
        binned = V - 1 - r
        live -= int(removed[r])
        slots = offs[starts[r] : starts[r + 1]]
        if len(slots) and (np.any(slots >= 3 * live) or np.any(buf[slots] != binned)):
            raise EngineLoadError("SWPM_RECORD_BAD_CHANGE", f"record {r}")
        if len(np.unique(slots)) != len(slots):
            raise EngineLoadError("SWPM_RECORD_BAD_CHANGE", f"record {r} lists a slot twice")
        a, b = np.searchsorted(vals, [binned, binned + 1])
        held = np.concatenate([order[a:b], np.asarray(added.get(binned, []), np.int64)])
        left = np.setdiff1d(held[held < 3 * live], slots)
        if len(left):
            raise EngineLoadError("SWPM_PREFIX_VIOLATION", f"record {r}")
        buf[slots] = kept[r]
        added.setdefault(int(kept[r]), []).extend(int(x) for x in slots)
    return live


def range_max(a: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """max(a[lo:hi]) per range (-1 for an empty one), by a sparse table: O(n log n) once, O(1) a range."""
    a = np.asarray(a, dtype=np.int64)
    n_len = np.asarray(hi, np.int64) - np.asarray(lo, np.int64)
    out = np.full(len(n_len), -1, np.int64)
    ne = n_len > 0
    if not np.any(ne) or len(a) == 0:
        return out
    lo_, ln = np.asarray(lo, np.int64)[ne], n_len[ne]
    lg = np.floor(np.log2(ln)).astype(np.int64)
    levels = [a]
    while (1 << len(levels)) <= ln.max():
        prev, h = levels[-1], 1 << (len(levels) - 1)
        levels.append(np.maximum(prev[:-h], prev[h:]))
    res = np.empty(len(ln), np.int64)
    for j in np.unique(lg):
        m = lg == j
        t = levels[j]
        res[m] = np.maximum(t[lo_[m]], t[lo_[m] + ln[m] - (1 << j)])
    out[ne] = res
    return out


def _touched(slots: np.ndarray, n: int, prim: str) -> np.ndarray:
    """Triangle starts whose triangle holds one of ``slots``."""
    if prim == "list":
        return np.unique(slots - slots % 3)
    js = np.unique(np.concatenate([slots - 2, slots - 1, slots]))
    return js[(js >= 0) & (js + 2 < n)]


def _nondegenerate_at(lst: np.ndarray, js: np.ndarray, restart: int | None, prim: str) -> int:
    if len(js) == 0:
        return 0
    a, b, c = lst[js], lst[js + 1], lst[js + 2]
    ok = (a != b) & (b != c) & (a != c)
    if prim == "strip" and restart is not None:
        ok &= (a != restart) & (b != restart) & (c != restart)
    return int(ok.sum())


# ---------------------------------------------------------------- rasterisation
def strip_triangles(s: np.ndarray, restart: int | None, opengl: bool = False) -> np.ndarray:
    """Non-degenerate triangles of a strip draw with primitive restart at ``restart``.

    Vulkan's order for odd i is (i, i+2, i+1), OpenGL's and the spec's (i+1, i, i+2): the same winding.
    """
    s = np.asarray(s, dtype=np.int64)
    n = len(s)
    if n < 3:
        return np.zeros((0, 3), np.int64)
    j = np.arange(n - 2)
    rs = s == restart if restart is not None else np.zeros(n, bool)
    seg_start = np.maximum.accumulate(np.where(rs, np.arange(n) + 1, 0))[:-2]
    ok = ~(rs[j] | rs[j + 1] | rs[j + 2])
    odd = (j - seg_start) % 2 == 1
    a, b, c = s[j], s[j + 1], s[j + 2]
    if opengl:
        t = np.stack([np.where(odd, b, a), np.where(odd, a, b), c], axis=1)
    else:
        t = np.stack([a, np.where(odd, c, b), np.where(odd, b, c)], axis=1)
    t = t[ok]
    return t[(t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])]


def list_triangles(s: np.ndarray) -> np.ndarray:
    t = np.asarray(s, dtype=np.int64).reshape(-1, 3)
    return t[(t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])]


def count_triangles(s: np.ndarray, restart: int | None, prim: str) -> int:
    return len(strip_triangles(s, restart) if prim == "strip" else list_triangles(s))


def canonical(tris: np.ndarray) -> np.ndarray:
    """Rotate each triangle so its smallest index comes first (keeps winding), then sort the rows."""
    t = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    m = np.argmin(t, axis=1)
    r = np.arange(len(t))
    t = np.stack([t[r, m], t[r, (m + 1) % 3], t[r, (m + 2) % 3]], axis=1)
    return t[np.lexsort(t.T[::-1])] if len(t) else t


# ---------------------------------------------------------------- the GPU side
@dataclass
class Draw:
    """One indexed draw: ``buffer[first : first + count]`` as ``topology``, restart at its type's all ones."""

    buffer: np.ndarray
    first: int
    count: int
    topology: str  # "list" or "strip"
    vertex_count: int  # vertices bound for this draw

    @property
    def indices(self) -> np.ndarray:
        return self.buffer[self.first : self.first + self.count]

    def rasterise(self) -> np.ndarray:
        ones = int(np.iinfo(self.buffer.dtype).max)
        if self.topology == "strip":
            return strip_triangles(self.indices, ones)
        return list_triangles(self.indices)

    def max_vertex(self) -> int:
        ones = np.iinfo(self.buffer.dtype).max
        i = self.indices
        i = i[i != ones] if self.topology == "strip" else i
        return int(i.max()) if len(i) else -1


def upload_indices(f: SwpmFile, arr: np.ndarray, restart: int | None, notes: list[str]) -> np.ndarray:
    """What the GPU gets for an index array: the file's bytes when they fit the API, else a load-time copy.

    The API restarts a strip only at all ones of the bound index type (Vulkan, D3D12, Metal). When the file's
    restart index is another value, follow the spec's informative note (§3.5): draw from u16 indices if every
    value fits, else rewrite the restarts.
    """
    if restart is None:
        ones = np.iinfo(arr.dtype).max
        if np.any(arr == ones):
            # (a list's too: WebGL 2 restarts at u16's all ones in every draw; spec 1 makes a file of
            # V > 0xFFFF u32)
            notes.append("an index of a draw without restart holds the all-ones value (WebGL 2 restarts)")
        return arr
    if restart == np.iinfo(arr.dtype).max:
        return arr
    if (
        restart == 0xFFFF
        and arr.dtype == np.uint32
        and (len(arr) == 0 or int(arr[arr != restart].max(initial=0)) < 0xFFFF)
    ):
        notes.append("u32 pool with restart 0xFFFF uploaded as u16")
        return arr.astype(np.uint16)
    notes.append(f"restart {restart:#x} rewritten to all ones of {arr.dtype}")
    out = arr.copy()
    out[arr == restart] = np.iinfo(arr.dtype).max
    return out


class Engine:
    """The file's shared GPU buffers and draws; instances for the encodings that edit indices."""

    def __init__(self, f: SwpmFile) -> None:
        self.f = f
        self.notes: list[str] = []
        a = f.arrays
        if f.encoding == "sliding-window":
            self.pool = upload_indices(f, a["index_pool"], a["restart_index"], self.notes)
        elif f.encoding == "vanilla":
            self.pool = upload_indices(f, a["indices"], None, self.notes)
        elif f.encoding == "skip-strip":
            r = a["restart_index"]
            self.pool = upload_indices(f, a["level_indices"], r, self.notes)
            self.collapsed = upload_indices(f, a["levels"]["level_collapsed_indices"], r, self.notes)
        else:
            self.pool = upload_indices(f, a["level_static_indices"], None, self.notes)
            lv = a["levels"]
            self.dyn = lv["level_dynamic_indices"]
            self.dyn_collapsed = lv["level_dynamic_collapsed_indices"]

    def can_draw(self, k: int) -> bool:
        """A streaming reader draws LOD k once the vertex records it binds have arrived (§4 (c))."""
        return int(self.f.vertex_counts[k]) <= self.f.vertices_present

    def file_offset(self, arr: np.ndarray) -> int | None:
        """The byte offset in the file of an uploaded array that is a view of it (None: a load-time copy)."""
        base = np.frombuffer(self.f.data, np.uint8)
        if not np.shares_memory(arr, base):
            return None
        return int(arr.ctypes.data - base.ctypes.data)

    def draws(self, k: int) -> list[Draw]:
        """Sliding window: a window record look-up, one contiguous draw."""
        f = self.f
        assert f.encoding == "sliding-window"
        w = f.arrays["windows"][k]
        strips = bool(f.features & SW_STRIPS)
        count = int(f.arrays["window_index_counts"][k])
        return [Draw(self.pool, int(w[0]), count, "strip" if strips else "list", int(w[2]))]

    def instance(self) -> Instance:
        return {"vanilla": VanillaInstance, "skip-strip": SkipInstance, "mixed": MixedInstance}[
            self.f.encoding
        ](self)


class Instance:
    """A per-object index buffer allocated once; ``set_lod`` edits it in place (no per-frame allocation)."""

    def __init__(self, eng: Engine) -> None:
        self.eng = eng
        self.f = eng.f
        self.k = -1

    def draws(self) -> list[Draw]:
        raise NotImplementedError

    def set_lod(self, k: int) -> None:
        raise NotImplementedError


class VanillaInstance(Instance):
    """§3.6: apply records forward (slots to kept, then drop tris_removed), undo them backward."""

    def __init__(self, eng: Engine) -> None:
        super().__init__(eng)
        f = self.f
        self.buf = eng.pool.copy()
        self.rec = f.arrays["records"]
        self.offs = f.arrays["change_offsets"]
        self.r = 0  # records applied
        self.p = 0  # change_offsets position of record r's first slot
        self.live = len(self.buf) // 3
        self.k = 0

    def _apply(self) -> None:
        r = self.r
        cc = self.rec[r, 2]
        self.buf[self.offs[self.p : self.p + cc]] = self.rec[r, 0]
        self.p += cc
        self.live -= self.rec[r, 1]
        self.r += 1

    def _undo(self) -> None:
        r = self.r - 1
        # walking back, the record after r carries r's change_count (Forsyth's prev field)
        cc = self.rec[r + 1, 3] if r + 1 < len(self.rec) else self.rec[r, 2]
        self.p -= cc
        self.buf[self.offs[self.p : self.p + cc]] = self.f.V - 1 - r
        self.live += self.rec[r, 1]
        self.r -= 1

    def set_lod(self, k: int) -> None:
        target = int(self.f.arrays["record_counts"][k])
        while self.r < target:
            self._apply()
        while self.r > target:
            self._undo()
        self.k = k

    def draws(self) -> list[Draw]:
        return [Draw(self.buf, 0, 3 * int(self.live), "list", int(self.f.vertex_counts[self.k]))]


class SkipInstance(Instance):
    """§3.7: one level's list per instance; a finer level starts from its collapsed list, undoing records."""

    def __init__(self, eng: Engine) -> None:
        super().__init__(eng)
        f = self.f
        lv = f.arrays["levels"]
        self.ist = lv["level_index_start"]
        self.rst = lv["level_record_start"]
        self.buf = np.empty(int(np.diff(self.ist).max()), dtype=eng.pool.dtype)
        self.level = -1
        self.len = 0
        self.r = 0
        self.rec = f.arrays["records"]
        self.offs = f.arrays["change_offsets"]
        self.starts = f.arrays["record_starts"]
        self.topology = "strip" if f.arrays["primitive"] == "strip" else "list"

    def _enter(self, l: int, collapsed: bool) -> None:
        a, b = int(self.ist[l]), int(self.ist[l + 1])
        self.len = b - a
        self.buf[: self.len] = (self.eng.collapsed if collapsed else self.eng.pool)[a:b]
        self.r = int(self.rst[l + 1] if collapsed else self.rst[l])
        self.level = l

    def set_lod(self, k: int) -> None:
        f = self.f
        l = int(f.arrays["level_of_lod"][k])
        if l != self.level:
            self._enter(l, collapsed=self.level > l)
        target = int(f.arrays["record_counts"][k])
        while self.r < target:
            s = self.offs[self.starts[self.r] : self.starts[self.r + 1]]
            self.buf[s] = self.rec[self.r, 0]
            self.r += 1
        while self.r > target:
            self.r -= 1
            s = self.offs[self.starts[self.r] : self.starts[self.r + 1]]
            self.buf[s] = self.rec[self.r, 1]
        self.k = k

    def draws(self) -> list[Draw]:
        return [Draw(self.buf, 0, self.len, self.topology, int(self.f.vertex_counts[self.k]))]


class MixedInstance(Instance):
    """§3.8: a per-instance dynamic list edited by the records, then the shared static list's live prefix."""

    def __init__(self, eng: Engine) -> None:
        super().__init__(eng)
        f = self.f
        lv = f.arrays["levels"]
        self.sst, self.dst, self.rst = (
            lv["level_static_start"],
            lv["level_dynamic_start"],
            lv["level_record_start"],
        )
        self.buf = np.empty(max(1, int(np.diff(self.dst).max())), dtype=eng.pool.dtype)
        self.rec = f.arrays["records"]
        self.offs = f.arrays["change_offsets"]
        self.starts = f.arrays["record_starts"]
        self.level = -1

    def set_lod(self, k: int) -> None:
        f = self.f
        l = int(f.arrays["level_of_lod"][k])
        if l != self.level:
            collapsed = self.level > l
            a, b = int(self.dst[l]), int(self.dst[l + 1])
            self.buf[: b - a] = (self.eng.dyn_collapsed if collapsed else self.eng.dyn)[a:b]
            r0, r1 = int(self.rst[l]), int(self.rst[l + 1])
            self.r = r1 if collapsed else r0
            self.d_live = (b - a) // 3 - (int(self.rec[r0:r1, 2].sum()) if collapsed else 0)
            self.s_live = (int(self.sst[l + 1] - self.sst[l])) // 3 - (
                int(self.rec[r0:r1, 1].sum()) if collapsed else 0
            )
            self.level = l
        target = int(f.arrays["record_counts"][k])
        while self.r < target:
            s = self.offs[self.starts[self.r] : self.starts[self.r + 1]]
            self.buf[s] = self.rec[self.r, 0]
            self.s_live -= self.rec[self.r, 1]
            self.d_live -= self.rec[self.r, 2]
            self.r += 1
        while self.r > target:
            self.r -= 1
            s = self.offs[self.starts[self.r] : self.starts[self.r + 1]]
            self.buf[s] = f.V - 1 - self.r
            self.s_live += self.rec[self.r, 1]
            self.d_live += self.rec[self.r, 2]
        self.k = k

    def draws(self) -> list[Draw]:
        vc = int(self.f.vertex_counts[self.k])
        return [
            Draw(self.buf, 0, 3 * int(self.d_live), "list", vc),
            Draw(self.eng.pool, int(self.sst[self.level]), 3 * int(self.s_live), "list", vc),
        ]


def drawn_triangles(draws: list[Draw]) -> np.ndarray:
    """Every oriented triangle the draws rasterise, concatenated."""
    parts = [d.rasterise() for d in draws]
    return np.concatenate(parts) if parts else np.zeros((0, 3), np.int64)


def load(data: bytes, streaming: bool = False) -> tuple[SwpmFile, Engine]:
    f = SwpmFile(data, streaming=streaming)
    return f, Engine(f)
