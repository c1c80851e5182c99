"""Conformance vectors checked against the independent reader (tests/independent_reader.py).

The reader was written from spec/format.md and spec/errors.md only. Everything a vector pins is compared:
validity, the ordered list of problems (code, severity, offset), every summary field and every buffer's
name, shape and sha256.
"""

from __future__ import annotations

import hashlib
import json
import random
import struct
import sys
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from independent_reader import _Reader, read, read_prefix, read_ranges  # noqa: E402

VECTORS = Path(__file__).resolve().parent.parent / "spec" / "vectors"
MANIFEST = json.loads((VECTORS / "manifest.json").read_text())
CASES = [pytest.param(v, id=v["name"]) for v in MANIFEST["vectors"]]
PREFIX_CASES = [pytest.param(v, c, id=c["name"]) for v in MANIFEST["vectors"] for c in v.get("prefixes", [])]
RANGE_CASES = [pytest.param(v, c, id=c["name"]) for v in MANIFEST["vectors"] for c in v.get("ranges", [])]


def _load(vector: dict[str, Any]) -> tuple[bytes, dict[str, Any]]:
    data = (VECTORS / vector["file"]).read_bytes()
    expected = json.loads((VECTORS / vector["expected"]).read_text())
    return data, expected


def test_manifest_matches_files() -> None:
    names = [v["name"] for v in MANIFEST["vectors"]]
    assert len(names) == len(set(names))
    for vector in MANIFEST["vectors"]:
        data, expected = _load(vector)
        assert hashlib.sha256(data).hexdigest() == vector["sha256"], vector["name"]
        assert expected["valid"] is vector["valid"], vector["name"]
        assert ("summary" in expected) is vector["valid"], vector["name"]


@pytest.mark.parametrize("vector", CASES)
def test_validity_and_problems(vector: dict[str, Any]) -> None:
    """Validity and the exact, ordered list of problems (code, severity, offset) of every vector."""
    data, expected = _load(vector)
    got = read(data)
    assert got["valid"] is expected["valid"] is vector["valid"]
    assert got["problems"] == expected["problems"]


@pytest.mark.parametrize(("vector", "case"), PREFIX_CASES)
def test_prefix_case(vector: dict[str, Any], case: dict[str, Any]) -> None:
    """Every prefix case (format.md 4.1): the whole verdict on the file's first n bytes (problems with need,
    needed(k), the finest drawable LOD, its arrays); finishing is reading the whole file (test above)."""
    data, _ = _load(vector)
    expected = json.loads((VECTORS / case["expected"]).read_text())
    assert read_prefix(data[: case["length"]]) == expected


@pytest.mark.parametrize(("vector", "case"), RANGE_CASES)
def test_range_case(vector: dict[str, Any], case: dict[str, Any]) -> None:
    """Every range case (format.md 4.2): the whole verdict on the file's held ranges (problems with the
    range to fetch, the ranges each LOD needs, the drawable LODs, what each draws); finishing is reading the
    whole file (test_validity_and_problems)."""
    data, _ = _load(vector)
    expected = json.loads((VECTORS / case["expected"]).read_text())
    assert read_ranges(data, [tuple(r) for r in case["ranges"]]) == expected


def test_range_cases_cover_every_rule_of_4_2() -> None:
    """Each rule of format.md 4.2 has a range case: the header and table held or not, a bad magic, every
    byte held, deferred CRCs and padding (found at once when held), INDX partly held (opened with its
    content deferred, or a held list's SWPM_PREFIX_VIOLATION), drawable LODs not consecutive, unsorted and
    overlapping ranges, and ranges that open but whose file is rejected on finishing."""
    seen: set[str] = set()
    for vector in MANIFEST["vectors"]:
        data, whole = _load(vector)
        for case in vector.get("ranges", []):
            got = json.loads((VECTORS / case["expected"]).read_text())
            held = sorted((o, o + n) for o, n in case["ranges"])
            seen |= {q["code"] for q in got["problems"]}
            if any(b > a2 for (_, b), (a2, _) in zip(held, held[1:], strict=False)) or held != [
                (o, o + n) for o, n in case["ranges"]
            ]:
                seen.add("unsorted or overlapping")
            if not got["opened"]:
                for q in got["problems"]:
                    if q["code"] == "SWPM_RANGES_NOT_HELD":
                        seen.add(f"need [{q['need_start'] and 'o'}, ...)")
                continue
            seen.add("opened")
            lods = got["drawable_lods"]
            if not lods:
                seen.add("none drawable")
            elif lods != list(range(lods[0], lods[-1] + 1)):
                seen.add("not consecutive")
            elif lods[-1] < len(got["needed"]) - 1:
                seen.add("a coarser LOD not drawable")
            if not whole["valid"]:
                seen.add("opened, rejected on finishing")
            if whole["valid"] and any(o == 0 and n >= len(data) for o, n in case["ranges"]):
                seen.add("every byte")
    assert {
        "SWPM_RANGES_NOT_HELD",
        "need [0, ...)",
        "need [o, ...)",
        "SWPM_HEADER_BAD_MAGIC",
        "SWPM_CHUNK_CRC_MISMATCH",
        "SWPM_PADDING_NONZERO",
        "SWPM_PREFIX_VIOLATION",
        "SWPM_INDEX_OUT_OF_RANGE",
        "opened",
        "none drawable",
        "not consecutive",
        "a coarser LOD not drawable",
        "opened, rejected on finishing",
        "unsorted or overlapping",
        "every byte",
    } <= seen, seen


def test_prefix_cases_cover_every_rule_of_4_1() -> None:
    """Each rule of format.md 4.1 has a prefix case (the codes, deferred checks, drawable LODs), and with a
    valid SMAP every band's prefix_length is needed(first_lod) of an opened prefix."""
    seen: set[str] = set()
    bands_checked = 0
    for vector in MANIFEST["vectors"]:
        data, whole = _load(vector)
        for case in vector.get("prefixes", []):
            got = json.loads((VECTORS / case["expected"]).read_text())
            n = case["length"]
            codes = [q["code"] for q in got["problems"]]
            seen |= set(codes)
            if n < len(data) and got["opened"]:
                seen.add("opened")
                seen.add("drawable" if got["finest_drawable"] is not None else "none drawable")
                if not whole["valid"]:
                    seen.add("opened, rejected on finishing")
                if {q["code"] for q in whole["problems"]} - set(codes) - {"SWPM_SMAP_INVALID"}:
                    seen.add("deferred")
            smap = _smap_bands(data)
            if got["opened"] and smap and "SWPM_SMAP_INVALID" not in {q["code"] for q in whole["problems"]}:
                for first, _count, prefix_length in smap:
                    assert prefix_length == got["needed"][first], case["name"]
                    bands_checked += 1
    assert {
        "SWPM_PREFIX_TOO_SHORT",
        "SWPM_PREFIX_NOT_STREAMABLE",
        "SWPM_HEADER_BAD_MAGIC",
        "SWPM_CHUNK_CRC_MISMATCH",
        "opened",
        "drawable",
        "none drawable",
        "opened, rejected on finishing",
        "deferred",
    } <= seen, seen
    assert bands_checked >= 2


def _mutant(rng: random.Random, files: list[bytes], trial: int, flips: tuple[int, int], near: float) -> bytes:
    """A vector with ``flips`` (fewest, most) bytes changed, each in the first 320 bytes (header, table) with
    probability ``near``; on odd trials its CRCs fixed where the table still reads."""
    buf = bytearray(rng.choice(files))
    for _ in range(rng.randint(*flips)):
        at = rng.randrange(min(len(buf), 320)) if rng.random() < near else rng.randrange(len(buf))
        buf[at] = rng.choice((0, 1, 0xFF, rng.randrange(256)))
    if trial % 2:
        try:
            return _fix_crcs(buf)
        except struct.error:  # (a table the mutation moved out of the file)
            pass
    return bytes(buf)


def test_prefix_mutants_agree_with_the_reference_reader() -> None:
    """Mutated vectors (header, table and payload bytes; CRCs fixed or not) cut at chunk boundaries, VERT's
    records and random places: read_prefix gives the codec's verdict (format.md 4.1), and a prefix error
    other than the two prefix codes means the whole file is rejected (4.1: perhaps with another error)."""
    from swpm_usd.format.vectors import prefix_result

    rng = random.Random(4141)
    files = [_load(v)[0] for v in MANIFEST["vectors"]]
    checked = 0
    for trial in range(120):
        data = _mutant(rng, files, trial, flips=(1, 2), near=0.7)
        whole = read(data)
        count, table = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
        cuts = {0, 8, 63, 64, len(data) - 1, len(data), *(rng.randrange(len(data) + 1) for _ in range(4))}
        if count <= 16 and table + 32 * count <= len(data):
            for i in range(count):
                off = struct.unpack_from("<Q", data, table + 32 * i + 8)[0]
                cuts |= {off - 1, off, off + 16, off + 17} if off < len(data) else set()
        for n in sorted(c for c in cuts if 0 <= c <= len(data)):
            got = read_prefix(data[:n])
            assert got == prefix_result(data[:n]), (trial, n)
            if any(
                q["severity"] == "error" and not q["code"].startswith("SWPM_PREFIX_") for q in got["problems"]
            ):
                assert not whole["valid"], (trial, n)
            checked += 1
    assert checked > 1000


def test_range_mutants_agree_with_the_reference_reader() -> None:
    """Mutated vectors (header, table and payload bytes; CRCs fixed or not) opened from random byte ranges
    cut at chunk boundaries, VERT's header and random places (unsorted, overlapping, abutting): read_ranges
    gives the codec's verdict (format.md 4.2), and a range error other than SWPM_RANGES_NOT_HELD means the
    whole file is rejected (4.2: perhaps with another error)."""
    from swpm_usd.format.vectors import ranges_result

    rng = random.Random(4242)
    files = [_load(v)[0] for v in MANIFEST["vectors"]]
    checked = opened = 0
    for trial in range(160):
        data = _mutant(rng, files, trial, flips=(0, 2), near=0.6)
        if len(data) < 64:
            continue
        top = min(len(data), struct.unpack_from("<Q", data, 40)[0])  # (ranges past file_size: the caller's)
        count, table = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
        cuts, skeleton = {0, 8, 64, top}, []
        if count <= 16 and table + 32 * count <= len(data):
            cuts.add(table + 32 * count)
            for i in range(count):
                ctype, _flags, off, length = struct.unpack_from("<4sIQQ", data, table + 32 * i)
                cuts |= {x for x in (off, off + 1, off + 16, off + length - 1, off + length) if 0 <= x <= top}
                if ctype in (b"INDX", b"VERT") and off + length <= top:  # (what opening needs, often held)
                    head = (off, rng.randint(min(16, length), length))
                    skeleton.append((0, off) if ctype == b"INDX" else head)
        points = sorted(c for c in cuts if c <= top)
        whole = None
        for _ in range(3):
            ranges = list(skeleton) if rng.random() < 0.6 else []
            if rng.random() < 0.3 and len(points) > 1:
                ranges.append((0, rng.choice(points[1:])))
            for _ in range(rng.randint(1, 4)):
                a = rng.choice(points)
                b = rng.choice([*points, min(top, a + rng.randrange(1, 40))])
                if b > a:
                    ranges.append((a, b - a))
            rng.shuffle(ranges)
            if not ranges:
                continue
            got = read_ranges(data, ranges)
            assert got == ranges_result(data, ranges), (trial, ranges)
            checked += 1
            opened += got["opened"]
            if any(q["severity"] == "error" and q["code"] != "SWPM_RANGES_NOT_HELD" for q in got["problems"]):
                whole = read(data) if whole is None else whole
                assert not whole["valid"], (trial, ranges)
    assert checked > 300 and opened > 30, (checked, opened)


def _smap_bands(data: bytes) -> list[tuple[int, int, int]]:
    """(first_lod, lod_count, prefix_length) of each SMAP band (format.md 4), or [] without SMAP."""
    count, table = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    for i in range(count):
        ctype, _flags, off, _length = struct.unpack_from("<4sIQQ", data, table + 32 * i)
        if ctype == b"SMAP":
            bands = struct.unpack_from("<I", data, off)[0]
            return [
                (first, lods, prefix)
                for first, lods, _rs, _rn, prefix in (
                    struct.unpack_from("<IIIIQ", data, off + 8 + 24 * b) for b in range(bands)
                )
            ]
    return []


@pytest.mark.parametrize("vector", [c for c in CASES if c.values[0]["valid"]])
def test_summary(vector: dict[str, Any]) -> None:
    """Every summary field and every buffer's name, shape and sha256 (format.md §7)."""
    data, expected = _load(vector)
    got = read(data)
    assert "summary" in got
    want, have = expected["summary"], got["summary"]
    assert sorted(have) == sorted(want)
    for field in ("encoding", "index_width", "lod_count", "vertex_count", "triangle_count", "params"):
        assert have[field] == want[field], field
    assert sorted(have["buffers"]) == sorted(want["buffers"])
    for name, buf in want["buffers"].items():
        assert have["buffers"][name] == buf, name
    assert have == want


def _fix_crcs(buf: bytearray) -> bytes:
    """Recompute every chunk CRC and the file CRC so that corruption reaches the payload checks."""
    if len(buf) < 64:
        return bytes(buf)
    count = struct.unpack_from("<I", buf, 24)[0]
    table = struct.unpack_from("<Q", buf, 32)[0]
    if count > 1024 or table + 32 * count > len(buf):
        return bytes(buf)
    for i in range(count):
        eo = table + 32 * i
        off, length = struct.unpack_from("<QQ", buf, eo + 8)
        if off + length <= len(buf):
            crc = zlib.crc32(bytes(buf[off : off + length]), zlib.crc32(bytes(buf[eo : eo + 4])))
            struct.pack_into("<I", buf, eo + 24, crc)
    struct.pack_into("<I", buf, 48, 0)
    struct.pack_into("<I", buf, 48, zlib.crc32(bytes(buf[: table + 32 * count])))
    return bytes(buf)


def _check(result: dict[str, Any]) -> None:
    assert isinstance(result["valid"], bool)
    for p in result["problems"]:
        assert p["severity"] in ("error", "warning", "info")
        assert p["offset"] is None or p["offset"] >= 0
    if not result["valid"]:
        assert any(p["severity"] == "error" for p in result["problems"])


def test_corruption_never_raises() -> None:
    """Truncated and corrupted files never raise, hang or allocate from an unchecked count."""
    valid = [_load(v)[0] for v in MANIFEST["vectors"] if v["valid"]]
    smallest = min(valid, key=len)
    for cut in range(len(smallest)):
        result = read(smallest[:cut])
        _check(result)
        assert not result["valid"]
    rng = random.Random(20240601)
    for data in valid:
        for trial in range(300):
            buf = bytearray(data)
            for _ in range(rng.randint(1, 3)):
                buf[rng.randrange(len(buf))] = rng.choice((0, 1, 0xFF, rng.randrange(256)))
            _check(read(_fix_crcs(buf) if trial % 2 else bytes(buf)))
    # corruption inside the payloads, CRCs fixed, so that it reaches the encodings' checks
    for data in valid:
        table, count = struct.unpack_from("<Q", data, 32)[0], struct.unpack_from("<I", data, 24)[0]
        spans = [struct.unpack_from("<QQ", data, table + 32 * i + 8) for i in range(count)]
        for _trial in range(300):
            buf = bytearray(data)
            for _ in range(rng.randint(1, 3)):
                offset, length = rng.choice(spans)
                at = offset + rng.randrange(max(length, 1))
                if rng.random() < 0.5 and at + 2 <= offset + length:
                    struct.pack_into("<H", buf, at, rng.choice((0, 1, 2, 3, 4, 5, 0xFFFF)))
                elif at < len(buf):
                    buf[at] = rng.choice((0, 1, 2, 3, 4, 5, 0xFF, rng.randrange(256)))
            _check(read(_fix_crcs(buf)))


# META edits of the same length (JSON whitespace pads them), CRCs fixed so that they reach §3.1/§3.7.
META_EDITS = [
    # duplicate key in a nested object: not RFC 8259 JSON (§3.1)
    ("mixed", b'"cache_size":16,"level_threshold":0.25', b'"cache_size":16,"cache_size"     :0.25', "JSON"),
    # NaN is not JSON (§3.1)
    ("skip-strip-strip", b'"restart_index":65535', b'"restart_index":NaN  ', "JSON"),
    # restart_index a boolean (§3.7)
    ("skip-strip-strip", b'"restart_index":65535', b'"restart_index":true ', "FIELD"),
    # restart_index at or above 2^32 (§3.7)
    ("skip-strip-strip", b'"restart_index":65535', b'"restart_index":4.3e9', "FIELD"),
    # a number that rounds to infinity in binary64 is not JSON, as Infinity is not (§3.1)
    ("skip-strip-strip", b'"restart_index":65535', b'"restart_index":9e999', "JSON"),
    # a strips' restart index below V = 5 is a vertex (§3.7)
    ("skip-strip-strip", b'"restart_index":65535', b'"restart_index":    4', "FIELD"),
    # a leading byte-order mark is not JSON (§3.1)
    (
        "minimal-vanilla",
        b'{"encoding":"vanilla","generator":"swpm-usd conformance"',
        b'\xef\xbb\xbf{"encoding":"vanilla","generator":"swpm-usd conforma"',
        "JSON",
    ),
]


@pytest.mark.parametrize(("name", "old", "new", "what"), META_EDITS)
def test_meta_rules(name: str, old: bytes, new: bytes, what: str) -> None:
    vector = next(v for v in MANIFEST["vectors"] if v["name"] == name)
    data, _expected = _load(vector)
    assert data.count(old) == 1 and len(old) == len(new)
    result = read(_fix_crcs(bytearray(data.replace(old, new))))
    meta = data.index(b'{"encoding"')
    assert result["problems"] == [{"code": "SWPM_META_BAD_" + what, "severity": "error", "offset": meta}]


# The points a later audit settled (§2.2, §2.3, §3.6), on files patched here from the vectors' bytes.
def _entries(data: bytes) -> list[tuple[bytes, int, int, int]]:
    """(type, entry offset, payload offset, length) of every chunk-table entry."""
    count, table = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    out = []
    for i in range(count):
        ctype, _flags, offset, length = struct.unpack_from("<4sIQQ", data, table + 32 * i)
        out.append((ctype, table + 32 * i, offset, length))
    return out


def _entry(data: bytes, ctype: bytes) -> tuple[int, int, int]:
    return next((e, o, n) for t, e, o, n in _entries(data) if t == ctype)


def _vector(name: str) -> bytes:
    return _load(next(v for v in MANIFEST["vectors"] if v["name"] == name))[0]


def _append_duplicate(data: bytes, ctype: bytes) -> tuple[bytes, int]:
    """``data`` with one more table entry, listed and laid out last, holding a copy of ``ctype``'s payload
    (every payload moves 32 bytes on, so the new entry fits in the table); returns it and the new entry."""
    entries = _entries(data)
    table = struct.unpack_from("<Q", data, 32)[0]
    table_end = table + 32 * len(entries)
    out = bytearray(data[:table_end])
    struct.pack_into("<I", out, 24, len(entries) + 1)
    for _t, eo, offset, _n in entries:
        struct.pack_into("<Q", out, eo + 8, offset + 32)
    eo, po, pl = _entry(data, ctype)
    out += data[eo : eo + 32] + data[table_end:]
    out += bytes(-len(out) % 8)
    struct.pack_into("<Q", out, table_end + 8, len(out))
    out += data[po : po + pl]
    struct.pack_into("<Q", out, 40, len(out))
    return _fix_crcs(out), table_end


def test_a_trailing_duplicate_is_out_of_streaming_order() -> None:
    """§2.3: a duplicate after one entry of every type (VERT VERT, VERT INDX) is reported at its position."""
    for ctype in (b"VERT", b"INDX"):
        data, eo = _append_duplicate(_vector("minimal-vanilla"), ctype)
        problems = [(p["code"], p["offset"]) for p in read(data)["problems"]]
        assert problems == [("SWPM_CHUNK_DUPLICATE", eo), ("SWPM_STREAM_ORDER", eo)], ctype


def test_padding_before_a_chunk_past_the_end() -> None:
    """§2.2: the gap before a chunk that starts past the end of the file is checked up to the end of the file
    (its first file_size bytes), after the entry's SWPM_CHUNK_OUT_OF_BOUNDS."""
    base = _vector("minimal-vanilla")
    eo, vo, vl = _entry(base, b"VERT")
    moved = bytearray(base)
    struct.pack_into("<Q", moved, eo + 8, len(base) + 4)  # the next multiple of 8 past the end
    bounds, gap = ("SWPM_CHUNK_OUT_OF_BOUNDS", eo + 8), ("SWPM_PADDING_NONZERO", vo)
    cases = [
        (moved, [bounds, gap]),  # VERT's old payload is left in the gap
        (moved[:vo] + bytes(vl), [bounds]),
        (moved[:vo] + bytes(vl - 1) + b"\1", [bounds, gap]),
    ]
    for data, want in cases:
        problems = [(p["code"], p["offset"]) for p in read(_fix_crcs(bytearray(data)))["problems"]]
        assert problems == want
    trailing = _fix_crcs(moved[:vo] + bytes(vl)) + b"\1" * 8  # bytes after file_size are not padding
    problems = [(p["code"], p["offset"]) for p in read(trailing)["problems"]]
    assert problems == [("SWPM_FILE_TRAILING_BYTES", len(base)), bounds]


@pytest.mark.parametrize(("name", "ctype", "at"), [("skip-strip-list", b"SREC", 16), ("mixed", b"MREC", 20)])
def test_a_slot_listed_twice_is_a_bad_change(name: str, ctype: bytes, at: int) -> None:
    """§3.6-3.8: the changes of a record are made in the order listed; its second slot replaced by its first
    (slot 2 listed twice, u16 offsets at ``at``): SWPM_RECORD_BAD_CHANGE at the record's row, not a collapsed
    list that differs."""
    data = bytearray(_vector(name))
    _, po, _ = _entry(bytes(data), ctype)
    assert struct.unpack_from("<2H", data, po + at) == (2, 5)
    struct.pack_into("<H", data, po + at + 2, 2)
    problems = [(p["code"], p["offset"]) for p in read(_fix_crcs(data))["problems"]]
    assert problems == [("SWPM_RECORD_BAD_CHANGE", po + 8)]


# The LODs as format.md defines them, decoded from the independent reader's arrays (§3.4-3.8): every LOD draws
# only vertices below its vertex count and as many triangles as LODS says.
def _strip_triangles(lst: np.ndarray, primitive: str, restart: int | None) -> np.ndarray:
    """The triangles of a skip-strip level list (§3.7), degenerate ones included."""
    if primitive == "list":
        return lst.reshape(-1, 3)
    strips = np.split(lst, np.flatnonzero(lst == restart)) if restart is not None else [lst]
    tris = []
    for n, s in enumerate(strips):
        s = s[1:] if n else s  # after a restart index
        for i in range(len(s) - 2):
            tris.append((s[i], s[i + 1], s[i + 2]) if i % 2 == 0 else (s[i + 1], s[i], s[i + 2]))
    return np.array(tris, np.int64).reshape(-1, 3)


def _decode_lods(data: bytes) -> tuple[dict[str, np.ndarray], list[np.ndarray]]:
    """Every LOD's drawn triangles: vanilla and mixed the live ones, sliding-window its window, skip-strip the
    non-degenerate ones of its level's list after RCNT[k] records."""
    rd = _Reader(data)
    assert rd.run()["valid"]
    b = {k: np.asarray(v).astype(np.int64) for k, v in rd.buffers.items() if np.asarray(v).dtype.kind in "iu"}
    L, V = len(b["vertex_counts"]), len(rd.buffers["points"])
    enc = rd.encoding
    if enc == "sliding-window" and "window_index_counts" in b:  # a strip pool (SW_STRIPS, §3.5)
        restart = rd.params["restart_index"]
        out = []
        for (f, _t, _v), n in zip(b["window_records"], b["window_index_counts"], strict=True):
            tris = _strip_triangles(b["index_pool"][f : f + n], "strip", restart)
            out.append(
                tris[(tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])]
            )
        return b, out
    if enc == "sliding-window":
        return b, [b["index_pool"][f : f + 3 * t].reshape(-1, 3) for f, t, _v in b["window_records"]]
    cc = b["collapse_change_count"]
    cstart = np.concatenate([[0], np.cumsum(cc)])
    offs, kept, rcnt = b["collapse_change_offsets"], b["collapse_kept"], b["lod_record_counts"]
    lods = []
    for k in range(L):
        if enc == "vanilla":
            lst, first_rec = b["indices"].copy(), 0
        else:
            first = b["level_first_lod"]
            lv = int(np.searchsorted(first, k, side="right") - 1)
            first_rec = int(b["level_record_start"][lv])
            if enc == "skip-strip":
                s = b["level_index_start"]
                lst = b["level_indices"][s[lv] : s[lv + 1]].copy()
            else:
                s, d = b["level_static_start"], b["level_dynamic_start"]
                static = b["level_static_indices"][s[lv] : s[lv + 1]]
                lst = b["level_dynamic_indices"][d[lv] : d[lv + 1]].copy()
        for r in range(first_rec, int(rcnt[k])):
            assert (lst[offs[cstart[r] : cstart[r + 1]]] == V - 1 - r).all()
            lst[offs[cstart[r] : cstart[r + 1]]] = kept[r]
        applied = slice(first_rec, int(rcnt[k]))
        if enc == "vanilla":
            tris = lst[: len(lst) - 3 * int(b["collapse_tris_removed"][applied].sum())].reshape(-1, 3)
        elif enc == "mixed":
            live_d = len(lst) // 3 - int(b["collapse_dynamic_tris_removed"][applied].sum())
            live_s = len(static) // 3 - int(b["collapse_static_tris_removed"][applied].sum())
            tris = np.concatenate([lst[: 3 * live_d], static[: 3 * live_s]]).reshape(-1, 3)
        else:
            primitive = rd.params.get("primitive", "strip")
            restart = rd.params.get("restart_index") if primitive == "strip" else None
            tris = _strip_triangles(lst, primitive, restart)
            tris = tris[(tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])]
        lods.append(tris)
    return b, lods


@pytest.mark.parametrize("vector", [c for c in CASES if c.values[0]["valid"]])
def test_every_lod_keeps_the_vertex_prefix_and_its_triangle_count(vector: dict[str, Any]) -> None:
    """§3.2-3.8 decoded independently of the codec: LOD k draws only vertices [0, vertex_count(k)) and
    triangle_count(k) triangles, and the same triangles as the codec's ``triangles_at(k)``."""
    import swpm_usd

    data, _expected = _load(vector)
    b, lods = _decode_lods(data)
    pm = swpm_usd.load(VECTORS / vector["file"])
    for k, tris in enumerate(lods):
        assert tris.size == 0 or int(tris.max()) < int(b["vertex_counts"][k]), k
        assert len(tris) == int(b["triangle_counts"][k]), k
        ours = sorted(map(tuple, np.sort(tris, axis=1).tolist()))
        theirs = sorted(map(tuple, np.sort(np.asarray(pm.triangles_at(k)), axis=1).tolist()))
        assert ours == theirs, k


# OFFSET32 (§1): every valid vector rewritten with u16 idx and u32 off tables (tests/offset32_transcode.py,
# from the spec alone) reads as the same values, the tables now u32.
IDX_ARRAYS = {
    "indices",
    "index_pool",
    "level_indices",
    "level_collapsed_indices",
    "level_static_indices",
    "level_dynamic_indices",
    "level_dynamic_collapsed_indices",
}
LODS_ARRAYS = {"vertex_counts", "triangle_counts", "lod_errors", "points"}


def _without_offset32(vector: dict[str, Any]) -> bool:
    return vector["valid"] and not struct.unpack_from("<I", _load(vector)[0], 20)[0] & 0x40


@pytest.mark.parametrize("vector", [c for c in CASES if _without_offset32(c.values[0])])
def test_offset32_rewrite_reads_the_same_values(vector: dict[str, Any]) -> None:
    from offset32_transcode import to_offset32

    data, _expected = _load(vector)
    before = _Reader(data)
    assert before.run()["valid"]
    rewritten = to_offset32(data)
    after = _Reader(rewritten)
    got = after.run()
    assert got["valid"], got["problems"]
    assert (got["summary"]["index_width"], got["summary"]["offset_width"]) == (2, 4)
    assert sorted(after.buffers) == sorted(before.buffers)
    for name, old in before.buffers.items():
        new = after.buffers[name]
        if name in LODS_ARRAYS or name.startswith("attribute:"):
            assert new.dtype == old.dtype and np.array_equal(new, old, equal_nan=True), name
            continue
        assert new.dtype == np.dtype("<u2" if name in IDX_ARRAYS else "<u4"), name
        want = old.astype(np.int64)
        want[want == 0xFFFFFFFF] = 0xFFFF  # a u32 file's restart index, as a u32 -> u16 copy makes it
        assert np.array_equal(new.astype(np.int64), want), name
    # the bit is what makes the tables u32: cleared, the same bytes are not a valid file
    cleared = bytearray(rewritten)
    struct.pack_into("<I", cleared, 20, struct.unpack_from("<I", cleared, 20)[0] & ~0x40)
    assert not read(_fix_crcs(cleared))["valid"]


@pytest.mark.parametrize("name", ["vanilla-u32", "skip-strip-strip-u32", "sliding-window-strips-u32"])
def test_offset32_with_index32(name: str) -> None:
    """§2.1: OFFSET32 with INDEX32 is an error at the features field that does not stop the checks; the file
    is read with off = idx = u32, so a valid u32 file then has that one problem."""
    data = bytearray(_vector(name))
    struct.pack_into("<I", data, 20, struct.unpack_from("<I", data, 20)[0] | 0x40)
    got = read(_fix_crcs(data))
    assert not got["valid"]
    want = {"code": "SWPM_HEADER_OFFSET32_WITH_INDEX32", "severity": "error", "offset": 20}
    assert got["problems"] == [want]


def _vector_as_offset32(vector: dict[str, Any]) -> bytes:
    data = _load(vector)[0]
    return data if struct.unpack_from("<I", data, 20)[0] & 0x40 else _offset32(data)


def _offset32(data: bytes) -> bytes:
    from offset32_transcode import to_offset32

    return to_offset32(data)


@pytest.mark.parametrize("vector", [c for c in CASES if c.values[0]["valid"]])
def test_offset32_mutations_agree_with_the_reference_reader(vector: dict[str, Any]) -> None:
    """Every valid vector as an OFFSET32 file (itself, or rewritten), one 2- or 4-byte value of a table or
    list changed (CRCs fixed): this reader lists exactly the problems (code, severity, offset) the reference
    validator lists, so the O-sized offsets of errors.md agree beyond the vectors that pin them."""
    from swpm_usd.format.reader import validate_bytes

    data = _vector_as_offset32(vector)
    count, table = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    spans = [struct.unpack_from("<4sIQQ", data, table + 32 * i) for i in range(count)]
    spans = [(o, n) for t, _f, o, n in spans if t not in (b"META", b"LODS", b"VERT") and n >= 8]
    rng = random.Random(191)
    problems = 0
    for _ in range(25):
        offset, length = rng.choice(spans)
        size = rng.choice((2, 4))
        at = offset + 2 * rng.randrange((length - size) // 2 + 1)
        fmt = "<H" if size == 2 else "<I"
        old = struct.unpack_from(fmt, data, at)[0]
        new = rng.choice((old + 1, old - 1, old + 3, 0, 1, 0xFFFF, 0x10000, rng.randrange(70000)))
        buf = bytearray(data)
        struct.pack_into(fmt, buf, at, new & (0xFFFF if size == 2 else 0xFFFFFFFF))
        mutated = _fix_crcs(buf)
        mine = read(mutated)["problems"]
        theirs = [
            {"code": q.code, "severity": q.severity, "offset": q.offset}
            for q in validate_bytes(mutated).problems
        ]
        assert mine == theirs, f"+{at - offset}: {old} -> {new}"
        problems += len(mine)
    assert problems > 0
