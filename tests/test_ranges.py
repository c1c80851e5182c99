"""Reading byte ranges of a file (spec/format.md 4.2): ``swpm_usd.format.ranges``. For every valid vector with
an ``SMAP`` and real files of every encoding (sliding-window lists and strips, skip-strip, mixed, vanilla),
each band's ``SMAP`` ranges (plus what the reader asks for) draw that band's LODs exactly as the whole file
does, a LOD whose ranges are not held is not drawable, finishing gives the whole-file verdict, and
corruption outside the held ranges is found only on finishing, inside them at once.
"""

from __future__ import annotations

import json
import os
import random
import struct
import tracemalloc
from typing import Any

import numpy as np
import pytest
from conftest import refix_crcs, shared_mesh
from test_c_reader import MANIFEST, VECTORS, _mutate, _mutate_values

import swpm_usd
from swpm_usd.format import SwpmFormatError, encode_bytes, load_bytes, validate_bytes
from swpm_usd.format.ranges import open_ranges, ranges_for_lod, read_lod, validate_ranges

VALID = [v["name"] for v in MANIFEST["vectors"] if v["valid"]]
VARIANTS = {
    "sw-list": ("sliding-window", {}),
    "sw-strip": ("sliding-window", {"primitive": "strip", "cluster": True, "optimize_connectivity": True}),
    "skip-strip": ("skip-strip", {}),
    "mixed": ("mixed", {}),
    "vanilla": ("vanilla", {}),
}
_FILES: dict[tuple[str, str], bytes] = {}


def _file(mesh: str, variant: str) -> bytes:
    if (mesh, variant) not in _FILES:
        enc, kw = VARIANTS[variant]
        _FILES[mesh, variant] = encode_bytes(swpm_usd.build(shared_mesh(f"{mesh}.obj"), enc, **kw))
    return _FILES[mesh, variant]


def _reader(data: bytes, log: list[tuple[int, int]]) -> Any:
    def read(o: int, n: int) -> bytes:
        log.append((o, n))
        return data[o : o + n]

    return read


def _same_draws(data: bytes, whole: Any, fr: Any) -> None:
    for k in fr.drawable_lods:
        a, b = fr.draw_stream(int(k)), whole.draw_stream(int(k))
        assert a[0] == b[0] and np.array_equal(a[1], b[1]), k
        pts = fr.lod_points(int(k))
        assert (
            np.array_equal(pts, whole.points[: pts.shape[0]], equal_nan=True)
            and pts.shape[0] == whole.vertex_counts[k]
        )


def _check_bands(data: bytes, coarse_only: bool = False) -> list[Any]:
    """Per band: open its SMAP ranges (plus what the reader asks for); its LODs draw as the whole file."""
    whole = load_bytes(data)
    L = whole.lod_count
    out, seen = [], set()
    for k in range(L - 1, -1, -1) if coarse_only else range(L):
        key = tuple(ranges_for_lod(data, k))
        if key in seen:
            continue
        seen.add(key)
        fr = read_lod(_reader(data, []), k, head=64)
        assert k in fr.drawable_lods
        spans = fr.held
        for j in range(L):  # drawable exactly when every range LOD j needs lies inside a held span
            inside = all(
                any(o <= a and a + n <= o + m for o, m in spans) for a, n in fr.needed_ranges(j) if n
            )
            assert (j in fr.drawable_lods) == inside, j
        _same_draws(data, whole, fr)
        fr.finish(data)  # the whole-file verdict: valid
        out.append(fr)
        if coarse_only:
            break
    assert out
    return out


def _has_smap(data: bytes) -> bool:
    try:
        ranges_for_lod(data, 0)
    except ValueError:
        return False
    return True


@pytest.mark.parametrize("name", VALID)
def test_valid_vectors_every_band(name: str) -> None:
    data = (VECTORS / "valid" / f"{name}.swpm").read_bytes()
    if not _has_smap(data):
        return
    _check_bands(data)


@pytest.mark.parametrize("variant", list(VARIANTS))
@pytest.mark.parametrize("mesh", ["suzanne", "spot", "cow"])
def test_real_files_bands(mesh: str, variant: str) -> None:
    data = _file(mesh, variant)
    frs = _check_bands(data, coarse_only=mesh != "suzanne")
    for k in (0, load_bytes(data).lod_count - 1):  # a writer's SMAP: its band's ranges alone draw the LOD
        fr = open_ranges({o: data[o : o + n] for o, n in ranges_for_lod(data, k)})
        assert k in fr.drawable_lods and (k == 0 or fr._p.indx_partial == (variant != "vanilla"))
    fr = frs[-1]
    if variant != "vanilla":  # the coarsest band's ranges: a part of the file, not every LOD drawable
        assert fr.held_bytes < len(data)
        assert 0 not in fr.drawable_lods
        with pytest.raises(IndexError):
            fr.draw_stream(0)


def _held(data: bytes, k: int) -> dict[int, bytes]:
    log: list[tuple[int, int]] = []
    fr = read_lod(_reader(data, log), k, head=64)
    return {o: data[o : o + n] for o, n in fr.held}


@pytest.mark.parametrize("variant", ["sw-list", "sw-strip", "skip-strip", "mixed"])
def test_corruption_outside_found_on_finishing_inside_at_once(variant: str) -> None:
    data = _file("suzanne", variant)
    whole = load_bytes(data)
    k = whole.lod_count - 1
    held = _held(data, k)
    fr = open_ranges(held)
    # INDX: one element the coarsest LOD does not draw, out of range (its CRC fixed: only content is wrong)
    to, count = struct.unpack_from("<QI", data, 32)[0], struct.unpack_from("<I", data, 24)[0]
    entries = {data[to + 32 * i : to + 32 * i + 4]: to + 32 * i for i in range(count)}
    e = entries[b"INDX"]
    off, ln = struct.unpack_from("<QQ", data, e + 8)
    W = fr.index_width
    lo, hi = (int(x) for x in fr.index_need[k])
    outside = next(i for i in range(ln // W) if not lo <= i < hi and i * W + off not in held)
    d = bytearray(data)
    d[off + outside * W : off + (outside + 1) * W] = b"\xfe" * W
    bad = refix_crcs(bytes(d))
    fr2 = open_ranges({o: bad[o : o + len(b)] for o, b in held.items()})  # opens: the element is not held
    assert k in fr2.drawable_lods
    with pytest.raises(SwpmFormatError):
        fr2.finish(bad)
    # inside: an element the coarsest LOD draws, CRC fixed: found at once (prefix property)
    if hi > lo:
        d = bytearray(data)
        d[off + lo * W : off + (lo + 1) * W] = b"\xfe" * W
        bad = refix_crcs(bytes(d))
        rep = validate_ranges({o: bad[o : o + len(b)] for o, b in held.items()})
        assert not rep.valid and rep.errors[0].code in ("SWPM_PREFIX_VIOLATION", "SWPM_INDEX_OUT_OF_RANGE")
    # a table byte (held): its CRC no longer matches, found at once
    d = bytearray(data)
    w = entries[b"LODS"]
    loff = struct.unpack_from("<Q", data, w + 8)[0]
    d[loff] ^= 0x40
    rep = validate_ranges({o: bytes(d[o : o + len(b)]) for o, b in held.items()})
    assert not rep.valid and rep.errors[0].code == "SWPM_CHUNK_CRC_MISMATCH"
    # VERT's tail (not held) changed: opens, finishing finds VERT's CRC
    d = bytearray(data)
    d[-1] ^= 0xFF
    fr3 = open_ranges({o: bytes(d[o : o + len(b)]) for o, b in held.items()})
    with pytest.raises(SwpmFormatError) as exc:
        fr3.finish(bytes(d))
    assert exc.value.report.errors[0].code == "SWPM_CHUNK_CRC_MISMATCH"


def test_not_held_names_the_range() -> None:
    data = _file("suzanne", "sw-list")
    rep = validate_ranges({0: data[:64]})
    assert rep.errors[0].code == "SWPM_RANGES_NOT_HELD" and rep.summary["range_need"][0] == 0
    rep = validate_ranges({0: data[:10]})
    assert rep.errors[0].code == "SWPM_RANGES_NOT_HELD" and rep.summary["range_need"] == [0, 64]
    rep = validate_ranges({0: b"SWPN" + data[4:8], 8: data[8:64]})  # the magic from ranges that abut
    assert rep.errors[0].code == "SWPM_HEADER_BAD_MAGIC"
    pieces = {o: data[o : o + 1000] for o in range(0, len(data), 1000)}  # the whole file, in pieces
    assert list(open_ranges(pieces).drawable_lods) == list(range(load_bytes(data).lod_count))
    fr = open_ranges({0: data})
    assert fr.complete and list(fr.drawable_lods) == list(range(fr.lod_count))
    with pytest.raises(ValueError):
        open_ranges({0: data[:64], len(data) - 4: data[-4:] + b"xx"})


def test_fuzz_errors_of_ranges_are_errors_of_the_file() -> None:
    """Mutants (random bytes, INDX values and record fields, CRCs mostly fixed) read through the coarsest
    band's ranges and through a mid band's: an error other than SWPM_RANGES_NOT_HELD is an error of the whole
    file too (reading zeros where bytes are not held never invents one), and ranges that open finish with
    the whole file's verdict."""
    rng = random.Random(214)
    seeds = [_file("suzanne", v) for v in ("sw-list", "sw-strip", "skip-strip", "mixed", "vanilla")]
    opened = reported = 0
    for i in range(400):
        data = rng.choice(seeds)
        bad = _mutate_values(rng, data) if i % 2 else _mutate(rng, data)
        L = load_bytes(data).lod_count
        k = rng.choice([L - 1, L // 2])
        held = {o: bad[o : o + n] for o, n in ranges_for_lod(data, k)}
        whole = validate_bytes(bad)
        try:
            rep = validate_ranges(held)
        except ValueError:  # a range past the mutant's file_size: the caller's error
            continue
        codes = {p.code for p in rep.errors} - {"SWPM_RANGES_NOT_HELD"}
        if codes:
            reported += 1
            assert not whole.valid, (i, codes)
        if rep.valid:
            opened += 1
            fr = open_ranges(held)
            if whole.valid:
                fr.finish(bad)
            else:
                with pytest.raises(SwpmFormatError) as exc:
                    fr.finish(bad)
                assert exc.value.report.errors[0].code == whole.errors[0].code
    assert opened > 50 and reported > 50, (opened, reported)


def test_a_huge_file_size_allocates_nothing_and_fails_on_finishing() -> None:
    """The buffer stops at the last byte held, not at the header's file_size (a hostile one: 1 TiB)."""
    data = bytearray(_file("suzanne", "sw-list"))
    struct.pack_into("<Q", data, 40, 1 << 40)
    bad = refix_crcs(bytes(data))
    k = load_bytes(_file("suzanne", "sw-list")).lod_count - 1
    held = {o: bad[o : o + n] for o, n in ranges_for_lod(bad, k)}
    fr = open_ranges(held)  # (SMAP's ranges lie inside the file: file_size is only larger)
    assert fr.file_size == 1 << 40 and k in fr.drawable_lods and fr._p.buf.shape[0] < len(bad)
    with pytest.raises(SwpmFormatError) as exc:
        fr.finish(bad)
    assert exc.value.report.errors[0].code == "SWPM_FILE_SIZE_MISMATCH"


def test_ranges_that_overlap_or_extend() -> None:
    """Ranges may overlap when they agree; a byte given two values is the caller's error (ValueError naming
    the file), never a fault of the file's; ``extend`` with a shorter range at a held offset keeps what was
    held (it replaced it before, dropping the rest of the range)."""
    data = _file("suzanne", "sw-list")
    n = len(data)
    whole = open_ranges({0: data[: n // 2], n // 4: data[n // 4 :]}, path="s.swpm")
    assert whole.held == [(0, n)] and list(whole.drawable_lods) == list(range(whole.lod_count))
    clash = bytes(b ^ 1 for b in data[n // 4 : n // 4 + 8])
    with pytest.raises(ValueError, match=rf"s\.swpm: .* byte {n // 4} "):
        open_ranges({0: data[: n // 2], n // 4: clash}, path="s.swpm")
    with pytest.raises(ValueError, match="byte 3 "):  # (in the header, before file_size is known)
        validate_ranges({0: data[:64], 3: b"\xff"})
    part = open_ranges({o: data[o : o + ln] for o, ln in ranges_for_lod(data, whole.lod_count - 1)})
    assert part.held[0][0] == 0 and part.held[0][1] > 64 and not part.complete
    more = part.extend({0: data[:64]})
    assert more.held == part.held
    full = part.extend({0: data[:64], 64: data[64:]})
    assert full.held == [(0, n)] and full.complete
    with pytest.raises(ValueError):
        part.extend({100: clash})
    assert list(part.extend({}).drawable_lods) == list(part.drawable_lods)


def test_whole_file_reads_skip_no_check() -> None:
    """The prefix and range plumbing leaves a whole-file read as it was: ``prefix`` and ``indx_partial``
    (which gate deferred checks) stay False and nothing is marked held for every vector, valid or not, and
    a file read through ranges that hold every byte gets the whole file's report."""
    from swpm_usd.format.reader import _check

    for v in MANIFEST["vectors"]:
        data = (VECTORS / v["file"]).read_bytes()
        rep, p = _check(np.frombuffer(data, np.uint8), None)
        if p is not None:
            assert not p.prefix and not p.indx_partial and p.held is None, v["name"]
        try:
            ranged = validate_ranges({0: data[: len(data) // 2], len(data) // 2: data[len(data) // 2 :]})
        except ValueError:  # a range past a file_size that is too small: the caller's error
            continue
        if len(data) >= 64 and int.from_bytes(data[40:48], "little") == len(data):
            assert [(e.code, e.offset) for e in ranged.problems] == [(e.code, e.offset) for e in rep.problems]


def test_read_lod_fetches_a_table_after_indx() -> None:
    """A file not in streaming order (spec 2.3), its encoding's tables after INDX (spec 4.2): ``read_lod`` of
    the coarsest LOD fetches each table the reader names (SWPM_RANGES_NOT_HELD with its payload's range)
    and draws it as the whole file does; the table is never decoded from bytes not held."""
    from swpm_usd.format.vectors import _entries, reorder

    data = _file("suzanne", "sw-list")
    types = [t for t, *_ in _entries(data)]
    order = [0, 1, 2, types.index(b"INDX"), types.index(b"WREC"), types.index(b"VERT")]
    moved = reorder(data, order)
    wrec = next((o, n) for t, _, o, n in _entries(moved) if t == b"WREC")
    whole = load_bytes(moved)
    L = whole.lod_count
    log: list[tuple[int, int]] = []
    fr = read_lod(_reader(moved, log), L - 1)
    assert wrec in log and L - 1 in fr.drawable_lods
    _same_draws(moved, whole, fr)
    held = {0: moved[: wrec[0]]}  # everything before WREC (INDX and VERT's header are not in it)
    ch = {t: (o, n) for t, _, o, n in _entries(moved)}
    vo = ch[b"VERT"][0]
    held[vo] = moved[vo:]
    rep = validate_ranges(held)
    assert rep.errors[0].code == "SWPM_RANGES_NOT_HELD" and rep.summary["range_need"] == [wrec[0], sum(wrec)]


def _cli(*args: str) -> Any:
    from click.testing import CliRunner

    from swpm_usd.cli import main

    return CliRunner().invoke(main, ["validate", *args])


def test_cli_validate_ranges(tmp_path: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    """``validate FILE --ranges OFF:LEN,...`` (spec 4.2): the coarsest band of SMAP checks once (counted at
    the codec's check) and draws the LODs open_ranges draws (exit 0; --json's summary "ranges", the text's
    line); the header alone is SWPM_RANGES_NOT_HELD naming the range to fetch (exit 1, "fetch next"); a
    range past the end of the file, or past the header's file_size, is a usage error naming it (exit 2);
    a fault inside the held ranges is the file's error (exit 1)."""
    import swpm_usd.format.ranges as ranges_mod

    data = _file("suzanne", "sw-list")
    path = tmp_path / "s.swpm"
    path.write_bytes(data)
    L = load_bytes(data).lod_count
    spans = ranges_for_lod(data, L - 1)
    spec = ",".join(f"{o}:{n}" for o, n in spans)
    calls: list[int] = []
    real = ranges_mod._check

    def counted(*a: Any, **k: Any) -> Any:
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(ranges_mod, "_check", counted)
    ok = _cli(str(path), "--ranges", spec, "--json")
    assert ok.exit_code == 0, ok.output
    assert len(calls) == 1
    got = json.loads(ok.output)["summary"]["ranges"]
    fr = open_ranges({o: data[o : o + n] for o, n in spans})
    lods = fr.drawable_lods.tolist()
    assert got["drawable_lods"] == lods and got["finest_drawable"] == lods[0] > 0 and L - 1 in lods
    assert got["held_bytes"] == fr.held_bytes < len(data) and got["file_size"] == len(data)
    assert not got["complete"] and got["needed_ranges"][str(L - 1)] == [
        list(r) for r in fr.needed_ranges(L - 1)
    ]
    text = _cli(str(path), "--ranges", spec)
    assert text.exit_code == 0
    assert f"ranges: {fr.held_bytes} of {len(data)} bytes held draw LODs {lods[0]}..{lods[-1]}" in text.output
    # the header alone: the table and what lies before INDX are fetched next
    head = _cli(str(path), "--ranges", "0:64", "--json")
    assert head.exit_code == 1
    rep = json.loads(head.output)
    need = rep["summary"]["range_need"]
    assert rep["problems"][0]["code"] == "SWPM_RANGES_NOT_HELD" and need[0] == 0 and need[1] > 64
    assert f"fetch next: 0:{need[1]}" in _cli(str(path), "--ranges", "0:64").output
    # the caller's errors: usage errors naming the range
    past = _cli(str(path), "--ranges", f"0:64,{len(data) - 8}:9")
    assert past.exit_code == 2 and f"{len(data) - 8}:9 ends at byte {len(data) + 1}" in past.output
    longer = tmp_path / "longer.swpm"  # 8 bytes after file_size: inside the file on disk, outside SWPM's
    longer.write_bytes(data + bytes(8))
    beyond = _cli(str(longer), "--ranges", f"0:{len(data) + 8}")
    assert beyond.exit_code == 2 and "outside the file" in beyond.output, beyond.output
    # a fault in a held range (META's first byte): the file's error, found at once
    meta = struct.unpack_from("<Q", data, struct.unpack_from("<Q", data, 32)[0] + 8)[0]
    b = bytearray(data)
    b[meta] = ord("x")
    bad = tmp_path / "bad.swpm"
    bad.write_bytes(refix_crcs(bytes(b)))
    first = validate_bytes(bad.read_bytes()).errors[0]
    out = _cli(str(bad), "--ranges", spec, "--json")
    assert out.exit_code == 1
    assert (json.loads(out.output)["problems"][0]["code"], first.code) == ("SWPM_META_BAD_JSON",) * 2


def test_cli_validate_lod(tmp_path: Any) -> None:
    """``validate FILE --lod K``: what LOD K needs, fetched as read_lod fetches it (the same reads, in
    order, none repeated), opened; LOD K draws (exit 0); a LOD the file does not have is a usage error (exit
    2); a file whose held bytes hold an error exits 1 with it."""
    data = _file("suzanne", "sw-list")
    path = tmp_path / "s.swpm"
    path.write_bytes(data)
    L = load_bytes(data).lod_count
    for k in (L - 1, L // 2):
        log: list[tuple[int, int]] = []
        fr = read_lod(_reader(data, log), k)
        out = _cli(str(path), "--lod", str(k), "--json")
        assert out.exit_code == 0, out.output
        got = json.loads(out.output)["summary"]["ranges"]
        assert got["lod"] == k and [tuple(r) for r in got["reads"]] == log
        assert len(set(log)) == len(log), log  # (a range held is not read again: [0, INDX) was, twice)
        assert k in got["drawable_lods"] and got["drawable_lods"] == fr.drawable_lods.tolist()
    text = _cli(str(path), "--lod", str(L - 1))
    assert text.exit_code == 0 and f"read for LOD {L - 1}: 0:4096," in text.output
    none = _cli(str(path), "--lod", str(L))
    assert none.exit_code == 2 and f"no such LOD: LOD {L} of {L}" in none.output
    b = bytearray(data)
    b[8] = 2  # major version 2: the header's error, whatever is fetched
    bad = tmp_path / "bad.swpm"
    bad.write_bytes(bytes(b))
    out = _cli(str(bad), "--lod", "0", "--json")
    assert (
        out.exit_code == 1
        and json.loads(out.output)["problems"][0]["code"] == "SWPM_HEADER_UNSUPPORTED_MAJOR"
    )


def test_read_lod_of_a_file_longer_than_its_file_size(tmp_path: Any) -> None:
    """A file with bytes after its header's file_size (SWPM_FILE_TRAILING_BYTES, a warning: the file is
    valid) shorter than ``read_lod``'s first read: the bytes it reads past file_size are not the file's, so
    it does not hold them (a held range past file_size is the caller's error, spec 4.2 step 1): each LOD
    draws as the file's own bytes draw it, and ``validate --lod`` exits 0 (it was a usage error, exit 2,
    "no such LOD: ... lies outside the file")."""
    data = (VECTORS / "valid" / "minimal-vanilla.swpm").read_bytes()
    longer = data + bytes(8)
    whole = load_bytes(data)
    for k in range(whole.lod_count):
        fr = read_lod(_reader(longer, []), k)
        assert k in fr.drawable_lods and fr.file_size == len(data)
        _same_draws(data, whole, fr)
    path = tmp_path / "longer.swpm"
    path.write_bytes(longer)
    out = _cli(str(path), "--lod", "0", "--json")
    assert out.exit_code == 0, out.output
    assert 0 in json.loads(out.output)["summary"]["ranges"]["drawable_lods"]


def test_validate_lod_of_a_file_size_below_the_header_is_the_files_error(tmp_path: Any) -> None:
    """A header whose file_size is below 64 puts the header itself past file_size: a range reader reports the
    file's error as format.md 5 does (spec 4.2 step 1), not the caller's. ``validate --lod`` refused the
    ranges as a usage error (exit 2, "lies outside the file") before."""
    data = bytearray((VECTORS / "valid" / "minimal-vanilla.swpm").read_bytes())
    struct.pack_into("<Q", data, 40, 10)
    path = tmp_path / "small.swpm"
    path.write_bytes(bytes(data))
    out = _cli(str(path), "--lod", "0", "--json")
    assert out.exit_code == 1, out.output
    got = [(p["code"], p["offset"]) for p in json.loads(out.output)["problems"]]
    whole = validate_bytes(bytes(data))
    assert got == [(p.code, p.offset) for p in whole.problems]
    assert got == [("SWPM_FILE_TRAILING_BYTES", 10), ("SWPM_TABLE_TRUNCATED", 24)]


@pytest.mark.parametrize("variant", ["sw-list", "sw-strip", "skip-strip", "mixed"])
def test_read_lod_reads_no_byte_twice(variant: str) -> None:
    """``read_lod`` fetched a range it held in part again whole (SMAP's [0, INDX) over the first 4096 bytes,
    VERT's header up to three times): each byte is read once now, and every LOD it opens draws as the whole
    file draws it."""
    data = _file("suzanne", variant)
    whole = load_bytes(data)
    for k in sorted({0, whole.lod_count // 2, whole.lod_count - 1}):
        log: list[tuple[int, int]] = []
        fr = read_lod(_reader(data, log), k)
        spans = sorted((o, o + min(n, len(data) - o)) for o, n in log)
        assert all(a[1] <= b[0] for a, b in zip(spans, spans[1:], strict=False)), (k, spans)
        assert k in fr.drawable_lods
        _same_draws(data, whole, fr)


def _far_file(far_byte: int) -> tuple[bytes, dict[int, bytes]]:
    """minimal-vanilla whose header claims file_size 2^41, and the ranges: all of its 620 bytes and 16 bytes
    at 2^40 (trailing padding of the claimed file; ``far_byte`` the first of them)."""
    data = bytearray((VECTORS / "valid" / "minimal-vanilla.swpm").read_bytes())
    struct.pack_into("<Q", data, 40, 1 << 41)
    data = refix_crcs(bytes(data))
    return data, {0: data, 1 << 40: bytes([far_byte]) + bytes(15)}


def _rss() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.parametrize("far_byte", [0, 7])
def test_a_range_far_past_the_others_is_held_sparsely(far_byte: int) -> None:
    """A 16-byte range at 2^40 of a file whose header claims 2^41 bytes: the reader held the ranges in one
    buffer up to the last byte held (np.zeros of 2^40 bytes: MemoryError, or a terabyte traced) and read
    the padding between them byte by byte. It holds them sparsely now: the far range costs its own pages,
    and is still read (a non-zero byte there is the trailing padding's SWPM_PADDING_NONZERO, at the end of
    VERT, the gap's start)."""
    data, held = _far_file(far_byte)
    open_ranges({0: (VECTORS / "valid" / "minimal-vanilla.swpm").read_bytes()})  # (imports made: not traced)
    rss = _rss()
    tracemalloc.start()
    try:
        rep = validate_ranges(held)
        fr = open_ranges(held) if rep.valid else None
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1 << 20, peak
    assert _rss() - rss < 64 << 20
    if far_byte:
        assert [(q.code, q.offset) for q in rep.problems] == [("SWPM_PADDING_NONZERO", len(data))]
    else:
        assert rep.valid, rep.problems
        assert fr is not None and fr.drawable_lods.tolist() == [0, 1]
        whole = load_bytes((VECTORS / "valid" / "minimal-vanilla.swpm").read_bytes())
        assert np.array_equal(fr.lod_points(0), whole.points)


def test_a_range_past_what_a_reader_maps_is_the_callers_error() -> None:
    """Ranges are held in virtual memory up to the last held byte, at most MAX_RANGE_END (2^46) bytes: a
    range past it (at 2^50 of a file claiming 2^51) is refused as the caller's, a ValueError naming it, as a
    range past file_size is, not a MemoryError or an attempt to map 2^50 bytes."""
    from swpm_usd.format.ranges import MAX_RANGE_END

    data = bytearray((VECTORS / "valid" / "minimal-vanilla.swpm").read_bytes())
    struct.pack_into("<Q", data, 40, 1 << 51)
    data = bytearray(refix_crcs(bytes(data)))
    assert MAX_RANGE_END < 1 << 50
    with pytest.raises(ValueError, match=f"ends at {(1 << 50) + 16}, past the {MAX_RANGE_END}"):
        validate_ranges({0: bytes(data), 1 << 50: bytes(16)})
    assert validate_ranges({0: bytes(data), MAX_RANGE_END - 16: bytes(16)}).valid  # (at the limit: held)
