"""Reading byte ranges from C (spec/format.md 4.2): the C reader's ``swpm_open_ranges`` /
``swpm_ranges_finish`` (through ``swpm_dump --ranges``) agree with ``swpm_usd.format.open_ranges`` on the
verdict, the code, its offset and the range to fetch, the drawable LODs and the CRC of every drawable LOD's
points and ``INDX`` elements, band by band of ``SMAP`` for every valid vector and for real files of every
encoding; the bytes not held set to 0x00 and to 0xAA give the same output (nothing unheld is read), also
under AddressSanitizer with the held ranges copied into a buffer of their own; finishing gives the
whole-file verdict. A file whose tables follow INDX needs them held, in C as in Python; the contract
swpm_reader.h states on the held ranges (order, overlap, empty ranges, SWPM_READER_BAD_RANGES) is checked by
tests/c_bad_ranges.c, also under ASan / UBSan.
"""

from __future__ import annotations

import json
import struct
import subprocess
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import refix_crcs
from test_c_reader import MANIFEST, VECTORS, _lpm, _pm, _vpm
from test_prefix import POOL, _chunks, dump, dump_san  # noqa: F401  (fixtures: the C reader built once per module)

from swpm_usd.format import SwpmFormatError, encode_bytes, open_prefix, validate_bytes
from swpm_usd.format.ranges import ranges_for_lod, validate_ranges

VALID = [v["name"] for v in MANIFEST["vectors"] if v["valid"]]
#: the valid vectors with an SMAP (the others have no bands to read)
BANDED = [n for n in VALID if b"SMAP" in _chunks((VECTORS / "valid" / f"{n}.swpm").read_bytes())]


def _held(data: bytes, spans: list[tuple[int, int]]) -> dict[int, bytes]:
    held: dict[int, bytes] = {}
    for o, n in spans:
        if n and len(data[o : o + n]) > len(held.get(o, b"")):
            held[o] = data[o : o + n]
    return held


def _expected(data: bytes, spans: list[tuple[int, int]]) -> dict[str, Any]:
    """What ``swpm_dump --ranges`` must print, from the Python codec."""
    from swpm_usd.format.ranges import open_ranges

    held = _held(data, spans)
    rep = validate_ranges(held)
    if not rep.valid:
        e = rep.errors[0]
        out: dict[str, Any] = {"ok": False, "code": e.code, "offset": e.offset}
        if e.code == "SWPM_RANGES_NOT_HELD":
            start, end = rep.summary["range_need"]
            out["need"] = end
            if start:
                out["need_start"] = start
        return out
    fr = open_ranges(held)
    L = fr.lod_count
    lods = [int(k) for k in fr.drawable_lods]
    c = 0
    for k in lods:
        c = zlib.crc32(np.ascontiguousarray(fr.lod_points(k), "<f4").tobytes(), c)
        c = zlib.crc32(np.ascontiguousarray(fr.lod_index_elements(k)).tobytes(), c)
    needed = [[x for r in fr.needed_ranges(k) for x in r] for k in sorted({0, L - 1})]
    out = {"ok": True, "lod_count": L, "finest": lods[0] if lods else L, "drawable": lods, "drawn_crc": c}
    out["needed"] = needed
    full = validate_bytes(data)
    if full.valid:
        pm = fr.finish(data)
        out["finish"] = {"ok": True}
        out["whole_crc"] = [
            zlib.crc32(np.ascontiguousarray(pm.points, "<f4").tobytes()),
            zlib.crc32(np.ascontiguousarray(open_prefix(data).buffers[POOL[fr.encoding]]).tobytes()),
        ]
    else:
        e = full.errors[0]
        out["finish"] = {"ok": False, "code": e.code, "offset": e.offset}
        with pytest.raises(SwpmFormatError):
            fr.finish(data)
    return out


def _c(binary: Path, path: Path, spans: list[tuple[int, int]], fill: int) -> dict[str, Any]:
    spec = ",".join(f"{o}:{n}" for o, n in spans if n)
    cmd = [str(binary), "--ranges", spec, "--fill", f"{fill:02x}", str(path)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr[-2000:]
    return json.loads(proc.stdout)


def _agree(binary: Path, path: Path, data: bytes, spans: list[tuple[int, int]]) -> dict[str, Any]:
    want = _expected(data, spans)
    got = _c(binary, path, spans, 0x00)
    assert got == want, (path.name, spans, got, want)
    assert _c(binary, path, spans, 0xAA) == got, (path.name, spans)  # an unheld byte read would differ
    return got


def _bands(data: bytes) -> list[list[tuple[int, int]]]:
    """SMAP's ranges for each band (by its first LOD), as ``ranges_for_lod`` names them."""
    smap = _chunks(data).get(b"SMAP")
    if smap is None:
        return []
    off = smap[0]
    B = struct.unpack_from("<I", data, off)[0]
    firsts = [struct.unpack_from("<I", data, off + 8 + 24 * b)[0] for b in range(B)]
    return [ranges_for_lod(data, k) for k in firsts]


def _run_file(binary: Path, path: Path, data: bytes) -> list[dict[str, Any]]:
    got = []
    bands = _bands(data)
    assert bands, path.name
    for spans in bands:
        got.append(_agree(binary, path, data, spans))
        # one range short: the header alone, and the band without its last range (SWPM_RANGES_NOT_HELD or
        # fewer LODs drawn)
        got.append(_agree(binary, path, data, [(0, 64)]))
        if len(spans) > 1:
            got.append(_agree(binary, path, data, spans[:-1]))
    return got


@pytest.mark.parametrize("name", BANDED)
def test_valid_vectors_band_by_band(dump: Path, name: str) -> None:  # noqa: F811
    path = VECTORS / "valid" / f"{name}.swpm"
    data = path.read_bytes()
    got = _run_file(dump, path, data)
    assert any(o["ok"] and o["drawable"] for o in got)


REAL = [
    ("sliding-window-list", lambda m: _pm(m, "list")),
    ("sliding-window-strip", lambda m: _pm(m, "strip")),
    ("vanilla", _vpm),
    ("skip-strip", lambda m: _lpm(m, "skip-strip")),
    ("mixed", lambda m: _lpm(m, "mixed")),
]


@pytest.mark.parametrize("mesh", ["suzanne", "spot", "cow"])
@pytest.mark.parametrize(("variant", "build"), REAL, ids=[r[0] for r in REAL])
def test_real_files_band_by_band(dump: Path, tmp_path: Path, mesh: str, variant: str, build: Any) -> None:  # noqa: F811
    data = encode_bytes(build(mesh))
    path = tmp_path / f"{mesh}-{variant}.swpm"
    path.write_bytes(data)
    got = _run_file(dump, path, data)
    drawn = [o for o in got if o["ok"] and o["drawable"]]
    assert drawn, got  # the coarsest band at least draws from its ranges
    L = drawn[0]["lod_count"]
    assert any(L - 1 in o["drawable"] for o in drawn)
    if variant != "vanilla":  # a band's ranges draw from a fraction of the file, not all of it
        assert any(o["drawable"][0] > 0 for o in drawn)


def _coarsest_band(data: bytes) -> list[tuple[int, int]]:
    return _bands(data)[-1]


def test_sanitizer_fresh_buffers(dump_san: Path, tmp_path: Path) -> None:  # noqa: F811
    """Under AddressSanitizer / UBSan the held ranges sit in a buffer of their own up to the last held byte
    (odd addresses), filled with 0xAA elsewhere: every band of a vector of each encoding and the coarsest
    band of real sliding-window, skip-strip and mixed files open, draw and finish as Python's."""
    for name in BANDED[:12]:
        path = VECTORS / "valid" / f"{name}.swpm"
        data = path.read_bytes()
        for spans in _bands(data):
            assert _c(dump_san, path, spans, 0xAA) == _expected(data, spans), name
    for variant, build in REAL[:2] + REAL[3:]:
        data = encode_bytes(build("suzanne"))
        path = tmp_path / f"{variant}.swpm"
        path.write_bytes(data)
        spans = _coarsest_band(data)
        got = _c(dump_san, path, spans, 0xAA)
        assert got == _expected(data, spans) and got["ok"] and got["drawable"], variant


def _set_index(data: bytes, element: int, value: int) -> bytes:
    """INDX element ``element`` set to ``value`` (little-endian, the file's width), CRCs recomputed."""
    ch = _chunks(data)
    io, _ = ch[b"INDX"]
    features = struct.unpack_from("<I", data, 20)[0]
    w = 4 if features & 1 else 2
    b = bytearray(data)
    b[io + w * element : io + w * (element + 1)] = value.to_bytes(w, "little")
    return refix_crcs(bytes(b))


def test_drawn_element_and_deferred_faults(dump: Path, tmp_path: Path) -> None:  # noqa: F811
    """A drawn window's element at or past its vertex count: SWPM_PREFIX_VIOLATION at that element, from
    C as from Python (spec 4.2 step 3); the same fault in an element the ranges do not hold is deferred:
    the ranges open, draw, and finishing gives the whole file's error. A VERT byte past the ranges changed
    (its CRC fails): deferred the same way."""
    for variant, build in (REAL[0], REAL[3], REAL[4]):
        data = encode_bytes(build("suzanne"))
        spans = _coarsest_band(data)
        io = _chunks(data)[b"INDX"][0]
        w = 4 if struct.unpack_from("<I", data, 20)[0] & 1 else 2
        held_idx = [
            (o, n)
            for o, n in spans
            if o >= io and o + n <= _chunks(data)[b"INDX"][0] + _chunks(data)[b"INDX"][1]
        ]
        assert held_idx, variant
        o, n = held_idx[0]
        V = struct.unpack_from("<I", data, _chunks(data)[b"VERT"][0])[0]
        bad = _set_index(data, (o - io) // w, V - 1)  # (the finest vertex: past any coarse LOD's count)
        path = tmp_path / f"{variant}-drawn.swpm"
        path.write_bytes(bad)
        got = _agree(dump, path, bad, spans)
        assert got["code"] == "SWPM_PREFIX_VIOLATION" and got["offset"] == o, (variant, got)
        far = _set_index(data, 0 if o > io else (o + n - io) // w, V)  # an element not held: out of range
        path = tmp_path / f"{variant}-deferred.swpm"
        path.write_bytes(far)
        got = _agree(dump, path, far, spans)
        assert got["ok"] and got["drawable"] and not got["finish"]["ok"], (variant, got)
        assert got["finish"]["code"] == validate_bytes(far).errors[0].code
    data = encode_bytes(REAL[0][1]("suzanne"))
    spans = _coarsest_band(data)
    vo, vl = _chunks(data)[b"VERT"]
    b = bytearray(data)
    b[vo + vl - 1] ^= 0x40  # the finest vertex's last byte: past the coarsest band's VERT range
    path = tmp_path / "vert-crc.swpm"
    path.write_bytes(bytes(b))
    got = _agree(dump, path, bytes(b), spans)
    assert got["ok"] and got["finish"]["code"] == "SWPM_CHUNK_CRC_MISMATCH", got


def test_record_faults_before_indx_found_at_once(dump: Path, tmp_path: Path) -> None:  # noqa: F811
    """Spec 4.2 step 3: with INDX not all held, a record check that reads no INDX element still runs (a
    skip-strip record's binned vertex, a mixed record's removal counts): the range read of the coarsest band
    reports the whole file's first error at once, in C as in Python; only the replays wait. Each file is
    changed at the first SREC / MREC byte (after its counts) whose change makes the whole file fail with a
    record error, CRCs recomputed."""
    for variant, build in (REAL[3], REAL[4]):
        data = encode_bytes(build("suzanne"))
        spans = _coarsest_band(data)
        tag = b"SREC" if variant == "skip-strip" else b"MREC"
        ro, rl = _chunks(data)[tag]
        for pos in range(ro + 8, ro + rl):
            b = bytearray(data)
            b[pos] ^= 0x01
            bad = refix_crcs(bytes(b))
            whole = validate_bytes(bad)
            if not whole.valid and whole.errors[0].code.startswith("SWPM_RECORD_"):
                break
        else:
            raise AssertionError(f"{variant}: no record byte fails the whole file")
        path = tmp_path / f"{variant}-record.swpm"
        path.write_bytes(bad)
        got = _agree(dump, path, bad, spans)
        assert not got["ok"] and got["code"] == whole.errors[0].code, (variant, got, whole.errors[0])
        assert got["offset"] == whole.errors[0].offset, (variant, got)


#: a vector of each encoding, whose tables and SMAP are moved after INDX below
AFTER_INDX = ["minimal-vanilla", "sliding-window-offset32", "skip-strip-strip", "mixed"]


@pytest.mark.parametrize("name", AFTER_INDX)
def test_tables_after_indx_must_be_held(dump: Path, dump_san: Path, tmp_path: Path, name: str) -> None:  # noqa: F811
    """Spec 4.2 (a table after INDX): a file laid out META LODS INDX [tables] SMAP VERT, held as [0, INDX's
    end) and all of VERT: SWPM_RANGES_NOT_HELD names each table's payload in the order of 2.3, in C as in
    Python (they used to differ: Python decoded the tables' unheld bytes as zeros, reporting errors of the
    whole file it does not have), also under ASan / UBSan; once every table is held the ranges open and
    draw every LOD, with no SMAP warning while SMAP is not held (a wrong map, SWPM_SMAP_INVALID in the
    whole file and in ranges that hold it, waits for finishing when they do not)."""
    from swpm_usd.format.vectors import _entries, reorder

    data = (VECTORS / "valid" / f"{name}.swpm").read_bytes()
    types = [t for t, *_ in _entries(data)]
    tables = [i for i, t in enumerate(types) if t not in (b"META", b"LODS", b"SMAP", b"INDX", b"VERT")]
    order = [0, 1, types.index(b"INDX"), *tables, types.index(b"SMAP"), types.index(b"VERT")]
    moved = reorder(data, order)
    path = tmp_path / f"{name}-after-indx.swpm"
    path.write_bytes(moved)
    ch = {t: (o, n) for t, _, o, n in _entries(moved)}
    io, il = ch[b"INDX"]
    vo, vl = ch[b"VERT"]
    spans = [(0, io + il), (vo, vl)]
    want = [ch[types[i]] for i in tables]  # the tables, in the order of 2.3 (the vector's own order)
    asked = []
    while True:
        got = _agree(dump, path, moved, spans)
        if got["ok"]:
            break
        assert got["code"] == "SWPM_RANGES_NOT_HELD", got
        start, end = got.get("need_start", 0), got["need"]
        assert got["offset"] == start
        asked.append((start, end - start))
        spans.append((start, end - start))
    assert asked == want
    for held_spans in (spans[:2], spans):  # under ASan / UBSan: the first refusal, and the ranges opened
        assert _c(dump_san, path, held_spans, 0xAA) == _expected(moved, held_spans)
    assert got["drawable"] == list(range(got["lod_count"])) and got["finish"] == {"ok": True}
    so, sl = ch[b"SMAP"]
    b = bytearray(moved)
    b[so] += 1  # band_count: SMAP's length no longer matches its counts
    bad = refix_crcs(bytes(b))
    assert "SWPM_SMAP_INVALID" in validate_bytes(bad).codes()
    assert "SWPM_SMAP_INVALID" in validate_ranges(_held(bad, [*spans, (so, sl)])).codes()
    rep = validate_ranges(_held(bad, spans))  # SMAP not held: not read as zeros, checked on finishing
    assert rep.valid and "SWPM_SMAP_INVALID" not in rep.codes() and "SWPM_STREAM_ORDER" in rep.codes()


def _build_bad_ranges(out: Path, extra: list[str]) -> Path:
    from test_c_reader import FLAGS, ROOT, RUNTIME

    src = ROOT / "tests" / "c_bad_ranges.c"
    subprocess.run(["cc", *FLAGS, *extra, "-I", str(RUNTIME), "-o", str(out), str(src)], check=True)
    return out


@pytest.fixture(scope="module")
def bad_ranges(tmp_path_factory: pytest.TempPathFactory, dump: Path) -> Path:  # noqa: F811
    return _build_bad_ranges(tmp_path_factory.mktemp("cc-bad") / "c_bad_ranges", [])


@pytest.fixture(scope="module")
def bad_ranges_san(tmp_path_factory: pytest.TempPathFactory, dump_san: Path) -> Path:  # noqa: F811
    from test_c_reader import SANITIZE

    return _build_bad_ranges(tmp_path_factory.mktemp("cc-bad-san") / "c_bad_ranges_san", SANITIZE)


BAD = {"code": "SWPM_READER_BAD_RANGES", "offset": 0, "need_start": 0, "need": 0}


@pytest.mark.parametrize("san", [False, True], ids=["plain", "asan-ubsan"])
@pytest.mark.parametrize("source", ["sliding-window-suzanne", "skip-strip-strip"])
def test_held_ranges_contract(
    bad_ranges: Path, bad_ranges_san: Path, tmp_path: Path, source: str, san: bool
) -> None:
    """swpm_reader.h's contract on the held ranges (tests/c_bad_ranges.c, also under ASan / UBSan), on
    the coarsest band of SMAP: listed in reverse, overlapping and abutting, or with empty ranges anywhere
    (at 0, at the buffer's end, past it, at 2^64 - 1) the ranges open exactly as given (the same drawable
    LODs, those of Python's open_ranges); a range one byte past the buffer, one that wraps past 2^64, ranges
    past the header's file_size, and NULL with a count are SWPM_READER_BAD_RANGES; no range is
    SWPM_RANGES_NOT_HELD for the header; finishing with a held byte changed, or with a buffer that ends
    inside a held range, is SWPM_READER_BAD_RANGES, with the file itself the whole file's verdict. Python's
    open_ranges holds the same contract (reordered, overlapping and empty ranges the same; past file_size
    and a changed byte on finishing a ValueError)."""
    from swpm_usd.format.ranges import open_ranges

    if source == "sliding-window-suzanne":
        data = encode_bytes(REAL[0][1]("suzanne"))
        path = tmp_path / "suzanne.swpm"
        path.write_bytes(data)
    else:
        path = VECTORS / "valid" / f"{source}.swpm"
        data = path.read_bytes()
    spans = _coarsest_band(data)
    binary = bad_ranges_san if san else bad_ranges
    spec = ",".join(f"{o}:{n}" for o, n in spans)
    proc = subprocess.run([str(binary), str(path), spec], capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr[-2000:]
    got = {d.pop("case"): d for d in map(json.loads, proc.stdout.splitlines())}
    fr = open_ranges(_held(data, spans))
    drawable = [int(k) for k in fr.drawable_lods]
    opened = {"code": None, "offset": 0, "need_start": 0, "need": 0, "drawable": drawable}
    assert drawable and got["given"] == opened
    if source == "sliding-window-suzanne":  # the coarsest band: a fraction of the file, not every LOD
        assert drawable[0] > 0 and sum(n for _, n in spans) < len(data) // 2
    for case in ("reversed", "overlapping", "zero-length"):
        assert got[case] == opened, case
    for case in ("past-buffer", "wraps", "past-file-size", "null-held", "finish-differs", "finish-short"):
        assert got[case] == BAD, case
    assert got["none-held"] == {"code": "SWPM_RANGES_NOT_HELD", "offset": 0, "need_start": 0, "need": 64}
    assert got["finish-ok"] == {**opened, "drawable": list(range(fr.lod_count))}
    # Python: the same held bytes as pieces out of order, overlapping, with empty ones anywhere
    pieces = {len(data) + 4096: b"", 7: b""}
    pieces |= {o + n // 2: data[o + n // 2 : o + n] for o, n in reversed(spans)}
    pieces |= {o: data[o : o + n] for o, n in reversed(spans)}
    fr2 = open_ranges(pieces)
    assert fr2.drawable_lods.tolist() == drawable and fr2.held == fr.held
    with pytest.raises(ValueError, match="outside the file"):
        open_ranges({**_held(data, spans), len(data) - 4: data[-4:] + b"\0"})
    b = bytearray(data)
    o, n = spans[-1]
    b[o + n - 1] ^= 1
    with pytest.raises(ValueError, match="differ"):
        fr.finish(bytes(b))


@pytest.mark.parametrize("item", ["0:99999", "abc", "0:", ":5", "0:64x", "5", "-1:5", ","])
def test_swpm_dump_refuses_a_range_item_it_cannot_hold(dump, item):  # noqa: F811 - (the fixture)
    # a range past the file, or an item that is not OFF:LEN, was dropped silently (the ranges read as fewer)
    path = VECTORS / "valid" / "minimal-vanilla.swpm"
    proc = subprocess.run([str(dump), "--ranges", f"0:64,{item}", str(path)], capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stdout == ""
    assert f"--ranges item {item.rstrip(',')}:" in proc.stderr and "620 bytes" in proc.stderr
    ok = subprocess.run([str(dump), "--ranges", "0:64,", str(path)], capture_output=True, text=True)
    assert ok.returncode == 0 and '"code":"SWPM_RANGES_NOT_HELD"' in ok.stdout


@pytest.mark.parametrize("san", [False, True], ids=["plain", "asan-ubsan"])
def test_far_range_reads_only_what_is_held(tmp_path: Path, dump: Path, dump_san: Path, san: bool) -> None:  # noqa: F811
    """A 16-byte range at 2^40 of a file whose header claims 2^41 (tests/c_far_range.c): the buffer is
    virtual memory readable only where the ranges are held, so a byte read between them faults. The C
    reader walked the padding after VERT byte by byte up to the last held byte (a SIGSEGV at the first page
    not held; 2^40 reads with a readable buffer); it reads the held bytes of a gap only now, and agrees with
    Python's open_ranges: zeros there open (LODs 0 and 1), a non-zero byte is SWPM_PADDING_NONZERO at the
    gap's start, VERT's end."""
    from test_c_reader import FLAGS, ROOT, RUNTIME, SANITIZE

    from swpm_usd.format.ranges import open_ranges

    exe = tmp_path / "c_far_range"
    extra = SANITIZE if san else []
    src = ROOT / "tests" / "c_far_range.c"
    subprocess.run(["cc", *FLAGS, *extra, "-I", str(RUNTIME), "-o", str(exe), str(src)], check=True)
    vector = VECTORS / "valid" / "minimal-vanilla.swpm"
    far = 1 << 40
    data = bytearray(vector.read_bytes())
    struct.pack_into("<Q", data, 40, 2 * far)
    data = bytearray(refix_crcs(bytes(data)))
    for byte in (0, 7):
        out = subprocess.run([str(exe), str(vector), str(far), f"{byte:02x}"], capture_output=True, text=True)
        assert out.returncode == 0, out.stderr[-2000:]
        got = json.loads(out.stdout)
        held = {0: bytes(data), far: bytes([byte]) + bytes(15)}
        rep = validate_ranges(held)
        if rep.valid:
            assert got == {"code": None, "offset": 0, "drawable": open_ranges(held).drawable_lods.tolist()}
            assert got["drawable"] == [0, 1]
        else:
            assert (got["code"], got["offset"]) == (rep.errors[0].code, rep.errors[0].offset)
            assert got == {"code": "SWPM_PADDING_NONZERO", "offset": len(data)}


def test_header_mutants_three_readers_agree(tmp_path: Path, dump: Path) -> None:  # noqa: F811
    """Header mutants of the range vectors (file_size 0..80 and near the length, header_size, table_offset,
    chunk_count; CRCs mostly fixed) opened from random held ranges, the header often among them: the
    independent reader's verdict is the codec's (spec 4.2 step 1's file_size below 64 included), the C
    reader's first error (code, offset, range to fetch) or drawable LODs are the codec's, and the bytes not
    held set to 0x00 or 0xAA change nothing in C (none is read). Ranges past a file_size of 64 or more are
    the caller's error (ValueError, SWPM_READER_BAD_RANGES): the test draws none."""
    import random

    from independent_reader import read_ranges

    from swpm_usd.format.vectors import ranges_result

    rng = random.Random(226)
    names = ["file-size-below-header", "mixed-two-levels", "skip-strip-level-of-two-lods", "long-header"]
    files = [
        next(
            (VECTORS / kind / f"{n}.swpm")
            for kind in ("valid", "invalid")
            if (VECTORS / kind / f"{n}.swpm").exists()
        )
        for n in names
    ]
    seeds = [p.read_bytes() for p in files]
    path = tmp_path / "mutant.swpm"
    below = codes = 0
    seen: set[str] = set()
    for trial in range(150):
        d = bytearray(rng.choice(seeds))
        if rng.random() < 0.6:
            struct.pack_into("<Q", d, 40, rng.randrange(81))
        elif rng.random() < 0.5:
            struct.pack_into("<Q", d, 40, rng.choice([len(d) - 8, len(d), len(d) + 8]))
        for off, fmt, values in (
            (12, "<I", [0, 63, 64, 72, 128, len(d) + 64]),  # header_size
            (32, "<Q", [0, 56, 64, 72, 96, len(d)]),  # table_offset
            (24, "<I", [0, 1, 3, 1025]),  # chunk_count
        ):
            if rng.random() < 0.25:
                struct.pack_into(fmt, d, off, rng.choice(values))
        data = refix_crcs(bytes(d)) if rng.random() < 0.8 else bytes(d)
        fs = struct.unpack_from("<Q", data, 40)[0]
        top = len(data) if fs < 64 else min(len(data), fs)
        cuts = sorted({0, 8, 40, 48, 64, 72, 96, top, rng.randrange(top + 1)} & set(range(top + 1)))
        ranges = [(0, rng.choice([64, 72, 96, top]))] if rng.random() < 0.8 else []
        for _ in range(rng.randint(0, 3)):
            a, b = rng.choice(cuts), rng.choice(cuts)
            if b > a:
                ranges.append((a, b - a))
        ranges = [(o, min(n, top - o)) for o, n in ranges if o < top and n > 0]
        if not ranges:
            continue
        want = ranges_result(data, ranges)
        assert read_ranges(data, ranges) == want, (trial, ranges)
        path.write_bytes(data)
        got = _c(dump, path, ranges, 0x00)
        assert _c(dump, path, ranges, 0xAA) == got, (trial, ranges)
        errors = [q for q in want["problems"] if q["severity"] == "error"]
        if errors:
            e = errors[0]
            expect = {"ok": False, "code": e["code"], "offset": e["offset"]}
            if e["code"] == "SWPM_RANGES_NOT_HELD":
                expect["need"] = e["need"]
                if e["need_start"]:
                    expect["need_start"] = e["need_start"]
            assert {k: got.get(k) for k in expect} == expect, (trial, ranges, got)
            seen.add(e["code"])
            codes += 1
        else:
            assert got["ok"] and got["drawable"] == want["drawable_lods"], (trial, ranges, got)
        below += fs < 64 and any(o == 0 and n >= 64 for o, n in ranges)
    assert below > 40 and codes > 60, (below, codes)
    assert {"SWPM_TABLE_TRUNCATED", "SWPM_HEADER_BAD_SIZE", "SWPM_RANGES_NOT_HELD"} <= seen, seen
