"""Adversarial files written from spec/format.md alone (a second reader's audit): edge values the vectors do
not hold, each with the codes and offsets the spec gives, no crash, no allocation from a count.

The files are built here byte by byte (``_file``: a header, a chunk table and payloads laid out as §2 says),
not with the project's writer, so that they can hold what a writer never produces.
"""

from __future__ import annotations

import json
import struct
import sys
import time
import tracemalloc
import zlib
from pathlib import Path
from typing import Any

import pytest

from swpm_usd.format import SwpmEncodeError, SwpmFormatError, encode_bytes, load_bytes, validate_bytes

VALID = Path(__file__).resolve().parents[1] / "spec" / "vectors" / "valid"
FEATURE = {"vanilla": 2, "sliding-window": 4, "skip-strip": 8, "mixed": 16}
P3 = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]


def _align(n: int, a: int) -> int:
    return (n + a - 1) // a * a


KNOWN = {b"META", b"LODS", b"RCNT", b"WREC", b"VREC", b"SKIP", b"SREC", b"MLVL", b"MREC", b"INDX", b"VERT"}


def _file(
    encoding: str, chunks: list[tuple[bytes, bytes]], *, critical: dict[bytes, int] | None = None
) -> bytes:
    """A v1.0 file: 64-byte header, table at 64, payloads on 8-byte boundaries in the order given, CRCs
    right. Every chunk is critical but SMAP and unknown types, unless ``critical`` says otherwise."""
    table_end = 64 + 32 * len(chunks)
    pos = _align(table_end, 8)
    table, body = bytearray(), bytearray()
    for i, (t, payload) in enumerate(chunks):
        flag = (critical or {}).get(t, 1 if t in KNOWN else 0)
        table += struct.pack("<4sIQQII", t, flag, pos, len(payload), zlib.crc32(payload, zlib.crc32(t)), 0)
        body += payload
        nxt = _align(pos + len(payload), 8) if i < len(chunks) - 1 else pos + len(payload)
        body += bytes(nxt - pos - len(payload))
        pos = nxt
    head = bytearray(64)
    head[:8] = b"SWPM\r\n\x1a\n"
    struct.pack_into("<HHIIIII", head, 8, 1, 0, 64, 0, FEATURE[encoding], len(chunks), 0)
    out = head + table + bytes(_align(table_end, 8) - table_end) + body
    struct.pack_into("<QQ", out, 32, 64, len(out))
    struct.pack_into("<I", out, 48, zlib.crc32(bytes(out[:table_end])))
    return bytes(out)


def _meta(encoding: str, params: dict[str, Any] | None = None) -> bytes:
    doc = {"encoding": encoding, "generator": "adversarial", "params": params or {}, "source_digest": None}
    return json.dumps(doc).encode()


def _lods(rows: list[tuple[int, int, float]]) -> bytes:
    return b"".join(struct.pack("<IIf", *r) for r in rows)


def _vert(points: list[tuple[float, float, float]]) -> bytes:
    return struct.pack("<IIII", len(points), 0, 12, 16) + b"".join(struct.pack("<3f", *p) for p in points)


def _u16(values: list[int]) -> bytes:
    return struct.pack(f"<{len(values)}H", *values)


def _records(rows: list[list[int]], offsets: list[int]) -> bytes:
    table = _u16([v for r in rows for v in r])
    return struct.pack("<II", len(rows), len(offsets)) + table + bytes(-len(table) % 4) + _u16(offsets)


def _levels(first_lod: list[int], starts: list[list[int]], tail: list[list[int]]) -> bytes:
    """SKIP / MLVL: level_count, the length of the tail arrays (C or D), then every array, each but the last
    padded to 4 bytes."""
    arrays = [first_lod, *starts, *tail]
    out = bytearray(struct.pack("<II", len(first_lod), len(tail[0])))
    for i, a in enumerate(arrays):
        out += _u16(a)
        if i < len(arrays) - 1:
            out += bytes(-len(out) % 4)
    return bytes(out)


def _vanilla_zero(points: list[tuple[float, float, float]]) -> bytes:
    return _file(
        "vanilla",
        [
            (b"META", _meta("vanilla")),
            (b"LODS", _lods([(len(points), 0, 0.0)])),
            (b"RCNT", _u16([0])),
            (b"VREC", _records([], [])),
            (b"INDX", b""),
            (b"VERT", _vert(points)),
        ],
    )


def _problems(data: bytes) -> list[tuple[str, int | None]]:
    return [(p.code, p.offset) for p in validate_bytes(data).problems]


def _entry(data: bytes, t: bytes) -> tuple[int, int, int]:
    """(entry offset, payload offset, length) of the first chunk of type ``t``."""
    count, to = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    for i in range(count):
        tt, _, off, ln = struct.unpack_from("<4sIQQ", data, to + 32 * i)
        if tt == t:
            return to + 32 * i, off, ln
    raise KeyError(t)


def _patch(data: bytes, offset: int, fmt: str, *values: Any) -> bytes:
    """``data`` with ``values`` packed at ``offset``, every chunk CRC and the file CRC recomputed (none when
    the chunk table no longer lies inside the file)."""
    b = bytearray(data)
    struct.pack_into(fmt, b, offset, *values)
    count, to = struct.unpack_from("<I", b, 24)[0], struct.unpack_from("<Q", b, 32)[0]
    if to + 32 * count > len(b):
        return bytes(b)
    for i in range(count):
        t, _, off, ln = struct.unpack_from("<4sIQQ", b, to + 32 * i)
        if off + ln <= len(b):
            struct.pack_into("<I", b, to + 32 * i + 24, zlib.crc32(bytes(b[off : off + ln]), zlib.crc32(t)))
    struct.pack_into("<I", b, 48, 0)
    struct.pack_into("<I", b, 48, zlib.crc32(bytes(b[: to + 32 * count])))
    return bytes(b)


def _with_meta(text: bytes) -> bytes:
    """A valid one-triangle sliding-window file whose META payload is ``text``."""
    return _file(
        "sliding-window",
        [
            (b"META", text),
            (b"LODS", _lods([(3, 1, 0.0)])),
            (b"WREC", _u16([0, 1, 3])),
            (b"INDX", _u16([0, 1, 2])),
            (b"VERT", _vert(P3)),
        ],
    )


def _nested(frames: int, data: bytes) -> list[tuple[str, int | None]]:
    return _problems(data) if frames == 0 else _nested(frames - 1, data)


# -- META: the limits RFC 8259 leaves to a parser, fixed by spec 3.1 -----------------------------------------
def _deep(depth: int) -> bytes:
    inner = depth - 1  # the top-level object is depth 1
    return b'{"encoding":"sliding-window","params":{},"x":' + b"[" * inner + b"]" * inner + b"}"


@pytest.mark.parametrize("depth, valid", [(128, True), (129, False), (500, False)])
def test_meta_nesting_limit_is_fixed_whatever_the_callers_stack(depth: int, valid: bool) -> None:
    """Spec 3.1: arrays and objects nest at most 128 deep. Python's own limit depended on how deep the caller
    already was: 500 levels were valid from a shallow stack and SWPM_META_BAD_JSON from 600 frames down."""
    data = _with_meta(_deep(depth))
    want = [] if valid else [("SWPM_META_BAD_JSON", _entry(data, b"META")[1])]
    assert _problems(data) == want
    assert _nested(600, data) == want


@pytest.mark.parametrize(
    "literal, valid",
    [
        (b"1e400", False),
        (b"-1e400", False),
        (str(2**1024 - 2**970).encode(), False),  # rounds to infinity (ties to even)
        (b"1" * 700, False),
        (b"1e308", True),
        (str(2**1024 - 2**970 - 1).encode(), True),  # rounds to the largest finite binary64
        (b"-0", True),
    ],
)
def test_meta_numbers_must_be_finite_in_binary64(literal: bytes, valid: bool) -> None:
    """Spec 3.1: a number that rounds to infinity is rejected as Infinity is; an integer below that is exact.
    A 700-digit integer was valid or not depending on Python's str-to-int digit limit (PYTHONINTMAXSTRDIGITS);
    1e400 was read as inf, which the writer then refused to save (allow_nan=False)."""
    data = _with_meta(b'{"encoding":"sliding-window","params":{"x":' + literal + b"}}")
    want = [] if valid else [("SWPM_META_BAD_JSON", _entry(data, b"META")[1])]
    assert _problems(data) == want
    if valid:
        assert load_bytes(data).params["x"] == json.loads(literal)


def test_meta_integers_do_not_depend_on_the_digit_limit() -> None:
    """The largest finite integer (309 digits) reads exactly under Python's lowest digit limit (640) too."""
    big = 2**1024 - 2**970 - 1
    data = _with_meta(b'{"params":{"x":' + str(big).encode() + b"}}")
    old = sys.get_int_max_str_digits()
    sys.set_int_max_str_digits(640)
    try:
        assert load_bytes(data).params["x"] == big
        assert _problems(_with_meta(b'{"params":{"x":' + b"1" * 700 + b"}}"))[0][0] == "SWPM_META_BAD_JSON"
    finally:
        sys.set_int_max_str_digits(old)


def test_meta_unpaired_surrogate_and_brackets_in_strings_are_json() -> None:
    """Spec 3.1: strings have no limit: an escaped unpaired surrogate is valid JSON; brackets inside strings
    do not nest."""
    text = b'{"params":{"name":"\\ud800","b":"' + b"[" * 300 + b'\\"{"}}'
    data = _with_meta(text)
    assert _problems(data) == []
    assert load_bytes(data).params["name"] == "\ud800"


def test_meta_depth_scan_is_linear_on_an_unterminated_string() -> None:
    """An unterminated string of 20,000 escaped quotes (40 KB) is not JSON, as quickly as the parser says so:
    the depth scan before parsing restarted a string at each quote (quadratic: 10 s for this file, 5 ms
    without the scan)."""
    data = _with_meta(b'{"params":{},"a":"' + b'\\"' * 20000)
    times = []
    for _ in range(3):  # the best of three: two xdist workers share the CI's 2 cores with its other jobs
        start = time.perf_counter()
        assert _problems(data) == [("SWPM_META_BAD_JSON", _entry(data, b"META")[1])]
        times.append(time.perf_counter() - start)
    assert min(times) < 2.0, times  # (3-16 ms measured at a load of 9)


def _nest(depth: int) -> list[Any]:
    out: list[Any] = []
    for _ in range(depth - 1):
        out = [out]
    return out


@pytest.mark.parametrize(
    "value, written",
    [
        (_nest(126), True),  # META depth 128: the object, params, then 126 lists
        (_nest(127), False),
        (10**400, False),
        (-(10**400), False),
        (2**1024 - 2**970, False),  # rounds to infinity
        (2**1024 - 2**970 - 1, True),
    ],
    ids=["depth-128", "depth-129", "1e400", "-1e400", "rounds-to-inf", "largest-finite"],
)
def test_the_writer_does_not_write_meta_the_reader_rejects(value: Any, written: bool) -> None:
    """A params value that makes META nest deeper than spec 3.1 allows, or an integer too large for binary64,
    is refused by the writer (SwpmEncodeError, a ValueError as NaN's is); it wrote a file its own reader
    rejected as SWPM_META_BAD_JSON. What it writes, the reader reads back."""
    pm = load_bytes((VALID / "minimal-vanilla.swpm").read_bytes())
    pm.params["x"] = value
    if not written:
        with pytest.raises(SwpmEncodeError, match=r"spec 3\.1"):
            encode_bytes(pm)
        return
    data = encode_bytes(pm)
    assert validate_bytes(data).valid
    assert load_bytes(data).params["x"] == value


# -- exact arithmetic (spec 1): sums and products do not wrap ------------------------------------------------
def test_offsets_and_counts_that_would_wrap_are_out_of_bounds() -> None:
    base = (VALID / "minimal-vanilla.swpm").read_bytes()
    ve, vo, _ = _entry(base, b"VERT")
    re_, ro, _ = _entry(base, b"VREC")
    se, so, _ = _entry(base, b"SMAP")
    cases = {
        # offset + length = 2^64 + 8 (wraps to 8)
        "chunk-offset": (_patch(base, ve + 8, "<Q", 2**64 - 8), ("SWPM_CHUNK_OUT_OF_BOUNDS", ve + 8)),
        "chunk-length": (_patch(base, ve + 16, "<Q", 2**64 - 8), ("SWPM_CHUNK_OUT_OF_BOUNDS", ve + 8)),
        # table_offset + 32 x 7 wraps to 160
        "table-offset": (_patch(base, 32, "<Q", 2**64 - 64), ("SWPM_TABLE_TRUNCATED", 24)),
        # 12 V = 12 x 2^30 + 60: wraps to the 60 bytes of 5 vertices at 32 bits
        "vert-count": (_patch(base, vo, "<I", 2**30 + 5), ("SWPM_COUNT_EXCEEDS_CHUNK", vo)),
        # 16 + 16 A wraps to 16
        "attribute-count": (_patch(base, vo + 4, "<I", 2**28), ("SWPM_COUNT_EXCEEDS_CHUNK", vo + 4)),
        # 4 W R = 8 (2^29 + 1) wraps to 8, the table of one record
        "record-count": (_patch(base, ro, "<I", 2**29 + 1), ("SWPM_COUNT_EXCEEDS_CHUNK", ro + 8)),
        # W M = 2 (2^31 + 2) wraps to 4
        "offset-count": (_patch(base, ro + 4, "<I", 2**31 + 2), ("SWPM_COUNT_EXCEEDS_CHUNK", ro + 16)),
    }
    assert re_ and se
    for name, (data, first) in cases.items():
        assert _problems(data)[:1] == [first], name
    # an SMAP range at 2^64 - 16 of length 32 ends past the file: SMAP is ancillary, the file stays valid
    bands = struct.unpack_from("<I", base, so)[0]
    data = _patch(base, so + 8 + 24 * bands, "<QQ", 2**64 - 16, 32)
    assert _problems(data) == [("SWPM_SMAP_INVALID", so + 8 + 24 * bands)]
    load_bytes(data)


def test_hostile_counts_allocate_nothing_from_the_count() -> None:
    """Spec 1: a count that fails its check allocates nothing: every hostile file here is rejected with less
    memory than 1 MB (the counts ask for up to 2^32 x stride bytes)."""
    base = (VALID / "minimal-vanilla.swpm").read_bytes()
    _, vo, _ = _entry(base, b"VERT")
    _, ro, _ = _entry(base, b"VREC")
    files = [
        _patch(base, vo, "<I", 0xFFFFFFFF),
        _patch(base, vo, "<I", 2**30 + 5),
        _patch(base, ro, "<I", 0xFFFFFFFF),
        _patch(base, ro + 4, "<I", 0xFFFFFFFF),
        _patch(base, 24, "<I", 1024),
    ]
    validate_bytes(base)  # warm (kernels loaded)
    for data in files:
        tracemalloc.start()
        try:
            with pytest.raises(SwpmFormatError):
                load_bytes(data)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak < 1 << 20


# -- zero counts: valid files a writer never makes ----------------------------------------------------------
ZERO = {
    "vanilla-no-vertices": lambda: _vanilla_zero([]),
    "vanilla-no-triangles": lambda: _vanilla_zero(P3),
    "sliding-empty-pool": lambda: _file(
        "sliding-window",
        [
            (b"META", _meta("sliding-window")),
            (b"LODS", _lods([(3, 0, 0.0)])),
            (b"WREC", _u16([0, 0, 3])),
            (b"INDX", b""),
            (b"VERT", _vert(P3)),
        ],
    ),
    "skip-empty-list": lambda: _file(
        "skip-strip",
        [
            (b"META", _meta("skip-strip", {"primitive": "list"})),
            (b"LODS", _lods([(3, 0, 0.0)])),
            (b"RCNT", _u16([0])),
            (b"SKIP", _levels([0], [[0, 0]] * 3, [[]])),
            (b"SREC", _records([], [])),
            (b"INDX", b""),
            (b"VERT", _vert(P3)),
        ],
    ),
    "mixed-empty-lists": lambda: _file(
        "mixed",
        [
            (b"META", _meta("mixed")),
            (b"LODS", _lods([(3, 0, 0.0)])),
            (b"RCNT", _u16([0])),
            (b"MLVL", _levels([0], [[0, 0]] * 3, [[], []])),
            (b"MREC", _records([], [])),
            (b"INDX", b""),
            (b"VERT", _vert(P3)),
        ],
    ),
}


@pytest.mark.parametrize("name", sorted(ZERO))
def test_zero_counts_are_valid_and_load(name: str) -> None:
    data = ZERO[name]()
    assert _problems(data) == []
    pm = load_bytes(data)
    assert pm.lod_count == 1 and len(pm.triangles_at(0)) == 0
    assert pm.draw_stream(0)[1].size == 0


# -- chunk table: what the first entry of a type is (spec 5, step 2) ---------------------------------------
def _fan_sliding() -> list[tuple[bytes, bytes]]:
    return [
        (b"META", _meta("sliding-window")),
        (b"LODS", _lods([(3, 1, 0.0)])),
        (b"WREC", _u16([0, 1, 3])),
        (b"INDX", _u16([0, 1, 2])),
        (b"VERT", _vert(P3)),
    ]


def test_a_broken_first_entry_is_its_types_chunk() -> None:
    """The first META fails its CRC: it is still META's chunk, so the second META is a duplicate and META is
    not missing."""
    chunks = _fan_sliding()
    data = _file("sliding-window", [chunks[0], (b"META", _meta("sliding-window")), *chunks[1:]])
    e0, o0, _ = _entry(data, b"META")
    b = bytearray(data)
    b[o0] ^= 1  # the first META's payload: its CRC no longer matches
    assert _problems(bytes(b)) == [
        ("SWPM_CHUNK_CRC_MISMATCH", e0 + 24),
        ("SWPM_CHUNK_DUPLICATE", e0 + 32),
        ("SWPM_STREAM_ORDER", e0 + 32),  # the second META stands where LODS belongs (spec 2.3)
    ]


def test_bad_critical_bit_does_not_stop_the_duplicate_check() -> None:
    chunks = _fan_sliding()
    data = _file("sliding-window", [*chunks[:2], (b"LODS", chunks[1][1]), *chunks[2:]], critical={b"LODS": 0})
    e1 = _entry(data, b"LODS")[0] + 32
    assert _problems(data) == [
        ("SWPM_CHUNK_BAD_FLAGS", e1 - 32 + 4),
        ("SWPM_CHUNK_BAD_FLAGS", e1 + 4),
        ("SWPM_CHUNK_DUPLICATE", e1),
        ("SWPM_STREAM_ORDER", e1),
    ]


def test_no_encoding_bit_means_no_missing_chunk_and_no_stream_order() -> None:
    data = _patch(_file("sliding-window", _fan_sliding()[::-1]), 20, "<I", 0)
    assert _problems(data) == [("SWPM_HEADER_BAD_ENCODING", 20)]


def test_rcnt_problems_are_one_problem() -> None:
    """errors.md: RCNT not from 0, decreasing and above R at once are one SWPM_RECORD_BAD_COUNTS."""
    base = (VALID / "minimal-vanilla.swpm").read_bytes()
    _, ro, _ = _entry(base, b"RCNT")
    assert _problems(_patch(base, ro, "<2H", 5, 1)) == [("SWPM_RECORD_BAD_COUNTS", ro)]


def test_overlapping_windows_report_the_lowest_offending_element() -> None:
    """Spec 3.5: LOD 1's window draws vertex 4 at INDX element 8, LOD 2's (overlapping, listed later) draws
    vertex 3 at element 2: the problem is at element 2, the lowest in INDX."""
    pool = [0, 1, 3, 0, 1, 2, 1, 2, 4, 0, 1, 4]
    points = [*P3, (1.0, 1.0, 0.0), (0.5, 0.5, 1.0)]
    data = _file(
        "sliding-window",
        [
            (b"META", _meta("sliding-window")),
            (b"LODS", _lods([(5, 3, 0.0), (4, 2, 0.1), (3, 1, 0.2)])),
            (b"WREC", _u16([3, 3, 5, 3, 2, 4, 0, 1, 3])),
            (b"INDX", _u16(pool)),
            (b"VERT", _vert(points)),
        ],
    )
    assert _problems(data) == [("SWPM_PREFIX_VIOLATION", _entry(data, b"INDX")[1] + 2 * 2)]


# -- OFFSET32 (required-feature bit 6, spec 1): the tables u32, the lists u16 --------------------------------
def _u32(values: list[int]) -> bytes:
    return struct.pack(f"<{len(values)}I", *values)


def _offset32(wrec: bytes, indx: bytes, restart_strips: bool = False) -> bytes:
    """A one-triangle sliding-window file with the OFFSET32 bit set (the features patched in, CRCs again)."""
    params = {"primitive": "strip", "restart_index": 0xFFFF} if restart_strips else {}
    data = _file(
        "sliding-window",
        [
            (b"META", _meta("sliding-window", params)),
            (b"LODS", _lods([(3, 1, 0.0)])),
            (b"WREC", wrec),
            (b"INDX", indx),
            (b"VERT", _vert(P3)),
        ],
    )
    return _patch(data, 20, "<I", FEATURE["sliding-window"] | (0x20 if restart_strips else 0) | 0x40)


def test_an_offset32_file_reads_its_tables_as_u32_and_its_lists_as_u16() -> None:
    """WREC is 3 O L = 12 bytes of u32, INDX u16: valid, and loaded as such; a WREC of 3 W L = 6 bytes (u16,
    as a reader ignoring the bit would read it) is SWPM_CHUNK_BAD_LENGTH at its entry's length field."""
    data = _offset32(_u32([0, 1, 3]), _u16([0, 1, 2]))
    assert _problems(data) == []
    pm = load_bytes(data)
    assert pm.window_records.dtype.itemsize == 4 and pm.index_pool.dtype.itemsize == 2
    assert pm.triangles_at(0).tolist() == [[0, 1, 2]]
    bad = _offset32(_u16([0, 1, 3]), _u16([0, 1, 2]))
    assert _problems(bad) == [("SWPM_CHUNK_BAD_LENGTH", _entry(bad, b"WREC")[0] + 16)]
    # a window's triangle_count field is at window + O
    wrong = _offset32(_u32([0, 2, 3]), _u16([0, 1, 2]))
    assert _problems(wrong)[0] == ("SWPM_WINDOW_COUNT_MISMATCH", _entry(wrong, b"WREC")[1] + 4)


def test_an_offset32_strip_pool_restarts_at_0xffff() -> None:
    """SW_STRIPS with OFFSET32: rows of 4 O bytes, the u16 pool joined by 0xFFFF; index_count at window +
    3 O."""
    pool = _u16([0, 1, 2, 0xFFFF, 0, 1, 2])
    assert _problems(_offset32(_u32([4, 1, 3, 3]), pool, restart_strips=True)) == []
    short = _offset32(_u32([4, 1, 3, 2]), pool, restart_strips=True)
    assert _problems(short) == [("SWPM_WINDOW_STRIP_TRIANGLES", _entry(short, b"WREC")[1] + 3 * 4)]
