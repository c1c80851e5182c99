"""Reading byte ranges from C (spec/format.md 4.2): the C reader's ``swpm_open_ranges`` /
``swpm_ranges_finish`` (through ``swpm_dump --ranges``) agree with ``swpm_usd.format.open_ranges`` on the
verdict, the code, its offset and the range to fetch, the drawable LODs and the CRC of every drawable LOD's
points and ``INDX`` elements, band by band of ``SMAP`` for every valid vector and for real files of every
encoding; the bytes not held set to 0x00 and to 0xAA give the same output (nothing unheld is read), also
under AddressSanitizer with the held ranges copied into a buffer of their own; finishing gives the
whole-file verdict.
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
