"""Tests of the SWPM v1 codec (swpm_usd.format): layout vs spec, round trips, atomic save, errors, CLI."""

from __future__ import annotations

import json
import os
import re
import stat
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import swpm_usd
from swpm_usd.encode.base import ENCODINGS
from swpm_usd.format import SwpmFormatError, encode_bytes, load, load_bytes, save, validate, validate_bytes
from swpm_usd.format import layout as L
from swpm_usd.format.errors import CATALOGUE, render_markdown
from swpm_usd.format.vectors import fan_sliding, fan_vanilla
from swpm_usd.mesh import Mesh

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "spec" / "format.md"
#: the reader's modules: the structure pass and API, and the content checks split out of it
READER = [ROOT / "swpm_usd" / "format" / f for f in ("reader.py", "parsed.py", "meta.py")]
READER += sorted((ROOT / "swpm_usd" / "format").glob("check_*.py"))


# -- layout == spec ---------------------------------------------------------------------------------------
def _spec_table(heading: str) -> list[tuple[int, int, str]]:
    """(offset, size, field) rows of the first byte table after ``heading`` in spec/format.md."""
    text = SPEC.read_text()
    section = text[text.index(heading) :]
    rows = []
    for line in section.splitlines()[2:]:
        if rows and not line.startswith("|"):
            break
        m = re.match(r"\|\s*(\d+)\s*\|\s*(\d+)\s*\|\s*[\w\[\]]+\s*\|\s*(\w+)", line)
        if m:
            rows.append((int(m.group(1)), int(m.group(2)), m.group(3)))
    return rows


@pytest.mark.parametrize(
    ("heading", "dtype"),
    [
        ("### 2.1 Header", L.HEADER),
        ("### 2.2 Chunk table entry", L.CHUNK_ENTRY),
        ("### 3.2 `LODS`", L.LOD_ROW),
    ],
)
def test_dtypes_match_spec_tables(heading: str, dtype: np.dtype) -> None:
    rows = _spec_table(heading)
    assert sum(size for _, size, _ in rows) == dtype.itemsize
    assert [off for off, _, _ in rows] == [dtype.fields[n][1] for n in dtype.names]


def test_sizes_match_spec() -> None:
    for name, size in L.SPEC_SIZES.items():
        assert getattr(L, name).itemsize == size, name
    for dt in (L.HEADER, L.CHUNK_ENTRY, L.LOD_ROW, L.VERT_HEADER, L.ATTR_DESC, L.SMAP_BAND, L.SMAP_RANGE):
        for n in dt.names:
            base = dt.fields[n][0].base
            assert base.str[0] in "<|", (dt, n)  # explicit little-endian (or byte-sized)
    assert "24 B" in SPEC.read_text() and "16 N" in SPEC.read_text()


# -- round trips -------------------------------------------------------------------------------------------
def _fan_mesh() -> Mesh:
    rng = np.random.default_rng(0)
    n = 12
    g = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 2).astype(np.float32)
    pts = np.c_[g, rng.random(n * n).astype(np.float32) * 0.1]
    tris = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1
            tris += [(a, b, c), (a, c, d)]
    attrs = {"uv": g / n, "color": (rng.random((n * n, 4)) * 255).astype(np.uint8)}
    return Mesh(pts, np.array(tris), attrs)


@pytest.fixture(scope="module")
def grid_pm() -> swpm_usd.ProgressiveMesh:
    return swpm_usd.build(_fan_mesh(), "vanilla")


def _same(a: swpm_usd.ProgressiveMesh, b: swpm_usd.ProgressiveMesh) -> None:
    assert a.encoding == b.encoding
    np.testing.assert_array_equal(a.points, b.points)
    assert list(a.attributes) == list(b.attributes)
    for k in a.attributes:
        np.testing.assert_array_equal(a.attributes[k], b.attributes[k])
        assert a.attributes[k].dtype == b.attributes[k].dtype
    ba, bb = a.buffers(), b.buffers()
    assert sorted(ba) == sorted(bb)
    for k in ba:
        np.testing.assert_array_equal(ba[k], bb[k], err_msg=k)
    np.testing.assert_array_equal(a.vertex_counts, b.vertex_counts)
    np.testing.assert_array_equal(a.triangle_counts, b.triangle_counts)
    np.testing.assert_array_equal(a.lod_errors, b.lod_errors)
    assert a.params == b.params
    for k in sorted({0, a.lod_count // 2, a.lod_count - 1}):
        ka, sa = a.draw_stream(k)
        kb, sb = b.draw_stream(k)
        assert ka == kb
        np.testing.assert_array_equal(sa, sb)


def test_vanilla_round_trip_zero_copy(grid_pm, tmp_path: Path) -> None:
    path = save(grid_pm, tmp_path / "grid.swpm")
    rep = validate(path)
    assert rep.valid, rep.format()
    q = load(path)
    _same(grid_pm, q)
    # zero copy: read-only views of the mapping, file dtype kept (u16 here)
    assert not q.points.flags.writeable and not q.points.flags.owndata
    assert q.indices.dtype == np.dtype("<u2") and not q.indices.flags.owndata
    assert q.attributes["color"].dtype == np.uint8


def test_u32_when_values_exceed_u16(grid_pm, tmp_path: Path) -> None:
    data = encode_bytes(grid_pm, index_width=4)
    q = load_bytes(data)
    assert q.indices.dtype == np.dtype("<u4")
    _same(grid_pm, q)
    # a value above 65535 forces u32 without asking
    raw = fan_vanilla(lod_errors=np.array([0, 70000.0], np.float32))
    raw.raw_buffers = dict(raw.raw_buffers, collapse_change_offsets=[2, 5])
    assert validate_bytes(encode_bytes(raw)).summary["index_width"] == 2
    from swpm_usd.format.writer import choose_index_width

    assert choose_index_width({"a": np.array([65535], np.uint32)}) == 2
    assert choose_index_width({"a": np.array([65536], np.uint32)}) == 4


@pytest.mark.parametrize(
    ("encoding", "params"),
    [("sliding-window", {}), ("skip-strip", {}), ("skip-strip", {"primitive": "list"})],
)
def test_other_encodings_round_trip(encoding: str, params: dict, tmp_path: Path) -> None:
    assert encoding in ENCODINGS
    pm = swpm_usd.build(_fan_mesh(), encoding, **params)
    path = save(pm, tmp_path / "x.swpm")
    rep = validate(path)
    assert rep.valid, rep.format()
    _same(pm, load(path))


@pytest.mark.parametrize("encoding", ["vanilla", "skip-strip", "mixed"])
def test_errors_beyond_float32_still_save_a_valid_file(encoding: str, tmp_path: Path) -> None:
    """Points near float32's largest value (finite, so every loader takes them) can give a LOD an error (a
    distance, computed in float64) beyond float32's range: it is stored as float32's largest value, not as
    inf, which the writer wrote and every reader rejected (SWPM_LOD_NOT_MONOTONE: error is not finite)."""
    rng = np.random.default_rng(0)
    n = 300  # a random hub (benchmarks/bench_hostile.py): its coarse errors exceed its coordinates
    pts = rng.normal(size=(n + 1, 3))
    pts *= 3e38 / np.abs(pts).max()
    mesh = Mesh.from_arrays(pts.astype(np.float32), np.c_[np.zeros(n, int), rng.integers(1, n + 1, (n, 2))])
    pm = swpm_usd.build(mesh, encoding)
    assert np.isfinite(pm.lod_errors).all() and pm.lod_errors[-1] == np.finfo(np.float32).max
    assert (np.diff(pm.lod_errors) >= 0).all()
    path = save(pm, tmp_path / "x.swpm")
    rep = validate(path)
    assert rep.valid, rep.format()
    _same(pm, load(path))


def test_hand_made_sliding_window_buffers_validate() -> None:
    """Without the sliding-window implementation the codec still writes and checks its chunks."""
    rep = validate_bytes(encode_bytes(fan_sliding()))
    assert rep.valid, rep.format()
    assert rep.summary["encoding"] == "sliding-window"


def test_streaming_map_prefixes_shrink_coarse_to_fine(grid_pm) -> None:
    import struct

    from swpm_usd.format.vectors import chunk

    data = encode_bytes(grid_pm)
    _, off, _ = chunk(data, L.SMAP)
    bands, _ = struct.unpack_from("<II", data, off)
    rows = [struct.unpack_from("<IIIIQ", data, off + 8 + 24 * b) for b in range(bands)]
    prefixes = [r[4] for r in rows]
    assert bands > 1 and prefixes == sorted(prefixes, reverse=True) and prefixes[0] == len(data)
    _, voff, _ = chunk(data, L.VERT)
    _, _, stride, data_offset = struct.unpack_from("<IIII", data, voff)
    first, count = rows[-1][0], rows[-1][1]
    coarse_max = max(grid_pm.vertex_count_at(k) for k in range(first, first + count))
    # the coarsest band needs everything before VERT plus only its vertex prefix
    assert prefixes[-1] == voff + data_offset + coarse_max * stride < len(data)


def test_save_is_atomic(grid_pm, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "a.swpm"
    save(grid_pm, path)
    before = path.read_bytes()

    def boom(*a, **k):  # noqa: ANN002, ANN003, ANN202
        raise OSError("disk full")

    monkeypatch.setattr("swpm_usd.format.writer.os.replace", boom)
    with pytest.raises(OSError):
        save(swpm_usd.build(_fan_mesh(), "vanilla", seam_weight=3.0), path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.swpm"]


def test_a_failed_save_names_the_file_asked_for(grid_pm, tmp_path: Path) -> None:
    """The OSError of a save that cannot write names the output, not the temporary file beside it (encode
    printed "Permission denied: '/out/.a.swpm.x1y2z3.tmp'"), and keeps its errno subclass."""
    with pytest.raises(IsADirectoryError) as exc:
        save(grid_pm, tmp_path)  # a folder
    assert exc.value.filename == str(tmp_path) and ".tmp" not in str(exc.value)
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "file").write_bytes(b"")
    with pytest.raises(OSError) as exc:
        save(grid_pm, tmp_path / "file" / "a.swpm")  # its folder is a file
    assert exc.value.filename == str(tmp_path / "file" / "a.swpm")
    from swpm_usd.cli import main

    r = CliRunner().invoke(
        main, ["encode", str(_write_fan_obj(tmp_path / "g.obj")), "-o", str(tmp_path / "file" / "a.swpm")]
    )
    assert r.exit_code == 1 and f"cannot write {tmp_path / 'file' / 'a.swpm'}" in r.stderr


@pytest.mark.parametrize(
    ("attribute", "what"),
    [
        (np.arange(4, dtype=np.int64), "int64, shape (4, 1)"),
        (np.ones((4, 300), np.float32), "float32, shape (4, 300)"),
    ],
)
def test_an_attribute_the_format_cannot_store_is_a_typed_error(
    tmp_path: Path, attribute: np.ndarray, what: str
) -> None:
    """save raised a bare ValueError (no SwpmError: an `except SwpmError` let it through) without saying
    what the format can store; it is an SwpmEncodeError, still a ValueError, that lists it; nothing is
    written."""
    from swpm_usd.format import SwpmEncodeError

    mesh = Mesh.from_arrays(
        np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], np.float32),
        [[0, 1, 2], [1, 3, 2]],
        {"a": attribute},
    )
    pm = swpm_usd.build(mesh, "vanilla")
    with pytest.raises(
        SwpmEncodeError, match=rf"attribute 'a' \({re.escape(what)}\) cannot be stored in SWPM v1: "
    ) as exc:
        save(pm, tmp_path / "a.swpm")
    assert isinstance(exc.value, swpm_usd.SwpmError) and isinstance(exc.value, ValueError)
    assert "u8 i8 u16 i16 u32 i32 f16 f32 f64" in str(exc.value) and "1 to 255" in str(exc.value)
    assert list(tmp_path.iterdir()) == []


def test_save_is_deterministic(grid_pm) -> None:
    assert encode_bytes(grid_pm) == encode_bytes(grid_pm)


# -- errors ------------------------------------------------------------------------------------------------
def test_errors_md_is_generated_from_catalogue() -> None:
    assert (ROOT / "spec" / "errors.md").read_text() == render_markdown()


def test_every_reported_code_is_catalogued() -> None:
    used = set(re.findall(r'"(SWPM_[A-Z0-9_]+)"', "".join(p.read_text() for p in READER)))
    assert used, "no codes found"
    assert used <= set(CATALOGUE)
    for e in CATALOGUE.values():
        assert e.severity in ("error", "warning", "info")


def test_load_raises_one_exception_with_full_report(tmp_path: Path) -> None:
    data = bytearray(encode_bytes(fan_vanilla(buffers={"indices": [1, 2, 4, 2, 3, 9, 0, 1, 4, 3, 0, 9]})))
    data[20] |= 0x80  # unknown feature bit as well
    path = tmp_path / "bad.swpm"
    path.write_bytes(bytes(data))
    with pytest.raises(SwpmFormatError) as info:
        load(path)
    codes = info.value.report.codes()
    assert "SWPM_HEADER_UNKNOWN_FEATURE" in codes and "SWPM_CHECKSUM_MISMATCH" in codes
    assert all(p.offset is None or p.offset >= 0 for p in info.value.report.problems)
    rep = validate_bytes(encode_bytes(fan_vanilla(buffers={"indices": [1, 2, 4, 2, 3, 9, 0, 1, 4, 3, 0, 9]})))
    assert [p.code for p in rep.problems].count(
        "SWPM_INDEX_OUT_OF_RANGE"
    ) == 2  # every problem, not the first


def test_huge_count_allocates_nothing() -> None:
    from swpm_usd.format.vectors import chunk, patch

    base = encode_bytes(fan_vanilla())
    _, roff, _ = chunk(base, L.VREC)
    bad = patch(base, roff, "<I", 0xFFFFFFFF)
    tracemalloc.start()
    rep = validate_bytes(bad)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert "SWPM_COUNT_EXCEEDS_CHUNK" in rep.codes()
    assert peak < 1_000_000


def test_unknown_ancillary_is_ignored_and_critical_rejected() -> None:
    ok = encode_bytes(fan_vanilla(), extra_chunks=[(b"zXTR", False, b"x" * 5)])
    assert load_bytes(ok).lod_count == 2
    bad = encode_bytes(fan_vanilla(), extra_chunks=[(b"zXTR", True, b"x")])
    with pytest.raises(SwpmFormatError) as info:
        load_bytes(bad)
    assert info.value.report.codes() == ["SWPM_CHUNK_UNKNOWN_CRITICAL"]


# -- CLI ---------------------------------------------------------------------------------------------------
def _write_fan_obj(path: Path) -> Path:
    """:func:`_fan_mesh` written as an OBJ file at ``path``."""
    m = _fan_mesh()
    path.write_text(
        "".join(f"v {x} {y} {z}\n" for x, y, z in m.points)
        + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in m.triangles)
    )
    return path


def test_cli(tmp_path: Path) -> None:
    from swpm_usd.cli import main

    obj = _write_fan_obj(tmp_path / "grid.obj")
    out = tmp_path / "grid.swpm"
    r = CliRunner().invoke(main, ["encode", str(obj), "-o", str(out), "--encoding", "vanilla"])
    assert r.exit_code == 0, r.output
    assert load(out).params
    assert validate(out).valid
    r = CliRunner().invoke(main, ["validate", str(out)])
    assert r.exit_code == 0 and "valid" in r.output
    r = CliRunner().invoke(
        main, ["validate", str(ROOT / "spec/vectors/invalid/overlapping-chunks.swpm"), "--json"]
    )
    assert r.exit_code == 1 and "SWPM_CHUNK_OVERLAP" in r.output
    r = CliRunner().invoke(main, ["validate"])
    assert r.exit_code == 2
    r = CliRunner().invoke(main, ["inspect", str(out), "--json"])
    assert r.exit_code == 0 and '"lod_count"' in r.output
    r = CliRunner().invoke(main, ["inspect", str(out)])
    assert r.exit_code == 0 and "VERT" in r.output
    r = CliRunner().invoke(main, ["conformance", str(ROOT / "spec" / "vectors")])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["encode", str(tmp_path / "missing.obj"), "-o", str(out)])
    assert r.exit_code == 1


def test_inspect_of_a_file_it_cannot_read_shows_unknowns_as_unknown(tmp_path: Path) -> None:
    """inspect of a truncated file printed "INVALID SWPM ? ?, index u0": the index width it could not read
    as a width of 0 bits (then "? ?, index u?": what it could not read is now left out)."""
    from swpm_usd.cli import main

    cut = tmp_path / "cut.swpm"
    cut.write_bytes(encode_bytes(fan_vanilla())[:40])  # type: ignore[arg-type]
    r = CliRunner().invoke(main, ["inspect", str(cut)])
    assert r.exit_code == 1 and r.stdout.splitlines()[0] == f"{cut}: INVALID SWPM"


def test_rows_below_one_is_a_usage_error(tmp_path: Path) -> None:
    """build / inspect --rows -3 (or 0) printed a table as if nothing were wrong; it is a usage error (2)."""
    from swpm_usd.cli import main

    out = tmp_path / "g.swpm"
    save(swpm_usd.build(_fan_mesh(), "vanilla"), out)
    obj = _write_fan_obj(tmp_path / "g.obj")
    for args in (["build", str(obj)], ["inspect", str(out)]):
        for rows in ("-3", "0"):
            r = CliRunner().invoke(main, [*args, "--rows", rows])
            assert r.exit_code == 2 and "--rows" in r.stderr, r.output
        r = CliRunner().invoke(main, [*args, "--rows", "1", "--json"])
        assert r.exit_code == 0 and [row["lod"] for row in json.loads(r.stdout)["lods"]][0] == 0


def test_build_and_encode_share_usage_errors_and_encode_never_overwrites_its_input(tmp_path: Path) -> None:
    from swpm_usd.cli import main

    obj = tmp_path / "victim.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    before = obj.read_bytes()
    out = str(tmp_path / "x.swpm")
    for args, message in (
        (["-e", "foo"], "--encoding"),
        (["-e", "mixed", "-p", "foo=1"], "foo not a parameter of mixed"),
        (["-e", "sliding-window", "-p", "mu=abc"], "mu: 'abc' is not of type 'number'"),
        (["-p", "cache_size"], "--param expects NAME=VALUE"),
    ):
        for cmd in (["build", str(obj)], ["encode", str(obj), "-o", out]):
            r = CliRunner().invoke(main, [*cmd, *args])
            assert r.exit_code == 2 and message in r.output, (cmd, args, r.output)
    # -o: the input itself (also through a link), or not a .swpm name, is refused; nothing is written
    (tmp_path / "link.swpm").symlink_to(obj)
    for target, message in (
        (obj, "victim.obj is the input"),
        (tmp_path / "link.swpm", "link.swpm is the input"),
        (tmp_path / "x.usda", "the output must be a .swpm file"),
    ):
        r = CliRunner().invoke(main, ["encode", str(obj), "-o", str(target)])
        assert r.exit_code == 2 and message in r.output, r.output
    assert obj.read_bytes() == before and not (tmp_path / "x.usda").exists()


def test_encode_json_reports_the_written_file_and_failures_as_json(tmp_path: Path) -> None:
    from swpm_usd.cli import main

    obj = _write_fan_obj(tmp_path / "grid.obj")
    out = tmp_path / "grid.swpm"
    runner = CliRunner()  # click 8.2: result.stdout holds stdout alone
    r = runner.invoke(
        main, ["encode", str(obj), "-o", str(out), "-e", "skip-strip", "-p", "primitive=list", "--json"]
    )
    assert r.exit_code == 0, r.output
    summary = json.loads(r.stdout)
    pm = load(out)
    info = validate(out).summary
    assert summary["input"] == str(obj) and summary["output"] == str(out)
    assert summary["encoding"] == "skip-strip" and summary["params"]["primitive"] == "list"
    assert summary["lod_count"] == pm.lod_count and summary["vertices"] == pm.vertex_count
    assert summary["triangles"] == info["triangle_count"] == _fan_mesh().triangle_count
    assert summary["coarsest_triangles"] == pm.triangle_count_at(pm.lod_count - 1)
    assert summary["bytes"] == out.stat().st_size
    assert (summary["global_bytes"], summary["instance_bytes"]) == (pm.global_bytes, pm.instance_bytes)
    assert summary["source_digest"] == "sha256:" + __import__("hashlib").sha256(obj.read_bytes()).hexdigest()
    assert summary["build_seconds"] >= 0
    # invalid input: exit 1, the error (naming the file) as JSON on stdout and as text on stderr
    broken = tmp_path / "broken.obj"
    broken.write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    for source in (broken, tmp_path / "missing.obj"):
        r = runner.invoke(main, ["encode", str(source), "-o", str(tmp_path / "b.swpm"), "--json"])
        assert r.exit_code == 1, r.output
        failure = json.loads(r.stdout)
        assert failure["input"] == str(source) and failure["output"] == str(tmp_path / "b.swpm")
        assert source.name in failure["error"] and r.stderr.startswith("error: ")
    assert not (tmp_path / "b.swpm").exists()
    # a usage error exits 2 with click's text on stderr, and --json prints it as JSON too, as build --json's
    # (stdout was empty: tests/test_cli_json.py)
    r = runner.invoke(main, ["encode", str(obj), "-o", str(tmp_path / "c.swpm"), "-e", "foo", "--json"])
    assert r.exit_code == 2 and "--encoding" in r.stderr
    failure = json.loads(r.stdout)
    assert failure["input"] == str(obj) and failure["output"] == str(tmp_path / "c.swpm")
    assert "--encoding" in failure["error"] and failure["usage_error"] is True


_TWO_TRIANGLES_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n"
_TWO_TRIANGLES_PLY = (
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
    "0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2\n"
)


def _sha256(data: bytes) -> str:
    return "sha256:" + __import__("hashlib").sha256(data).hexdigest()


def test_encode_reads_an_obj_once_and_digests_the_bytes_it_built_from(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # encode read its input a second time after the build for its source_digest: a file replaced meanwhile
    # (an exporter writing the next version) got the new file's digest on an output built from the old one
    import builtins
    import io

    from swpm_usd.cli import main

    obj = _write_fan_obj(tmp_path / "grid.obj")
    built_from = obj.read_bytes()
    opened: list[str] = []
    build_module = sys.modules["swpm_usd.build"]
    real_open, real_build = builtins.open, build_module.build

    def counting_open(file, *args, **kwargs):  # (io.open: pathlib's; builtins.open: the rest)
        if isinstance(file, (str, os.PathLike)) and Path(file) == obj:
            opened.append(str(file))
        return real_open(file, *args, **kwargs)

    def build_then_replace(*args, **kwargs):
        pm = real_build(*args, **kwargs)
        tmp = tmp_path / "next.obj"
        tmp.write_text(_TWO_TRIANGLES_OBJ)
        os.replace(tmp, obj)  # (the next version, renamed over it as an exporter writes it)
        return pm

    monkeypatch.setattr(builtins, "open", counting_open)
    monkeypatch.setattr(io, "open", counting_open)
    monkeypatch.setattr(build_module, "build", build_then_replace)
    out = tmp_path / "grid.swpm"
    r = CliRunner().invoke(main, ["encode", str(obj), "-o", str(out), "--json"])
    monkeypatch.undo()
    assert r.exit_code == 0, r.output
    summary = json.loads(r.stdout)
    assert summary["triangles"] == _fan_mesh().triangle_count  # (built from the first version)
    assert summary["source_digest"] == _sha256(built_from) != _sha256(obj.read_bytes())
    assert summary["source_digest"].encode() in out.read_bytes()  # (the file's own record of it)
    assert len(opened) == 1, opened  # (the load's and the digest's read are one)


def test_encode_loads_an_obj_from_its_bytes_through_load_mesh(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # encode's OBJ, read once, was parsed by the OBJ loader called directly, past load_mesh and its checks:
    # a second entry point, which a check added to load_mesh would not reach
    import swpm_usd.io
    from swpm_usd.cli import main

    obj = _write_fan_obj(tmp_path / "grid.obj")
    calls: list[tuple[str, bool]] = []
    real = swpm_usd.io.load_mesh

    def recorded(path, **kwargs):
        calls.append((str(path), bool(kwargs.get("data"))))
        return real(path, **kwargs)

    monkeypatch.setattr(swpm_usd.io, "load_mesh", recorded)
    r = CliRunner().invoke(main, ["encode", str(obj), "-o", str(tmp_path / "grid.swpm"), "--json"])
    assert r.exit_code == 0, r.output
    assert calls == [(str(obj), True)], calls


def test_encode_refuses_an_input_loaded_by_path_that_changed_before_it_was_hashed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a PLY (as a USD stage, a GLB) is read by its loader through its path: the digest, taken once it is
    # loaded, would be of another file's bytes than the mesh's, so encode says so (exit 1) and writes nothing
    from swpm_usd import io
    from swpm_usd.cli import main

    ply = tmp_path / "a.ply"
    ply.write_text(_TWO_TRIANGLES_PLY)
    out = tmp_path / "a.swpm"
    r = CliRunner().invoke(main, ["encode", str(ply), "-o", str(out), "--json"])
    assert r.exit_code == 0 and json.loads(r.stdout)["source_digest"] == _sha256(ply.read_bytes())
    out.unlink()
    real = io.load_mesh

    def load_then_replace(path, **kwargs):
        mesh = real(path, **kwargs)
        tmp = tmp_path / "next.ply"
        tmp.write_text(_TWO_TRIANGLES_PLY.replace("1 1 0\n", "2 2 0\n"))
        os.replace(tmp, ply)
        return mesh

    monkeypatch.setattr(io, "load_mesh", load_then_replace)
    r = CliRunner().invoke(main, ["encode", str(ply), "-o", str(out), "--json"])
    assert r.exit_code == 1, r.output
    failure = json.loads(r.stdout)
    assert failure["code"] == "INPUT_CHANGED" and str(ply) in failure["error"], failure
    assert (failure["file"], failure["format"]) == (str(ply), "ply"), failure
    assert "changed while it was read" in r.stderr and not out.exists()


def test_help_lists_the_registered_encodings_and_their_parameters(monkeypatch: pytest.MonkeyPatch) -> None:
    from swpm_usd.cli import main
    from swpm_usd.encode import BUILDERS
    from swpm_usd.encodings import ENCODING_PARAMS

    # an encoding registered later is listed too: the help is read from the registry (its parameters, which
    # the help lists without importing the encoders)
    extra = {**BUILDERS["vanilla"][1], "knob": 3, "mode": "fast", "flag": False, "auto_pick": None}
    monkeypatch.setitem(BUILDERS, "test-encoding", (BUILDERS["vanilla"][0], extra))
    monkeypatch.setitem(ENCODING_PARAMS, "test-encoding", extra)
    runner = CliRunner()
    helps = {cmd: runner.invoke(main, [cmd, "--help"]) for cmd in ("encode", "build")}
    helps["group"] = runner.invoke(main, ["--help"])
    for name, r in helps.items():
        assert r.exit_code == 0, r.output
        assert all(len(line) <= 80 for line in r.output.splitlines()), (name, r.output)
        listed = r.output[r.output.index("Encodings (--encoding):") :]
        for encoding in BUILDERS:
            assert re.search(rf"^    {re.escape(encoding)}( |$)", listed, re.M), (name, encoding)
        assert "boundary_weight=8.0 seam_weight=2.0" in listed  # the parameters every encoding takes
    for name in ("encode", "build"):
        text = " ".join(helps[name].output.split())
        for encoding, (_, defaults) in BUILDERS.items():
            for param, value in defaults.items():
                shown = value if isinstance(value, str) else json.dumps(value)
                assert f"{param}={shown}" in text, (name, encoding, param)
        assert "knob=3 mode=fast flag=false auto_pick=null" in text
        assert "-e, --encoding" in text and "-p, --param NAME=VALUE" in text  # the options keep their names
    assert "knob" not in helps["group"].output and "swpm-pipeline encode --help" in helps["group"].output


def test_every_help_fits_80_columns() -> None:
    # run --help kept its description in one unwrapped paragraph, 100 columns wide
    from swpm_usd.cli import main

    runner = CliRunner()
    for name in [None, *main.commands]:
        r = runner.invoke(main, [name, "--help"] if name else ["--help"], terminal_width=80)
        assert r.exit_code == 0, r.output
        assert max(len(line) for line in r.output.splitlines()) <= 80, (name, r.output)


# -- mixed ---------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def cow_mixed() -> swpm_usd.ProgressiveMesh:
    cow = Path("/work/shared/meshes/cow.obj")
    if not cow.exists():
        pytest.skip("cow.obj not available")
    return swpm_usd.build(swpm_usd.load_mesh(cow), "mixed")


def test_mixed_round_trip_cow(cow_mixed, tmp_path: Path) -> None:
    path = save(cow_mixed, tmp_path / "cow.swpm")
    rep = validate(path)
    assert rep.valid, rep.format()
    assert rep.summary["encoding"] == "mixed"
    q = load(path)
    _same(cow_mixed, q)
    assert not q.level_static_indices.flags.owndata and not q.level_dynamic_indices.flags.owndata
    lods = sorted({0, 1, cow_mixed.lod_count // 3, cow_mixed.lod_count // 2, cow_mixed.lod_count - 1})
    for k in lods:
        np.testing.assert_array_equal(cow_mixed.draw_stream(k)[1], q.draw_stream(k)[1])
        calls_a, calls_b = cow_mixed.draw_calls(k), q.draw_calls(k)
        assert len(calls_a) == len(calls_b) == 2
        for (pa, ia), (pb, ib) in zip(calls_a, calls_b, strict=True):
            assert pa == pb
            np.testing.assert_array_equal(ia, ib)
    # instances of the loaded mesh walk up and down across level boundaries like the original
    ia, ib = cow_mixed.instance(), q.instance()
    for k in (cow_mixed.lod_count - 1, 0, cow_mixed.lod_count // 2):
        np.testing.assert_array_equal(ia.draw_stream(k)[1], ib.draw_stream(k)[1])


def test_mixed_u32_and_streaming_map(cow_mixed) -> None:
    q = load_bytes(encode_bytes(cow_mixed, index_width=4))
    assert q.level_static_indices.dtype == np.dtype("<u4")
    _same(cow_mixed, q)
    rep = validate_bytes(encode_bytes(cow_mixed))
    assert rep.valid and not [p for p in rep.problems if p.code == "SWPM_SMAP_INVALID"]
    assert [c["type"] for c in rep.summary["chunks"]] == [
        "META", "LODS", "SMAP", "RCNT", "MLVL", "MREC", "INDX", "VERT"
    ]  # fmt: skip


@pytest.mark.parametrize(
    ("buffers", "code"),
    [
        ({"collapse_change_offsets": [2, 6]}, "SWPM_INDEX_OUT_OF_RANGE"),
        ({"level_static_start": [0, 9]}, "SWPM_MIXED_BAD_LEVELS"),
        ({"level_dynamic_start": [0, 5]}, "SWPM_MIXED_BAD_LEVELS"),
        ({"level_record_start": [0, 2]}, "SWPM_MIXED_BAD_LEVELS"),
        ({"level_first_lod": [1]}, "SWPM_MIXED_BAD_LEVELS"),
        ({"level_dynamic_indices": [1, 2, 4, 2, 3, 8]}, "SWPM_INDEX_OUT_OF_RANGE"),
        ({"level_dynamic_collapsed_indices": [1, 2, 4, 2, 3, 0]}, "SWPM_PREFIX_VIOLATION"),
        ({"collapse_static_tris_removed": [3]}, "SWPM_RECORD_BAD_COUNTS"),
        ({"collapse_dynamic_tris_removed": [1]}, "SWPM_RECORD_BAD_COUNTS"),
        ({"collapse_kept": [4]}, "SWPM_RECORD_BAD_KEPT"),
        ({"collapse_prev_change_count": [1]}, "SWPM_RECORD_BAD_COUNTS"),
        ({"collapse_change_offsets": [0, 5]}, "SWPM_RECORD_BAD_CHANGE"),
        ({"level_dynamic_collapsed_indices": [1, 2, 0, 2, 3, 1]}, "SWPM_MIXED_BAD_LEVELS"),
        ({"collapse_change_count": [1], "collapse_change_offsets": [2]}, "SWPM_PREFIX_VIOLATION"),
    ],
)
def test_mixed_defects_are_coded(buffers: dict, code: str) -> None:
    from swpm_usd.format.vectors import fan_mixed

    assert validate_bytes(encode_bytes(fan_mixed())).valid
    rep = validate_bytes(encode_bytes(fan_mixed(buffers=buffers)))
    assert not rep.valid and code in rep.codes(), rep.format()
    with pytest.raises(SwpmFormatError):
        load_bytes(encode_bytes(fan_mixed(buffers=buffers)))


def test_mixed_huge_counts_allocate_nothing() -> None:
    from swpm_usd.format.vectors import chunk, fan_mixed, patch

    base = encode_bytes(fan_mixed())
    for t, at in ((L.MLVL, 0), (L.MLVL, 4), (L.MREC, 0), (L.MREC, 4)):
        _, off, _ = chunk(base, t)
        bad = patch(base, off + at, "<I", 0xFFFFFFFF)
        tracemalloc.start()
        rep = validate_bytes(bad)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert "SWPM_COUNT_EXCEEDS_CHUNK" in rep.codes(), (t, at, rep.format())
        assert peak < 1_000_000


@pytest.mark.parametrize(
    "make, buffer, value, code",
    [
        ("skip", "collapse_kept", [77], "SWPM_INDEX_OUT_OF_RANGE"),
        ("skip", "collapse_binned", [88], "SWPM_INDEX_OUT_OF_RANGE"),
        ("skip", "level_collapsed_indices", [1, 2, 0, 2, 3, 0, 0, 1, 0, 3, 0, 99], "SWPM_INDEX_OUT_OF_RANGE"),
        ("mixed", "collapse_prev_change_count", [7], "SWPM_RECORD_BAD_COUNTS"),
        ("vanilla", "collapse_prev_change_count", [7], "SWPM_RECORD_BAD_COUNTS"),
    ],
)
def test_reported_offset_is_the_bad_value(make: str, buffer: str, value: list[int], code: str) -> None:
    """The offset a problem reports points at the stored value that breaks the rule (spec/errors.md, column
    "Offset reported"): a record column is strided in its table, an array after others in its chunk."""
    import struct

    from swpm_usd.format.vectors import fan_mixed, fan_skip

    pm = {"skip": fan_skip, "mixed": fan_mixed, "vanilla": fan_vanilla}[make]()
    pm.raw_buffers[buffer] = value
    data = encode_bytes(pm)  # type: ignore[arg-type]
    found = [p for p in validate_bytes(data).problems if p.code == code]
    assert found, validate_bytes(data).format()
    bad = max(value)
    assert struct.unpack_from("<H", data, found[0].offset)[0] == bad


@pytest.mark.parametrize("params", [{"primitive": "fan"}, {"restart_index": True}, {"restart_index": -1}])
def test_skip_strip_decoding_params_are_checked(params: dict) -> None:
    """Skip-strip's ``primitive`` and ``restart_index`` decide how its lists decode: a bad one is an error of
    validate (not only of load)."""
    from swpm_usd.format.vectors import fan_skip

    pm = fan_skip()
    pm.params.update(params)
    rep = validate_bytes(encode_bytes(pm))  # type: ignore[arg-type]
    assert not rep.valid and [p.code for p in rep.errors] == ["SWPM_META_BAD_FIELD"]


@pytest.mark.parametrize("replacement", [b'"source_digest":NaN ', b'"encoding":"vanilla"'])
def test_meta_must_be_strict_json(replacement: bytes) -> None:
    """META is JSON: NaN/Infinity and duplicate keys (Python's json accepts both) are SWPM_META_BAD_JSON."""
    from swpm_usd.format.vectors import fix_crcs

    data = encode_bytes(fan_vanilla())  # type: ignore[arg-type]
    old = b'"source_digest":null'
    assert data.count(old) == 1 and len(replacement) == len(old)
    bad = fix_crcs(data.replace(old, replacement))
    assert [p.code for p in validate_bytes(bad).errors] == ["SWPM_META_BAD_JSON"]


def test_meta_with_a_byte_order_mark_is_not_json() -> None:
    """Spec 3.1: a leading byte-order mark is not JSON (RFC 8259 lets a parser ignore it; SWPM does not)."""
    from swpm_usd.format.vectors import chunk, fix_crcs

    data = encode_bytes(fan_vanilla(), generator="swpm-usd conformance")  # type: ignore[arg-type]
    _, mo, _ = chunk(data, L.META)
    old = b'{"encoding":"vanilla","generator":"swpm-usd conformance"'
    new = b"\xef\xbb\xbf" + old.replace(b"conformance", b"conforma")
    assert data.count(old) == 1 and len(new) == len(old)
    found = [(p.code, p.offset) for p in validate_bytes(fix_crcs(data.replace(old, new))).errors]
    assert found == [("SWPM_META_BAD_JSON", mo)]


@pytest.mark.parametrize("make", ["skip", "mixed"])
def test_level_count_zero_is_a_level_table_problem(make: str) -> None:
    """Spec 3.7 / 3.8: level_count 0 is SWPM_LEVEL_BAD_TABLE at SKIP's payload, a bad level_first_lod
    (SWPM_MIXED_BAD_LEVELS at its start, payload + 8) in MLVL."""
    from swpm_usd.format.vectors import chunk, fan_mixed, fan_skip, fix_crcs

    pm = (fan_skip if make == "skip" else fan_mixed)(buffers={"level_first_lod": []})  # n = 0
    for name in ("level_index_start", "level_collapsed_start", "level_static_start", "level_dynamic_start"):
        if name in pm.raw_buffers:
            pm.raw_buffers[name] = [0]
    pm.raw_buffers["level_record_start"] = [0]
    data = encode_bytes(pm)  # type: ignore[arg-type]
    _, at, _ = chunk(data, L.SKIP if make == "skip" else L.MLVL)
    assert np.frombuffer(data[at : at + 4], "<u4")[0] == 0
    code = "SWPM_LEVEL_BAD_TABLE" if make == "skip" else "SWPM_MIXED_BAD_LEVELS"
    found = [(p.code, p.offset) for p in validate_bytes(fix_crcs(data)).errors]
    assert found == [(code, at if make == "skip" else at + 8)]


def test_skip_strip_record_checks_all_run() -> None:
    """Spec 5, stage (c): R >= V is reported and the other record checks of the stage still run."""
    from swpm_usd.format.vectors import fan_skip

    pm = fan_skip(
        buffers={
            "collapse_kept": [0, 0, 0, 0, 0],
            "collapse_binned": [4, 3, 2, 1, 0],
            "collapse_change_count": [4, 0, 0, 0, 0],
            "collapse_prev_change_count": [0, 4, 0, 0, 0],
            "level_record_start": [0, 5],
        }
    )
    codes = {p.code for p in validate_bytes(encode_bytes(pm)).errors}  # type: ignore[arg-type]
    assert {"SWPM_RECORD_BAD_COUNTS", "SWPM_RECORD_BAD_KEPT"} <= codes


@pytest.mark.parametrize("make", ["vanilla", "mixed"])
def test_kept_is_checked_when_records_reach_vertex_count(make: str) -> None:
    """Spec 5, vanilla and mixed stage (a): "every check of a stage runs", so R >= V (SWPM_RECORD_BAD_COUNTS)
    does not hide a record that keeps a vertex not below the one it bins (SWPM_RECORD_BAD_KEPT); R = V = 5
    all-zero records: record 4 bins vertex 0 and keeps vertex 0."""
    from swpm_usd.format.vectors import chunk, fan_mixed

    zeros = [0, 0, 0, 0, 0]
    if make == "vanilla":
        over = {"collapse_tris_removed": zeros}
    else:
        over = {"collapse_static_tris_removed": zeros, "collapse_dynamic_tris_removed": zeros}
        over["level_record_start"] = [0, 5]
    over |= {
        "collapse_kept": zeros,
        "collapse_change_count": zeros,
        "collapse_prev_change_count": zeros,
        "collapse_change_offsets": [],
    }
    pm = {"vanilla": fan_vanilla, "mixed": fan_mixed}[make](buffers=over)
    data = encode_bytes(pm)  # type: ignore[arg-type]
    _, rec_at, _ = chunk(data, L.VREC if make == "vanilla" else L.MREC)
    errors = [(p.code, p.offset) for p in validate_bytes(data).errors]
    cols, W = (4 if make == "vanilla" else 5), 2
    assert ("SWPM_RECORD_BAD_COUNTS", rec_at) in errors, errors
    assert ("SWPM_RECORD_BAD_KEPT", rec_at + 8 + 4 * cols * W) in errors, errors


def test_stream_order_names_the_misplaced_duplicate() -> None:
    """SWPM_STREAM_ORDER is reported at the entry found where the order expects another: a second META
    listed after SMAP, not the first META (which is in place)."""
    from swpm_usd.format.vectors import chunk, fix_crcs

    data = bytearray(encode_bytes(fan_vanilla(), extra_chunks=[(b"zXTR", False, b"{}")]))  # type: ignore[arg-type]
    eo, _, _ = chunk(bytes(data), b"zXTR")
    data[eo : eo + 8] = b"META" + L.CHUNK_CRITICAL.to_bytes(4, "little")
    found = [(p.code, p.offset) for p in validate_bytes(fix_crcs(data)).problems]
    assert ("SWPM_CHUNK_DUPLICATE", eo) in found, found
    assert [p for p in found if p[0] == "SWPM_STREAM_ORDER"] == [("SWPM_STREAM_ORDER", eo)], found


def test_stride_must_be_a_multiple_of_every_element_size() -> None:
    """Spec 3.3: stride is a multiple of every attribute's element size. An f64 attribute at offset 16 of a
    stride-28 record (a multiple of 4, ends within the stride) is SWPM_VERT_BAD_LAYOUT."""
    from swpm_usd.format.vectors import chunk, fix_crcs

    data = bytearray(encode_bytes(fan_vanilla(attributes={"w": np.zeros((5, 1), "<f8")})))  # type: ignore[arg-type]
    _, vo, vl = chunk(bytes(data), L.VERT)
    V, A, stride, at = np.frombuffer(bytes(data[vo : vo + 16]), "<u4")
    assert (A, stride) == (1, 24)
    # grow each record by 4 bytes: stride 28, data_offset and the chunk's length follow
    recs = np.frombuffer(bytes(data[vo + at : vo + vl]), np.uint8).reshape(V, stride)
    grown = np.concatenate([recs, np.zeros((V, 4), np.uint8)], axis=1).tobytes()
    payload = bytes(data[vo : vo + 8]) + np.uint32(28).tobytes() + bytes(data[vo + 12 : vo + at]) + grown
    out = bytes(data[:vo]) + payload
    eo, _, _ = chunk(bytes(data), L.VERT)
    out = bytearray(out)
    out[eo + 16 : eo + 24] = len(payload).to_bytes(8, "little")
    out[40:48] = len(out).to_bytes(8, "little")
    rep = validate_bytes(fix_crcs(out))
    assert [(p.code, p.offset) for p in rep.errors] == [("SWPM_VERT_BAD_LAYOUT", vo)], rep.format()


@pytest.mark.parametrize("umask", [0o022, 0o027, 0o077])
def test_atomic_writes_get_the_mode_of_a_plain_open(grid_pm, tmp_path: Path, umask: int) -> None:
    from swpm_usd.fileio import atomic_write_bytes

    old = os.umask(umask)
    try:
        save(grid_pm, tmp_path / "a.swpm")
        atomic_write_bytes(tmp_path / "m.json", b"{}")
        with open(tmp_path / "plain", "wb"):
            pass
    finally:
        os.umask(old)
    want = stat.S_IMODE((tmp_path / "plain").stat().st_mode)
    assert want == 0o666 & ~umask
    for name in ("a.swpm", "m.json"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == want, name


@pytest.mark.parametrize("mode", [0o640, 0o600, 0o444, 0o755])
def test_atomic_writes_keep_the_mode_of_the_file_they_replace(grid_pm, tmp_path: Path, mode: int) -> None:
    """A file replaced by a temporary file renamed over it took the umask's mode (0o644), not its own: an
    output made private (0o600) became readable by everyone on the next write. A new file still gets a plain
    open()'s mode."""
    from swpm_usd.fileio import atomic_write_bytes

    old = os.umask(0o022)
    try:
        for name in ("a.swpm", "m.json"):
            (tmp_path / name).write_bytes(b"old")
            os.chmod(tmp_path / name, mode)
        save(grid_pm, tmp_path / "a.swpm")
        atomic_write_bytes(tmp_path / "m.json", b"{}")
        atomic_write_bytes(tmp_path / "new.json", b"{}")
    finally:
        os.umask(old)
    assert (tmp_path / "m.json").read_bytes() == b"{}" and load(tmp_path / "a.swpm").lod_count
    for name in ("a.swpm", "m.json"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == mode, name
    assert stat.S_IMODE((tmp_path / "new.json").stat().st_mode) == 0o644


def test_conformance_reports_an_unusable_manifest_and_finds_the_vectors_from_elsewhere(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from swpm_usd.cli import main

    bad = tmp_path / "bad"
    bad.mkdir()
    for text in ("{", "[]", '{"vectors": 3}'):
        (bad / "manifest.json").write_text(text)
        r = CliRunner().invoke(main, ["conformance", str(bad), "--json"])
        assert r.exit_code == 1 and (r.exception is None or isinstance(r.exception, SystemExit)), r.output
        assert "manifest.json" in json.loads(r.stdout)["error"]
    (bad / "manifest.json").write_text(
        '{"vectors": [{"name": "no-expected", "file": "a.swpm"}, '
        '{"name": "missing", "file": "a.swpm", "expected": "a.json"}, 7]}'
    )
    r = CliRunner().invoke(main, ["conformance", str(bad)])
    assert r.exit_code == 1 and (r.exception is None or isinstance(r.exception, SystemExit)), r.output
    assert "FAIL no-expected: unusable manifest entry: no 'expected' key" in r.output
    assert "FAIL missing: unusable manifest entry:" in r.output and "0/3 passed" in r.output
    monkeypatch.chdir(tmp_path)  # the default spec/vectors is not here: the checkout's are used
    r = CliRunner().invoke(main, ["conformance"])
    assert r.exit_code == 0 and "passed" in r.output, r.output


# -- the points a later audit left open (format.md 2.2, 2.3, 3.6) --------------------------------------------
def _vert_moved_past_end(gap: bytes | None, trailing: bytes = b"") -> bytes:
    """The minimal file with VERT's offset moved to the first multiple of 8 past the end of the file; ``gap``
    (if given) replaces the bytes VERT's payload left behind, ``trailing`` follows file_size."""
    from swpm_usd.format.vectors import chunk, fix_crcs

    data = bytearray(encode_bytes(fan_vanilla()))  # type: ignore[arg-type]
    eo, vo, vl = chunk(bytes(data), L.VERT)
    assert vo + vl == len(data)
    if gap is not None:
        data[vo:] = gap.ljust(vl, b"\0")
    data[eo + 8 : eo + 16] = L.align(len(data) + 1, 8).to_bytes(8, "little")
    return fix_crcs(data) + trailing


GAP_CASES = {  # gap bytes (None: VERT's old payload), bytes after file_size, problems
    "old-payload": (None, b"", ["SWPM_CHUNK_OUT_OF_BOUNDS", "SWPM_PADDING_NONZERO"]),
    "zero-gap": (b"", b"", ["SWPM_CHUNK_OUT_OF_BOUNDS"]),
    "last-byte": (bytes(75) + b"\1", b"", ["SWPM_CHUNK_OUT_OF_BOUNDS", "SWPM_PADDING_NONZERO"]),
    "trailing-bytes": (b"", b"\1" * 8, ["SWPM_FILE_TRAILING_BYTES", "SWPM_CHUNK_OUT_OF_BOUNDS"]),
}


@pytest.mark.parametrize(("gap", "trailing", "want"), list(GAP_CASES.values()), ids=list(GAP_CASES))
def test_padding_before_a_chunk_past_the_end_is_checked_up_to_the_end(
    gap: bytes | None, trailing: bytes, want: list[str]
) -> None:
    """Spec 2.2 / 5 step 2: the gap before a chunk that starts past the end of the file is the bytes from the
    end of the previous payload to the end of the file (its first file_size bytes); the entry's
    SWPM_CHUNK_OUT_OF_BOUNDS comes first, then the gap's SWPM_PADDING_NONZERO at the gap's start."""
    from swpm_usd.format.vectors import chunk

    data = _vert_moved_past_end(gap, trailing)
    eo, _, _ = chunk(data, L.VERT)
    _, io, il = chunk(data, L.INDX)
    found = [(p.code, p.offset) for p in validate_bytes(data).problems]
    where = {
        "SWPM_CHUNK_OUT_OF_BOUNDS": eo + 8,
        "SWPM_PADDING_NONZERO": io + il,
        "SWPM_FILE_TRAILING_BYTES": len(data) - len(trailing),
    }
    assert found == [(c, where[c]) for c in want]


@pytest.mark.parametrize("dup", [L.VERT, L.INDX])
def test_a_trailing_duplicate_is_out_of_streaming_order(dup: bytes) -> None:
    """Spec 2.3: a duplicate listed after one entry of every type of the order is reported at that position
    (a position past the end of the order differs), not skipped; a duplicate INDX after VERT is reported
    there too, not at VERT. SWPM_CHUNK_DUPLICATE rejects the file either way."""
    from swpm_usd.format.vectors import chunk, fix_crcs, reorder

    base = encode_bytes(fan_vanilla())  # type: ignore[arg-type]
    _, po, pl = chunk(base, dup)
    data = encode_bytes(fan_vanilla(), extra_chunks=[(b"zXTR", True, base[po : po + pl])])  # type: ignore[arg-type]
    data = bytearray(reorder(data, [0, 1, 2, 4, 5, 6, 7, 3]))  # zXTR listed (and laid out) last
    eo, _, _ = chunk(bytes(data), b"zXTR")
    data[eo : eo + 4] = dup
    found = [(p.code, p.offset) for p in validate_bytes(fix_crcs(data)).problems]
    assert found == [("SWPM_CHUNK_DUPLICATE", eo), ("SWPM_STREAM_ORDER", eo)]


@pytest.mark.parametrize("make", ["vanilla", "skip-list", "skip-strip", "mixed"])
def test_a_record_that_changes_a_slot_twice_is_rejected(make: str) -> None:
    """Spec 3.6 (3.7, 3.8): a record's changes are made in the order listed, so a slot it lists twice no
    longer holds the binned vertex the second time: SWPM_RECORD_BAD_CHANGE at the record's row, the only
    problem, although the record without the repeat (the fan's own buffers) is valid and the set of slots it
    changes is the same."""
    from swpm_usd.format.vectors import chunk, fan_mixed, fan_skip, fan_skip_strip

    makers = {"vanilla": fan_vanilla, "skip-list": fan_skip, "skip-strip": fan_skip_strip, "mixed": fan_mixed}
    pm = makers[make]()
    assert validate_bytes(encode_bytes(pm)).valid  # type: ignore[arg-type]
    own = list(pm.raw_buffers["collapse_change_offsets"])
    assert pm.raw_buffers["collapse_change_count"] == [len(own)]  # one record
    pm.raw_buffers["collapse_change_offsets"] = [own[0], *own]  # its first slot listed twice
    pm.raw_buffers["collapse_change_count"] = [len(own) + 1]
    data = encode_bytes(pm)  # type: ignore[arg-type]
    _, rec, _ = chunk(data, {"vanilla": L.VREC, "mixed": L.MREC}.get(make, L.SREC))
    found = [(p.code, p.offset) for p in validate_bytes(data).problems]
    assert found == [("SWPM_RECORD_BAD_CHANGE", rec + 8)]


@pytest.mark.parametrize(
    ("encoding", "params"),
    [
        ("vanilla", {}),
        ("skip-strip", {"primitive": "strip", "restart": True}),
        ("skip-strip", {"primitive": "strip", "restart": False}),
        ("skip-strip", {"primitive": "list"}),
        ("mixed", {}),
    ],
)
def test_encoders_never_list_a_slot_twice_in_one_record(encoding: str, params: dict) -> None:
    """What the writers produce is never rejected by spec 3.6's rule: each record lists each slot once."""
    from conftest import shared_mesh

    for mesh in (_fan_mesh(), shared_mesh("cow.obj")):
        pm = swpm_usd.build(mesh, encoding, **params)
        b = pm.buffers()
        counts = np.asarray(b["collapse_change_count"], np.int64)
        record = np.repeat(np.arange(counts.shape[0]), counts)
        slots = np.asarray(b["collapse_change_offsets"], np.int64)
        assert slots.shape == record.shape and counts.sum() > 0
        pairs = record * (int(slots.max()) + 1) + slots
        assert np.unique(pairs).shape == pairs.shape, encoding
        rep = validate_bytes(encode_bytes(pm))
        assert rep.valid, rep.format()


# -- found by reading the spec as a second implementer (format.md 3.7, 4, 5) --------------------------------
SKIP_TABLE_CASES = {  # fan_skip buffers that break the level table by itself; INDX holds 9 (V = 5) in both
    "collapsed-start": {
        "level_indices": [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 0, 9],
        "level_collapsed_start": [0, 15],
        "level_collapsed_indices": [1, 2, 0, 2, 3, 0, 0, 1, 0, 3, 0, 0, 0, 1, 2],
    },
    "partial-triangle": {
        "level_indices": [1, 2, 4, 2, 3, 4, 0, 1, 4, 3, 9],
        "level_index_start": [0, 11],
        "level_collapsed_start": [0, 11],
        "level_collapsed_indices": [1, 2, 0, 2, 3, 0, 0, 1, 0, 3, 9],
    },
}


@pytest.mark.parametrize("case", list(SKIP_TABLE_CASES))
def test_skip_level_table_by_itself_is_a_stage_a_check(case: str) -> None:
    """Spec 5 step 4, skip-strip (a): the level table by itself (its start arrays, level_collapsed_start =
    level_index_start, whole triangles for "list") is checked before the values < V and ends the checks;
    only its agreement with RCNT is a stage (c) check. So INDX holding 9 is not reported."""
    from swpm_usd.format.vectors import chunk, fan_skip

    data = encode_bytes(fan_skip(buffers=SKIP_TABLE_CASES[case]))  # type: ignore[arg-type]
    _, so, _ = chunk(data, L.SKIP)
    found = [(p.code, p.offset) for p in validate_bytes(data).problems]
    assert found == [("SWPM_LEVEL_BAD_TABLE", so)]


def test_smap_band_checks_come_before_the_ranges_in_the_file() -> None:
    """Spec 4: the bands (range_count <= 16 among them) are checked before every range lies in the file;
    one SWPM_SMAP_INVALID, at band 0 (payload + 8), not at the range table (vector smap-17-ranges)."""
    from swpm_usd.format.vectors import chunk, fan_smap

    assert validate_bytes(fan_smap([(0, 8)] * 13)).problems == []  # 16 ranges
    data = fan_smap([(0, 8)] * 13 + [(-1, 8)])  # 17 ranges, the last outside the file
    _, so, _ = chunk(data, L.SMAP)
    assert [(p.code, p.offset) for p in validate_bytes(data).problems] == [("SWPM_SMAP_INVALID", so + 8)]
    data = fan_smap([(0, 8)] * 13 + [(-1, 8)], range_count=16)  # the band names 16, the 17th is outside
    assert [(p.code, p.offset) for p in validate_bytes(data).problems] == [("SWPM_SMAP_INVALID", so + 32)]
    data = fan_smap([(0, 8)] * 13 + [(-1, 0)])  # 17 ranges, all in the file
    assert [(p.code, p.offset) for p in validate_bytes(data).problems] == [("SWPM_SMAP_INVALID", so + 8)]


def test_smap_ranges_lie_in_the_file_as_read() -> None:
    """Spec 4, 5: the file is read as its first file_size bytes, so a range that ends in bytes after file_size
    lies outside the file (SWPM_SMAP_INVALID at the range table; vector smap-range-in-trailing-bytes)."""
    from swpm_usd.format.vectors import chunk, fan_smap

    assert validate_bytes(fan_smap([(-1, 0)]) + bytes(8)).errors == []
    data = fan_smap([(-1, 8)]) + bytes(8)
    _, so, _ = chunk(data, L.SMAP)
    found = [(p.code, p.offset) for p in validate_bytes(data).problems]
    assert found == [("SWPM_FILE_TRAILING_BYTES", len(data) - 8), ("SWPM_SMAP_INVALID", so + 32)]


def _smap_table(data: bytes) -> tuple[list[tuple[int, ...]], list[tuple[int, int]]]:
    from swpm_usd.format.vectors import chunk

    _, so, _ = chunk(data, L.SMAP)
    B, N = (int(x) for x in np.frombuffer(data[so : so + 8], "<u4"))
    bands = np.frombuffer(data[so + 8 : so + 8 + 24 * B], L.SMAP_BAND)
    ranges = np.frombuffer(data[so + 8 + 24 * B : so + 8 + 24 * B + 16 * N], L.SMAP_RANGE)
    return [tuple(int(x) for x in b) for b in bands], [(int(o), int(n)) for o, n in ranges]


def test_an_empty_window_adds_nothing_to_the_index_hull() -> None:
    """Spec 4: the (b) hull of a band holds the INDX elements its LODs draw; an empty window adds nothing,
    wherever its first_index points, and a band of empty windows has no (b) hull, so no range is needed and
    prefix_length is the largest end of the other two (vector smap-empty-index-hull: VERT laid out before
    INDX, so (a) ends at INDX's offset). The writer writes these hulls and the reader accepts only them."""
    from swpm_usd.format.vectors import chunk, patch, quad_sliding_empty_windows, restream

    data = restream(quad_sliding_empty_windows(), [0, 1, 2, 3, 5, 4])
    _, io, il = chunk(data, L.INDX)
    _, vo, _ = chunk(data, L.VERT)
    assert vo < io and io + il == len(data)
    bands, ranges = _smap_table(data)
    assert [b[4] for b in bands] == [len(data), io]  # band 1 (LOD 2, an empty window at 9) ends at INDX
    assert ranges[1] == (io + 2 * 3, 2 * 6)  # band 0: pool [3, 9) of LOD 0; LOD 1's empty window at 0 not
    eo, _, _ = chunk(data, L.VERT)
    assert [(p.code, p.offset) for p in validate_bytes(data).problems] == [("SWPM_STREAM_ORDER", eo)]
    _, so, _ = chunk(data, L.SMAP)
    band1 = so + 8 + 24
    wrong = patch(data, band1 + 16, "<Q", io + 2 * 9)  # the empty window's position counted as an end
    assert [p.code for p in validate_bytes(wrong).problems] == ["SWPM_STREAM_ORDER", "SWPM_SMAP_INVALID"]
    assert validate_bytes(wrong).problems[1].offset == band1 + 16
