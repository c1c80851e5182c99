"""Reading a prefix of a file (spec/format.md 4.1): ``swpm_usd.format.open_prefix`` and the C reader's
``swpm_open_prefix`` / ``swpm_prefix_finish`` (through ``swpm_dump --prefix``) agree on the verdict, the
finest drawable LOD and the bytes each LOD needs, at every chunk boundary, at each LOD's needed length and
one byte less and at random cuts, for every valid vector and real files of every encoding; the arrays of a
drawable LOD are the whole-file reader's; finishing gives the whole-file verdict, also for files whose only
corruption lies in the part a prefix defers (VERT's CRC, the padding after VERT, file_size).
"""

from __future__ import annotations

import json
import random
import shutil
import struct
import subprocess
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import refix_crcs
from test_c_reader import MANIFEST, SANITIZE, VECTORS, _compile, _lpm, _mutate, _pm, _vpm

from swpm_usd.format import (
    SwpmFormatError,
    encode_bytes,
    load_bytes,
    open_prefix,
    validate_bytes,
    validate_prefix,
)

VALID = [v["name"] for v in MANIFEST["vectors"] if v["valid"]]
#: the index list of each encoding that ``swpm_index_pool`` views (INDX)
POOL = {
    "vanilla": "indices",
    "sliding-window": "index_pool",
    "skip-strip": "level_indices",
    "mixed": "level_static_indices",
}


@pytest.fixture(scope="module")
def dump(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _compile(tmp_path_factory.mktemp("cc") / "swpm_dump", [])


@pytest.fixture(scope="module")
def dump_san(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The sanitizer build (test_c_reader's dump_san fails the same way when the toolchain has none)."""
    if shutil.which("cc") is None:
        pytest.fail("no C compiler (cc): the C reader's tests need one (README, Set up)")
    d = tmp_path_factory.mktemp("cc-san")
    (d / "probe.c").write_text("int main(void) { return 0; }\n")
    ok = subprocess.run(["cc", *SANITIZE, "-o", str(d / "probe"), str(d / "probe.c")], capture_output=True)
    if ok.returncode != 0 or subprocess.run([str(d / "probe")], capture_output=True).returncode != 0:
        pytest.fail("the C compiler builds no AddressSanitizer / UBSan program (README, Set up)")
    return _compile(d / "swpm_dump_san", SANITIZE)


def _chunks(data: bytes) -> dict[bytes, tuple[int, int]]:
    """(offset, length) of each chunk type's first entry."""
    count, to = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    out: dict[bytes, tuple[int, int]] = {}
    for i in range(count):
        t, _, off, ln = struct.unpack_from("<4sIQQ", data, to + 32 * i)
        out.setdefault(t, (off, ln))
    return out


def _cuts(data: bytes, rng: random.Random, lods: int = 12) -> list[int]:
    """Every chunk boundary (and one byte either side), VERT's vertex records' start, each of up to ``lods``
    LODs' needed bytes and one less, and random cuts."""
    count, to = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    cuts = {0, 8, 63, 64, to + 32 * count - 1, to + 32 * count, len(data) - 1, len(data)}
    chunks = _chunks(data)
    for off, ln in chunks.values():
        cuts |= {off - 1, off, off + 1, off + ln - 1, off + ln}
    (vo, _), (lo, ll) = chunks[b"VERT"], chunks[b"LODS"]
    _, _, stride, doff = struct.unpack_from("<4I", data, vo)
    cuts |= {vo + doff - 1, vo + doff}
    L = ll // 12
    for k in {0, L // 10, L - 1, *np.linspace(0, L - 1, min(L, lods)).astype(int).tolist()}:
        need = vo + doff + struct.unpack_from("<I", data, lo + 12 * k)[0] * stride
        cuts |= {need - 1, need}
    cuts |= {rng.randrange(len(data) + 1) for _ in range(6)}
    return sorted(c for c in cuts if 0 <= c <= len(data))


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Bit for bit (a NaN point equals itself)."""
    return a.shape == b.shape and np.ascontiguousarray(a).tobytes() == np.ascontiguousarray(b).tobytes()


def _first_error(rep: Any) -> dict[str, Any]:
    e = rep.errors[0]
    out = {"ok": False, "code": e.code, "offset": e.offset}
    if e.code == "SWPM_PREFIX_TOO_SHORT":
        out["need"] = rep.summary["prefix_need"]
    return out


def _expected(data: bytes, n: int, whole: Any) -> dict[str, Any]:
    """What ``swpm_dump --prefix n`` must print, from the Python codec; checks the views on the way."""
    part = data[:n]
    rep = validate_prefix(part)
    out: dict[str, Any] = {"n": n}
    if not rep.valid:
        out.update(_first_error(rep))
        return out
    fp = open_prefix(part)
    L = fp.lod_count
    fin = fp.finest_drawable if fp.finest_drawable is not None else L
    out.update(ok=True, file_size=fp.file_size, lod_count=L, finest=fin)
    out["needed"] = [fp.needed_bytes(0), fp.needed_bytes(min(fin, L - 1)), fp.needed_bytes(L - 1)]
    if fin < L:
        pts = fp.lod_points(fin)
        out["points_crc"] = zlib.crc32(np.ascontiguousarray(pts, "<f4").tobytes())
        if whole is not None:  # the views of every drawable LOD are the whole file's arrays
            for k in (fin, L - 1):
                vc = int(fp.vertex_counts[k])
                assert _same(fp.lod_points(k), whole.points[:vc])
                for name, a in fp.lod_attributes(k).items():
                    assert _same(a, whole.attributes[name][:vc])
    else:
        out["points_crc"] = None
        with pytest.raises(IndexError):
            fp.lod_points(L - 1)
    out["pool_crc"] = zlib.crc32(np.ascontiguousarray(fp.buffers[POOL[fp.encoding]]).tobytes())
    full = validate_bytes(data)
    out["finish"] = {"ok": True} if full.valid else {k: v for k, v in _first_error(full).items()}
    if full.valid:
        pm = fp.finish(data)
        assert whole is None or _same(pm.points, whole.points)
        out["whole_crc"] = [
            zlib.crc32(np.ascontiguousarray(pm.points, "<f4").tobytes()),
            zlib.crc32(np.ascontiguousarray(open_prefix(data).buffers[POOL[fp.encoding]]).tobytes()),
        ]
    else:
        with pytest.raises(SwpmFormatError) as exc:
            fp.finish(data)
        assert exc.value.report.to_dict() == full.to_dict()  # the whole-file verdict, every problem
    return out


def _c_lines(binary: Path, path: Path, cuts: list[int]) -> list[dict[str, Any]]:
    proc = subprocess.run(
        [str(binary), "--prefix", *map(str, cuts), str(path)], capture_output=True, text=True
    )
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr[-2000:]
    return [json.loads(line) for line in proc.stdout.splitlines()]


def _agree(binary: Path, path: Path, data: bytes, cuts: list[int], whole: Any) -> list[dict[str, Any]]:
    got = _c_lines(binary, path, cuts)
    assert len(got) == len(cuts)
    for n, out in zip(cuts, got, strict=True):
        smap = out.pop("smap", None)
        want = _expected(data, n, whole)
        assert out == want, (path.name, n, out, want)
        fp = open_prefix(data[:n]) if out["ok"] else None
        streams = fp is not None and not {"SWPM_STREAM_ORDER", "SWPM_SMAP_INVALID"} & set(fp.report.codes())
        if (
            smap and streams
        ):  # a valid SMAP of a streaming file: a band's prefix_length is its first LOD's need
            for band in smap:
                assert band[3] == fp.needed_bytes(band[0]), (path.name, band)
    return got


@pytest.mark.parametrize("name", VALID)
def test_valid_vectors(dump: Path, name: str) -> None:
    path = VECTORS / "valid" / f"{name}.swpm"
    data = path.read_bytes()
    got = _agree(dump, path, data, _cuts(data, random.Random(name)), load_bytes(data))
    codes = {o.get("code") for o in got}
    assert "SWPM_PREFIX_TOO_SHORT" in codes
    # a file that streams opens before its end, and its coarsest LOD draws before its finest
    if "SWPM_PREFIX_NOT_STREAMABLE" not in codes:
        opened = [o for o in got if o["ok"]]
        assert opened[0]["n"] < len(data)
        assert any(o["finest"] == o["lod_count"] - 1 for o in opened) or opened[0]["lod_count"] == 1


REAL = [
    ("sliding-window-list", lambda m: _pm(m, "list")),
    ("sliding-window-strip", lambda m: _pm(m, "strip")),
    ("vanilla", _vpm),
    ("skip-list", lambda m: _lpm(m, "skip-list")),
    ("skip-strip", lambda m: _lpm(m, "skip-strip")),
    ("mixed", lambda m: _lpm(m, "mixed")),
]


@pytest.mark.parametrize("mesh", ["suzanne", "spot", "cow"])
@pytest.mark.parametrize(("variant", "build"), REAL, ids=[r[0] for r in REAL])
def test_real_files(dump: Path, tmp_path: Path, mesh: str, variant: str, build: Any) -> None:
    data = encode_bytes(build(mesh))
    path = tmp_path / f"{mesh}-{variant}.swpm"
    path.write_bytes(data)
    whole = load_bytes(data)
    got = _agree(dump, path, data, _cuts(data, random.Random(mesh + variant)), whole)
    L = len(whole.vertex_counts)
    # every LOD draws at its needed length and not one byte before (the cuts hold LODs 0, L/10, L-1)
    for o in got:
        if o["ok"] and o["n"] < len(data):
            assert o["needed"][1] <= o["n"] if o["finest"] < L else o["needed"][2] > o["n"]
    assert any(o["ok"] and o["finest"] == L - 1 for o in got)


def _deferred_mutants(data: bytes) -> dict[str, bytes]:
    """Files whose only fault lies past a prefix that opens: VERT's CRC (a vertex of LOD 0 changed), a
    non-zero byte in padding after VERT, a file_size past the file's end (a truncated download)."""
    vo, vl = _chunks(data)[b"VERT"]
    out = {}
    b = bytearray(data)
    b[vo + vl - 1] ^= 0x40  # LOD 0's last vertex: VERT's CRC is not fixed
    out["vert-crc"] = bytes(b)
    padded = bytearray(data + bytes(8))
    struct.pack_into("<Q", padded, 40, len(padded))
    padded = bytearray(refix_crcs(bytes(padded)))
    padded[-3] = 1
    out["padding-after-vert"] = bytes(padded)
    longer = bytearray(data)
    struct.pack_into("<Q", longer, 40, len(data) + 16)
    out["file-size-past-end"] = refix_crcs(bytes(longer))
    return out


@pytest.mark.parametrize(
    "source", ["minimal-vanilla", "sliding-window-strips", "skip-strip-strip", "mixed", "cow"]
)
def test_finish_deferred_faults(dump: Path, tmp_path: Path, source: str) -> None:
    base = (
        encode_bytes(_pm("cow", "list"))
        if source == "cow"
        else (VECTORS / "valid" / f"{source}.swpm").read_bytes()
    )
    for kind, data in _deferred_mutants(base).items():
        path = tmp_path / f"{kind}.swpm"
        path.write_bytes(data)
        rep = validate_bytes(data)
        assert not rep.valid
        cuts = _cuts(data, random.Random(kind))
        got = _agree(dump, path, data, cuts, None)
        opened = [o for o in got if o["ok"]]
        assert opened, kind  # the prefix opens: the fault is only found on finishing
        assert {json.dumps(o["finish"]) for o in opened} == {json.dumps(_first_error(rep))}
        want = {
            "vert-crc": "SWPM_CHUNK_CRC_MISMATCH",
            "padding-after-vert": "SWPM_PADDING_NONZERO",
            "file-size-past-end": "SWPM_FILE_SIZE_MISMATCH",
        }[kind]
        assert opened[0]["finish"]["code"] == want


def test_not_streamable_and_python_api(tmp_path: Path) -> None:
    data = (VECTORS / "valid" / "smap-empty-index-hull.swpm").read_bytes()  # INDX after VERT
    rep = validate_prefix(data[: len(data) - 1])
    assert rep.errors[0].code == "SWPM_PREFIX_NOT_STREAMABLE"
    assert validate_prefix(data).valid  # a whole file is read whole
    full = (VECTORS / "valid" / "minimal-vanilla.swpm").read_bytes()
    with pytest.raises(SwpmFormatError) as exc:
        open_prefix(full[:100], path="x.swpm")
    assert exc.value.file == "x.swpm" and exc.value.report.summary["prefix_need"] > 100
    fp = open_prefix(full[:608])
    assert (fp.coarsest_drawable, fp.finest_drawable, list(fp.drawable_lods)) == (1, 1, [1])
    assert fp.needed_bytes(0) == 620 and fp.needed_bytes(1) == 608 and not fp.complete
    fp2 = fp.extend(full[608:])
    assert fp2.complete and list(fp2.drawable_lods) == [0, 1]
    with pytest.raises(ValueError):
        fp.finish(b"x" + full[1:])


def test_fuzz_prefixes_against_python(dump_san: Path, tmp_path: Path) -> None:
    """Mutants of the valid vectors and a real file, each opened at a few cuts by the sanitizer build (the
    prefix in a buffer of exactly its length: a read past it trips ASan), against the Python codec."""
    rng = random.Random(211)
    seeds = [(VECTORS / "valid" / f"{n}.swpm").read_bytes() for n in VALID]
    seeds.append(encode_bytes(_pm("suzanne", "strip")))
    differ, codes, opened = [], set(), 0
    for i in range(600):
        seed = seeds[-1] if i % 8 == 0 else rng.choice(seeds[:-1])
        if i % 6 == 5 and b"VERT" in _chunks(seed) and _chunks(seed)[b"VERT"][1] > 16:
            m = bytearray(seed)  # a fault only the whole file shows: a vertex record's byte, CRC not fixed
            vo, vl = _chunks(seed)[b"VERT"]
            m[rng.randrange(vo + vl - 12, vo + vl)] ^= 1 << rng.randrange(8)
            m = bytes(m)
        else:
            m = _mutate(rng, seed)
        path = tmp_path / f"m{i}.swpm"
        path.write_bytes(m)
        # two cuts anywhere, three in the last fifth (where VERT's records lie), the whole file
        cuts = {rng.randrange(len(m) + 1) for _ in range(2)} | {len(m)}
        cuts |= {rng.randrange(len(m) * 4 // 5, len(m) + 1) for _ in range(3)}
        for n, out in zip(sorted(cuts), _c_lines(dump_san, path, sorted(cuts)), strict=True):
            out.pop("smap", None)
            want = _expected(m, n, None)
            codes.add(out.get("code"))
            opened += out["ok"] and n < len(m)
            if out != want:
                differ.append((i, n, out, want))
    assert not differ, differ[:5]
    assert {None, "SWPM_PREFIX_TOO_SHORT", "SWPM_PREFIX_NOT_STREAMABLE"} <= codes and len(codes) > 20
    assert opened > 150  # prefixes shorter than the file opened (and finished against the whole)


def test_cli_validate_prefix() -> None:
    from click.testing import CliRunner

    from swpm_usd.cli import main

    path = str(VECTORS / "valid" / "minimal-vanilla.swpm")
    short = CliRunner().invoke(main, ["validate", path, "--prefix", "100", "--json"])
    assert short.exit_code == 1
    rep = json.loads(short.output)
    assert rep["problems"][0]["code"] == "SWPM_PREFIX_TOO_SHORT" and rep["summary"]["prefix_need"] == 288
    ok = CliRunner().invoke(main, ["validate", path, "--prefix", "608", "--json"])
    assert ok.exit_code == 0
    assert json.loads(ok.output)["summary"]["prefix"] == {
        "bytes": 608,
        "file_size": 620,
        "complete": False,
        "finest_drawable": 1,
        "drawable_lods": [1, 1],
        "needed_bytes": {"0": 620, "1": 608},
    }
    text = CliRunner().invoke(main, ["validate", path, "--prefix", "620"])
    assert text.exit_code == 0 and "620 of 620 bytes draw LODs 0..1" in text.output
    huge = CliRunner().invoke(main, ["validate", path, "--prefix", str(1 << 60)])  # (was a MemoryError)
    assert huge.exit_code == 0 and "620 of 620 bytes draw LODs 0..1" in huge.output, huge.output


def test_cli_validate_prefix_checks_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """``validate --prefix N`` runs the codec's checks over the prefix once (it called validate_prefix, then
    open_prefix for the summary: every check twice), counted at the check both call."""
    from click.testing import CliRunner

    import swpm_usd.format.prefix as prefix_mod
    from swpm_usd.cli import main

    calls: list[int] = []
    real = prefix_mod._check

    def counted(*a: Any, **k: Any) -> Any:
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(prefix_mod, "_check", counted)
    path = str(VECTORS / "valid" / "minimal-vanilla.swpm")
    ok = CliRunner().invoke(main, ["validate", path, "--prefix", "608", "--json"])
    assert ok.exit_code == 0 and json.loads(ok.output)["summary"]["prefix"]["finest_drawable"] == 1
    assert len(calls) == 1
    short = CliRunner().invoke(main, ["validate", path, "--prefix", "100"])
    assert short.exit_code == 1 and "SWPM_PREFIX_TOO_SHORT" in short.output and len(calls) == 2
