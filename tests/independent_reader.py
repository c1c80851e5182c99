"""Independent reader for SWPM v1, written from spec/format.md and spec/errors.md only.

It does not import or look at the project's own codec (``swpm_usd``); its purpose is to test whether the
specification is precise enough for a second implementation to agree with the conformance vectors.

``read(data)`` returns ``{"valid", "problems", "summary"}`` in the shape of the vectors' expected JSON.

Where the spec is silent this reader applies the following interpretations (each one is a spec gap):

* Offsets: a problem is reported at the absolute offset of the first byte of the *first field involved*
  in the broken rule: a header field, a chunk-table entry field, a payload field, or an array element.
  Padding problems are reported at the first non-zero padding byte; a count that needs more bytes than
  remain is reported at the count field; a missing chunk is reported with offset ``None``.
* Multiplicity: every code is reported at most once per chunk (at its first occurrence).
* Cascades: after a structural error in the header, table or chunk layout the payloads are not decoded;
  after a failed check inside an encoding's tables the dependent checks (record replay) are skipped.
* Buffers: the spec does not say which arrays are exposed, under which names, or how a buffer is hashed.
  This reader exposes every array it decodes under a name taken from the spec text and hashes the
  array's bytes exactly as stored in the file (little-endian, the stored element type, C order).
"""

from __future__ import annotations

import hashlib
import json
import math
import struct
import zlib
from typing import Any

import numpy as np

MAGIC = b"SWPM\r\n\x1a\n"
HEADER_SIZE = 64
ENTRY_SIZE = 32
MAX_CHUNKS = 1024

INDEX32 = 1 << 0
ENCODING_BITS = {1 << 1: "vanilla", 1 << 2: "sliding-window", 1 << 3: "skip-strip", 1 << 4: "mixed"}
KNOWN_FEATURES = INDEX32 | sum(ENCODING_BITS)

CRITICAL = {
    "META": True,
    "LODS": True,
    "SMAP": False,
    "RCNT": True,
    "WREC": True,
    "VREC": True,
    "SKIP": True,
    "SREC": True,
    "MLVL": True,
    "MREC": True,
    "INDX": True,
    "VERT": True,
}
ENCODING_TABLES = {
    "vanilla": ["RCNT", "VREC"],
    "sliding-window": ["WREC"],
    "skip-strip": ["RCNT", "SKIP", "SREC"],
    "mixed": ["RCNT", "MLVL", "MREC"],
}

SEVERITY = {
    "SWPM_HEADER_TRUNCATED": "error",
    "SWPM_HEADER_BAD_MAGIC": "error",
    "SWPM_HEADER_UNSUPPORTED_MAJOR": "error",
    "SWPM_HEADER_NEWER_MINOR": "info",
    "SWPM_HEADER_BAD_SIZE": "error",
    "SWPM_HEADER_UNKNOWN_FEATURE": "error",
    "SWPM_HEADER_BAD_ENCODING": "error",
    "SWPM_HEADER_RESERVED_NONZERO": "warning",
    "SWPM_FILE_SIZE_MISMATCH": "error",
    "SWPM_FILE_TRAILING_BYTES": "warning",
    "SWPM_CHECKSUM_MISMATCH": "error",
    "SWPM_TABLE_TRUNCATED": "error",
    "SWPM_TABLE_TOO_LARGE": "error",
    "SWPM_TABLE_BAD_OFFSET": "error",
    "SWPM_CHUNK_BAD_TYPE": "error",
    "SWPM_CHUNK_OUT_OF_BOUNDS": "error",
    "SWPM_CHUNK_MISALIGNED": "error",
    "SWPM_CHUNK_OVERLAP": "error",
    "SWPM_CHUNK_OUT_OF_ORDER": "error",
    "SWPM_CHUNK_CRC_MISMATCH": "error",
    "SWPM_CHUNK_DUPLICATE": "error",
    "SWPM_CHUNK_UNKNOWN_CRITICAL": "error",
    "SWPM_CHUNK_UNKNOWN_ANCILLARY": "info",
    "SWPM_CHUNK_MISSING": "error",
    "SWPM_CHUNK_NOT_ALLOWED": "error",
    "SWPM_CHUNK_BAD_FLAGS": "error",
    "SWPM_CHUNK_BAD_LENGTH": "error",
    "SWPM_COUNT_EXCEEDS_CHUNK": "error",
    "SWPM_PADDING_NONZERO": "error",
    "SWPM_STREAM_ORDER": "warning",
    "SWPM_META_BAD_JSON": "error",
    "SWPM_META_BAD_FIELD": "error",
    "SWPM_LOD_EMPTY": "error",
    "SWPM_LOD_NOT_MONOTONE": "error",
    "SWPM_LOD_VERTEX_COUNT": "error",
    "SWPM_VERT_BAD_LAYOUT": "error",
    "SWPM_VERT_NONFINITE": "warning",
    "SWPM_INDEX_WIDTH": "error",
    "SWPM_INDEX_OUT_OF_RANGE": "error",
    "SWPM_WINDOW_OUT_OF_POOL": "error",
    "SWPM_WINDOW_NOT_MONOTONE": "error",
    "SWPM_WINDOW_COUNT_MISMATCH": "error",
    "SWPM_PREFIX_VIOLATION": "error",
    "SWPM_RECORD_BAD_KEPT": "error",
    "SWPM_RECORD_BAD_COUNTS": "error",
    "SWPM_RECORD_BAD_CHANGE": "error",
    "SWPM_LEVEL_BAD_TABLE": "error",
    "SWPM_MIXED_BAD_LEVELS": "error",
    "SWPM_SMAP_INVALID": "warning",
}

# elem_type -> (numpy dtype, size)
ELEM_TYPES = {
    1: ("<u1", 1),
    2: ("<i1", 1),
    3: ("<u2", 2),
    4: ("<i2", 2),
    5: ("<u4", 4),
    6: ("<i4", 4),
    7: ("<f2", 2),
    8: ("<f4", 4),
    9: ("<f8", 8),
}

STRUCTURAL = {
    "SWPM_TABLE_TRUNCATED",
    "SWPM_TABLE_TOO_LARGE",
    "SWPM_TABLE_BAD_OFFSET",
    "SWPM_CHUNK_BAD_TYPE",
    "SWPM_CHUNK_OUT_OF_BOUNDS",
    "SWPM_CHUNK_MISALIGNED",
    "SWPM_CHUNK_OVERLAP",
    "SWPM_CHUNK_OUT_OF_ORDER",
    "SWPM_CHUNK_DUPLICATE",
    "SWPM_CHUNK_UNKNOWN_CRITICAL",
    "SWPM_CHUNK_MISSING",
    "SWPM_CHUNK_NOT_ALLOWED",
    "SWPM_CHUNK_BAD_FLAGS",
    "SWPM_HEADER_BAD_SIZE",
}


def _align4(n: int) -> int:
    return (n + 3) & ~3


class _Fail(Exception):
    """Raised to stop decoding one group of checks after an error was reported."""


class _Report:
    def __init__(self) -> None:
        self.problems: list[dict[str, Any]] = []
        self._seen: set[tuple[str, str]] = set()

    def add(self, code: str, offset: int | None, scope: str | None = None) -> None:
        if scope is not None:
            key = (code, scope)
            if key in self._seen:
                return
            self._seen.add(key)
        self.problems.append({"code": code, "severity": SEVERITY[code], "offset": offset})

    def has_error(self, codes: set[str] | None = None) -> bool:
        return any(p["severity"] == "error" and (codes is None or p["code"] in codes) for p in self.problems)

    def error_count(self) -> int:
        return sum(1 for p in self.problems if p["severity"] == "error")


class _Chunk:
    def __init__(self, ctype: str, entry: int, flags: int, offset: int, length: int) -> None:
        self.type = ctype
        self.entry = entry
        self.flags = flags
        self.offset = offset
        self.length = length


def _hash(arr: np.ndarray) -> dict[str, Any]:
    return {
        "sha256": hashlib.sha256(np.ascontiguousarray(arr).tobytes()).hexdigest(),
        "shape": list(arr.shape),
    }


class _Reader:
    def __init__(self, data: bytes) -> None:
        self.raw = bytes(data)
        self.data = self.raw
        self.rep = _Report()
        self.chunks: dict[str, _Chunk] = {}
        self.order: list[_Chunk] = []
        self.encoding = ""
        self.W = 2
        self.idt = "<u2"
        self.buffers: dict[str, np.ndarray] = {}
        self.params: dict[str, Any] = {}
        self.V = 0
        self.L = 0
        self.T0 = 0

    # ----------------------------------------------------------------- helpers
    def add(self, code: str, offset: int | None, scope: str | None = None) -> None:
        self.rep.add(code, offset, scope)

    def u16(self, off: int) -> int:
        return struct.unpack_from("<H", self.data, off)[0]

    def u32(self, off: int) -> int:
        return struct.unpack_from("<I", self.data, off)[0]

    def u64(self, off: int) -> int:
        return struct.unpack_from("<Q", self.data, off)[0]

    def idx_array(self, off: int, count: int) -> np.ndarray:
        """The idx[count] array at absolute ``off``; the caller has checked the bounds."""
        return np.frombuffer(self.data, dtype=self.idt, count=count, offset=off)

    def check_zero(self, start: int, end: int, scope: str) -> None:
        """Padding [start, end) MUST be zero; report the first non-zero byte."""
        end = min(end, len(self.data))
        if start >= end:
            return
        seg = self.data[start:end]
        if seg.count(0) != len(seg):
            first = next(i for i, b in enumerate(seg) if b)
            self.add("SWPM_PADDING_NONZERO", start + first, scope)

    # ----------------------------------------------------------------- header
    def run(self) -> dict[str, Any]:
        d = self.raw
        if len(d) < HEADER_SIZE:
            self.add("SWPM_HEADER_TRUNCATED", 0)
            return self.result()
        if d[:8] != MAGIC:
            self.add("SWPM_HEADER_BAD_MAGIC", 0)
            return self.result()
        major, minor = struct.unpack_from("<HH", d, 8)
        if major != 1:
            self.add("SWPM_HEADER_UNSUPPORTED_MAJOR", 8)
            return self.result()
        if minor > 0:
            self.add("SWPM_HEADER_NEWER_MINOR", 10)
        header_size, _flags, features, chunk_count, reserved0 = struct.unpack_from("<IIIII", d, 12)
        table_offset, file_size = struct.unpack_from("<QQ", d, 32)
        file_crc = self.u32(48)
        bad = False
        if features & ~KNOWN_FEATURES:
            self.add("SWPM_HEADER_UNKNOWN_FEATURE", 20)
            bad = True
        enc_bits = [b for b in ENCODING_BITS if features & b]
        if len(enc_bits) != 1:
            self.add("SWPM_HEADER_BAD_ENCODING", 20)
            bad = True
        if bad:
            return self.result()
        self.encoding = ENCODING_BITS[enc_bits[0]]
        self.W = 4 if features & INDEX32 else 2
        self.idt = "<u4" if self.W == 4 else "<u2"
        if reserved0:
            self.add("SWPM_HEADER_RESERVED_NONZERO", 28)
        for off in (52, 56, 60):
            if self.u32(off):
                self.add("SWPM_HEADER_RESERVED_NONZERO", off)
        # file size: a shorter file is an error, a longer one is cut at file_size (ignored bytes)
        if len(d) < file_size:
            self.add("SWPM_FILE_SIZE_MISMATCH", 40)
        elif len(d) > file_size:
            self.add("SWPM_FILE_TRAILING_BYTES", file_size)
            self.data = d[: max(file_size, HEADER_SIZE)]
        size = len(self.data)
        if header_size < HEADER_SIZE or header_size > size:
            self.add("SWPM_HEADER_BAD_SIZE", 12)
            return self.result()
        if chunk_count > MAX_CHUNKS:
            self.add("SWPM_TABLE_TOO_LARGE", 24)
            return self.result()
        if table_offset < header_size or table_offset % 8:
            self.add("SWPM_TABLE_BAD_OFFSET", 32)
            return self.result()
        table_end = table_offset + ENTRY_SIZE * chunk_count
        if table_end > size:
            self.add("SWPM_TABLE_TRUNCATED", 24)
            return self.result()
        buf = bytearray(self.data[:table_end])
        buf[48:52] = b"\0\0\0\0"
        if zlib.crc32(bytes(buf)) & 0xFFFFFFFF != file_crc:
            self.add("SWPM_CHECKSUM_MISMATCH", 48)
        self.read_table(table_offset, chunk_count, table_end, file_size)
        if self.rep.has_error(STRUCTURAL) or self.rep.has_error({"SWPM_FILE_SIZE_MISMATCH"}):
            return self.result()
        self.stream_order()
        self.decode()
        return self.result()

    # ----------------------------------------------------------------- table
    def read_table(self, table_offset: int, count: int, table_end: int, file_size: int) -> None:
        size = len(self.data)
        covered_end = table_end
        prev_offset = -1
        for i in range(count):
            eo = table_offset + ENTRY_SIZE * i
            raw_type, flags, offset, length, crc, _res = struct.unpack_from("<4sIQQII", self.data, eo)
            scope = f"entry{i}"
            if not all(
                c in b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789" for c in raw_type
            ):
                self.add("SWPM_CHUNK_BAD_TYPE", eo, scope)
                continue
            ctype = raw_type.decode("ascii")
            critical = bool(flags & 1)  # other flag bits: unknown, ignored (§5)
            ok = True
            if offset % 8:
                self.add("SWPM_CHUNK_MISALIGNED", eo + 8, scope)
                ok = False
            if offset + length > size:
                self.add("SWPM_CHUNK_OUT_OF_BOUNDS", eo + 8, scope)
                ok = False
            if offset < prev_offset:
                self.add("SWPM_CHUNK_OUT_OF_ORDER", eo + 8, scope)
                ok = False
            elif offset < covered_end:
                self.add("SWPM_CHUNK_OVERLAP", eo + 8, scope)
                ok = False
            elif ok:
                self.check_zero(covered_end, offset, "between")
            prev_offset = max(prev_offset, offset)
            if offset + length <= size:
                covered_end = max(covered_end, offset + length)
            if ok:
                payload = self.data[offset : offset + length]
                if zlib.crc32(payload, zlib.crc32(raw_type)) & 0xFFFFFFFF != crc:
                    self.add("SWPM_CHUNK_CRC_MISMATCH", eo + 24, scope)
            chunk = _Chunk(ctype, eo, flags, offset, length)
            if ctype not in CRITICAL:
                if critical:
                    self.add("SWPM_CHUNK_UNKNOWN_CRITICAL", eo, scope)
                else:
                    self.add("SWPM_CHUNK_UNKNOWN_ANCILLARY", eo, scope)
                self.order.append(chunk)
                continue
            if critical != CRITICAL[ctype]:
                self.add("SWPM_CHUNK_BAD_FLAGS", eo + 4, scope)
            allowed = (
                ctype in ("META", "LODS", "SMAP", "INDX", "VERT") or ctype in ENCODING_TABLES[self.encoding]
            )
            if not allowed:
                self.add("SWPM_CHUNK_NOT_ALLOWED", eo, scope)
            if ctype in self.chunks:
                self.add("SWPM_CHUNK_DUPLICATE", eo, scope)
                continue
            self.chunks[ctype] = chunk
            self.order.append(chunk)
        if not self.rep.has_error(STRUCTURAL):
            self.check_zero(covered_end, min(size, file_size), "between")
        for ctype in ["META", "LODS", *ENCODING_TABLES[self.encoding], "INDX", "VERT"]:
            if ctype not in self.chunks:
                self.add("SWPM_CHUNK_MISSING", None)

    def stream_order(self) -> None:
        expected = ["META", "LODS", "SMAP", *ENCODING_TABLES[self.encoding], "INDX", "VERT"]
        known = [c for c in self.order if c.type in CRITICAL]
        want = [t for t in expected if t in self.chunks]
        for c, t in zip(known, want, strict=True):
            if c.type != t:
                self.add("SWPM_STREAM_ORDER", c.entry, "order")
                return
        # unknown ancillary chunks may follow SMAP, but VERT stays last
        seen_smap = "SMAP" not in self.chunks
        for i, c in enumerate(self.order):
            if c.type == "SMAP":
                seen_smap = True
            elif c.type not in CRITICAL and (not seen_smap or i == len(self.order) - 1):
                self.add("SWPM_STREAM_ORDER", c.entry, "order")
                return

    # ----------------------------------------------------------------- payloads
    def decode(self) -> None:
        self.read_meta()
        if not self.read_lods() or not self.read_vert():
            return
        if not self.read_indx():
            return
        try:
            if self.encoding == "vanilla":
                self.read_vanilla()
            elif self.encoding == "sliding-window":
                self.read_sliding()
            elif self.encoding == "skip-strip":
                self.read_skip_strip()
            else:
                self.read_mixed()
        except _Fail:
            return
        if "SMAP" in self.chunks and self.rep.error_count() == 0:
            self.read_smap()

    def read_meta(self) -> None:
        c = self.chunks["META"]
        raw = self.data[c.offset : c.offset + c.length]

        def no_constants(name: str) -> Any:
            raise ValueError(name)

        try:
            meta = json.loads(raw.decode("utf-8"), parse_constant=no_constants)
        except (UnicodeDecodeError, ValueError, RecursionError):
            meta = None
        if not isinstance(meta, dict):
            self.add("SWPM_META_BAD_JSON", c.offset, "META")
            return
        if meta.get("encoding") != self.encoding:
            self.add("SWPM_META_BAD_FIELD", c.offset, "META")
        if "generator" in meta and not isinstance(meta["generator"], str):
            self.add("SWPM_META_BAD_FIELD", c.offset, "META")
        sd = meta.get("source_digest")
        if sd is not None and not (
            isinstance(sd, str)
            and sd.startswith("sha256:")
            and len(sd) > 7
            and all(ch in "0123456789abcdefABCDEF" for ch in sd[7:])
        ):
            self.add("SWPM_META_BAD_FIELD", c.offset, "META")
        params = meta.get("params", {})
        if not isinstance(params, dict):
            self.add("SWPM_META_BAD_FIELD", c.offset, "META")
            params = {}
        self.params = params

    def read_lods(self) -> bool:
        c = self.chunks["LODS"]
        if c.length % 12:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.offset, "LODS")
            return False
        L = c.length // 12
        if L == 0:
            self.add("SWPM_LOD_EMPTY", c.offset, "LODS")
            return False
        rows = np.frombuffer(self.data, dtype="<u4", count=3 * L, offset=c.offset).reshape(L, 3)
        vc = rows[:, 0].astype(np.int64)
        tc = rows[:, 1].astype(np.int64)
        err = np.frombuffer(self.data, dtype="<f4", count=3 * L, offset=c.offset).reshape(L, 3)[:, 2]
        # monotonicity is a semantic rule: the rest of the file still decodes, so it is not fatal
        for k in range(L):
            base = c.offset + 12 * k
            if not math.isfinite(float(err[k])):
                self.add("SWPM_LOD_NOT_MONOTONE", base + 8, "LODS")
            if k == 0:
                continue
            if vc[k] > vc[k - 1]:
                self.add("SWPM_LOD_NOT_MONOTONE", base, "LODS")
            if tc[k] > tc[k - 1]:
                self.add("SWPM_LOD_NOT_MONOTONE", base + 4, "LODS")
            if err[k] < err[k - 1]:
                self.add("SWPM_LOD_NOT_MONOTONE", base + 8, "LODS")
        self.L = L
        self.vc = vc
        self.tc = tc
        self.T0 = int(tc[0])
        self.buffers["vertex_count"] = np.ascontiguousarray(rows[:, 0])
        self.buffers["triangle_count"] = np.ascontiguousarray(rows[:, 1])
        self.buffers["error"] = np.ascontiguousarray(err)
        return True

    def read_vert(self) -> bool:
        c = self.chunks["VERT"]
        p = c.offset
        n = c.length
        if n < 16:
            self.add("SWPM_CHUNK_BAD_LENGTH", p, "VERT")
            return False
        V, A, stride, data_offset = struct.unpack_from("<IIII", self.data, p)
        if A > 255:
            self.add("SWPM_VERT_BAD_LAYOUT", p + 4, "VERT")
            return False
        if 16 + 16 * A > n:
            self.add("SWPM_COUNT_EXCEEDS_CHUNK", p + 4, "VERT")
            return False
        if stride < 12 or stride % 4:
            self.add("SWPM_VERT_BAD_LAYOUT", p + 8, "VERT")
            return False
        if data_offset % 8 or data_offset < 16 + 16 * A or data_offset > n:
            self.add("SWPM_VERT_BAD_LAYOUT", p + 12, "VERT")
            return False
        if V * stride > n - data_offset:
            self.add("SWPM_COUNT_EXCEEDS_CHUNK", p, "VERT")
            return False
        if data_offset + V * stride != n:
            self.add("SWPM_CHUNK_BAD_LENGTH", p, "VERT")
            return False
        names_start = 16 + 16 * A
        name_used = bytearray(data_offset - names_start)
        rec_used = bytearray(stride)
        rec_used[0:12] = b"\1" * 12
        names: set[str] = set()
        attrs: list[tuple[str, str, int, int]] = []
        ok = True
        for a in range(A):
            do = p + 16 + 16 * a
            name_off, name_len, et, comps, aoff, ares = struct.unpack_from("<IHBBII", self.data, do)
            if name_len < 1 or name_off < names_start or name_off + name_len > data_offset:
                self.add("SWPM_VERT_BAD_LAYOUT", do, "VERT")
                ok = False
                continue
            try:
                name = self.data[p + name_off : p + name_off + name_len].decode("utf-8")
            except UnicodeDecodeError:
                self.add("SWPM_VERT_BAD_LAYOUT", do, "VERT")
                ok = False
                continue
            if name in names:
                self.add("SWPM_VERT_BAD_LAYOUT", do, "VERT")
                ok = False
            names.add(name)
            name_used[name_off - names_start : name_off - names_start + name_len] = b"\1" * name_len
            if et not in ELEM_TYPES:
                self.add("SWPM_VERT_BAD_LAYOUT", do + 6, "VERT")
                ok = False
                continue
            dt, es = ELEM_TYPES[et]
            if comps < 1:
                self.add("SWPM_VERT_BAD_LAYOUT", do + 7, "VERT")
                ok = False
                continue
            if stride % es:
                self.add("SWPM_VERT_BAD_LAYOUT", p + 8, "VERT")
                ok = False
            if aoff % es or aoff + es * comps > stride:
                self.add("SWPM_VERT_BAD_LAYOUT", do + 8, "VERT")
                ok = False
                continue
            if any(rec_used[aoff : aoff + es * comps]):
                self.add("SWPM_VERT_BAD_LAYOUT", do + 8, "VERT")
                ok = False
            rec_used[aoff : aoff + es * comps] = b"\1" * (es * comps)
            if ares:
                self.add("SWPM_VERT_BAD_LAYOUT", do + 12, "VERT")
                ok = False
            attrs.append((name, dt, comps, aoff))
        if not ok:
            return False
        for i, used in enumerate(name_used):
            if not used and self.data[p + names_start + i]:
                self.add("SWPM_PADDING_NONZERO", p + names_start + i, "VERT")
                break
        gaps = [i for i, used in enumerate(rec_used) if not used]
        if gaps and V:
            recs = np.frombuffer(self.data, dtype=np.uint8, count=V * stride, offset=p + data_offset)
            recs = recs.reshape(V, stride)[:, gaps]
            nz = np.argwhere(recs)
            if len(nz):
                v, g = nz[0]
                self.add("SWPM_PADDING_NONZERO", p + data_offset + int(v) * stride + gaps[int(g)], "VERT")
        self.V = V
        pos_dt = np.dtype({"names": ["p"], "formats": [("<f4", (3,))], "offsets": [0], "itemsize": stride})
        pts = np.frombuffer(self.data, dtype=pos_dt, count=V, offset=p + data_offset)["p"]
        self.buffers["position"] = np.ascontiguousarray(pts)
        bad = ~np.isfinite(pts)
        if bad.any():
            first = int(np.argmax(bad.reshape(-1)))
            self.add("SWPM_VERT_NONFINITE", p + data_offset + (first // 3) * stride + 4 * (first % 3), "VERT")
        for name, dt, comps, aoff in attrs:
            adt = np.dtype(
                {"names": ["a"], "formats": [(dt, (comps,))], "offsets": [aoff], "itemsize": stride}
            )
            arr = np.frombuffer(self.data, dtype=adt, count=V, offset=p + data_offset)["a"]
            self.buffers[f"attribute:{name}"] = np.ascontiguousarray(arr.reshape(V, comps))
        if int(self.vc[0]) != V:
            self.add("SWPM_LOD_VERTEX_COUNT", self.chunks["LODS"].offset, "LODS")
            return False
        for k in range(self.L):
            if self.vc[k] > V:
                self.add("SWPM_LOD_VERTEX_COUNT", self.chunks["LODS"].offset + 12 * k, "LODS")
                return False
        return True

    def read_indx(self) -> bool:
        c = self.chunks["INDX"]
        if c.length % self.W:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.offset, "INDX")
            return False
        self.indx = self.idx_array(c.offset, c.length // self.W)
        restart = None
        if self.encoding == "skip-strip":
            r = self.params.get("restart_index")
            if isinstance(r, int) and not isinstance(r, bool):
                restart = r
        self.restart = restart
        vals = self.indx.astype(np.int64)
        bad = vals >= self.V
        if restart is not None:
            bad &= vals != restart
        if bad.any():
            self.add("SWPM_INDEX_OUT_OF_RANGE", c.offset + self.W * int(np.argmax(bad)), "INDX")
            return False
        return True

    # ------------------------------------------------------------ shared parts
    def read_rcnt(self, R: int) -> np.ndarray:
        c = self.chunks["RCNT"]
        if c.length != self.W * self.L:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.offset, "RCNT")
            raise _Fail
        rc = self.idx_array(c.offset, self.L)
        self.buffers["lod_record_counts"] = rc
        rcl = [int(x) for x in rc]
        for k, x in enumerate(rcl):
            off = c.offset + self.W * k
            if (k == 0 and x != 0) or (k > 0 and x < rcl[k - 1]) or x > R or int(self.vc[k]) != self.V - x:
                self.add("SWPM_RECORD_BAD_COUNTS", off, "RCNT")
                raise _Fail
        return np.array(rcl, dtype=np.int64)

    def read_records(self, ctype: str, cols: int) -> tuple[np.ndarray, np.ndarray, int]:
        """A VREC-layout chunk: (records[R, cols], change_offsets[M], offsets array position)."""
        c = self.chunks[ctype]
        p = c.offset
        if c.length < 8:
            self.add("SWPM_CHUNK_BAD_LENGTH", p, ctype)
            raise _Fail
        R, M = struct.unpack_from("<II", self.data, p)
        need = cols * self.W * R
        if need > c.length - 8:
            self.add("SWPM_COUNT_EXCEEDS_CHUNK", p, ctype)
            raise _Fail
        ao = 8 + _align4(need)
        if ao > c.length or M * self.W > c.length - ao:
            self.add("SWPM_COUNT_EXCEEDS_CHUNK", p + 4, ctype)
            raise _Fail
        if ao + M * self.W != c.length:
            self.add("SWPM_CHUNK_BAD_LENGTH", p, ctype)
            raise _Fail
        self.check_zero(p + 8 + need, p + ao, ctype)
        if R and R >= self.V:
            self.add("SWPM_RECORD_BAD_COUNTS", p, ctype)
            raise _Fail
        recs = self.idx_array(p + 8, cols * R).reshape(R, cols)
        offs = self.idx_array(p + ao, M)
        cc_col = cols - 2
        cc = recs[:, cc_col].astype(np.int64)
        if int(cc.sum()) != M:
            self.add("SWPM_RECORD_BAD_COUNTS", p + 4, ctype)
            raise _Fail
        for r in range(R):
            prev = int(cc[r - 1]) if r else 0
            if int(recs[r, cols - 1]) != prev:
                self.add("SWPM_RECORD_BAD_COUNTS", p + 8 + self.W * (cols * r + cols - 1), ctype)
                raise _Fail
        return recs, offs, p + ao

    def rec_field(self, ctype: str, cols: int, r: int, col: int) -> int:
        return self.chunks[ctype].offset + 8 + self.W * (cols * r + col)

    def check_kept(self, ctype: str, recs: np.ndarray, cols: int) -> None:
        for r in range(recs.shape[0]):
            if int(recs[r, 0]) >= self.V - 1 - r:
                self.add("SWPM_RECORD_BAD_KEPT", self.rec_field(ctype, cols, r, 0), ctype)
                raise _Fail

    # ----------------------------------------------------------------- vanilla
    def read_vanilla(self) -> None:
        ic = self.chunks["INDX"]
        n = len(self.indx)
        if n != 3 * self.T0:
            self.add("SWPM_CHUNK_BAD_LENGTH", ic.offset, "INDX")
            raise _Fail
        self.buffers["indices"] = self.indx
        recs, offs, op = self.read_records("VREC", 4)
        R = recs.shape[0]
        for i, name in enumerate(["kept", "tris_removed", "change_count", "prev_change_count"]):
            self.buffers[name] = np.ascontiguousarray(recs[:, i])
        self.buffers["change_offsets"] = offs
        rc = self.read_rcnt(R)
        self.check_kept("VREC", recs, 4)
        # replay the records
        ind = [int(x) for x in self.indx]
        refs = [0] * self.V
        for x in ind:
            refs[x] += 1
        live = self.T0
        cum = [0]
        c = 0
        offl = [int(x) for x in offs]
        for r in range(R):
            binned = self.V - 1 - r
            kept, tr, cc = int(recs[r, 0]), int(recs[r, 1]), int(recs[r, 2])
            if tr > live:
                self.add("SWPM_RECORD_BAD_COUNTS", self.rec_field("VREC", 4, r, 1), "VREC")
                raise _Fail
            after = live - tr
            for j in range(c, c + cc):
                s = offl[j]
                if s >= n:
                    self.add("SWPM_INDEX_OUT_OF_RANGE", op + self.W * j, "VREC")
                    raise _Fail
                if ind[s] != binned or s >= 3 * after:
                    self.add("SWPM_RECORD_BAD_CHANGE", op + self.W * j, "VREC")
                    raise _Fail
                ind[s] = kept
                refs[binned] -= 1
                refs[kept] += 1
            c += cc
            for s in range(3 * after, 3 * live):
                refs[ind[s]] -= 1
            live = after
            cum.append(cum[-1] + tr)
            if refs[binned]:
                self.add("SWPM_RECORD_BAD_CHANGE", self.rec_field("VREC", 4, r, 0), "VREC")
                raise _Fail
        for k in range(self.L):
            if int(self.tc[k]) != self.T0 - cum[int(rc[k])]:
                self.add("SWPM_RECORD_BAD_COUNTS", self.chunks["RCNT"].offset + self.W * k, "RCNT")
                raise _Fail

    # ---------------------------------------------------------- sliding window
    def read_sliding(self) -> None:
        c = self.chunks["WREC"]
        W = self.W
        if c.length != 3 * W * self.L:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.offset, "WREC")
            raise _Fail
        rows = self.idx_array(c.offset, 3 * self.L).reshape(self.L, 3)
        self.buffers["index_pool"] = self.indx
        self.buffers["window_records"] = rows
        pool = len(self.indx)
        vals = self.indx.astype(np.int64)
        for k in range(self.L):
            base = c.offset + 3 * W * k
            first, tcount, vcount = (int(x) for x in rows[k])
            if k and tcount > int(rows[k - 1, 1]):
                self.add("SWPM_WINDOW_NOT_MONOTONE", base + W, "WREC")
            if tcount != int(self.tc[k]):
                self.add("SWPM_WINDOW_COUNT_MISMATCH", base + W, "WREC")
            if vcount != int(self.vc[k]):
                self.add("SWPM_WINDOW_COUNT_MISMATCH", base + 2 * W, "WREC")
            if first + 3 * tcount > pool:
                self.add("SWPM_WINDOW_OUT_OF_POOL", base, "WREC")
                continue
            win = vals[first : first + 3 * tcount]
            bad = win >= int(self.vc[k])
            if bad.any():
                pos = first + int(np.argmax(bad))
                self.add("SWPM_PREFIX_VIOLATION", self.chunks["INDX"].offset + W * pos, "INDX")

    # -------------------------------------------------------------- level table
    def level_arrays(self, ctype: str, head: int, sizes: list[int]) -> list[tuple[np.ndarray, int]]:
        """Consecutive idx arrays starting at payload+head, each starting at a multiple of 4."""
        c = self.chunks[ctype]
        out = []
        pos = head
        for i, count in enumerate(sizes):
            pos = _align4(pos)
            if count * self.W > c.length - min(pos, c.length) or pos > c.length:
                self.add("SWPM_COUNT_EXCEEDS_CHUNK", c.offset + (0 if i < 3 else 4), ctype)
                raise _Fail
            out.append((self.idx_array(c.offset + pos, count), c.offset + pos))
            end = pos + count * self.W
            if i + 1 < len(sizes):
                self.check_zero(c.offset + end, c.offset + _align4(end), ctype)
            pos = end
        if pos != c.length:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.offset, ctype)
            raise _Fail
        return out

    def check_levels(
        self,
        code: str,
        ctype: str,
        lfl: tuple[np.ndarray, int],
        starts: list[tuple[np.ndarray, int, int, int]],
    ) -> None:
        """level_first_lod starts at 0, increasing, < L; each start array within [0, hi], non-decreasing,
        steps a multiple of ``step``."""
        arr, off = lfl
        vals = [int(x) for x in arr]
        for i, x in enumerate(vals):
            if (i == 0 and x != 0) or (i and x <= vals[i - 1]) or x >= self.L:
                self.add(code, off + self.W * i, ctype)
                raise _Fail
        for arr, off, hi, step in starts:
            vals = [int(x) for x in arr]
            for i, x in enumerate(vals):
                if x > hi or (i and (x < vals[i - 1] or (x - vals[i - 1]) % step)):
                    self.add(code, off + self.W * i, ctype)
                    raise _Fail

    def level_of(self, lfl: list[int], k: int) -> int:
        lev = 0
        for i, f in enumerate(lfl):
            if f <= k:
                lev = i
        return lev

    # -------------------------------------------------------------- skip-strip
    def read_skip_strip(self) -> None:
        c = self.chunks["SKIP"]
        if c.length < 8:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.offset, "SKIP")
            raise _Fail
        n, C = struct.unpack_from("<II", self.data, c.offset)
        if n < 1:
            self.add("SWPM_LEVEL_BAD_TABLE", c.offset, "SKIP")
            raise _Fail
        if (4 * n + 3) * self.W > c.length or C * self.W > c.length:
            self.add(
                "SWPM_COUNT_EXCEEDS_CHUNK",
                c.offset if (4 * n + 3) * self.W > c.length else c.offset + 4,
                "SKIP",
            )
            raise _Fail
        arrs = self.level_arrays("SKIP", 8, [n, n + 1, n + 1, n + 1, C])
        (lfl, _), (lis, lis_o), (lcs, lcs_o), (lrs, lrs_o), (lci, lci_o) = arrs
        recs, offs, op = self.read_records("SREC", 4)
        R = recs.shape[0]
        names = ["level_first_lod", "level_index_start", "level_collapsed_start", "level_record_start"]
        for name, (a, _o) in zip(names, arrs[:4], strict=True):
            self.buffers[name] = a
        self.buffers["level_collapsed_indices"] = lci
        self.buffers["level_indices"] = self.indx
        for i, name in enumerate(["kept", "binned", "change_count", "prev_change_count"]):
            self.buffers[name] = np.ascontiguousarray(recs[:, i])
        self.buffers["change_offsets"] = offs
        N = len(self.indx)
        self.check_levels(
            "SWPM_LEVEL_BAD_TABLE",
            "SKIP",
            arrs[0],
            [(lis, lis_o, N, 1), (lcs, lcs_o, C, 1), (lrs, lrs_o, R, 1)],
        )
        rc = self.read_rcnt(R)
        restart = self.restart
        cvals = lci.astype(np.int64)
        bad = cvals >= self.V
        if restart is not None:
            bad &= cvals != restart
        if bad.any():
            self.add("SWPM_INDEX_OUT_OF_RANGE", lci_o + self.W * int(np.argmax(bad)), "SKIP")
            raise _Fail
        for r in range(R):
            if int(recs[r, 1]) != self.V - 1 - r:
                self.add("SWPM_RECORD_BAD_COUNTS", self.rec_field("SREC", 4, r, 1), "SREC")
                raise _Fail
        self.check_kept("SREC", recs, 4)
        lfl_l = [int(x) for x in lfl]
        lis_l = [int(x) for x in lis]
        lrs_l = [int(x) for x in lrs]
        starts = [0]
        for r in range(R):
            starts.append(starts[-1] + int(recs[r, 2]))
        offl = [int(x) for x in offs]
        for lev in range(n):
            lo, hi = lis_l[lev], lis_l[lev + 1]
            first_lod = lfl_l[lev]
            last_lod = lfl_l[lev + 1] - 1 if lev + 1 < n else self.L - 1
            lst = [int(x) for x in self.indx[lo:hi]]
            lim = int(self.vc[first_lod])
            for j, x in enumerate(lst):
                if x >= lim and x != restart:
                    self.add("SWPM_PREFIX_VIOLATION", self.chunks["INDX"].offset + self.W * (lo + j), "INDX")
                    raise _Fail
            # records of this level, replayed on a copy of its list
            lod_at = {int(rc[k]): k for k in range(first_lod, last_lod + 1)}
            for r in range(lrs_l[lev], lrs_l[lev + 1]):
                binned = self.V - 1 - r
                for j in range(starts[r], starts[r + 1]):
                    s = offl[j]
                    if s >= len(lst):
                        self.add("SWPM_INDEX_OUT_OF_RANGE", op + self.W * j, "SREC")
                        raise _Fail
                    if lst[s] != binned:
                        self.add("SWPM_RECORD_BAD_CHANGE", op + self.W * j, "SREC")
                        raise _Fail
                    lst[s] = int(recs[r, 0])
                k = lod_at.get(r + 1)
                if k is not None and any(x >= int(self.vc[k]) and x != restart for x in lst):
                    self.add("SWPM_PREFIX_VIOLATION", self.rec_field("SREC", 4, r, 0), "SREC")
                    raise _Fail
            clo, chi = int(lcs[lev]), int(lcs[lev + 1])
            if [int(x) for x in lci[clo:chi]] != lst:
                self.add("SWPM_LEVEL_BAD_TABLE", lcs_o + self.W * lev, "SKIP")
                raise _Fail

    # ------------------------------------------------------------------- mixed
    def read_mixed(self) -> None:
        c = self.chunks["MLVL"]
        if c.length < 8:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.offset, "MLVL")
            raise _Fail
        n, D = struct.unpack_from("<II", self.data, c.offset)
        if n < 1:
            self.add("SWPM_MIXED_BAD_LEVELS", c.offset, "MLVL")
            raise _Fail
        if (4 * n + 3) * self.W > c.length or 2 * D * self.W > c.length:
            self.add(
                "SWPM_COUNT_EXCEEDS_CHUNK",
                c.offset if (4 * n + 3) * self.W > c.length else c.offset + 4,
                "MLVL",
            )
            raise _Fail
        arrs = self.level_arrays("MLVL", 8, [n, n + 1, n + 1, n + 1, D, D])
        (lfl, _), (lss, lss_o), (lds, lds_o), (lrs, lrs_o), (ldi, ldi_o), (ldc, ldc_o) = arrs
        recs, offs, op = self.read_records("MREC", 5)
        R = recs.shape[0]
        names = [
            "level_first_lod",
            "level_static_start",
            "level_dynamic_start",
            "level_record_start",
            "level_dynamic_indices",
            "level_dynamic_collapsed_indices",
        ]
        for name, (a, _o) in zip(names, arrs, strict=True):
            self.buffers[name] = a
        self.buffers["level_static_indices"] = self.indx
        cols = ["kept", "static_tris_removed", "dynamic_tris_removed", "change_count", "prev_change_count"]
        for i, name in enumerate(cols):
            self.buffers[name] = np.ascontiguousarray(recs[:, i])
        self.buffers["change_offsets"] = offs
        N = len(self.indx)
        self.check_levels(
            "SWPM_MIXED_BAD_LEVELS",
            "MLVL",
            arrs[0],
            [(lss, lss_o, N, 3), (lds, lds_o, D, 3), (lrs, lrs_o, R, 1)],
        )
        rc = self.read_rcnt(R)
        lfl_l = [int(x) for x in lfl]
        lrs_l = [int(x) for x in lrs]
        for lev in range(n):
            if lrs_l[lev] != int(rc[lfl_l[lev]]):
                self.add("SWPM_MIXED_BAD_LEVELS", lrs_o + self.W * lev, "MLVL")
                raise _Fail
        for arr, off in ((ldi, ldi_o), (ldc, ldc_o)):
            bad = arr.astype(np.int64) >= self.V
            if bad.any():
                self.add("SWPM_INDEX_OUT_OF_RANGE", off + self.W * int(np.argmax(bad)), "MLVL")
                raise _Fail
        self.check_kept("MREC", recs, 5)
        starts = [0]
        for r in range(R):
            starts.append(starts[-1] + int(recs[r, 3]))
        offl = [int(x) for x in offs]
        io = self.chunks["INDX"].offset
        for lev in range(n):
            first_lod = lfl_l[lev]
            last_lod = lfl_l[lev + 1] - 1 if lev + 1 < n else self.L - 1
            lim = int(self.vc[first_lod])
            s_lo, s_hi = int(lss[lev]), int(lss[lev + 1])
            d_lo, d_hi = int(lds[lev]), int(lds[lev + 1])
            stat = [int(x) for x in self.indx[s_lo:s_hi]]
            dyn = [int(x) for x in ldi[d_lo:d_hi]]
            for j, x in enumerate(stat):
                if x >= lim:
                    self.add("SWPM_PREFIX_VIOLATION", io + self.W * (s_lo + j), "INDX")
                    raise _Fail
            for j, x in enumerate(dyn):
                if x >= lim:
                    self.add("SWPM_PREFIX_VIOLATION", ldi_o + self.W * (d_lo + j), "MLVL")
                    raise _Fail
            s_live, d_live = len(stat) // 3, len(dyn) // 3
            live_after = {lrs_l[lev]: s_live + d_live}
            for r in range(lrs_l[lev], lrs_l[lev + 1]):
                binned = self.V - 1 - r
                kept, s_tr, d_tr = int(recs[r, 0]), int(recs[r, 1]), int(recs[r, 2])
                if s_tr > s_live or d_tr > d_live:
                    self.add(
                        "SWPM_RECORD_BAD_COUNTS",
                        self.rec_field("MREC", 5, r, 1 if s_tr > s_live else 2),
                        "MREC",
                    )
                    raise _Fail
                s_live -= s_tr
                d_live -= d_tr
                for j in range(starts[r], starts[r + 1]):
                    s = offl[j]
                    if s >= len(dyn):
                        self.add("SWPM_INDEX_OUT_OF_RANGE", op + self.W * j, "MREC")
                        raise _Fail
                    if dyn[s] != binned or s >= 3 * d_live:
                        self.add("SWPM_RECORD_BAD_CHANGE", op + self.W * j, "MREC")
                        raise _Fail
                    dyn[s] = kept
                if binned in stat[: 3 * s_live] or binned in dyn[: 3 * d_live]:
                    self.add("SWPM_RECORD_BAD_CHANGE", self.rec_field("MREC", 5, r, 0), "MREC")
                    raise _Fail
                live_after[r + 1] = s_live + d_live
            if [int(x) for x in ldc[d_lo:d_hi]] != dyn:
                self.add("SWPM_MIXED_BAD_LEVELS", ldc_o + self.W * d_lo, "MLVL")
                raise _Fail
            lim_c = self.V - lrs_l[lev + 1]
            if any(x >= lim_c for x in dyn[: 3 * d_live]):
                self.add("SWPM_PREFIX_VIOLATION", ldc_o + self.W * d_lo, "MLVL")
                raise _Fail
            for k in range(first_lod, last_lod + 1):
                rk = int(rc[k])
                if rk not in live_after or live_after[rk] != int(self.tc[k]):
                    self.add("SWPM_RECORD_BAD_COUNTS", self.chunks["RCNT"].offset + self.W * k, "RCNT")
                    raise _Fail

    # -------------------------------------------------------------------- SMAP
    def read_smap(self) -> None:
        c = self.chunks["SMAP"]
        p = c.offset

        def invalid() -> None:
            self.add("SWPM_SMAP_INVALID", p, "SMAP")

        if c.length < 8:
            return invalid()
        B, N = struct.unpack_from("<II", self.data, p)
        if B < 1 or 24 * B + 16 * N > c.length - 8:
            return invalid()
        if c.length != 8 + 24 * B + 16 * N:
            return invalid()
        ranges = [struct.unpack_from("<QQ", self.data, p + 8 + 24 * B + 16 * i) for i in range(N)]
        ic, vc = self.chunks["INDX"], self.chunks["VERT"]
        stride, data_offset = struct.unpack_from("<II", self.data, vc.offset + 8)
        next_lod = 0
        for b in range(B):
            first, count, rs, rn, prefix = struct.unpack_from("<IIIIQ", self.data, p + 8 + 24 * b)
            if first != next_lod or count < 1 or first + count > self.L or rn > 16 or rs + rn > N:
                return invalid()
            next_lod = first + count
            band = ranges[rs : rs + rn]
            hulls = [(0, ic.offset)]
            b_lo, b_hi = None, None
            for k in range(first, first + count):
                lo, hi = self.lod_index_range(k)
                if hi > lo:
                    b_lo = lo if b_lo is None else min(b_lo, lo)
                    b_hi = hi if b_hi is None else max(b_hi, hi)
            if b_lo is not None and b_hi is not None:
                hulls.append((ic.offset + self.W * b_lo, ic.offset + self.W * b_hi))
            hulls.append((vc.offset, vc.offset + data_offset + int(self.vc[first]) * stride))
            for lo, hi in hulls:
                if not any(ro <= lo and hi <= ro + rl for ro, rl in band):
                    return invalid()
            if prefix != max(hi for _lo, hi in hulls):
                return invalid()
        if next_lod != self.L:
            return invalid()
        return None

    def lod_index_range(self, k: int) -> tuple[int, int]:
        """The INDX elements [lo, hi) that LOD k needs (§4 (b))."""
        if self.encoding == "vanilla":
            return 0, len(self.indx)
        if self.encoding == "sliding-window":
            first, tcount, _v = (int(x) for x in self.buffers["window_records"][k])
            return first, first + 3 * tcount
        lfl = [int(x) for x in self.buffers["level_first_lod"]]
        lev = self.level_of(lfl, k)
        key = "level_index_start" if self.encoding == "skip-strip" else "level_static_start"
        starts = self.buffers[key]
        return int(starts[lev]), int(starts[lev + 1])

    # ------------------------------------------------------------------ result
    def result(self) -> dict[str, Any]:
        valid = not self.rep.has_error()
        out: dict[str, Any] = {"valid": valid, "problems": self.rep.problems}
        if valid:
            out["summary"] = {
                "encoding": self.encoding,
                "index_width": self.W,
                "lod_count": self.L,
                "vertex_count": self.V,
                "triangle_count": self.T0,
                "params": self.params,
                "buffers": {name: _hash(arr) for name, arr in sorted(self.buffers.items())},
            }
        return out


def read(data: bytes) -> dict[str, Any]:
    """Validate and decode an SWPM v1 file held in memory; never raises on malformed input."""
    return _Reader(data).run()
