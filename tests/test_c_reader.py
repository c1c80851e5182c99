"""The C99 runtime reader (runtime/c/swpm_reader.h, written from spec/format.md and spec/errors.md) checked
against the conformance vectors, files the Python codec writes from real meshes, and mutated files.

``runtime/c/swpm_dump.c`` is compiled once per module with the system ``cc`` (``-std=c99 -Wall -Wextra
-Werror -O1``, and a second build with AddressSanitizer and UBSan when the toolchain has them). The reader
handles all four encodings (vanilla: its arrays and a per-instance index buffer moved by its collapse
records, compared with the Python product's triangles at every LOD; skip-strip and mixed: their arrays,
levels and a per-instance level list moved to every LOD, compared with what Python's instance draws).
"""

from __future__ import annotations

import hashlib
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
from conftest import refix_crcs, shared_mesh

import swpm_usd
from swpm_usd.format import encode_bytes, validate_bytes

ROOT = Path(__file__).resolve().parents[1]
RUNTIME = ROOT / "runtime" / "c"
VECTORS = ROOT / "spec" / "vectors"
MANIFEST = json.loads((VECTORS / "manifest.json").read_text())
UNSUPPORTED = "SWPM_READER_UNSUPPORTED_ENCODING"
SCRATCH = "SWPM_READER_SCRATCH_TOO_SMALL"
FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-O1"]
SANITIZE = ["-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all"]
# the codes of format.md 5 steps 1-2 (header, chunk table): found before the encoding matters
STEP_12_PREFIXES = (
    "SWPM_HEADER_",
    "SWPM_FILE_",
    "SWPM_CHECKSUM_",
    "SWPM_TABLE_",
    "SWPM_PADDING_",
    "SWPM_CHUNK_",
)


def _compile(out: Path, extra: list[str]) -> Path:
    cc = shutil.which("cc")
    if cc is None:
        pytest.fail("no C compiler (cc): the C reader's tests need one (README, Set up)")
    subprocess.run([cc, *FLAGS, *extra, "-o", str(out), str(RUNTIME / "swpm_dump.c")], check=True)
    return out


@pytest.fixture(scope="module")
def dump(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _compile(tmp_path_factory.mktemp("cc") / "swpm_dump", [])


@pytest.fixture(scope="module")
def dump_san(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("cc-san")
    probe = d / "probe.c"
    probe.write_text("int main(void) { return 0; }\n")
    cc = shutil.which("cc")
    if cc is None:
        pytest.fail("no C compiler (cc): the C reader's tests need one (README, Set up)")
    ok = subprocess.run([cc, *SANITIZE, "-o", str(d / "probe"), str(probe)], capture_output=True)
    if ok.returncode != 0 or subprocess.run([str(d / "probe")], capture_output=True).returncode != 0:
        pytest.fail("the C compiler builds no AddressSanitizer / UBSan program (README, Set up)")
    return _compile(d / "swpm_dump_san", SANITIZE)


def _run(binary: Path, path: Path) -> tuple[int, dict[str, Any]]:
    proc = subprocess.run([str(binary), str(path)], capture_output=True, text=True)
    assert proc.stderr == ""
    return proc.returncode, json.loads(proc.stdout)


def _check_many(binary: Path, paths: list[Path]) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for i in range(0, len(paths), 400):
        proc = subprocess.run(
            [str(binary), "--check", *map(str, paths[i : i + 400])], capture_output=True, text=True
        )
        assert proc.returncode == 0 and proc.stderr == "", proc.stderr[-2000:]
        out += [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(out) == len(paths)
    return out


def _is_sliding(data: bytes) -> bool:
    return len(data) >= 24 and struct.unpack_from("<I", data, 20)[0] & 0x1E == 0x04


def _is_vanilla(data: bytes) -> bool:
    return len(data) >= 24 and struct.unpack_from("<I", data, 20)[0] & 0x1E == 0x02


def _encoding_bit(data: bytes) -> int:
    return struct.unpack_from("<I", data, 20)[0] & 0x1E if len(data) >= 24 else 0


def _expected(data: bytes, problems: list[tuple[str, str, int | None]]) -> dict[str, Any]:
    """What the C reader must print for a file with these problems (code, severity, offset)."""
    errors = [(c, o) for c, s, o in problems if s == "error"]
    if not errors:
        return {"ok": True}
    return {"ok": False, "code": errors[0][0], "offset": errors[0][1]}


def _array(out: dict[str, Any], name: str, dtype: str) -> np.ndarray:
    return np.frombuffer(bytes.fromhex(out["arrays"][name]["hex"]), dtype=dtype)


VECTOR_CASES = [pytest.param(v, id=v["name"]) for v in MANIFEST["vectors"]]


@pytest.mark.parametrize("vector", VECTOR_CASES)
def test_vector(dump: Path, vector: dict[str, Any]) -> None:
    path = VECTORS / vector["file"]
    data = path.read_bytes()
    exp = json.loads((VECTORS / vector["expected"]).read_text())
    want = _expected(data, [(p["code"], p["severity"], p["offset"]) for p in exp["problems"]])
    rc, out = _run(dump, path)
    if not want["ok"]:
        assert rc == 1 and out == want
        return
    assert rc == 0 and out["ok"] is True
    summary = exp["summary"]
    for key in ("index_width", "offset_width", "lod_count", "vertex_count", "triangle_count"):
        assert out[key] == summary[key], key
    assert set(out["arrays"]) == set(summary["buffers"])
    for name, buf in summary["buffers"].items():
        got = out["arrays"][name]
        assert got["shape"] == buf["shape"], name
        assert hashlib.sha256(bytes.fromhex(got["hex"])).hexdigest() == buf["sha256"], name


def test_vectors_cover_both_sides(dump: Path) -> None:
    """The vectors exercise the reader: files of every encoding accepted and rejected, none refused."""
    paths = [VECTORS / v["file"] for v in MANIFEST["vectors"]]
    outs = _check_many(dump, paths)
    codes = {o.get("code") for o in outs}
    assert sum(o["ok"] for o in outs) >= 10 and UNSUPPORTED not in codes
    for enc in (0x08, 0x10):  # skip-strip, mixed: valid files and their own codes
        got = {
            o.get("code") for o, p in zip(outs, paths, strict=True) if _encoding_bit(p.read_bytes()) == enc
        }
        assert None in got and ("SWPM_LEVEL_BAD_TABLE" if enc == 0x08 else "SWPM_MIXED_BAD_LEVELS") in got
    assert {"SWPM_WINDOW_MID_STRIP", "SWPM_WINDOW_STRIP_TRIANGLES", "SWPM_PREFIX_VIOLATION"} <= codes
    # vanilla: every stage's codes reached (the replay's among them)
    vanilla = {o.get("code") for o, p in zip(outs, paths, strict=True) if _is_vanilla(p.read_bytes())}
    assert {"SWPM_RECORD_BAD_CHANGE", "SWPM_RECORD_BAD_COUNTS", "SWPM_PREFIX_VIOLATION", None} <= vanilla


def _check_picks(out: dict[str, Any], q: Any) -> None:
    """What an engine picks by error (swpm_lod_for_error) is Python's lod_for_error at every LOD's error,
    midway to the next and beyond; swpm_point reads the points Python reads."""
    assert len(out["lod_for_error"]) == 2 * q.lod_count + 2
    for target, k in out["lod_for_error"]:
        assert k == q.lod_for_error(target), target
    assert bytes.fromhex(out["points_getter"]) == np.ascontiguousarray(q.points, "<f4").tobytes()


# -- files the Python codec writes -------------------------------------------------------------------------
STRIP = {"primitive": "strip", "cluster": True, "optimize_connectivity": True}
REAL = [(m, v) for m in ("suzanne", "spot", "cow") for v in ("list", "strip")]
_PMS: dict[tuple[str, str], Any] = {}


def _pm(mesh: str, variant: str) -> Any:
    if (mesh, variant) not in _PMS:
        src = shared_mesh(f"{mesh}.obj")  # (fails, as every shared-mesh test, when ../shared is not here)
        _PMS[mesh, variant] = swpm_usd.build(src, "sliding-window", **(STRIP if variant == "strip" else {}))
    return _PMS[mesh, variant]


def _files(pm: Any, tmp: Path) -> dict[str, Path]:
    out = {}
    out["default"] = swpm_usd.save(pm, tmp / "default.swpm")
    out["legacy"] = swpm_usd.save(pm, tmp / "legacy.swpm", legacy_layout=True)
    (tmp / "index32.swpm").write_bytes(encode_bytes(pm, index_width=4))
    out["index32"] = tmp / "index32.swpm"
    return out


@pytest.mark.parametrize(("mesh", "variant"), REAL, ids=[f"{m}-{v}" for m, v in REAL])
def test_real_files(dump: Path, tmp_path: Path, mesh: str, variant: str) -> None:
    pm = _pm(mesh, variant)
    widths = set()
    for kind, path in _files(pm, tmp_path).items():
        rc, out = _run(dump, path)
        assert rc == 0 and out["ok"], (kind, out)
        q = swpm_usd.load(path)
        W, O = out["index_width"], out["offset_width"]
        widths.add(W)
        assert kind != "index32" or W == 4
        L, V = q.lod_count, q.vertex_count
        assert (out["lod_count"], out["vertex_count"]) == (L, V)
        assert _array(out, "points", "<f4").tobytes() == np.ascontiguousarray(q.points, "<f4").tobytes()
        for name, arr in q.attributes.items():
            got = np.frombuffer(
                bytes.fromhex(out["arrays"][f"attribute:{name}"]["hex"]), arr.dtype.newbyteorder("<")
            )
            assert np.array_equal(got.reshape(arr.shape), arr), name
        assert np.array_equal(_array(out, "vertex_counts", "<u4"), q.vertex_counts)
        assert np.array_equal(_array(out, "triangle_counts", "<u4"), q.triangle_counts)
        assert (
            _array(out, "lod_errors", "<f4").tobytes() == np.ascontiguousarray(q.lod_errors, "<f4").tobytes()
        )
        assert np.array_equal(_array(out, "index_pool", f"<u{W}"), q.index_pool)
        assert np.array_equal(_array(out, "window_records", f"<u{O}").reshape(L, 3), q.window_records)
        if variant == "strip":
            assert np.array_equal(_array(out, "window_index_counts", f"<u{O}"), q.window_index_counts)
            assert out["restart_index"] == q.params["restart_index"]
        else:
            assert "window_index_counts" not in out["arrays"] and out["restart_index"] is None
        # swpm_window is what the engine draws: the Python window, indices and all
        for k, (first, count, vc) in enumerate(out["windows"]):
            assert (first, vc) == (int(q.window_records[k, 0]), q.vertex_count_at(k))
            assert count == int(q.window_index_counts[k])
            assert np.array_equal(q.index_pool[first : first + count], q.draw_stream(k)[1].reshape(-1))
        for target, k in out["lod_for_triangles"]:
            assert k == q.lod_for_triangles(target), target
        _check_picks(out, q)
    assert 4 in widths


# -- vanilla files the Python codec writes: arrays, and an instance moved to every LOD and back -----------
VANILLA_MESHES = ("suzanne", "spot", "cow")
_VPMS: dict[str, Any] = {}


def _vpm(mesh: str) -> Any:
    if mesh not in _VPMS:
        _VPMS[mesh] = swpm_usd.build(shared_mesh(f"{mesh}.obj"), "vanilla")
    return _VPMS[mesh]


@pytest.mark.parametrize("mesh", VANILLA_MESHES)
def test_real_vanilla_files(dump: Path, tmp_path: Path, mesh: str) -> None:
    pm = _vpm(mesh)
    widths = set()
    for kind, path in _files(pm, tmp_path).items():
        rc, out = _run(dump, path)
        assert rc == 0 and out["ok"] and out["encoding"] == "vanilla", (kind, out)
        q = swpm_usd.load(path)
        W, O = out["index_width"], out["offset_width"]
        widths.add(W)
        assert kind != "index32" or W == 4
        L, V = q.lod_count, q.vertex_count
        assert (out["lod_count"], out["vertex_count"]) == (L, V)
        assert _array(out, "points", "<f4").tobytes() == np.ascontiguousarray(q.points, "<f4").tobytes()
        assert np.array_equal(_array(out, "vertex_counts", "<u4"), q.vertex_counts)
        assert np.array_equal(_array(out, "triangle_counts", "<u4"), q.triangle_counts)
        _check_picks(out, q)
        assert np.array_equal(_array(out, "indices", f"<u{W}"), q.indices)
        for name in (
            "collapse_kept",
            "collapse_tris_removed",
            "collapse_change_count",
            "collapse_change_offsets",
            "lod_record_counts",
        ):
            assert np.array_equal(_array(out, name, f"<u{O}"), getattr(q, name)), name
        prev = np.concatenate([[0], q.collapse_change_count[:-1]]) if len(q.collapse_change_count) else []
        assert np.array_equal(_array(out, "collapse_prev_change_count", f"<u{O}"), prev)
        # the instance at LODs 0, 1, ..., L-1, L-2, ..., 0: what the engine draws is Python's LOD, in order
        steps = out["instance"]
        assert [s[0] for s in steps] == [*range(L), *range(L - 2, -1, -1)]
        crcs = {}
        for k in range(L):
            tris = np.ascontiguousarray(q.triangles_at(k), f"<u{W}")
            crcs[k] = (3 * len(tris), q.vertex_count_at(k), zlib.crc32(tris.tobytes()))
            assert np.array_equal(tris, pm.triangles_at(k))
        for lod, count, vc, crc, *_ in steps:
            assert (count, vc, crc) == crcs[lod], lod
        # the dirty ranges: init and LOD 0 wrote the whole copy; later moves write within INDX (a move whose
        # records change no slot writes nothing: (0, 0)); tests/c_dirty_walk.c checks them against a mirror
        assert steps[0][4:6] == [0, len(q.indices)]
        assert all(s[4] < s[5] <= len(q.indices) or s[4] == s[5] == 0 for s in steps[1:])
        assert sum(s[5] - s[4] for s in steps[1:]) < (len(steps) - 1) * len(q.indices)
    assert 4 in widths


# -- skip-strip and mixed files the Python codec writes: arrays, and an instance moved to every LOD and back
LEVEL_VARIANTS = {
    "skip-list": ("skip-strip", {"primitive": "list"}),
    "skip-strip": ("skip-strip", {"primitive": "strip"}),
    "skip-strip-degenerate": ("skip-strip", {"primitive": "strip", "restart": False}),
    "mixed": ("mixed", {}),
}
LEVEL_REAL = [
    (m, v) for m in ("suzanne", "spot", "cow") for v in LEVEL_VARIANTS if m == "suzanne" or "degen" not in v
]
_LPMS: dict[tuple[str, str], Any] = {}


def _lpm(mesh: str, variant: str) -> Any:
    if (mesh, variant) not in _LPMS:
        enc, kw = LEVEL_VARIANTS[variant]
        _LPMS[mesh, variant] = swpm_usd.build(shared_mesh(f"{mesh}.obj"), enc, **kw)
    return _LPMS[mesh, variant]


SKIP_ARRAYS = (
    "level_indices",
    "level_first_lod",
    "level_index_start",
    "level_collapsed_start",
    "level_record_start",
    "level_collapsed_indices",
    "collapse_kept",
    "collapse_binned",
    "collapse_change_count",
    "collapse_prev_change_count",
    "collapse_change_offsets",
    "lod_record_counts",
)
MIXED_ARRAYS = (
    "level_static_indices",
    "level_first_lod",
    "level_static_start",
    "level_dynamic_start",
    "level_record_start",
    "level_dynamic_indices",
    "level_dynamic_collapsed_indices",
    "collapse_kept",
    "collapse_static_tris_removed",
    "collapse_dynamic_tris_removed",
    "collapse_change_count",
    "collapse_prev_change_count",
    "collapse_change_offsets",
    "lod_record_counts",
)


@pytest.mark.parametrize(("mesh", "variant"), LEVEL_REAL, ids=[f"{m}-{v}" for m, v in LEVEL_REAL])
def test_real_level_files(dump: Path, tmp_path: Path, mesh: str, variant: str) -> None:
    """Every array as Python reads it, the levels, and what an instance draws at every LOD (LODs 0 .. L-1 and
    back): the stream Python's instance draws (skip-strip: the level's edited list, which pm.triangles_at
    decodes; mixed: the live dynamic prefix, then the live static range of INDX), byte for byte."""
    pm = _lpm(mesh, variant)
    enc = LEVEL_VARIANTS[variant][0]
    paths = {"default": swpm_usd.save(pm, tmp_path / "default.swpm")}
    (tmp_path / "index32.swpm").write_bytes(encode_bytes(pm, index_width=4))
    paths["index32"] = tmp_path / "index32.swpm"
    for kind, path in paths.items():
        rc, out = _run(dump, path)
        assert rc == 0 and out["ok"] and out["encoding"] == enc, (kind, out)
        q = swpm_usd.load(path)
        W, O, L = out["index_width"], out["offset_width"], q.lod_count
        assert kind != "index32" or W == 4
        assert (out["lod_count"], out["vertex_count"]) == (L, q.vertex_count)
        assert np.array_equal(_array(out, "triangle_counts", "<u4"), q.triangle_counts)
        _check_picks(out, q)
        names = SKIP_ARRAYS if enc == "skip-strip" else MIXED_ARRAYS
        wide = {"level_indices", "level_collapsed_indices", "level_static_indices", "level_dynamic_indices"}
        for name in names:
            width = W if name in wide or name == "level_dynamic_collapsed_indices" else O
            want = q.collapse_prev_change_count if name == "collapse_prev_change_count" else getattr(q, name)
            assert np.array_equal(_array(out, name, f"<u{width}"), want), name
        if enc == "skip-strip":
            strip = LEVEL_VARIANTS[variant][1]["primitive"] == "strip"
            assert out["primitive_strip"] == int(strip)
            assert out["restart_index"] == (q.params.get("restart_index") if strip else None)
        assert out["level_of_lod"] == [pm.level_of_lod(k) for k in range(L)] if enc == "skip-strip" else True
        starts = q.level_index_start if enc == "skip-strip" else q.level_static_start
        for lv, row in enumerate(out["levels"]):
            assert row[2:6] == [
                int(q.level_record_start[lv]),
                int(q.level_record_start[lv + 1]),
                int(starts[lv]),
                int(starts[lv + 1] - starts[lv]),
            ]
        steps = out["instance"]
        assert [s[0] for s in steps] == [*range(L), *range(L - 2, -1, -1)]
        for step in steps:
            lod, count, vc, crc = step[0], step[2], step[3], step[4]
            assert vc == q.vertex_count_at(lod)
            if enc == "skip-strip":
                want = np.ascontiguousarray(q.draw_stream(lod)[1], f"<u{W}")
            else:
                dyn, static = (c[1] for c in q.draw_calls(lod))
                want = np.ascontiguousarray(dyn, f"<u{W}")
                first, n = step[5], step[6]
                assert np.array_equal(q.level_static_indices[first : first + n], static), lod
            assert (count, crc) == (len(want), zlib.crc32(want.tobytes())), lod
            # the dirty range taken after the step: within the level's list (init and LOD 0: all of level 0's)
            first, end = step[7:9] if enc == "mixed" else step[5:7]
            held = out["levels"][step[1]][7] if enc == "mixed" else count
            assert first <= end <= held and (step is not steps[0] or (first, end) == (0, held)), lod
        # and the triangles those streams draw (the file's restart index) are the built mesh's LOD
        for lod in (0, L // 2, L - 1):
            stream = q.draw_stream(lod)[1]
            tris = q._decode(stream) if enc == "skip-strip" else stream.reshape(-1, 3)
            assert np.array_equal(np.asarray(tris, np.int64), np.asarray(pm.triangles_at(lod), np.int64))


@pytest.mark.parametrize("variant", ["skip-strip", "mixed"])
def test_level_scratch(dump_san: Path, tmp_path: Path, variant: str) -> None:
    """The replay's scratch (format.md 5, skip-strip stage (d), mixed (d)): skip-strip W x the longest list of
    a level with records, mixed 8 V + W x its longest dynamic list + 7; exactly that is enough (under the
    sanitizer: nothing past it is touched), one byte less is SWPM_READER_SCRATCH_TOO_SMALL with that need."""
    pm = _lpm("suzanne", variant)
    data = encode_bytes(pm)
    path = tmp_path / "l.swpm"
    path.write_bytes(data)
    q = swpm_usd.load(path)
    W = 4 if struct.unpack_from("<I", data, 20)[0] & 1 else 2
    rs = q.level_record_start.astype(np.int64)
    starts = (q.level_index_start if variant == "skip-strip" else q.level_dynamic_start).astype(np.int64)
    longest = int(np.max(np.diff(starts)[np.diff(rs) > 0]))
    need = W * longest if variant == "skip-strip" else 8 * q.vertex_count + W * longest + 7
    for scratch, want in ((need, {"ok": True}), (need - 1, {"ok": False, "code": SCRATCH, "offset": None})):
        proc = subprocess.run(
            [str(dump_san), "--check-scratch", str(scratch), str(path)], capture_output=True, text=True
        )
        assert proc.returncode == 0 and proc.stderr == ""
        assert json.loads(proc.stdout) == (want if want["ok"] else {**want, "need": need})


def test_vanilla_scratch(dump: Path, dump_san: Path, tmp_path: Path) -> None:
    """The replay's scratch: INDX length + 8 V + 7 bytes is enough (under the sanitizer: nothing past it is
    touched), one byte less is SWPM_READER_SCRATCH_TOO_SMALL with that need; an error found before the
    replay is reported whatever the scratch; a file without records needs none."""
    data = encode_bytes(_vpm("suzanne"))
    path = tmp_path / "v.swpm"
    path.write_bytes(data)
    _, indx = _payload(data, b"INDX")
    need = len(indx) + 8 * _vpm("suzanne").vertex_count + 7
    for scratch, want in ((need, {"ok": True}), (need - 1, {"ok": False, "code": SCRATCH, "offset": None})):
        proc = subprocess.run(
            [str(dump_san), "--check-scratch", str(scratch), str(path)], capture_output=True, text=True
        )
        assert proc.returncode == 0 and proc.stderr == ""
        got = json.loads(proc.stdout)
        assert got == (want if want["ok"] else {**want, "need": need})
    # an error of stage (a) is reported whatever the scratch; a file with records that passes it needs some
    minimal = (VECTORS / "valid" / "minimal-vanilla.swpm").read_bytes()
    bad = [
        VECTORS / "invalid" / "record-keeps-binned-vertex.swpm",
        VECTORS / "valid" / "minimal-vanilla.swpm",
    ]
    proc = subprocess.run([str(dump), "--check-scratch", "0", *map(str, bad)], capture_output=True, text=True)
    first, second = (json.loads(line) for line in proc.stdout.splitlines())
    assert first == {"ok": False, "code": "SWPM_RECORD_BAD_KEPT", "offset": 504}
    assert second == {"ok": False, "code": SCRATCH, "offset": None, "need": 24 + 8 * 5 + 7}
    # no records (one LOD): no replay, no scratch
    _, lods = _payload(minimal, b"LODS")
    one_lod = _rebuild(minimal, {b"LODS": lods[:12], b"RCNT": bytes(2), b"VREC": bytes(8)})
    assert not [p for p in validate_bytes(one_lod).problems if p.severity == "error"]
    path.write_bytes(one_lod)
    proc = subprocess.run([str(dump), "--check-scratch", "0", str(path)], capture_output=True, text=True)
    assert json.loads(proc.stdout) == {"ok": True}


# -- differential fuzz: the sanitizer build against swpm_usd.format's validation ---------------------------
def _regions(data: bytes) -> list[tuple[int, int]]:
    """Header, table and chunk byte ranges (SMAP's aside) of a valid file: where mutations are aimed."""
    count, to = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    out = [(0, 64), (to, to + 32 * count)]
    for i in range(count):
        t, _, off, ln = struct.unpack_from("<4sIQQ", data, to + 32 * i)
        if t in (
            b"WREC",
            b"INDX",
            b"LODS",
            b"META",
            b"VERT",
            b"VREC",
            b"RCNT",
            b"SKIP",
            b"SREC",
            b"MLVL",
            b"MREC",
        ):
            out.append((off, off + ln)) if ln else None
    return out


def _mutate(rng: random.Random, data: bytes) -> bytes:
    b = bytearray(data)
    regions = _regions(data)
    for _ in range(rng.randint(1, 4)):
        if not b:
            break
        lo, hi = rng.choice(regions) if rng.random() < 0.8 else (0, len(b))
        pos = rng.randrange(lo, max(lo + 1, min(hi, len(b)))) if lo < len(b) else rng.randrange(len(b))
        kind = rng.choice(["bit", "bit", "byte", "word", "truncate", "insert"])
        if kind == "bit":
            b[pos] ^= 1 << rng.randrange(8)
        elif kind == "byte":
            b[pos] = rng.randrange(256)
        elif kind == "word":
            val = rng.choice([0, 1, 2, 3, 4, 5, 0xFFFF, 0xFFFFFFFF, 0x7FFFFFFF, 65536, 1 << 31])
            b[pos : pos + 4] = val.to_bytes(4, "little")
        elif kind == "truncate":
            del b[pos:]
        else:
            b[pos:pos] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))
    if len(b) >= 48 and len(b) != len(data) and rng.random() < 0.7:
        struct.pack_into("<Q", b, 40, len(b))  # file_size follows a truncation or insertion: reach the chunks
    out = bytes(b)
    return refix_crcs(out) if rng.random() < 0.7 else out


def _mutate_values(rng: random.Random, data: bytes) -> bytes:
    """A valid file with a few INDX values set to other vertices or WREC (vanilla: VREC, RCNT; skip-strip:
    SREC, SKIP, RCNT; mixed: MREC, MLVL, RCNT) fields nudged, CRCs fixed: mutants that reach the windows, the
    prefix property and the strips' triangle counts, or the record counts, level tables and replays."""
    d = bytearray(data)
    features = struct.unpack_from("<I", d, 20)[0]
    W, O = (4 if features & 1 else 2), (4 if features & 0x41 else 2)
    table = {
        0x02: [b"VREC", b"VREC", b"RCNT"],
        0x04: [b"WREC"],
        0x08: [b"SREC", b"SREC", b"SKIP", b"RCNT"],
        0x10: [b"MREC", b"MREC", b"MLVL", b"RCNT"],
    }[_encoding_bit(data)]
    table = rng.choice(table)
    (ei, ix), (ew, wr) = _payload(data, b"INDX"), _payload(data, table)
    io, wo = struct.unpack_from("<Q", d, ei + 8)[0], struct.unpack_from("<Q", d, ew + 8)[0]
    V = struct.unpack_from("<I", d, struct.unpack_from("<Q", d, _payload(data, b"VERT")[0] + 8)[0])[0]
    for _ in range(rng.randint(1, 3)):
        if rng.random() < 0.7:
            at, val = io + W * rng.randrange(len(ix) // W), rng.randrange(V)
            d[at : at + W] = val.to_bytes(W, "little")
        else:
            # (the u32 counts of VREC, SREC, MREC, SKIP and MLVL: nudge the off fields after them)
            skip = 8 if table in (b"VREC", b"SREC", b"MREC", b"SKIP", b"MLVL") else 0
            at = wo + skip + O * rng.randrange((len(wr) - skip) // O)
            val = max(0, int.from_bytes(d[at : at + O], "little") + rng.randint(-3, 3))
            d[at : at + O] = min(val, (1 << 8 * O) - 1).to_bytes(O, "little")
    return refix_crcs(bytes(d))


def _seeds(tmp: Path) -> list[bytes]:
    seeds = [p.read_bytes() for p in sorted((VECTORS / "valid").glob("*.swpm"))]
    seeds.append(encode_bytes(_pm("suzanne", "strip")))
    return seeds


def test_fuzz_against_python(dump_san: Path, tmp_path: Path) -> None:
    rng = random.Random(197)
    seeds = _seeds(tmp_path)
    mutants: list[bytes] = []
    for i in range(3000):
        seed = seeds[-1] if i % 10 == 0 else rng.choice(seeds[:-1])
        mutants.append(_mutate(rng, seed))
    # random bytes after the magic and version (as tests/test_fuzz_format.py): the header's checks
    prefix = b"SWPM\r\n\x1a\n\x01\x00"
    mutants += [prefix + rng.randbytes(rng.randrange(700)) for _ in range(300)]
    real = [encode_bytes(_pm("cow", v)) for v in ("list", "strip")]
    mutants += [_mutate_values(rng, rng.choice(real)) for _ in range(600)]
    # vanilla: a real file's mutants, raw and by value (records, RCNT, INDX)
    cow = encode_bytes(_vpm("cow"))
    mutants += [_mutate(rng, cow) for _ in range(200)]
    mutants += [_mutate_values(rng, cow) for _ in range(400)]
    # skip-strip (lists, strips with restarts) and mixed: real files' mutants, raw and by value
    levelled = [encode_bytes(_lpm("cow", v)) for v in ("skip-list", "skip-strip", "mixed")]
    mutants += [_mutate(rng, rng.choice(levelled)) for _ in range(300)]
    mutants += [_mutate_values(rng, rng.choice(levelled)) for _ in range(900)]
    paths = []
    for i, m in enumerate(mutants):
        p = tmp_path / f"m{i}.swpm"
        p.write_bytes(m)
        paths.append(p)
    got = _check_many(dump_san, paths)
    differ = []
    accepted = 0
    for i, (m, out) in enumerate(zip(mutants, got, strict=True)):
        rep = validate_bytes(m)
        want = _expected(m, [(p.code, p.severity, p.offset) for p in rep.problems])
        accepted += out["ok"]
        if out != want:
            differ.append((i, out, want))
    assert not differ, differ[:10]
    assert 30 < accepted < len(mutants) - 300  # both sides exercised
    # the content checks are reached, not only the header's
    assert {"SWPM_PREFIX_VIOLATION", "SWPM_WINDOW_STRIP_TRIANGLES", "SWPM_WINDOW_COUNT_MISMATCH"} <= {
        o.get("code") for o in got
    }
    vanilla = [o.get("code") for m, o in zip(mutants, got, strict=True) if _is_vanilla(m)]
    assert {"SWPM_RECORD_BAD_CHANGE", "SWPM_RECORD_BAD_COUNTS", "SWPM_LOD_VERTEX_COUNT", None} <= set(vanilla)
    for enc, own in ((0x08, "SWPM_LEVEL_BAD_TABLE"), (0x10, "SWPM_MIXED_BAD_LEVELS")):
        codes = {o.get("code") for m, o in zip(mutants, got, strict=True) if _encoding_bit(m) == enc}
        assert {
            own,
            "SWPM_RECORD_BAD_CHANGE",
            "SWPM_PREFIX_VIOLATION",
            "SWPM_RECORD_BAD_COUNTS",
            None,
        } <= codes


# -- META: the strict JSON of format.md 3.1, in files rebuilt around a given META payload -----------------
def _rebuild(data: bytes, payloads: dict[bytes, bytes]) -> bytes:
    """``data`` (a valid file) with the payloads of the chunk types given replaced and SMAP (ancillary,
    absolute offsets) dropped: the chunks laid out again one after another, offsets, file_size and every CRC
    recomputed."""
    count, to = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    chunks = []
    for i in range(count):
        t, flags, off, ln = struct.unpack_from("<4sIQQ", data, to + 32 * i)
        if t != b"SMAP":
            chunks.append((t, flags, payloads.get(t, data[off : off + ln])))
    table = bytearray()
    body = bytearray()
    pos = 64 + 32 * len(chunks)
    for t, flags, payload in chunks:
        table += struct.pack(
            "<4sIQQII", t, flags, pos + len(body), len(payload), zlib.crc32(payload, zlib.crc32(t)), 0
        )
        body += payload + bytes(-len(payload) % 8)
    head = bytearray(data[:64])
    struct.pack_into("<IQQI", head, 24, len(chunks), 0, 0, 0)
    struct.pack_into("<QQI", head, 32, 64, 64 + len(table) + len(body), 0)
    struct.pack_into("<I", head, 48, zlib.crc32(bytes(head + table)))
    return bytes(head + table + body)


def _payload(data: bytes, ctype: bytes) -> tuple[int, bytearray]:
    """(entry offset, a copy of the payload) of the chunk ``ctype``."""
    count, to = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    for i in range(count):
        t, _, off, ln = struct.unpack_from("<4sIQQ", data, to + 32 * i)
        if t == ctype:
            return to + 32 * i, bytearray(data[off : off + ln])
    raise KeyError(ctype)


def _with_meta(data: bytes, meta: bytes) -> bytes:
    return _rebuild(data, {b"META": meta})


DEEP = 128
STRIPS_PARAMS = '"params":{"primitive":"strip","restart_index":65535}'
META_CASES = {
    "plain": ("{" + STRIPS_PARAMS + "}", None),
    "escaped-encoding": ('{"encoding":"sliding\\u002dwindow",' + STRIPS_PARAMS + "}", None),
    "lone-surrogate": ('{"x":"\\ud800",' + STRIPS_PARAMS + "}", None),
    "depth-128": ('{"x":' + "[" * (DEEP - 1) + "]" * (DEEP - 1) + "," + STRIPS_PARAMS + "}", None),
    "depth-129": ('{"x":' + "[" * DEEP + "]" * DEEP + "," + STRIPS_PARAMS + "}", "SWPM_META_BAD_JSON"),
    "duplicate": ('{"a":1,"a":2,' + STRIPS_PARAMS + "}", "SWPM_META_BAD_JSON"),
    "duplicate-escaped": ('{"a":1,"\\u0061":2,' + STRIPS_PARAMS + "}", "SWPM_META_BAD_JSON"),
    "duplicate-pair": ('{"\\ud800\\udc00":1,"\U00010000":2,' + STRIPS_PARAMS + "}", "SWPM_META_BAD_JSON"),
    "duplicate-nested": ('{"p":{"b":1,"b":1},' + STRIPS_PARAMS + "}", "SWPM_META_BAD_JSON"),
    "largest-double": ('{"x":1.7976931348623157e308,' + STRIPS_PARAMS + "}", None),
    "tiny": ('{"x":-1e-400,' + STRIPS_PARAMS + "}", None),
    "below-infinity": ('{"x":' + str(2**1024 - 2**970 - 1) + "," + STRIPS_PARAMS + "}", None),
    "infinity-int": ('{"x":' + str(2**1024 - 2**970) + "," + STRIPS_PARAMS + "}", "SWPM_META_BAD_JSON"),
    "infinity-exp": ('{"x":-1e400,' + STRIPS_PARAMS + "}", "SWPM_META_BAD_JSON"),
    "infinity-frac": (
        '{"x":0.0000' + str(2**1024 - 2**970) + "e313," + STRIPS_PARAMS + "}",
        "SWPM_META_BAD_JSON",
    ),
    "nan": ('{"x":NaN,' + STRIPS_PARAMS + "}", "SWPM_META_BAD_JSON"),
    "bom": ("\ufeff{" + STRIPS_PARAMS + "}", "SWPM_META_BAD_JSON"),
    "trailing-comma": ("{" + STRIPS_PARAMS + ",}", "SWPM_META_BAD_JSON"),
    "control-char": ('{"x":"a\tb",' + STRIPS_PARAMS + "}", "SWPM_META_BAD_JSON"),
    "leading-zero": ('{"x":01,' + STRIPS_PARAMS + "}", "SWPM_META_BAD_JSON"),
    "not-object": ("[1]", "SWPM_META_BAD_JSON"),
    "params-array": ('{"params":[]}', "SWPM_META_BAD_FIELD"),
    "encoding-other": ('{"encoding":"vanilla",' + STRIPS_PARAMS + "}", "SWPM_META_BAD_FIELD"),
    "vanilla:plain": ('{"encoding":"vanilla","params":{}}', None),
    "vanilla:strip-params-ignored": ('{"params":{"primitive":"strip","restart_index":true}}', None),
    "vanilla:params-array": ('{"params":[]}', "SWPM_META_BAD_FIELD"),
    "vanilla:encoding-other": ('{"encoding":"sliding-window"}', "SWPM_META_BAD_FIELD"),
    "vanilla:duplicate": ('{"a":1,"a":2}', "SWPM_META_BAD_JSON"),
    "primitive-list": ('{"params":{"primitive":"list","restart_index":65535}}', "SWPM_META_BAD_FIELD"),
    "restart-float": ('{"params":{"primitive":"strip","restart_index":65535.0}}', "SWPM_META_BAD_FIELD"),
    "restart-true": ('{"params":{"primitive":"strip","restart_index":true}}', "SWPM_META_BAD_FIELD"),
    "restart-missing": ('{"params":{"primitive":"strip"}}', "SWPM_META_BAD_FIELD"),
    "restart-2-32": ('{"params":{"primitive":"strip","restart_index":4294967296}}', "SWPM_META_BAD_FIELD"),
    "restart-minus-zero": ('{"params":{"primitive":"strip","restart_index":-0}}', "SWPM_META_BAD_FIELD"),
    # skip-strip (format.md 3.7): a missing primitive is "strip", a list ignores restart_index's value
    "skip:plain": ('{"encoding":"skip-strip","params":{"primitive":"strip","restart_index":65535}}', None),
    "skip:primitive-missing": ('{"params":{"restart_index":65535}}', None),
    "skip:primitive-other": ('{"params":{"primitive":"fan","restart_index":65535}}', "SWPM_META_BAD_FIELD"),
    # (without a restart index, or with a list, the strips' restart entries 0xFFFF are vertex ids >= V)
    "skip:restart-null": ('{"params":{"primitive":"strip","restart_index":null}}', "SWPM_INDEX_OUT_OF_RANGE"),
    "skip:restart-true": ('{"params":{"primitive":"strip","restart_index":true}}', "SWPM_META_BAD_FIELD"),
    "skip:restart-float": ('{"params":{"primitive":"strip","restart_index":65535.0}}', "SWPM_META_BAD_FIELD"),
    "skip:restart-2-32": ('{"params":{"restart_index":4294967296}}', "SWPM_META_BAD_FIELD"),
    "skip:restart-below-v": ('{"params":{"primitive":"strip","restart_index":4}}', "SWPM_META_BAD_FIELD"),
    "skip:list-restart-below-v": (
        '{"params":{"primitive":"list","restart_index":4}}',
        "SWPM_INDEX_OUT_OF_RANGE",
    ),
    "skip:encoding-other": ('{"encoding":"mixed","params":{"restart_index":65535}}', "SWPM_META_BAD_FIELD"),
    "mixed:plain": ('{"encoding":"mixed","params":{"primitive":7}}', None),
    "mixed:encoding-other": ('{"encoding":"skip-strip"}', "SWPM_META_BAD_FIELD"),
}
META_SEEDS = {"vanilla": "minimal-vanilla", "skip": "skip-strip-strip", "mixed": "mixed"}


@pytest.mark.parametrize("case", sorted(META_CASES))
def test_meta_json(dump: Path, tmp_path: Path, case: str) -> None:
    text, code = META_CASES[case]
    seed = META_SEEDS.get(case.split(":")[0], "sliding-window-strips")
    data = _with_meta((VECTORS / "valid" / f"{seed}.swpm").read_bytes(), text.encode("utf-8"))
    path = tmp_path / "m.swpm"
    path.write_bytes(data)
    rep = validate_bytes(data)
    want = _expected(data, [(p.code, p.severity, p.offset) for p in rep.problems])
    _, out = _run(dump, path)
    assert out.get("code") == code  # what format.md 3.1 / 3.5 say
    assert out == want or (out["ok"] and want["ok"])  # and what swpm_usd.format says


# -- exact arithmetic (format.md 1): sums that wrap at 2^32 or 2^64 in a careless reader ---------------------
def _big_vertex_count() -> tuple[bytes, str, int]:
    data = (VECTORS / "valid" / "sliding-window.swpm").read_bytes()
    _, vert = _payload(data, b"VERT")
    struct.pack_into("<I", vert, 0, 2**30 + 5)  # 12 (2^30 + 5) bytes, 60 when wrapped at 2^32
    out = _rebuild(data, {b"VERT": vert})
    entry, _ = _payload(out, b"VERT")
    return out, "SWPM_COUNT_EXCEEDS_CHUNK", struct.unpack_from("<Q", out, entry + 8)[0]


def _chunk_at_2_64() -> tuple[bytes, str, int]:
    data = bytearray((VECTORS / "valid" / "sliding-window.swpm").read_bytes())
    entry, _ = _payload(bytes(data), b"VERT")
    struct.pack_into("<QQ", data, entry + 8, 2**64 - 8, 16)  # ends at 2^64 + 8, at 8 when wrapped
    table_end = 64 + 32 * struct.unpack_from("<I", data, 24)[0]
    struct.pack_into("<I", data, 48, 0)
    struct.pack_into("<I", data, 48, zlib.crc32(bytes(data[:table_end])))
    return bytes(data), "SWPM_CHUNK_OUT_OF_BOUNDS", entry + 8


def _window_3t_past_2_32() -> tuple[bytes, str, int]:
    data = (VECTORS / "valid" / "sliding-window-offset32.swpm").read_bytes()  # O = 4
    _, lods = _payload(data, b"LODS")
    _, wrec = _payload(data, b"WREC")
    for k in range(2):  # triangle_count 0x55555556: 3 x that is 2^32 + 2, 2 when wrapped
        struct.pack_into("<I", lods, 12 * k + 4, 0x55555556)
        struct.pack_into("<II", wrec, 12 * k, 0, 0x55555556)
    out = _rebuild(data, {b"LODS": lods, b"WREC": wrec})
    entry, _ = _payload(out, b"WREC")
    return out, "SWPM_WINDOW_OUT_OF_POOL", struct.unpack_from("<Q", out, entry + 8)[0]


def _strip_window_past_2_32() -> tuple[bytes, str, int]:
    data = (VECTORS / "valid" / "sliding-window-strips-offset32.swpm").read_bytes()  # O = 4, 4 fields
    _, wrec = _payload(data, b"WREC")
    struct.pack_into("<I", wrec, 16, 0xFFFFFFFF)  # window 1 first_index: + index_count wraps past 2^32
    out = _rebuild(data, {b"WREC": wrec})
    entry, _ = _payload(out, b"WREC")
    return out, "SWPM_WINDOW_OUT_OF_POOL", struct.unpack_from("<Q", out, entry + 8)[0] + 16


def _vrec_past_2_32(R: int, M: int, at_offsets: bool) -> tuple[bytes, str, int]:
    """vanilla-offset32 (O = 4) whose VREC declares R records (16 R bytes) and M change offsets (4 M bytes)
    but keeps its 32 bytes: 16 R or 4 M is 2^32, 0 when wrapped at 2^32."""
    data = (VECTORS / "valid" / "vanilla-offset32.swpm").read_bytes()
    _, vrec = _payload(data, b"VREC")
    struct.pack_into("<II", vrec, 0, R, M)
    out = _rebuild(data, {b"VREC": vrec})
    entry, _ = _payload(out, b"VREC")
    start = struct.unpack_from("<Q", out, entry + 8)[0]
    return out, "SWPM_COUNT_EXCEEDS_CHUNK", start + 8 + (16 * R if at_offsets else 0)


def _level_table_past_2_32(
    vector: str, ctype: bytes, count_at: int, value: int, at: int
) -> tuple[bytes, str, int]:
    """A valid skip-strip or mixed vector (O = 4) whose SKIP / MLVL declares a count (level_count, or
    collapsed / dynamic count) whose array needs 2^32 bytes or more: 0 or a few when wrapped at 2^32."""
    data = (VECTORS / "valid" / f"{vector}.swpm").read_bytes()
    _, payload = _payload(data, ctype)
    struct.pack_into("<I", payload, count_at, value)
    out = _rebuild(data, {ctype: payload})
    entry, _ = _payload(out, ctype)
    return out, "SWPM_COUNT_EXCEEDS_CHUNK", struct.unpack_from("<Q", out, entry + 8)[0] + at


EXACT = {
    # 4 (2^30) bytes of level_first_lod: 0 when wrapped
    "skip-levels-2-32": lambda: _level_table_past_2_32("skip-strip-strip-offset32", b"SKIP", 0, 2**30, 8),
    # D = 2^31 u16 dynamic indices: 2^32 bytes, at the array after the four level arrays (one level: 36)
    "mixed-dynamic-2-32": lambda: _level_table_past_2_32("mixed-offset32", b"MLVL", 4, 2**31, 36),
    "vanilla-records-2-32": lambda: _vrec_past_2_32(2**28, 0, False),
    "vanilla-offsets-2-32": lambda: _vrec_past_2_32(1, 2**30, True),
    "vertex-count-2-30": _big_vertex_count,
    "chunk-at-2-64": _chunk_at_2_64,
    "window-3t-past-2-32": _window_3t_past_2_32,
    "strip-window-past-2-32": _strip_window_past_2_32,
}


@pytest.mark.parametrize("case", sorted(EXACT))
def test_exact_arithmetic(dump_san: Path, tmp_path: Path, case: str) -> None:
    data, code, offset = EXACT[case]()
    path = tmp_path / "x.swpm"
    path.write_bytes(data)
    rc, out = _run(dump_san, path)
    assert rc == 1 and out == {"ok": False, "code": code, "offset": offset}
    rep = validate_bytes(data)
    assert _expected(data, [(p.code, p.severity, p.offset) for p in rep.problems]) == out


def test_readme_c_example_compiles(tmp_path: Path) -> None:
    """README's "Drawing from C" examples (sliding-window, vanilla, skip-strip and mixed, streaming), each in
    a function with stand-ins for the GL names, compile."""
    cc = shutil.which("cc")
    if cc is None:
        pytest.fail("no C compiler (cc): the C reader's tests need one (README, Set up)")
    text = (ROOT / "README.md").read_text()
    section = text.split("## Drawing from C", 1)[1].split("\n## ", 1)[0]
    blocks = [part.split("```", 1)[0] for part in section.split("```c\n")[1:]]
    assert len(blocks) == 4
    for i, block in enumerate(blocks):
        head = [line for line in block.splitlines() if line.startswith("#")]
        body = [line for line in block.splitlines() if not line.startswith("#")]
        src = "\n".join(
            [
                "#include <stdio.h>",
                *(head if i == 0 else ['#include "swpm_reader.h"', *head]),
                "typedef unsigned GLenum; typedef int GLsizei; typedef long GLintptr, GLsizeiptr;",
                "enum { GL_TRIANGLES = 4, GL_TRIANGLE_STRIP = 5, GL_ELEMENT_ARRAY_BUFFER = 0x8893,",
                "       GL_UNSIGNED_SHORT = 0x1403, GL_UNSIGNED_INT = 0x1405 };",
                "void glDrawElements(GLenum mode, GLsizei count, GLenum type, const void *indices);",
                "void glBufferSubData(GLenum t, GLintptr o, GLsizeiptr n, const void *data);",
                "void draw(const uint8_t *bytes, size_t length) {",
                *body,
                "}",
            ]
        )
        (tmp_path / f"example{i}.c").write_text(src)
        flags = [*FLAGS, "-Wno-unused-variable", "-Wno-unused-but-set-variable", "-I", str(RUNTIME)]
        subprocess.run(
            [cc, *flags, "-c", "-o", str(tmp_path / f"example{i}.o"), str(tmp_path / f"example{i}.c")],
            check=True,
        )


# -- an engine's build: strict warnings, C++, two translation units ----------------------------------------
STRICT = ["-Wall", "-Wextra", "-Wpedantic", "-Wconversion", "-Wsign-conversion", "-Wshadow", "-Wcast-align"]
STRICT_C = ["-std=c99", *STRICT, "-Wstrict-prototypes", "-Wmissing-prototypes", "-Werror"]
STRICT_CXX = ["-x", "c++", "-std=c++11", *STRICT, "-Wzero-as-null-pointer-constant", "-Wmissing-declarations"]


def test_header_strict_warnings_cxx_two_units(tmp_path: Path) -> None:
    """The implementation compiles without a warning at -O3 (-Wmaybe-uninitialized needs the optimiser) under
    an engine's strict flags, as C99 and as C++11; a C translation unit that includes the header alone links
    against the implementation built as C++ (extern "C": one definition of each symbol) and runs."""
    cc, cxx = shutil.which("cc"), shutil.which("c++")
    if cc is None or cxx is None:
        pytest.fail("no C / C++ compiler (cc, c++): the C reader's tests need both (README, Drawing from C)")
    impl = tmp_path / "impl.c"
    include = '#include "swpm_reader.h"\n'
    impl.write_text("#define SWPM_READER_IMPLEMENTATION\n" + 2 * include)  # twice: the include guards hold
    user = tmp_path / "user.c"
    user.write_text(
        '#include <stdio.h>\n#include "swpm_reader.h"\nint main(void) {\n'
        "    static const uint8_t none[1] = {0};\n    swpm_file f;\n"
        "    swpm_result r = swpm_open(none, 0, &f);\n"
        '    printf("%s %d %llu", r.code, r.has_offset, (unsigned long long)r.offset);\n    return 0;\n}\n'
    )
    inc = ["-I", str(RUNTIME)]
    run = [
        [cc, *STRICT_C, "-O3", *inc, "-c", "-o", str(tmp_path / "impl_c.o"), str(impl)],
        [cxx, *STRICT_CXX, "-Werror", "-O3", *inc, "-c", "-o", str(tmp_path / "impl_cxx.o"), str(impl)],
        [cc, *STRICT_C, "-O0", *inc, "-c", "-o", str(tmp_path / "user.o"), str(user)],
    ]
    for cmd in run:
        proc = subprocess.run(cmd, capture_output=True, text=True)
        assert proc.returncode == 0 and proc.stderr == "", (cmd, proc.stderr)
    exe = tmp_path / "user"
    subprocess.run([cxx, "-o", str(exe), str(tmp_path / "user.o"), str(tmp_path / "impl_cxx.o")], check=True)
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    assert out == "SWPM_HEADER_TRUNCATED 1 0"


def test_example_engine(tmp_path: Path) -> None:
    """runtime/c/example_engine.c, an engine's frame loop written from the README alone (buffers at odd
    addresses), builds under the strict warnings as C99 (and parses as C++11) and, on a file of each encoding
    (sliding-window list and strip pools), picks Python's LOD for every triangle budget and screen-space
    error, draws LODS triangle_count non-degenerate triangles with no index past the LOD's vertex count."""
    cc, cxx = shutil.which("cc"), shutil.which("c++")
    if cc is None or cxx is None:
        pytest.fail("no C / C++ compiler (cc, c++): the C reader's tests need both (README, Drawing from C)")
    src, exe = RUNTIME / "example_engine.c", tmp_path / "example_engine"
    subprocess.run([cc, *STRICT_C, "-O1", "-I", str(RUNTIME), "-o", str(exe), str(src), "-lm"], check=True)
    subprocess.run([cxx, *STRICT_CXX, "-Werror", "-fsyntax-only", "-I", str(RUNTIME), str(src)], check=True)
    pms = {
        "list": _pm("suzanne", "list"),
        "strip": _pm("suzanne", "strip"),
        "vanilla": _vpm("suzanne"),
        "skip-strip": _lpm("suzanne", "skip-strip"),
        "mixed": _lpm("suzanne", "mixed"),
    }
    for name, pm in pms.items():
        path = swpm_usd.save(pm, tmp_path / f"{name}.swpm")
        proc = subprocess.run([str(exe), str(path)], capture_output=True, check=True, text=True)
        out = json.loads(proc.stdout)
        q = swpm_usd.load(path)
        assert out["encoding"] == q.encoding and out["bad"] == 0, name
        assert len(out["frames"]) == (2 * q.lod_count if q.lod_count < 64 else 128)
        for by_error, target, k, drawn, used, _uploaded in out["frames"]:
            if by_error:
                assert k == q.lod_for_screen_error(target, 10.0, 1.0, 1080), (name, target)
            else:
                assert k == q.lod_for_triangles(target), (name, target)
            assert (drawn, used) == (q.triangle_counts[k], q.vertex_counts[k]), (name, k)
        assert {f[2] for f in out["frames"]} >= {0, q.lod_count - 1}, name  # both ends of the range
        # instances upload only their dirty range: all of it in the first frame, nothing when the LOD holds
        if name in ("vanilla", "skip-strip", "mixed"):
            frames = out["frames"]
            assert frames[0][5] > 0, name
            assert all(f[5] == 0 for e, f in zip(frames, frames[1:], strict=False) if f[2] == e[2]), name
            assert any(f[5] > 0 for e, f in zip(frames, frames[1:], strict=False) if f[2] != e[2]), name


# -- the instances' dirty ranges: uploading only them keeps a GPU copy equal to the buffer ---------------
DIRTY_CASES = [
    (m, v) for m in ("suzanne", "spot", "cow") for v in ("vanilla", "skip-strip", "skip-list", "mixed")
]


@pytest.fixture(scope="module")
def dirty_walk(tmp_path_factory: pytest.TempPathFactory) -> Path:
    cc = shutil.which("cc")
    if cc is None:
        pytest.fail("no C compiler (cc): the C reader's tests need one (README, Set up)")
    out = tmp_path_factory.mktemp("cc-dirty") / "c_dirty_walk"
    src = ROOT / "tests" / "c_dirty_walk.c"
    subprocess.run([cc, *FLAGS, "-I", str(RUNTIME), "-o", str(out), str(src)], check=True)
    return out


@pytest.mark.parametrize(("mesh", "variant"), DIRTY_CASES, ids=[f"{m}-{v}" for m, v in DIRTY_CASES])
def test_instance_dirty_range(dirty_walk: Path, tmp_path: Path, mesh: str, variant: str) -> None:
    """A random walk of set_lod calls (steps, jumps across levels, repeats): after init and after each call,
    copying only the taken dirty range into a mirror gives the instance's whole buffer (so what is drawn);
    a set_lod to the held LOD leaves the range empty; on average less is uploaded than is drawn (README)."""
    pm = _vpm(mesh) if variant == "vanilla" else _lpm(mesh, variant)
    path = swpm_usd.save(pm, tmp_path / f"{mesh}-{variant}.swpm")
    proc = subprocess.run(
        [str(dirty_walk), str(path), "7", "1500"], capture_output=True, check=True, text=True
    )
    out = json.loads(proc.stdout)
    assert out["mismatch"] == 0, out
    assert out["repeat"] > 0 and out["repeat_dirty"] == 0, out
    assert variant == "vanilla" or out["levels"] > 0, out  # level changes (whole-list copies) were walked
    assert 0 < out["uploaded"] < out["drawn"], out


def _first_error(problems: list[dict[str, Any]]) -> dict[str, Any]:
    e = next(q for q in problems if q["severity"] == "error")
    return {
        "ok": False,
        "code": e["code"],
        "offset": e["offset"],
        **({"need": e["need"]} if "need" in e else {}),
    }


@pytest.mark.parametrize(
    "vector", [v for v in MANIFEST["vectors"] if v.get("prefixes")], ids=lambda v: v["name"]
)
def test_prefix_cases(dump: Path, vector: dict[str, Any]) -> None:
    """Every prefix case of the vectors (format.md 4.1) through ``swpm_dump --prefix``: the first error (with
    need), or the finest drawable LOD, needed(k) and the CRC of the drawable points (whose SHA-256 the case
    gives), each SMAP band's prefix_length = needed(first_lod), and finishing = the vector's verdict."""
    path = VECTORS / vector["file"]
    data = path.read_bytes()
    whole = json.loads((VECTORS / vector["expected"]).read_text())
    cases = vector["prefixes"]
    proc = subprocess.run(
        [str(dump), "--prefix", *(str(c["length"]) for c in cases), str(path)], capture_output=True, text=True
    )
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr[-2000:]
    lines = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(lines) == len(cases)
    for case, got in zip(cases, lines, strict=True):
        exp = json.loads((VECTORS / case["expected"]).read_text())
        assert got["n"] == case["length"], case["name"]
        if not exp["opened"]:
            assert {k: got[k] for k in got if k != "n"} == _first_error(exp["problems"]), case["name"]
            continue
        needed, L = exp["needed"], len(exp["needed"])
        fin = L if exp["finest_drawable"] is None else exp["finest_drawable"]
        assert (got["ok"], got["lod_count"], got["finest"]) == (True, L, fin), case["name"]
        assert got["needed"] == [needed[0], needed[min(fin, L - 1)], needed[L - 1]], case["name"]
        if fin < L:  # the drawable points: the first vertex_count(fin) records' first 12 bytes
            count, table = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
            entries = [struct.unpack_from("<4sIQ", data, table + 32 * e) for e in range(count)]
            vo = next(off for ctype, _flags, off in entries if ctype == b"VERT")
            _, _, stride, at = struct.unpack_from("<4I", data, vo)
            count = exp["drawable"]["points"]["shape"][0]
            pts = b"".join(data[vo + at + stride * i : vo + at + stride * i + 12] for i in range(count))
            assert hashlib.sha256(pts).hexdigest() == exp["drawable"]["points"]["sha256"], case["name"]
            assert got["points_crc"] == zlib.crc32(pts), case["name"]
        else:
            assert got["points_crc"] is None, case["name"]
        for band in got.get("smap", []) if "SWPM_SMAP_INVALID" not in str(whole["problems"]) else []:
            assert band[3] == needed[band[0]], (case["name"], band)
        assert got["finish"] == ({"ok": True} if whole["valid"] else _first_error(whole["problems"])), case[
            "name"
        ]


@pytest.mark.parametrize(
    ("vector", "case"),
    [pytest.param(v, c, id=c["name"]) for v in MANIFEST["vectors"] for c in v.get("ranges", [])],
)
def test_range_cases(dump: Path, vector: dict[str, Any], case: dict[str, Any]) -> None:
    """Every range case of the vectors (format.md 4.2) through ``swpm_dump --ranges`` (the bytes not held
    filled with 0xA5, never read): the first error (with the range to fetch), or the drawable LODs, the
    CRC of what they draw (their points, then their INDX elements, whose SHA-256 the case gives), the
    ranges LODs 0 and L-1 need, and finishing = the vector's verdict."""
    path = VECTORS / vector["file"]
    data = path.read_bytes()
    whole = json.loads((VECTORS / vector["expected"]).read_text())
    exp = json.loads((VECTORS / case["expected"]).read_text())
    held = ",".join(f"{o}:{n}" for o, n in case["ranges"])
    proc = subprocess.run(
        [str(dump), "--ranges", held, "--fill", "a5", str(path)], capture_output=True, text=True
    )
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr[-2000:]
    got = json.loads(proc.stdout)
    if not exp["opened"]:
        first = _first_error(exp["problems"])
        if first["code"] == "SWPM_RANGES_NOT_HELD":
            first["need"] = next(q["need"] for q in exp["problems"] if q["code"] == first["code"])
            start = next(q["need_start"] for q in exp["problems"] if q["code"] == first["code"])
            if start:  # (swpm_dump prints need_start when it is not 0)
                first["need_start"] = start
        assert got == first
        return
    L = len(exp["needed"])
    lods = exp["drawable_lods"]
    assert (got["ok"], got["lod_count"], got["drawable"]) == (True, L, lods)
    assert got["finest"] == (lods[0] if lods else L)
    for k, flat in zip((0, L - 1), got["needed"], strict=False):
        assert flat == [x for a, b in exp["needed"][k] for x in (a, b - a)], k
    # what each drawable LOD draws: the points of its vertices (the first 12 bytes of each record), its INDX
    # elements; the case gives their SHA-256, swpm_dump one CRC over all of them
    count, table = struct.unpack_from("<I", data, 24)[0], struct.unpack_from("<Q", data, 32)[0]
    entries = [struct.unpack_from("<4sIQ", data, table + 32 * e) for e in range(count)]
    vo = next(off for ctype, _flags, off in entries if ctype == b"VERT")
    _, _, stride, at = struct.unpack_from("<4I", data, vo)
    drawn = b""
    for k in lods:
        draws, (_, *rest) = exp["drawable"][str(k)], exp["needed"][k]
        n = draws["points"]["shape"][0]
        pts = b"".join(data[vo + at + stride * i : vo + at + stride * i + 12] for i in range(n))
        assert hashlib.sha256(pts).hexdigest() == draws["points"]["sha256"], k
        elems = data[rest[0][0] : rest[0][1]] if len(rest) == 2 else b""
        assert hashlib.sha256(elems).hexdigest() == draws["indices"]["sha256"], k
        drawn += pts + elems
    assert got["drawn_crc"] == zlib.crc32(drawn)
    assert got["finish"] == ({"ok": True} if whole["valid"] else _first_error(whole["problems"]))
