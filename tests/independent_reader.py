"""Independent reader for SWPM v1, written from spec/format.md and spec/errors.md only.

It does not import or look at the project's own codec (``swpm_usd``); its purpose is to test whether the
specification is precise enough for a second implementation to agree with the conformance vectors.

``read(data)`` returns ``{"valid", "problems", "summary"}`` in the shape of the vectors' expected JSON:
the problems in the order of the checks of format.md §5 ("Reporting"), each at the offset the column
"Offset reported" of errors.md gives, and for a valid file the summary of §7.

``read_prefix(prefix)`` opens the first n bytes of a file as §4.1 says, in the shape of the vectors' prefix
cases: written from §4.1 before its codec counterpart was read, it agreed with the codec at every cut of
every vector at once. Where §4.1 was silent it decided, and the text now says so: with n < 64 step 1 applies
whatever file_size the bytes hold (the need is 64); a ``VERT`` header cut by n needs o + 16 (data_offset is
in it); a header_size past file_size is ``SWPM_HEADER_BAD_SIZE`` (a prefix cannot compare it with the file's
length), which the whole file reports as a table error.

``read_ranges(data, ranges)`` opens the byte ranges of a file it holds as §4.2 says, in the shape of the
vectors' range cases. It was written from §4.2's text before the codec's ``swpm_usd/format/ranges.py`` or the
C reader were read; comparing them, the text left these open and now says what the codec and the C reader
did (this reader had decided otherwise and follows the text):

* the chunk table's check needs [0, table end), all that ``file_crc`` covers (it had needed only the table
  and deferred the file CRC), and a header_size in [64, file_size] past the last byte held needs
  [0, header_size) where §5 checks header_size (it had needed only [0, 64));
* the held lists' ``SWPM_PREFIX_VIOLATION`` is one problem, found after step 5 of §5, LODs in order (it had
  reported one per LOD, in place of the prefix property's stage).
* skip-strip's collapsed lists' prefix waits with the replay (stage (d)), though it reads ``SKIP`` only (it
  had run it: the checks that read no ``INDX`` element ran); mixed's dynamic and collapsed lists' prefix
  (stage (c)) runs in all three;
* a header whose file_size is below 64 lies past its own file_size: each reader took it otherwise (the codec
  and the C reader refused the ranges as the caller's error, this one read the first file_size bytes as a
  file, ``SWPM_HEADER_TRUNCATED``); §4.2 step 1 now makes it the file's error, §5 run on the bytes held.

Where the readers disagreed and the text said which was right, a reader was fixed: the codec read bytes not
held as zeros (a table after ``INDX`` not held gave ``SWPM_CHUNK_BAD_LENGTH`` on a valid file, an ``SMAP``
not held ``SWPM_SMAP_INVALID``; the C reader and this one ask for the table and skip the ``SMAP``), and it
deferred the CRC of an empty payload past the last byte held (an empty payload is wholly held). The tables
after ``INDX`` are asked for in §2.3's order (the C reader's; the other two went by table order).

The spec settles the offsets, the order, the stages, the multiplicity, the buffers, strict JSON for
``META`` (no ``NaN``/``Infinity``, no duplicate key in any object) and the skip-strip ``params``. Since the
audit of a second reader (F1-F13) it also settles the cases this reader used to decide for itself, which it
now follows as written:

* An entry with a bad type gets every check of §5 step 2: its type is unknown, so it is also
  ``SWPM_CHUNK_UNKNOWN_CRITICAL`` or ``_ANCILLARY`` by its critical bit (no CRC, critical-bit, allowed or
  duplicate check).
* ``SWPM_STREAM_ORDER`` (§2.3): the entries of the encoding's chunk types, in table order with duplicates
  (unknown chunks and chunks of another encoding skipped wherever they are), compared position by position
  with ``META LODS SMAP [tables] INDX VERT`` restricted to the types present; the entry at the first
  differing position, else the first ``VERT`` when the last entry is not a ``VERT``.
* ``VERT`` (§3.3): length >= 16; the descriptors' count (``SWPM_COUNT_EXCEEDS_CHUNK`` at payload + 4);
  attribute_count <= 255, stride and data_offset (also one past the payload: ``SWPM_VERT_BAD_LAYOUT``);
  vertex_count (``SWPM_COUNT_EXCEEDS_CHUNK``); length; then the descriptors (stride a multiple of every
  element size) and the overlap.
* Stage 0 (§5 step 4): the record chunk, ``RCNT`` a multiple of O, ``INDX`` (vanilla: a multiple of 3 W),
  then ``SKIP``/``MLVL``; sliding-window ``WREC`` then ``INDX``. ``RCNT`` holding L counts is one of the
  counts of §3.6 in stage (a), after the change counts and ``prev_change_count``
  (``SWPM_CHUNK_BAD_LENGTH`` at its payload, its values then unchecked).
* Vanilla ``T0`` is ``INDX`` count / 3 (§3.4); a ``LODS`` triangle_count(0) other than that is
  ``SWPM_RECORD_BAD_COUNTS`` at row 0 in stage (b). The summary's ``triangle_count`` is ``LODS`` row 0 (§7).
* Skip-strip ``kept``/``binned`` >= V are ``SWPM_INDEX_OUT_OF_RANGE`` in stage (a), after ``INDX`` and
  ``level_collapsed_indices``; stage (c) checks ``binned`` = V-1-r, then ``kept`` < V-1-r.
* The start arrays of ``SKIP``/``MLVL``: element 0 = 0, element n = the total, non-decreasing.

A third audit (a reader written from the spec alone) found ``META`` open where RFC 8259 lets parsers set
limits, and the reference reader's answer depending on its environment (how deep the caller's stack was,
``PYTHONINTMAXSTRDIGITS``); §3.1 now fixes them: arrays and objects nest at most 128 deep, a number that
rounds to infinity in binary64 (``1e400``) is not JSON as ``Infinity`` is not, an integer below that is
exact, an escaped unpaired surrogate is accepted.

A later audit settled these (vectors ``chunk-moved-past-end``, ``duplicate-vert-trailing``,
``record-changes-slot-twice``), and wrote down the decisions this reader had made for itself:

* §2.2: the padding gap before a chunk that starts past the end of the file is checked up to the end of the
  file, after the entry's ``SWPM_CHUNK_OUT_OF_BOUNDS``.
* §2.3: in the stream-order comparison a position past the end of the order (a trailing duplicate, e.g. a
  second ``VERT`` after the first) differs.
* §3.6: a record's changes are made one after another in the order listed, so a slot listed twice by one
  record no longer holds the binned vertex the second time (``SWPM_RECORD_BAD_CHANGE``).
* §2.1, §5: ``header_size`` "past the end of the file" is compared with the length of the file as given;
  the table and the chunks are bounded by the bytes read (the file, cut at ``file_size`` when longer).
* §3.1: a leading BOM is not JSON. §3.7: a missing ``restart_index`` reads as null and it is type-checked
  for ``"list"`` too; it is an integer when JSON gives it without fraction or exponent (``65535.0`` and
  ``6.5535e4`` are ``SWPM_META_BAD_FIELD``). §3.7, §3.8: ``level_count`` 0 is a level-table problem
  (``SKIP``: payload; ``MLVL``: a bad ``level_first_lod``).
* §2.1, §3.5: the ``SW_STRIPS`` bit (a sliding-window strip pool): ``WREC`` rows of four fields, ``params``
  agreeing with the bit, every window starting a strip, each window's strips decoded on their own here (not
  by the prefix sum §3.5 suggests) against its triangle count.
* §5 step 2: ``SWPM_CHUNK_NOT_ALLOWED`` is only checked when exactly one encoding bit is set; a chunk that
  is not allowed is not also reported as a duplicate. ``SWPM_CHUNK_MISSING`` lists absent chunks in
  streaming order; a chunk is absent when no entry has its type.

Reading the spec as a second implementer (vectors ``skip-collapsed-start-not-index-start``,
``smap-17-ranges``, ``smap-range-in-trailing-bytes``, ``smap-empty-index-hull``) found the reference reader
deciding these differently; the spec now says what this reader did, and the reference reader follows:

* §5 skip-strip stage (a): the level table by itself (``level_collapsed_start`` = ``level_index_start``
  and whole triangles for ``"list"`` included) is checked before the values < V; only its agreement with
  ``RCNT`` is a stage (c) check.
* §4: the SMAP checks in order (length; the bands, ``range_count`` <= 16 among them; every range inside the
  file as read, i.e. its first ``file_size`` bytes; the hulls; ``prefix_length``), the first problem only.
  An LOD that needs no ``INDX`` element adds nothing to its band's (b) hull; an empty (b) hull needs no
  range and does not count for ``prefix_length``.

What the spec still leaves open, and how this reader decides:

* Replays (vanilla, mixed, skip-strip) stop at their first problem: one problem per replay, so a slot that
  does not hold the binned vertex is not also a prefix violation of the same record (vector
  ``record-changes-wrong-slot``); after a replay problem the collapsed list is not compared. Skip-strip's
  collapsed-list prefix check (stage (d), "then the collapsed lists' prefix") is a separate check of the
  stage: it runs over all levels even after a replay problem.

(The sliding-window prefix property's lowest offending element of ``INDX`` over all windows, which this
reader chose, is §3.5's rule since the third audit.)

Two integer types (§1, required-feature bit 6 ``OFFSET32``): ``idx`` (W bytes) only for the arrays an engine
uploads (``INDX``, ``level_collapsed_indices``, mixed's two dynamic lists), ``off`` (O bytes) for every table:
``WREC``, the record rows and ``change_offsets``, ``RCNT``, the four level-table arrays of ``SKIP``/``MLVL``.
O is 4 with ``INDEX32`` or ``OFFSET32``; both together are ``SWPM_HEADER_OFFSET32_WITH_INDEX32`` (after
``SW_STRIPS``, not stopping the header's checks, the file then read with O = W = 4). Read from the spec text
alone, where it was open:

* §1 lists ``RCNT`` and "the records' vertex columns" under ``off``; every record column (``kept``,
  ``binned``, the counts) and ``change_offsets`` are read as ``off``, as the layouts of §3.6-3.8 say.
* ``OFFSET32`` on a file whose tables all fit u16 (a writer SHOULD NOT set it) is valid: no code reports it.
"""

from __future__ import annotations

import hashlib
import json
import math
import struct
import zlib
from typing import Any

import numpy as np


def nesting(text: str) -> int:
    """The deepest nesting of arrays and objects in JSON ``text``, brackets inside strings not counted."""
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest


MAGIC = b"SWPM\r\n\x1a\n"
HEADER_SIZE = 64
ENTRY_SIZE = 32
MAX_CHUNKS = 1024
MAX_PER_CODE = 20

INDEX32 = 1 << 0
ENCODING_BITS = {1 << 1: "vanilla", 1 << 2: "sliding-window", 1 << 3: "skip-strip", 1 << 4: "mixed"}
SW_STRIPS = 1 << 5  # §2.1: a sliding-window strip pool
OFFSET32 = 1 << 6  # §1, §2.1: the table type off is u32 while idx is u16
KNOWN_FEATURES = INDEX32 | sum(ENCODING_BITS) | SW_STRIPS | OFFSET32
TYPE_CHARS = frozenset(b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789")

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
COMMON = ("META", "LODS", "SMAP", "INDX", "VERT")
ENCODING_TABLES = {
    "vanilla": ["RCNT", "VREC"],
    "sliding-window": ["WREC"],
    "skip-strip": ["RCNT", "SKIP", "SREC"],
    "mixed": ["RCNT", "MLVL", "MREC"],
}
RECORD_COLUMNS = {
    "vanilla": ("kept", "tris_removed", "change_count", "prev_change_count"),
    "skip-strip": ("kept", "binned", "change_count", "prev_change_count"),
    "mixed": ("kept", "static_tris_removed", "dynamic_tris_removed", "change_count", "prev_change_count"),
}

SEVERITY = {
    "SWPM_HEADER_TRUNCATED": "error",
    "SWPM_HEADER_BAD_MAGIC": "error",
    "SWPM_HEADER_UNSUPPORTED_MAJOR": "error",
    "SWPM_HEADER_NEWER_MINOR": "info",
    "SWPM_HEADER_BAD_SIZE": "error",
    "SWPM_HEADER_UNKNOWN_FEATURE": "error",
    "SWPM_HEADER_BAD_ENCODING": "error",
    "SWPM_HEADER_STRIPS_NOT_SLIDING": "error",
    "SWPM_HEADER_OFFSET32_WITH_INDEX32": "error",
    "SWPM_WINDOW_MID_STRIP": "error",
    "SWPM_WINDOW_STRIP_TRIANGLES": "error",
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
    "SWPM_PREFIX_TOO_SHORT": "error",
    "SWPM_PREFIX_NOT_STREAMABLE": "error",
    "SWPM_RANGES_NOT_HELD": "error",
    "SWPM_RECORD_BAD_KEPT": "error",
    "SWPM_RECORD_BAD_BINNED": "error",
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


def _align4(n: int) -> int:
    return (n + 3) & ~3


def _first_bad(values: list[int], bad: Any) -> int | None:
    """Index of the first element for which ``bad(i, x)`` holds, else None."""
    for i, x in enumerate(values):
        if bad(i, x):
            return i
    return None


class _Report:
    def __init__(self) -> None:
        self.problems: list[dict[str, Any]] = []
        self.counts: dict[str, int] = {}
        self.total = 0

    def add(self, code: str, offset: int | None) -> None:
        """Record a problem; beyond MAX_PER_CODE problems of one code they are only counted (§5)."""
        self.total += 1
        n = self.counts.get(code, 0) + 1
        self.counts[code] = n
        if n <= MAX_PER_CODE:
            self.problems.append({"code": code, "severity": SEVERITY[code], "offset": offset})

    def has_error(self) -> bool:
        return any(SEVERITY[code] == "error" for code in self.counts)


class _Chunk:
    def __init__(self, ctype: str, entry: int, offset: int, length: int) -> None:
        self.type = ctype
        self.entry = entry
        self.offset = offset
        self.length = length


def _hash(arr: np.ndarray) -> dict[str, Any]:
    return {
        "sha256": hashlib.sha256(np.ascontiguousarray(arr).tobytes()).hexdigest(),
        "shape": list(arr.shape),
    }


class _Reader:
    def __init__(self, data: bytes, prefix: bool = False, held: list[tuple[int, int]] | None = None) -> None:
        self.raw = bytes(data)
        self.data = self.raw
        # §4.1: reading a prefix, the first n bytes of a file of file_size bytes; self.size is the end of the
        # file (§1) that bounds the table and the chunks, while self.data holds only the bytes at hand
        self.prefix = prefix or held is not None
        # §4.2: reading byte ranges, the disjoint sorted runs [a, b) held (self.data holds zeros elsewhere)
        self.held_runs = held
        self.indx_whole = True  # §4.2 step 3: INDX wholly held (else the checks reading it are deferred)
        self.size = len(self.raw)
        self.rep = _Report()
        self.chunks: dict[str, _Chunk] = {}
        self.entries: list[_Chunk] = []
        self.encoding: str | None = None
        self.minor = 0
        self.strips = False
        self.W = 2
        self.idt = "<u2"
        self.O = 2
        self.odt = "<u2"
        self.buffers: dict[str, np.ndarray] = {}
        self.params: dict[str, Any] = {}
        self.V = 0
        self.L = 0
        self.T0 = 0
        self.vc: list[int] = []
        self.tc: list[int] = []
        self.stride = 0
        self.data_offset = 0
        self.attrs: list[Any] = []
        self.indx = np.zeros(0, dtype=np.int64)
        self.indx_off = 0
        self.level_first: list[int] = []
        self.level_starts: list[int] = []

    # ----------------------------------------------------------------- helpers
    def add(self, code: str, offset: int | None) -> None:
        self.rep.add(code, offset)

    def u32(self, off: int) -> int:
        return struct.unpack_from("<I", self.data, off)[0]

    def view(self, off: int, count: int, table: bool = False) -> np.ndarray:
        """The idx[count] array (``table``: off[count]) at absolute ``off`` (a view); the caller has checked
        the bounds."""
        dt = self.odt if table else self.idt
        if count == 0:
            return np.zeros(0, dtype=dt)
        end = off + count * np.dtype(dt).itemsize
        if end > len(self.data):  # (ranges: INDX past the last byte held; only its held elements are read)
            return np.frombuffer(self.data[off:] + bytes(end - len(self.data)), dtype=dt, count=count)
        return np.frombuffer(self.data, dtype=dt, count=count, offset=off)

    def check_zero(self, start: int, end: int) -> None:
        """The padding gap [start, end) MUST be zero; reported at the start of the gap (errors.md). Only the
        bytes at hand are checked: a prefix's or held range's others are checked on finishing (§4.1, §4.2)."""
        end = min(end, len(self.data))
        parts = [(start, end)] if self.held_runs is None else self.held_parts(start, end)
        if any(a < b and self.data[a:b].count(0) != b - a for a, b in parts):
            self.add("SWPM_PADDING_NONZERO", start)

    def held(self, a: int, b: int) -> bool:
        """Every byte of [a, b) is at hand (§4.2's held(a, b); a prefix holds [0, n))."""
        if self.held_runs is None:
            return b <= len(self.data)
        if b <= a:
            return True
        return any(s <= a and b <= e for s, e in self.held_runs)

    def held_parts(self, a: int, b: int) -> list[tuple[int, int]]:
        """The held parts of [a, b)."""
        assert self.held_runs is not None
        return [(max(a, s), min(b, e)) for s, e in self.held_runs if max(a, s) < min(b, e)]

    def first_unheld(self, a: int, b: int) -> int:
        """The first byte of [a, b) not held (the caller knows one is not)."""
        x = a
        for s, e in self.held_runs or []:
            if s <= x < e:
                x = e
        return x

    def not_held(self, start: int, end: int) -> bool:
        """§4.2: SWPM_RANGES_NOT_HELD at the first byte of [start, end) not held, with the range; True if
        reported."""
        if self.held(start, end):
            return False
        self.add("SWPM_RANGES_NOT_HELD", self.first_unheld(start, end))
        self.rep.problems[-1].update(need_start=start, need=end)
        return True

    def first_n(self, mask: np.ndarray, base: int, step: int, n: int = 3) -> None:
        """Report SWPM_INDEX_OUT_OF_RANGE at the first ``n`` set elements of ``mask``."""
        for i in np.flatnonzero(mask)[:n].tolist():
            self.add("SWPM_INDEX_OUT_OF_RANGE", base + step * i)

    # ----------------------------------------------------------------- step 1
    def run(self) -> dict[str, Any]:
        table = self.header()
        if table is None:
            return self.result()
        self.table(*table)
        if self.rep.has_error():
            return self.result()
        if self.held_runs is not None and not self.ranges_hold_the_skeleton():
            return self.result()
        if self.held_runs is None and self.prefix and not self.streams():
            return self.result()
        self.payloads()
        return self.result()

    def too_short(self, need: int) -> None:
        """§4.1: SWPM_PREFIX_TOO_SHORT at n, with the prefix length the failed check needs."""
        self.add("SWPM_PREFIX_TOO_SHORT", len(self.raw))
        self.rep.problems[-1]["need"] = need

    def streams(self) -> bool:
        """§4.1 step 3: the last table entry is a VERT and the prefix holds every byte before its records."""
        last = self.entries[-1]
        if last.type != "VERT":
            self.add("SWPM_PREFIX_NOT_STREAMABLE", last.entry)
            return False
        o, length = self.chunks["VERT"].offset, self.chunks["VERT"].length
        if length < 16:
            need = o + length
        elif len(self.data) < o + 16:
            need = o + 16  # data_offset is not at hand yet: the check needs VERT's header first
        else:
            need = o + max(16, min(self.u32(o + 12), length))
        if len(self.data) < need:
            self.too_short(need)
            return False
        return True

    def ranges_hold_the_skeleton(self) -> bool:
        """§4.2 step 3: every byte before INDX ((a) of §4) and VERT's bytes before its vertex records."""
        o, length = self.chunks["VERT"].offset, self.chunks["VERT"].length
        if self.not_held(0, self.chunks["INDX"].offset):
            return False
        if length < 16:
            return not self.not_held(o, o + length)
        if self.not_held(o, o + 16):  # data_offset is in VERT's 16-byte header
            return False
        if self.not_held(o, o + max(16, min(self.u32(o + 12), length))):
            return False
        # every other chunk steps 3-4 of §5 decode (before INDX in streaming order), in the order of §2.3;
        # SMAP, ancillary, is not checked when not wholly held
        for ctype in ["META", "LODS", *ENCODING_TABLES[self.encoding or "vanilla"]]:  # in §2.3's order
            c = self.chunks[ctype]
            if self.not_held(c.offset, c.offset + c.length):
                return False
        return True

    def header(self) -> tuple[int, int, int] | None:
        d = self.raw
        if len(d) < HEADER_SIZE:
            bad_magic = len(d) >= 8 and d[:8] != MAGIC
            self.add("SWPM_HEADER_BAD_MAGIC" if bad_magic else "SWPM_HEADER_TRUNCATED", 0)
            return None
        if d[:8] != MAGIC:
            self.add("SWPM_HEADER_BAD_MAGIC", 0)
            return None
        major, minor = struct.unpack_from("<HH", d, 8)
        if major != 1:
            self.add("SWPM_HEADER_UNSUPPORTED_MAJOR", 8)
            return None
        self.minor = minor
        if minor > 0:
            self.add("SWPM_HEADER_NEWER_MINOR", 10)
        header_size, _flags, features, chunk_count, reserved0 = struct.unpack_from("<IIIII", d, 12)
        table_offset, file_size = struct.unpack_from("<QQ", d, 32)
        file_crc = struct.unpack_from("<I", d, 48)[0]
        if header_size < HEADER_SIZE or header_size > (file_size if self.prefix else len(d)):
            self.add("SWPM_HEADER_BAD_SIZE", 12)
            return None
        # §4.1 step 2: a header_size in [64, file_size] past n; §4.2 step 2: past the last byte held
        if header_size > len(d) and self.held_runs is not None:
            self.not_held(0, header_size)
            return None
        if header_size > len(d):
            self.too_short(header_size)
            return None
        if features & ~KNOWN_FEATURES:
            self.add("SWPM_HEADER_UNKNOWN_FEATURE", 20)
        enc_bits = [b for b in ENCODING_BITS if features & b]
        if len(enc_bits) == 1:
            self.encoding = ENCODING_BITS[enc_bits[0]]
        else:
            self.add("SWPM_HEADER_BAD_ENCODING", 20)
        self.strips = bool(features & SW_STRIPS)
        if self.strips and not features & (1 << 2):
            self.add("SWPM_HEADER_STRIPS_NOT_SLIDING", 20)
        if features & OFFSET32 and features & INDEX32:
            # §2.1: does not stop the header's checks; the file is read with off = idx = u32
            self.add("SWPM_HEADER_OFFSET32_WITH_INDEX32", 20)
        self.W = 4 if features & INDEX32 else 2
        self.idt = "<u4" if self.W == 4 else "<u2"
        self.O = 4 if features & (INDEX32 | OFFSET32) else 2
        self.odt = "<u4" if self.O == 4 else "<u2"
        if minor == 0:
            if reserved0:
                self.add("SWPM_HEADER_RESERVED_NONZERO", 28)
            if any(d[52:64]):
                self.add("SWPM_HEADER_RESERVED_NONZERO", 52)
        if self.prefix:
            self.size = file_size  # the length is checked on finishing (§4.1 step 2)
        elif len(d) < file_size:
            self.add("SWPM_FILE_SIZE_MISMATCH", 40)
        elif len(d) > file_size:
            self.add("SWPM_FILE_TRAILING_BYTES", file_size)
            self.data = d[:file_size]
        if not self.prefix:
            self.size = len(self.data)
        if table_offset < header_size or table_offset % 8:
            self.add("SWPM_TABLE_BAD_OFFSET", 32)
            return None
        if chunk_count > MAX_CHUNKS:
            self.add("SWPM_TABLE_TOO_LARGE", 24)
            return None
        table_end = table_offset + ENTRY_SIZE * chunk_count
        if table_end > self.size:
            self.add("SWPM_TABLE_TRUNCATED", 24)
            return None
        if self.held_runs is not None:
            if self.not_held(0, table_end):  # §4.2 step 2: every byte to the table's end (file_crc's)
                return None
        elif table_end > len(self.data):  # §4.1 step 2: a table that ends past n, not past file_size
            self.too_short(table_end)
            return None
        buf = bytearray(self.data[:table_end])
        buf[48:52] = bytes(4)
        if zlib.crc32(bytes(buf)) & 0xFFFFFFFF != file_crc:
            self.add("SWPM_CHECKSUM_MISMATCH", 48)
        self.check_zero(header_size, table_offset)
        return table_offset, chunk_count, table_end

    # ----------------------------------------------------------------- step 2
    def table(self, table_offset: int, count: int, table_end: int) -> None:
        size = self.size
        last, end = -1, table_end
        for i in range(count):
            eo = table_offset + ENTRY_SIZE * i
            raw_type, flags, offset, length, crc, reserved = struct.unpack_from("<4sIQQII", self.data, eo)
            type_ok = all(c in TYPE_CHARS for c in raw_type)
            if not type_ok:
                self.add("SWPM_CHUNK_BAD_TYPE", eo)
            bounds_ok = offset + length <= size
            if not bounds_ok:
                self.add("SWPM_CHUNK_OUT_OF_BOUNDS", eo + 8)
            align_ok = offset % 8 == 0
            if not align_ok:
                self.add("SWPM_CHUNK_MISALIGNED", eo + 8)
            place_ok = True
            if offset < last:
                self.add("SWPM_CHUNK_OUT_OF_ORDER", eo + 8)
                place_ok = False
            else:
                if offset < end:
                    self.add("SWPM_CHUNK_OVERLAP", eo + 8)
                    place_ok = False
                else:
                    self.check_zero(end, offset)
                last, end = offset, max(end, offset + length)
            if self.minor == 0 and reserved:
                self.add("SWPM_HEADER_RESERVED_NONZERO", eo + 28)
            # a prefix checks the CRC of a payload that ends past n on finishing (§4.1 step 2)
            if type_ok and bounds_ok and align_ok and place_ok and self.held(offset, offset + length):
                payload = self.data[offset : offset + length]
                if zlib.crc32(payload, zlib.crc32(raw_type)) & 0xFFFFFFFF != crc:
                    self.add("SWPM_CHUNK_CRC_MISMATCH", eo + 24)
            # §5 step 2: an entry with a bad type gets every check of the step; its type is unknown
            chunk = _Chunk(raw_type.decode("ascii") if type_ok else "", eo, offset, length)
            self.entries.append(chunk)
            if chunk.type not in CRITICAL:
                unknown = "CRITICAL" if flags & 1 else "ANCILLARY"
                self.add("SWPM_CHUNK_UNKNOWN_" + unknown, eo)
                continue
            if bool(flags & 1) != CRITICAL[chunk.type]:
                self.add("SWPM_CHUNK_BAD_FLAGS", eo + 4)
            if self.encoding is not None and not (
                chunk.type in COMMON or chunk.type in ENCODING_TABLES[self.encoding]
            ):
                self.add("SWPM_CHUNK_NOT_ALLOWED", eo)
            elif chunk.type in self.chunks:
                self.add("SWPM_CHUNK_DUPLICATE", eo)
            else:
                self.chunks[chunk.type] = chunk
        self.check_zero(end, size)
        if self.encoding is None:
            return
        order = ["META", "LODS", "SMAP", *ENCODING_TABLES[self.encoding], "INDX", "VERT"]
        for ctype in order:
            if CRITICAL[ctype] and ctype not in self.chunks:
                self.add("SWPM_CHUNK_MISSING", None)
        self.stream_order(order)

    def stream_order(self, order: list[str]) -> None:
        """§2.3: the entries of the encoding's chunk types, in table order with duplicates (unknown chunks and
        chunks of another encoding skipped), against ``order`` restricted to the types present."""
        expected = [t for t in order if t in self.chunks]
        listed = [c for c in self.entries if c.type in order]
        for i, c in enumerate(listed):
            # a position past the end of ``expected`` (a trailing duplicate) differs too
            if i >= len(expected) or c.type != expected[i]:
                self.add("SWPM_STREAM_ORDER", c.entry)
                return
        vert = self.chunks.get("VERT")
        if vert is not None and self.entries[-1].type != "VERT":
            self.add("SWPM_STREAM_ORDER", vert.entry)

    # ----------------------------------------------------------------- step 3
    def payloads(self) -> None:
        meta_ok = self.read_meta()
        lods_ok = self.read_lods()
        vert_ok = self.read_vert()
        if lods_ok and vert_ok and self.vc[0] != self.V:
            self.add("SWPM_LOD_VERTEX_COUNT", self.chunks["LODS"].offset)
        if not (meta_ok and lods_ok and vert_ok):
            return
        enc = {
            "vanilla": self.vanilla,
            "sliding-window": self.sliding,
            "skip-strip": self.skip_strip,
            "mixed": self.mixed,
        }
        if self.encoding is not None:
            enc[self.encoding]()
        smap = self.chunks.get("SMAP")
        if (
            not self.rep.has_error()
            and smap is not None
            and self.held(smap.offset, smap.offset + smap.length)
        ):
            self.read_smap()
        if not self.rep.has_error() and not self.indx_whole:
            self.held_lods_below()

    def read_meta(self) -> bool:
        c = self.chunks["META"]

        def no_constants(name: str) -> Any:
            raise ValueError(name)

        def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
            obj = dict(pairs)
            if len(obj) != len(pairs):
                raise ValueError("duplicate key")
            return obj

        def finite(text: str) -> float:
            if not math.isfinite(float(text)):  # §3.1: a number that rounds to infinity is not accepted
                raise ValueError(text)
            return float(text)

        def integer(text: str) -> int:
            finite(text)
            return int(text)

        try:
            text = self.data[c.offset : c.offset + c.length].decode("utf-8")
            if nesting(text) > 128:  # §3.1: arrays and objects nest at most 128 deep
                raise ValueError("too deep")
            meta = json.loads(
                text,
                parse_constant=no_constants,
                parse_float=finite,
                parse_int=integer,
                object_pairs_hook=unique_keys,
            )
        except (UnicodeDecodeError, ValueError, RecursionError):
            meta = None
        if not isinstance(meta, dict):
            self.add("SWPM_META_BAD_JSON", c.offset)
            return False
        params = meta.get("params", {})
        if not isinstance(params, dict):
            self.add("SWPM_META_BAD_FIELD", c.offset)
            return False
        self.params = params
        if "encoding" in meta and meta["encoding"] != self.encoding:
            self.add("SWPM_META_BAD_FIELD", c.offset)
        if self.encoding == "skip-strip":
            # §3.7: each of these ends the checks (the encoding's checks do not run)
            if params.get("primitive", "strip") not in ("strip", "list"):
                self.add("SWPM_META_BAD_FIELD", c.offset)
                return False
            rst = params.get("restart_index")
            is_int = isinstance(rst, int) and not isinstance(rst, bool)
            if rst is not None and not (is_int and 0 <= rst < 1 << 32):
                self.add("SWPM_META_BAD_FIELD", c.offset)
                return False
        if self.encoding == "sliding-window":
            # §3.5: primitive "strip" exactly when SW_STRIPS is set (missing: "list"), then an integer restart
            # index; a restart index of a list pool is type-checked only
            prim = params.get("primitive", "list")
            rst = params.get("restart_index")
            is_int = isinstance(rst, int) and not isinstance(rst, bool)
            if (
                prim not in ("strip", "list")
                or (prim == "strip") != self.strips
                or (rst is not None and not (is_int and 0 <= rst < 1 << 32))
                or (self.strips and rst is None)
            ):
                self.add("SWPM_META_BAD_FIELD", c.offset)
                return False
        return True

    def read_lods(self) -> bool:
        c = self.chunks["LODS"]
        if c.length % 12:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.entry + 16)
            return False
        L = c.length // 12
        if L == 0:
            self.add("SWPM_LOD_EMPTY", c.offset)
            return False
        rows = np.frombuffer(self.data, dtype="<u4", count=3 * L, offset=c.offset).reshape(L, 3)
        err = np.frombuffer(self.data, dtype="<f4", count=3 * L, offset=c.offset).reshape(L, 3)[:, 2]
        vc, tc, ev = rows[:, 0].tolist(), rows[:, 1].tolist(), err.tolist()
        for col in (vc, tc):
            k = _first_bad(col, lambda i, x, col=col: i > 0 and x > col[i - 1])
            if k is not None:
                self.add("SWPM_LOD_NOT_MONOTONE", c.offset + 12 * k)
        k = _first_bad(ev, lambda i, x: not math.isfinite(x))
        if k is None:
            k = _first_bad(ev, lambda i, x: i > 0 and x < ev[i - 1])
        if k is not None:
            self.add("SWPM_LOD_NOT_MONOTONE", c.offset + 12 * k + 8)
        self.L, self.vc, self.tc, self.T0 = L, vc, tc, tc[0]
        self.buffers["vertex_counts"] = rows[:, 0]
        self.buffers["triangle_counts"] = rows[:, 1]
        self.buffers["lod_errors"] = err
        return True

    def read_vert(self) -> bool:
        c = self.chunks["VERT"]
        p, n = c.offset, c.length
        if n < 16:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.entry + 16)
            return False
        V, A, stride, data_offset = struct.unpack_from("<IIII", self.data, p)
        # §3.3: the order of the checks, the first problem ending them
        if 16 + 16 * A > n:
            self.add("SWPM_COUNT_EXCEEDS_CHUNK", p + 4)
            return False
        if A > 255 or stride < 12 or stride % 4 or data_offset % 8 or not 16 + 16 * A <= data_offset <= n:
            self.add("SWPM_VERT_BAD_LAYOUT", p)
            return False
        if V * stride > n - data_offset:
            self.add("SWPM_COUNT_EXCEEDS_CHUNK", p)
            return False
        if data_offset + V * stride != n:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.entry + 16)
            return False
        attrs = self.attributes(p, A, stride, data_offset)
        if attrs is None:
            self.add("SWPM_VERT_BAD_LAYOUT", p)
            return False
        self.V, self.stride, self.data_offset, self.attrs = V, stride, data_offset, attrs
        if self.prefix:  # §4.1 step 3: no vertex record is read; SWPM_VERT_NONFINITE waits for the file
            return True
        self.buffers.update(self.vertices(V))
        if not np.isfinite(self.buffers["points"]).all():
            self.add("SWPM_VERT_NONFINITE", p + data_offset)
        return True

    def vertices(self, count: int) -> dict[str, np.ndarray]:
        """The first ``count`` vertex records of ``VERT``: points and attributes (§3.3, §7)."""
        base, stride, out = self.chunks["VERT"].offset + self.data_offset, self.stride, {}
        pos_dt = np.dtype({"names": ["p"], "formats": [("<f4", (3,))], "offsets": [0], "itemsize": stride})
        pts = (
            np.frombuffer(self.data, dtype=pos_dt, count=count, offset=base)["p"]
            if count
            else np.zeros((0, 3))
        )
        out["points"] = pts.astype("<f4", copy=False)
        for name, dt, comps, aoff in self.attrs:
            adt = np.dtype(
                {"names": ["a"], "formats": [(dt, (comps,))], "offsets": [aoff], "itemsize": stride}
            )
            arr = (
                np.frombuffer(self.data, dtype=adt, count=count, offset=base)["a"]
                if count
                else np.zeros((0,), dt)
            )
            out[f"attribute:{name}"] = arr.reshape(count, comps)
        return out

    def attributes(self, p: int, A: int, stride: int, data_offset: int) -> list[Any] | None:
        """The attribute descriptors of §3.3, or None when one breaks a rule."""
        names_start = 16 + 16 * A
        used = bytearray(stride)
        used[0:12] = b"\1" * 12
        names: set[str] = set()
        attrs = []
        for a in range(A):
            name_off, name_len, et, comps, aoff, _res = struct.unpack_from(
                "<IHBBII", self.data, p + 16 + 16 * a
            )
            if name_len < 1 or name_off < names_start or name_off + name_len > data_offset:
                return None
            try:
                name = self.data[p + name_off : p + name_off + name_len].decode("utf-8")
            except UnicodeDecodeError:
                return None
            if name in names or et not in ELEM_TYPES or comps < 1:
                return None
            names.add(name)
            dt, es = ELEM_TYPES[et]
            if stride % es or aoff % es or aoff + es * comps > stride or any(used[aoff : aoff + es * comps]):
                return None
            used[aoff : aoff + es * comps] = b"\1" * (es * comps)
            attrs.append((name, dt, comps, aoff))
        return attrs

    # ------------------------------------------------------------ stage 0 parts
    def rcnt_layout(self) -> list[int] | None:
        """Stage 0: a whole number of counts (whether there are L of them is a §3.6 count, stage (a))."""
        c = self.chunks["RCNT"]
        if c.length % self.O:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.entry + 16)
            return None
        arr = self.view(c.offset, c.length // self.O, table=True)
        self.buffers["lod_record_counts"] = arr
        return arr.tolist()

    def record_layout(self, ctype: str) -> tuple[np.ndarray, np.ndarray, int] | None:
        """A VREC-layout chunk: (records[R, cols], change_offsets[M], offsets position)."""
        assert self.encoding is not None
        columns = RECORD_COLUMNS[self.encoding]
        cols = len(columns)
        c = self.chunks[ctype]
        p = c.offset
        if c.length < 8:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.entry + 16)
            return None
        R, M = struct.unpack_from("<II", self.data, p)
        need = cols * self.O * R
        if need > c.length - 8:
            self.add("SWPM_COUNT_EXCEEDS_CHUNK", p + 8)
            return None
        ao = 8 + _align4(need)
        if ao > c.length or M * self.O > c.length - ao:
            self.add("SWPM_COUNT_EXCEEDS_CHUNK", p + ao)
            return None
        if ao + M * self.O != c.length:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.entry + 16)
            return None
        recs = self.view(p + 8, cols * R, table=True).reshape(R, cols)
        offs = self.view(p + ao, M, table=True)
        for i, name in enumerate(columns):
            self.buffers["collapse_" + name] = recs[:, i]
        self.buffers["collapse_change_offsets"] = offs
        return recs.astype(np.int64), offs.astype(np.int64), p + ao

    def indx_layout(self) -> bool:
        c = self.chunks["INDX"]
        if c.length % self.W:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.entry + 16)
            return False
        count = c.length // self.W
        if self.encoding == "vanilla" and count % 3:  # §3.4: vanilla T0 = INDX count / 3
            self.add("SWPM_CHUNK_BAD_LENGTH", c.entry + 16)
            return False
        arr = self.view(c.offset, count)
        name = {
            "vanilla": "indices",
            "sliding-window": "index_pool",
            "skip-strip": "level_indices",
            "mixed": "level_static_indices",
        }[self.encoding or ""]
        self.buffers[name] = arr
        self.indx = arr.astype(np.int64)
        self.indx_off = c.offset
        self.indx_whole = self.held(c.offset, c.offset + c.length)
        return True

    def held_lods_below(self) -> None:
        """§4.2 step 3, INDX not wholly held, after step 5 of §5: for every LOD k in order whose (b) elements
        are held, each is below vertex_count(k) (skip-strip, mixed: of the first LOD of k's level), a strips'
        restart index exempt; else SWPM_PREFIX_VIOLATION at the first that is not (one problem)."""
        restart = None
        if self.strips or (
            self.encoding == "skip-strip" and self.params.get("primitive", "strip") == "strip"
        ):
            restart = self.params.get("restart_index")
        for k in range(self.L):
            lo, hi = self.lod_index_range(k)
            if hi <= lo or not self.held(self.indx_off + self.W * lo, self.indx_off + self.W * hi):
                continue
            sliding = self.encoding == "sliding-window"
            limit = self.vc[k] if sliding else self.vc[self.level_first[self.level_of(k)]]
            bad = np.flatnonzero(self.above(self.indx[lo:hi], limit, restart))
            if len(bad):
                self.add("SWPM_PREFIX_VIOLATION", self.indx_off + self.W * (lo + int(bad[0])))
                return

    def level_layout(self, ctype: str, extra: int, names: list[str]) -> list[tuple[np.ndarray, int]] | None:
        """SKIP/MLVL: u32 n, u32 count, then off arrays of n, n+1, n+1, n+1 and ``extra`` idx arrays of count
        (§3.7, §3.8)."""
        c = self.chunks[ctype]
        if c.length < 8:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.entry + 16)
            return None
        n, count = struct.unpack_from("<II", self.data, c.offset)
        sizes = [n, n + 1, n + 1, n + 1] + [count] * extra
        out = []
        pos = 8
        for i, size in enumerate(sizes):
            if i:
                pos = _align4(pos)
            table = i < 4  # the level tables are off, the lists an engine uploads idx (§3.7, §3.8)
            width = self.O if table else self.W
            if pos > c.length or size * width > c.length - pos:
                self.add("SWPM_COUNT_EXCEEDS_CHUNK", c.offset + pos)
                return None
            out.append((self.view(c.offset + pos, size, table), c.offset + pos))
            pos += size * width
        if pos != c.length:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.entry + 16)
            return None
        for name, (arr, _off) in zip(names, out, strict=True):
            self.buffers[name] = arr
        return [(arr.astype(np.int64), off) for arr, off in out]

    # ------------------------------------------------------------ shared checks
    def counts_36(self, ctype: str, recs: np.ndarray, M: int, rc: list[int]) -> bool:
        """§3.6 counts, in the order of §5 step 4: change counts sum to M, prev_change_count, RCNT holding L
        counts (its values then not checked), RCNT from 0, non-decreasing, <= R. True when all hold."""
        c = self.chunks[ctype]
        cols = recs.shape[1]
        R = recs.shape[0]
        ok = True
        cc = recs[:, cols - 2]
        if int(cc.sum()) != M:
            self.add("SWPM_RECORD_BAD_COUNTS", c.offset + 8)
            ok = False
        prev = np.concatenate([np.zeros(1, np.int64), cc[:-1]]) if R else cc
        bad = np.flatnonzero(recs[:, cols - 1] != prev)
        if len(bad):
            r = int(bad[0])
            self.add("SWPM_RECORD_BAD_COUNTS", c.offset + 8 + self.O * (cols * r + cols - 1))
            ok = False
        if len(rc) != self.L:
            self.add("SWPM_CHUNK_BAD_LENGTH", self.chunks["RCNT"].offset)
            ok = False
        elif rc[0] != 0 or any(rc[k] < rc[k - 1] for k in range(1, len(rc))) or max(rc) > R:
            self.add("SWPM_RECORD_BAD_COUNTS", self.chunks["RCNT"].offset)
            ok = False
        return ok

    def r_below_v(self, ctype: str, R: int) -> None:
        if R and R >= self.V:
            self.add("SWPM_RECORD_BAD_COUNTS", self.chunks[ctype].offset)

    def row(self, ctype: str, r: int, col: int = 0) -> int:
        cols = len(RECORD_COLUMNS[self.encoding or ""])
        return self.chunks[ctype].offset + 8 + self.O * (cols * r + col)

    def bad_kept(self, ctype: str, recs: np.ndarray) -> None:
        R = recs.shape[0]
        limit = self.V - 1 - np.arange(R, dtype=np.int64)
        for r in np.flatnonzero(recs[:, 0] >= limit)[:3].tolist():
            self.add("SWPM_RECORD_BAD_KEPT", self.row(ctype, r))

    def lods_vertex_counts(self, rc: list[int]) -> None:
        k = _first_bad(self.vc, lambda i, x: x != self.V - rc[i])
        if k is not None:
            self.add("SWPM_LOD_VERTEX_COUNT", self.chunks["LODS"].offset + 12 * k)

    def lods_row_bad_counts(self, expected: list[int]) -> None:
        k = _first_bad(self.tc, lambda i, x: x != expected[i])
        if k is not None:
            self.add("SWPM_RECORD_BAD_COUNTS", self.chunks["LODS"].offset + 12 * k)

    def level_of(self, k: int) -> int:
        lev = 0
        for i, f in enumerate(self.level_first):
            if f <= k:
                lev = i
        return lev

    @staticmethod
    def bad_change(lst: np.ndarray, slots: np.ndarray, binned: int) -> bool:
        """A record's changes, made one after another, find a slot not holding the binned vertex (§3.6: "when
        record r changes it"): one that does not hold it, or one changed twice (it then holds ``kept``)."""
        return bool((lst[slots] != binned).any()) or len(np.unique(slots)) < len(slots)

    @staticmethod
    def slot_starts(recs: np.ndarray) -> list[int]:
        cc = recs[:, recs.shape[1] - 2]
        return [0, *np.cumsum(cc).tolist()]

    def offsets_in_levels(
        self, starts: list[int], rs: list[int], list_starts: list[int], offs: np.ndarray, op: int
    ) -> None:
        """Change offsets of level l's records (record r's at ``starts[r]..starts[r + 1]``) index level l's
        list (first three bad ones reported)."""
        bad_offsets = []
        for lev in range(len(list_starts) - 1):
            for r in range(rs[lev], rs[lev + 1]):
                for j in range(starts[r], starts[r + 1]):
                    if offs[j] >= list_starts[lev + 1] - list_starts[lev]:
                        bad_offsets.append(j)
        for j in sorted(bad_offsets)[:3]:
            self.add("SWPM_INDEX_OUT_OF_RANGE", op + self.O * j)

    # ----------------------------------------------------------------- vanilla
    def vanilla(self) -> None:
        # stage 0: VREC, RCNT, INDX
        got = self.record_layout("VREC")
        rc = self.rcnt_layout() if got is not None else None
        if got is None or rc is None or not self.indx_layout():
            return
        recs, offs, op = got
        R, M, V, T0 = recs.shape[0], len(offs), self.V, len(self.indx) // 3
        mark = self.rep.total
        # (a)
        self.counts_36("VREC", recs, M, rc)
        if self.indx_whole:  # (§4.2: the index values wait for INDX)
            self.first_n(self.indx >= V, self.indx_off, self.W)
        self.r_below_v("VREC", R)
        self.bad_kept("VREC", recs)
        if int(recs[:, 1].sum()) > T0:
            self.add("SWPM_RECORD_BAD_COUNTS", self.row("VREC", 0, 1))
        self.first_n(offs >= 3 * T0, op, self.O)
        if self.rep.total > mark:
            return
        # (b)
        self.lods_vertex_counts(rc)
        removed = [0, *np.cumsum(recs[:, 1]).tolist()]
        self.lods_row_bad_counts([T0 - removed[rc[k]] for k in range(self.L)])
        if self.rep.total > mark:
            return
        # (c) the replay: one problem (§4.2: it waits for INDX; no LOD's (b), all of INDX, is held)
        if not self.indx_whole:
            return
        ind = self.indx.copy()
        starts = self.slot_starts(recs)
        live = T0
        refs = np.bincount(ind, minlength=V) if V else np.zeros(0, np.int64)
        for r in range(R):
            binned, kept, after = V - 1 - r, int(recs[r, 0]), live - int(recs[r, 1])
            slots = offs[starts[r] : starts[r + 1]]
            if self.bad_change(ind, slots, binned) or (len(slots) and int(slots.max()) >= 3 * after):
                self.add("SWPM_RECORD_BAD_CHANGE", self.row("VREC", r))
                return
            ind[slots] = kept
            refs[binned] -= len(slots)
            refs[kept] += len(slots)
            np.subtract.at(refs, ind[3 * after : 3 * live], 1)
            live = after
            if refs[binned]:
                self.add("SWPM_PREFIX_VIOLATION", self.row("VREC", r))
                return

    # ---------------------------------------------------------- sliding window
    def sliding(self) -> None:
        c = self.chunks["WREC"]
        W, O, L = self.W, self.O, self.L
        n = 4 if self.strips else 3  # §3.5: a fourth field, index_count, with SW_STRIPS
        if c.length != n * O * L:
            self.add("SWPM_CHUNK_BAD_LENGTH", c.entry + 16)
            return
        if not self.indx_layout():
            return
        raw = self.view(c.offset, n * L, table=True).reshape(L, n)
        self.buffers["window_records"] = raw[:, :3]
        rows = raw.tolist()
        first = [r[0] for r in rows]
        tcount = [r[1] for r in rows]
        vcount = [r[2] for r in rows]
        count = [r[3] if self.strips else 3 * r[1] for r in rows]
        restart = None
        if self.strips:
            self.buffers["window_index_counts"] = raw[:, 3]
            restart = self.params["restart_index"]
            if restart < self.V:  # §3.5: a vertex; ends the checks
                self.add("SWPM_META_BAD_FIELD", self.chunks["META"].offset)
                return
        pool = len(self.indx)
        mark = self.rep.total
        # (a)
        k = _first_bad(tcount, lambda i, x: x != self.tc[i])
        if k is not None:
            self.add("SWPM_WINDOW_COUNT_MISMATCH", c.offset + n * O * k + O)
        k = _first_bad(vcount, lambda i, x: x != self.vc[i])
        if k is not None:
            self.add("SWPM_WINDOW_COUNT_MISMATCH", c.offset + n * O * k + 2 * O)
        k = _first_bad(tcount, lambda i, x: i > 0 and x > tcount[i - 1])
        if k is not None:
            self.add("SWPM_WINDOW_NOT_MONOTONE", c.offset + n * O * k + O)
        outside = [k for k in range(L) if first[k] + count[k] > pool]
        for k in outside[:3]:
            self.add("SWPM_WINDOW_OUT_OF_POOL", c.offset + n * O * k)
        if self.indx_whole:
            self.first_n(self.above(self.indx, self.V, restart), self.indx_off, W)
        if self.strips and not outside and self.indx_whole:
            k = _first_bad(first, lambda i, x: count[i] > 0 and x > 0 and int(self.indx[x - 1]) != restart)
            if k is not None:
                self.add("SWPM_WINDOW_MID_STRIP", c.offset + n * O * k)
        if self.rep.total > mark:
            return
        # (b) the prefix property: the lowest offending INDX element (§4.2: per held window, the rest waits)
        if not self.indx_whole:
            return
        worst = None
        for k in range(L):
            win = self.indx[first[k] : first[k] + count[k]]
            bad = np.flatnonzero(self.above(win, vcount[k], restart))
            if len(bad):
                pos = first[k] + int(bad[0])
                worst = pos if worst is None else min(worst, pos)
        if worst is not None:
            self.add("SWPM_PREFIX_VIOLATION", self.indx_off + W * worst)
        if self.strips:
            # each window decoded on its own: the strips between its restart indices (§3.7's rule)
            for k in range(L):
                win = self.indx[first[k] : first[k] + count[k]].astype(np.int64)
                cuts = np.flatnonzero(win == restart).tolist()
                got = 0
                for a, b in zip([-1, *cuts], [*cuts, len(win)], strict=True):
                    got += self.triangles(win[a + 1 : b], False, restart)
                if got != tcount[k]:
                    self.add("SWPM_WINDOW_STRIP_TRIANGLES", c.offset + n * O * k + 3 * O)
                    return

    # -------------------------------------------------------------- skip-strip
    def skip_strip(self) -> None:
        names = [
            "level_first_lod",
            "level_index_start",
            "level_collapsed_start",
            "level_record_start",
            "level_collapsed_indices",
        ]
        # stage 0: SREC, RCNT, INDX, SKIP
        got = self.record_layout("SREC")
        rc = self.rcnt_layout() if got is not None else None
        if got is None or rc is None or not self.indx_layout():
            return
        levels = self.level_layout("SKIP", 1, names)
        if levels is None:
            return
        recs, offs, op = got
        (lfl, _), (lis, _), (lcs, _), (lrs, _), (lci, lci_o) = levels
        R, M, V, W, N, C = recs.shape[0], len(offs), self.V, self.W, len(self.indx), len(lci)
        skip_off = self.chunks["SKIP"].offset
        prim = self.params.get("primitive", "strip")
        rst = self.params.get("restart_index")
        restart = rst if prim == "strip" and isinstance(rst, int) and not isinstance(rst, bool) else None
        is_list = prim == "list"
        mark = self.rep.total
        # (a)
        self.counts_36("SREC", recs, M, rc)
        if restart is not None and restart < V:
            # a strips' restart index that is a vertex: META_BAD_FIELD, found with the level table (§3.7)
            self.add("SWPM_META_BAD_FIELD", self.chunks["META"].offset)
            return
        fl, ls, cs, rs = lfl.tolist(), lis.tolist(), lcs.tolist(), lrs.tolist()
        n = len(fl)
        table_ok = (
            n >= 1
            and fl[0] == 0
            and all(fl[i] > fl[i - 1] for i in range(1, n))
            and fl[-1] < self.L
            and all(self.monotone(arr, hi, 1) for arr, hi in ((ls, N), (cs, C), (rs, R)))
            and self.monotone(ls, N, 3 if is_list else 1)
            and cs == ls
        )
        if not table_ok:
            self.add("SWPM_LEVEL_BAD_TABLE", skip_off)
            return
        self.level_first, self.level_starts = fl, ls

        def over(arr: np.ndarray) -> np.ndarray:
            return (arr >= V) & (arr != restart) if restart is not None else arr >= V

        rec_base = self.chunks["SREC"].offset + 8
        if self.indx_whole:
            self.first_n(over(self.indx), self.indx_off, W)
        self.first_n(over(lci), lci_o, W)
        O = self.O
        self.first_n(recs[:, 0] >= V, rec_base, 4 * O)  # kept
        self.first_n(recs[:, 1] >= V, rec_base + O, 4 * O)  # binned
        if self.rep.total > mark:
            return
        # (b)
        starts = self.slot_starts(recs)
        self.offsets_in_levels(starts, rs, ls, offs, op)
        for lev in range(n if self.indx_whole else 0):
            bad = np.flatnonzero(self.above(self.indx[ls[lev] : ls[lev + 1]], self.vc[fl[lev]], restart))
            if len(bad):
                self.add("SWPM_PREFIX_VIOLATION", self.indx_off + W * (ls[lev] + int(bad[0])))
                break

        if self.rep.total > mark:
            return
        # (c)
        self.r_below_v("SREC", R)
        limit = V - 1 - np.arange(R, dtype=np.int64)
        for r in np.flatnonzero(recs[:, 1] != limit)[:3].tolist():
            self.add("SWPM_RECORD_BAD_BINNED", self.row("SREC", r, 1))
        for r in np.flatnonzero(recs[:, 0] >= limit)[:3].tolist():
            self.add("SWPM_RECORD_BAD_KEPT", self.row("SREC", r, 0))
        if any(rs[lev] != rc[fl[lev]] for lev in range(n)):
            self.add("SWPM_LEVEL_BAD_TABLE", skip_off)
        self.lods_vertex_counts(rc)
        if self.rep.total > mark:
            return
        # (d) the replay (§4.2: it waits for INDX), then the collapsed lists' prefix
        for lev in range(n if self.indx_whole else 0):
            lst = self.indx[ls[lev] : ls[lev + 1]].copy()
            bad_record = None
            for r in range(rs[lev], rs[lev + 1]):
                slots = offs[starts[r] : starts[r + 1]]
                if self.bad_change(lst, slots, V - 1 - r):
                    bad_record = r
                    break
                lst[slots] = recs[r, 0]
            if bad_record is not None:
                self.add("SWPM_RECORD_BAD_CHANGE", self.row("SREC", bad_record))
                break
            diff = np.flatnonzero(lci[cs[lev] : cs[lev + 1]] != lst)
            if len(diff):
                self.add("SWPM_LEVEL_BAD_TABLE", lci_o + W * (cs[lev] + int(diff[0])))
                break
        for lev in range(n if self.indx_whole else 0):  # (§4.2: with the replay, it waits for INDX)
            bad = np.flatnonzero(self.above(lci[cs[lev] : cs[lev + 1]], V - rs[lev + 1], restart))
            if len(bad):
                self.add("SWPM_PREFIX_VIOLATION", lci_o + W * (cs[lev] + int(bad[0])))
                break
        if self.rep.total > mark:
            return
        # (e) LODS triangle counts: non-degenerate triangles after records [level_record_start[l], RCNT[k])
        # RCNT is non-decreasing (stage a), so each level's records are applied once, in order (§4.2: they
        # wait for INDX).
        if not self.indx_whole:
            return
        expected = []
        for lev in range(n):
            lst = self.indx[ls[lev] : ls[lev + 1]].copy()
            applied, count = rs[lev], None
            for k in range(fl[lev], fl[lev + 1] if lev + 1 < n else self.L):
                if count is None or applied < rc[k]:
                    for r in range(applied, min(rc[k], R)):
                        slots = offs[starts[r] : starts[r + 1]]
                        lst[slots[slots < len(lst)]] = recs[r, 0]
                    applied = max(applied, rc[k])
                    count = self.triangles(lst, is_list, restart)
                expected.append(count)
        self.lods_row_bad_counts(expected)

    @staticmethod
    def monotone(arr: list[int], hi: int, step: int) -> bool:
        """A start array (§3.7, §3.8): element 0 = 0, the last = ``hi``, non-decreasing, steps a multiple of
        ``step``."""
        return (
            arr[0] == 0
            and arr[-1] == hi
            and all(arr[i] >= arr[i - 1] and (arr[i] - arr[i - 1]) % step == 0 for i in range(1, len(arr)))
        )

    @staticmethod
    def above(arr: np.ndarray, limit: int, restart: int | None) -> np.ndarray:
        bad = arr >= limit
        return bad & (arr != restart) if restart is not None else bad

    @staticmethod
    def triangles(lst: np.ndarray, is_list: bool, restart: int | None) -> int:
        if is_list:
            t = lst[: 3 * (len(lst) // 3)].reshape(-1, 3)
            a, b, c = t[:, 0], t[:, 1], t[:, 2]
        else:
            if len(lst) < 3:
                return 0
            a, b, c = lst[:-2], lst[1:-1], lst[2:]
        ok = (a != b) & (b != c) & (a != c)
        if not is_list and restart is not None:
            ok &= (a != restart) & (b != restart) & (c != restart)
        return int(ok.sum())

    # ------------------------------------------------------------------- mixed
    def mixed(self) -> None:
        names = [
            "level_first_lod",
            "level_static_start",
            "level_dynamic_start",
            "level_record_start",
            "level_dynamic_indices",
            "level_dynamic_collapsed_indices",
        ]
        # stage 0: MREC, RCNT, INDX, MLVL
        got = self.record_layout("MREC")
        rc = self.rcnt_layout() if got is not None else None
        if got is None or rc is None or not self.indx_layout():
            return
        levels = self.level_layout("MLVL", 2, names)
        if levels is None:
            return
        recs, offs, op = got
        (lfl, lfl_o), (lss, lss_o), (lds, lds_o), (lrs, lrs_o), (ldi, ldi_o), (ldc, ldc_o) = levels
        R, M, V, W, N, D = recs.shape[0], len(offs), self.V, self.W, len(self.indx), len(ldi)
        mark = self.rep.total
        # (a)
        counts_ok = self.counts_36("MREC", recs, M, rc)
        fl, ss, ds, rs = lfl.tolist(), lss.tolist(), lds.tolist(), lrs.tolist()
        n = len(fl)
        if not (n >= 1 and fl[0] == 0 and all(fl[i] > fl[i - 1] for i in range(1, n)) and fl[-1] < self.L):
            self.add("SWPM_MIXED_BAD_LEVELS", lfl_o)
            return
        bad_arrays = [
            off
            for arr, off, hi, step in ((ss, lss_o, N, 3), (ds, lds_o, D, 3), (rs, lrs_o, R, 1))
            if not self.monotone(arr, hi, step)
        ]
        if bad_arrays:
            self.add("SWPM_MIXED_BAD_LEVELS", bad_arrays[-1])
            return
        if counts_ok:
            lev = _first_bad(rs[:n], lambda i, x: x != rc[fl[i]])
            if lev is not None:
                self.add("SWPM_MIXED_BAD_LEVELS", lrs_o + self.O * lev)
                return
        self.level_first, self.level_starts = fl, ss
        if self.indx_whole:
            self.first_n(self.indx >= V, self.indx_off, W)
        self.first_n(ldi >= V, ldi_o, W)
        self.first_n(ldc >= V, ldc_o, W)
        self.r_below_v("MREC", R)
        self.bad_kept("MREC", recs)
        if self.rep.total > mark:
            return
        # (b)
        starts = self.slot_starts(recs)
        self.offsets_in_levels(starts, rs, ds, offs, op)
        s_rm = [0, *np.cumsum(recs[:, 1]).tolist()]
        d_rm = [0, *np.cumsum(recs[:, 2]).tolist()]
        for col, starts_arr, removed in ((1, ss, s_rm), (2, ds, d_rm)):
            if any(
                removed[rs[lev + 1]] - removed[rs[lev]] > (starts_arr[lev + 1] - starts_arr[lev]) // 3
                for lev in range(n)
            ):
                self.add("SWPM_RECORD_BAD_COUNTS", self.row("MREC", 0, col))
        if self.rep.total > mark:
            return
        # (c)
        self.lods_vertex_counts(rc)
        expected = []
        for k in range(self.L):
            lev = self.level_of(k)
            s_live = (ss[lev + 1] - ss[lev]) // 3 - (s_rm[rc[k]] - s_rm[rs[lev]])
            d_live = (ds[lev + 1] - ds[lev]) // 3 - (d_rm[rc[k]] - d_rm[rs[lev]])
            expected.append(s_live + d_live)
        self.lods_row_bad_counts(expected)
        for arr, off, st in ((self.indx, self.indx_off, ss), (ldi, ldi_o, ds)):
            if arr is self.indx and not self.indx_whole:
                continue
            for lev in range(n):
                bad = np.flatnonzero(arr[st[lev] : st[lev + 1]] >= self.vc[fl[lev]])
                if len(bad):
                    self.add("SWPM_PREFIX_VIOLATION", off + W * (st[lev] + int(bad[0])))
                    break
        for lev in range(n):
            d_live = (ds[lev + 1] - ds[lev]) // 3 - (d_rm[rs[lev + 1]] - d_rm[rs[lev]])
            bad = np.flatnonzero(ldc[ds[lev] : ds[lev] + 3 * d_live] >= V - rs[lev + 1])
            if len(bad):
                self.add("SWPM_PREFIX_VIOLATION", ldc_o + W * (ds[lev] + int(bad[0])))
                break
        if self.rep.total > mark:
            return
        # (d) the replay: one problem (§4.2: it waits for INDX)
        for lev in range(n if self.indx_whole else 0):
            stat = self.indx[ss[lev] : ss[lev + 1]]
            dyn = ldi[ds[lev] : ds[lev + 1]].copy()
            s_live, d_live = len(stat) // 3, len(dyn) // 3
            for r in range(rs[lev], rs[lev + 1]):
                binned = V - 1 - r
                s_live -= int(recs[r, 1])
                d_live -= int(recs[r, 2])
                slots = offs[starts[r] : starts[r + 1]]
                if self.bad_change(dyn, slots, binned) or (len(slots) and int(slots.max()) >= 3 * d_live):
                    self.add("SWPM_RECORD_BAD_CHANGE", self.row("MREC", r))
                    return
                dyn[slots] = recs[r, 0]
                if bool((stat[: 3 * s_live] == binned).any()) or bool((dyn[: 3 * d_live] == binned).any()):
                    self.add("SWPM_PREFIX_VIOLATION", self.row("MREC", r))
                    return
            diff = np.flatnonzero(ldc[ds[lev] : ds[lev + 1]] != dyn)
            if len(diff):
                self.add("SWPM_MIXED_BAD_LEVELS", ldc_o + W * (ds[lev] + int(diff[0])))
                return

    # -------------------------------------------------------------------- SMAP
    def read_smap(self) -> None:
        c = self.chunks["SMAP"]
        p = c.offset
        if c.length < 8:
            self.add("SWPM_SMAP_INVALID", p)
            return
        B, N = struct.unpack_from("<II", self.data, p)
        if c.length != 8 + 24 * B + 16 * N:
            self.add("SWPM_SMAP_INVALID", p)
            return
        bands = [struct.unpack_from("<IIIIQ", self.data, p + 8 + 24 * b) for b in range(B)]
        ranges = [struct.unpack_from("<QQ", self.data, p + 8 + 24 * B + 16 * i) for i in range(N)]
        next_lod = 0
        for first, count, rs, rn, _prefix in bands:
            if first != next_lod or count < 1 or rn > 16 or rs + rn > N:
                next_lod = -1
                break
            next_lod = first + count
        if B < 1 or next_lod != self.L:
            self.add("SWPM_SMAP_INVALID", p + 8)
            return
        if any(off + length > self.size for off, length in ranges):
            self.add("SWPM_SMAP_INVALID", p + 8 + 24 * B)
            return
        ic, vc = self.chunks["INDX"], self.chunks["VERT"]
        hulls = []
        for first, count, _rs, _rn, _prefix in bands:
            need = [(0, ic.offset)]
            spans = [self.lod_index_range(k) for k in range(first, first + count)]
            spans = [(lo, hi) for lo, hi in spans if hi > lo]
            if spans:
                lo, hi = min(s[0] for s in spans), max(s[1] for s in spans)
                need.append((ic.offset + self.W * lo, ic.offset + self.W * hi))
            vmax = max(self.vc[first : first + count])
            need.append((vc.offset, vc.offset + self.data_offset + vmax * self.stride))
            hulls.append(need)
        for b, (_first, _count, rs, rn, _prefix) in enumerate(bands):
            band = ranges[rs : rs + rn]
            if not all(any(ro <= lo and hi <= ro + rl for ro, rl in band) for lo, hi in hulls[b]):
                self.add("SWPM_SMAP_INVALID", p + 8 + 24 * b)
                return
        for b, band in enumerate(bands):
            if band[4] != max(hi for _lo, hi in hulls[b]):
                self.add("SWPM_SMAP_INVALID", p + 8 + 24 * b + 16)
                return

    def lod_index_range(self, k: int) -> tuple[int, int]:
        """The INDX elements [lo, hi) that LOD k needs (§4 (b))."""
        if self.encoding == "vanilla":
            return 0, len(self.indx)
        if self.encoding == "sliding-window":
            first, tcount, _v = (int(x) for x in self.buffers["window_records"][k])
            if "window_index_counts" in self.buffers:
                return first, first + int(self.buffers["window_index_counts"][k])
            return first, first + 3 * tcount
        lev = self.level_of(k)
        return self.level_starts[lev], self.level_starts[lev + 1]

    # ------------------------------------------------------------------ result
    def result(self) -> dict[str, Any]:
        valid = not self.rep.has_error()
        out: dict[str, Any] = {"valid": valid, "problems": self.rep.problems}
        if valid:
            out["summary"] = {
                "encoding": self.encoding,
                "index_width": self.W,
                "offset_width": self.O,
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


def read_prefix(prefix: bytes) -> dict[str, Any]:
    """Open ``prefix``, the first n bytes of an SWPM v1 file, as §4.1 reads it: ``{"length", "opened",
    "problems", "needed", "finest_drawable", "drawable"}``. ``problems`` are the prefix's (a
    ``SWPM_PREFIX_TOO_SHORT`` also gives ``need``); once opened, ``needed`` is needed(k) per LOD,
    ``finest_drawable`` k_min (None while no LOD is drawable) and ``drawable`` the hashes of the arrays of
    §7 over LOD k_min's vertices. Finishing is :func:`read` of the whole file. Never raises."""
    n = len(prefix)
    out: dict[str, Any] = {"length": n, "opened": False, "problems": []}
    if n < HEADER_SIZE:  # §4.1 step 1
        if n >= 8 and prefix[:8] != MAGIC:
            out["problems"] = [{"code": "SWPM_HEADER_BAD_MAGIC", "severity": "error", "offset": 0}]
        else:
            out["problems"] = [
                {"code": "SWPM_PREFIX_TOO_SHORT", "severity": "error", "offset": n, "need": 64}
            ]
        return out
    whole = n >= struct.unpack_from("<Q", prefix, 40)[0]  # the prefix is the whole file
    r = _Reader(prefix, prefix=not whole)
    verdict = r.run()
    out["problems"] = verdict["problems"]
    if r.rep.has_error():
        return out
    out["opened"] = True
    o = r.chunks["VERT"].offset
    needed = [o + r.data_offset + v * r.stride for v in r.vc]
    drawable = [k for k in range(r.L) if needed[k] <= n]
    out["needed"] = needed
    out["finest_drawable"] = drawable[0] if drawable else None
    if drawable:
        arrays = r.vertices(r.vc[drawable[0]])
        out["drawable"] = {name: _hash(arr) for name, arr in sorted(arrays.items())}
    return out


def _merge(ranges: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Held ranges (offset, length), in any order, overlapping or touching, as disjoint sorted runs
    [a, b): §4.2's held(a, b) asks only whether every byte is held."""
    runs: list[tuple[int, int]] = []
    for a, b in sorted((o, o + n) for o, n in ranges if n > 0):
        if runs and a <= runs[-1][1]:
            runs[-1] = (runs[-1][0], max(runs[-1][1], b))
        else:
            runs.append((a, b))
    return runs


def read_ranges(data: bytes, ranges: list[tuple[int, int]]) -> dict[str, Any]:
    """Open the byte ranges ``ranges`` ((offset, length) each) of the SWPM v1 file ``data`` as §4.2 reads
    them, reading no other byte: ``{"ranges", "opened", "problems", "needed", "drawable_lods",
    "drawable"}``. ``problems`` are the ranges' (a ``SWPM_RANGES_NOT_HELD`` also gives the range it needs,
    ``need_start`` and ``need``); once opened, ``needed`` lists per LOD the ranges (a), (b) (none when empty)
    and (c) of §4, ``drawable_lods`` the LODs whose three are held and ``drawable`` per such LOD (by its
    number) the hashes of its vertices' arrays (§7 names) and of its (b) elements (``indices``). Finishing is
    :func:`read` of the whole file. Ranges past the file (an error of the caller) are not held."""
    runs = _merge([(o, min(n, len(data) - o)) for o, n in ranges if o < len(data)])
    buf = bytearray(runs[-1][1] if runs else 0)
    for a, b in runs:
        buf[a:b] = data[a:b]
    out: dict[str, Any] = {"ranges": [list(r) for r in ranges], "opened": False, "problems": []}

    def held(a: int, b: int) -> bool:
        return b <= a or any(s <= a and b <= e for s, e in runs)

    if not held(0, HEADER_SIZE):  # §4.2 step 1
        if held(0, 8) and bytes(buf[:8]) != MAGIC:
            out["problems"] = [{"code": "SWPM_HEADER_BAD_MAGIC", "severity": "error", "offset": 0}]
        else:
            first = runs[0][1] if runs and runs[0][0] == 0 else 0
            out["problems"] = [
                {
                    "code": "SWPM_RANGES_NOT_HELD",
                    "severity": "error",
                    "offset": first,
                    "need_start": 0,
                    "need": HEADER_SIZE,
                }
            ]
        return out
    file_size = struct.unpack_from("<Q", buf, 40)[0]
    if file_size < HEADER_SIZE:  # §4.2 step 1: the header lies past file_size; §5 reads the bytes held
        r = _Reader(bytes(buf))
        r.run()
        out["problems"] = r.rep.problems
        return out
    if held(0, file_size):  # every byte: read as §5 reads the file
        verdict = read(bytes(buf[:file_size]))
        r = _Reader(bytes(buf[:file_size]))
        r.run()
        out["problems"] = verdict["problems"]
        if not verdict["valid"]:
            return out
        r.held_runs = [(0, file_size)]
    else:
        r = _Reader(bytes(buf), held=runs)
        r.run()
        out["problems"] = r.rep.problems
        if r.rep.has_error():
            return out
    out["opened"] = True
    ic, vc = r.chunks["INDX"], r.chunks["VERT"]
    needed, drawable = [], {}
    for k in range(r.L):
        lo, hi = r.lod_index_range(k)
        need = [[0, ic.offset]]
        if hi > lo:
            need.append([ic.offset + r.W * lo, ic.offset + r.W * hi])
        need.append([vc.offset, vc.offset + r.data_offset + r.vc[k] * r.stride])
        needed.append(need)
        if all(held(a, b) for a, b in need):
            arrays = r.vertices(r.vc[k])
            arrays["indices"] = r.view(ic.offset + r.W * lo, hi - lo)
            drawable[str(k)] = {name: _hash(arr) for name, arr in sorted(arrays.items())}
    out["needed"] = needed
    out["drawable_lods"] = [int(k) for k in drawable]
    out["drawable"] = drawable
    return out
