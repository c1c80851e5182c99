"""Rewrite a valid `.swpm` file as an OFFSET32 file, from spec/format.md alone (§1, §2, §3.5-3.8).

Test tool for the independent reader and the engine model: a file of fewer than 65,536 vertices gets `idx`
u16 (`INDX`, skip-strip's `level_collapsed_indices`, mixed's two dynamic lists) and `off` u32 (`WREC`, the
record rows and change offsets, `RCNT`, the level tables), the required-feature bit `OFFSET32` set and
`INDEX32` cleared. A u32 file's restart index 0xFFFFFFFF becomes 0xFFFF (what a u32 -> u16 copy makes of it,
§3.5), in the arrays and in `META.params`. `SMAP` is dropped (its byte ranges would move; it is ancillary).
Every value is kept, so each `off` array holds what it held and each `idx` array the same values narrowed.
It never imports `swpm_usd`.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np

INDEX32, OFFSET32 = 1, 64
RECORD_COLUMNS = {b"VREC": 4, b"SREC": 4, b"MREC": 5}
LEVEL_LISTS = {b"SKIP": 1, b"MLVL": 2}


def _align(n: int, a: int) -> int:
    return (n + a - 1) // a * a


def _narrow(a: np.ndarray) -> np.ndarray:
    """idx values as u16: a u32 restart 0xFFFFFFFF becomes 0xFFFF; every other value must fit below it."""
    a = a.astype(np.int64)
    a[a == 0xFFFFFFFF] = 0xFFFF
    if len(a) and int(a.max()) > 0xFFFF:
        raise ValueError("an idx value does not fit u16")
    return a.astype("<u2")


def _records(p: bytes, cols: int, O: int) -> bytes:
    R, M = struct.unpack_from("<II", p, 0)
    dt = "<u4" if O == 4 else "<u2"
    rec = np.frombuffer(p, dt, cols * R, 8)
    offs = np.frombuffer(p, dt, M, 8 + _align(cols * O * R, 4))
    out = struct.pack("<II", R, M) + rec.astype("<u4").tobytes()
    out += bytes(-len(out) % 4)  # align4 (a no-op for u32 rows; kept for the rule)
    return out + offs.astype("<u4").tobytes()


def _levels(p: bytes, lists: int, W: int, O: int) -> bytes:
    n, count = struct.unpack_from("<II", p, 0)
    odt, idt = ("<u4" if O == 4 else "<u2"), ("<u4" if W == 4 else "<u2")
    out, pos = bytearray(struct.pack("<II", n, count)), 8
    for i, size in enumerate([n, n + 1, n + 1, n + 1] + [count] * lists):
        pos = _align(pos, 4) if i else pos
        table = i < 4
        arr = np.frombuffer(p, odt if table else idt, size, pos)
        pos += size * (O if table else W)
        out += bytes(-len(out) % 4) if i else b""
        out += arr.astype("<u4").tobytes() if table else _narrow(arr).tobytes()
    return bytes(out)


def to_offset32(data: bytes) -> bytes:
    """The OFFSET32 file holding ``data``'s values (``data``: a valid file without OFFSET32)."""
    _header_size, flags, features, count = struct.unpack_from("<IIII", data, 12)
    table = struct.unpack_from("<Q", data, 32)[0]
    if features & OFFSET32:
        raise ValueError("already OFFSET32")
    W = 4 if features & INDEX32 else 2
    O = W
    chunks = []
    for i in range(count):
        ctype, cflags, off, length = struct.unpack_from("<4sIQQ", data, table + 32 * i)
        p = data[off : off + length]
        if ctype == b"SMAP":
            continue
        if ctype == b"INDX":
            p = _narrow(np.frombuffer(p, "<u4" if W == 4 else "<u2")).tobytes()
        elif ctype in (b"RCNT", b"WREC"):
            p = np.frombuffer(p, "<u4" if O == 4 else "<u2").astype("<u4").tobytes()
        elif ctype in RECORD_COLUMNS:
            p = _records(p, RECORD_COLUMNS[ctype], O)
        elif ctype in LEVEL_LISTS:
            p = _levels(p, LEVEL_LISTS[ctype], W, O)
        elif ctype == b"META":
            p = p.replace(b'"restart_index":4294967295', b'"restart_index":65535')
        chunks.append((ctype, cflags, p))
    table_end = 64 + 32 * len(chunks)
    out = bytearray(table_end)
    pos = _align(table_end, 8)
    for i, (ctype, cflags, p) in enumerate(chunks):
        out += bytes(pos - len(out))
        crc = zlib.crc32(p, zlib.crc32(ctype)) & 0xFFFFFFFF
        struct.pack_into("<4sIQQII", out, 64 + 32 * i, ctype, cflags, pos, len(p), crc, 0)
        out += p
        pos = _align(len(out), 8)
    out[0:12] = data[0:8] + struct.pack("<HH", 1, 0)
    new_features = (features & ~INDEX32) | OFFSET32
    struct.pack_into("<IIIII", out, 12, 64, flags, new_features, len(chunks), 0)
    struct.pack_into("<QQ", out, 32, 64, len(out))
    struct.pack_into("<I", out, 48, zlib.crc32(bytes(out[:table_end])) & 0xFFFFFFFF)
    return bytes(out)
