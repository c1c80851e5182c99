"""Small warts a new user met (helper-245): the generators' commands warned, a sliding window's direct
build took any cache size, and a few command-line messages and exit codes."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    ("module", "args", "checked_in"),
    [
        ("swpm_usd.format.errors", [], "spec/errors.md"),
        ("swpm_usd.format.errors", ["--c"], "runtime/c/swpm_codes.h"),
        ("swpm_usd.pipeline.schema", [], "pipeline/pipeline.schema.json"),
    ],
)
def test_the_generators_commands_run_without_runpys_warning(module, args, checked_in):
    """Their packages imported them before runpy ran them: ``RuntimeWarning: 'swpm_usd.format.errors' found
    in sys.modules after import of package 'swpm_usd.format'``, on every regeneration."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONDONTWRITEBYTECODE": "1"}
    proc = subprocess.run(
        [sys.executable, "-W", "error::RuntimeWarning", "-m", module, *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr[-2000:]
    assert proc.stdout == (ROOT / checked_in).read_text(), f"regenerate: python -m {module} {' '.join(args)}"


def _ply(triangles: int) -> bytes:
    """An ASCII PLY of ``triangles`` triangles in a row (a strip's worth of vertices)."""
    verts = [f"{i} {i % 2} 0" for i in range(triangles + 2)]
    faces = [f"3 {i} {i + 1} {i + 2}" if i % 2 == 0 else f"3 {i + 1} {i} {i + 2}" for i in range(triangles)]
    header = (
        f"ply\nformat ascii 1.0\nelement vertex {len(verts)}\nproperty float x\nproperty float y\n"
        f"property float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    return (header + "\n".join(verts + faces) + "\n").encode()


@pytest.mark.parametrize("binary", [False, True])
def test_a_ply_is_read_once_and_the_bytes_checked_are_the_bytes_parsed(tmp_path, monkeypatch, binary):
    """The loader read a PLY for its checks, then trimesh read the file again: two reads of a large scan,
    and a file replaced between them was parsed unchecked. Here it is replaced right after the first read."""
    import pathlib

    import trimesh

    from swpm_usd.io import load_mesh

    path = tmp_path / "scan.ply"
    first, second = _ply(4), _ply(9)
    if binary:
        first, second = (
            trimesh.exchange.ply.export_ply(trimesh.load(trimesh.util.wrap_as_stream(d), file_type="ply"))
            for d in (first, second)
        )
    path.write_bytes(first)
    reads = []
    read_bytes = pathlib.Path.read_bytes

    def read_then_replaced(self: pathlib.Path) -> bytes:
        data = read_bytes(self)
        if self == path:
            reads.append(len(data))
            path.write_bytes(second)
        return data

    monkeypatch.setattr(pathlib.Path, "read_bytes", read_then_replaced)
    mesh = load_mesh(path)
    assert reads == [len(first)]
    assert mesh.triangle_count == 4, "trimesh parsed the file read again, not the bytes the loader checked"


@pytest.mark.parametrize("cache_size", [0, 1025, 10**9])
def test_a_direct_sliding_window_build_bounds_its_cache_size_as_build_does(cache_size):
    """``build()`` refused ``cache_size=10**9`` (its FIFO simulations allocate that many entries); the
    encoder called directly took it."""
    import swpm_usd
    from swpm_usd.encode.slidingwindow import build_sliding_window
    from swpm_usd.errors import BuildError

    mesh = swpm_usd.Mesh.from_arrays([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(BuildError) as via_build:
        swpm_usd.build(mesh, encoding="sliding-window", cache_size=cache_size)
    with pytest.raises(BuildError) as direct:
        build_sliding_window(mesh, cache_size=cache_size)
    assert str(direct.value) == str(via_build.value)
    assert ("at least 1" if cache_size < 1 else "at most 1024") in str(direct.value)


@pytest.fixture(scope="module")
def swpm_bytes() -> bytes:
    from conftest import shared_mesh

    import swpm_usd
    from swpm_usd.format import encode_bytes

    return encode_bytes(swpm_usd.build(shared_mesh("suzanne.obj"), encoding="vanilla"))


@pytest.mark.parametrize("kept", [0, 5000])
def test_validate_lod_of_a_cut_or_empty_file_lists_its_problems_not_a_usage_error(tmp_path, swpm_bytes, kept):
    """``validate cut.swpm --lod 0`` said "Invalid value for --lod: no such LOD: cut.swpm: LOD 0 did not
    become drawable" and exited 2, as if the command line were wrong: the file is (exit 1, its problems)."""
    from click.testing import CliRunner

    from swpm_usd.cli import main

    cut = tmp_path / "cut.swpm"
    cut.write_bytes(swpm_bytes[:kept])
    for args in (["validate", str(cut), "--lod", "0"], ["validate", str(cut), "--lod", "3", "--json"]):
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 1, result.output
        assert "no such LOD" not in result.output
        code = "SWPM_HEADER_TRUNCATED" if kept == 0 else "SWPM_CHUNK_OUT_OF_BOUNDS"
        assert code in result.output and str(cut) in result.output, result.output
    # a LOD a valid file does not have stays the usage error it is
    whole = tmp_path / "whole.swpm"
    whole.write_bytes(swpm_bytes)
    result = CliRunner().invoke(main, ["validate", str(whole), "--lod", "99999"])
    assert result.exit_code == 2 and "no such LOD: LOD 99999 of" in result.output, result.output


@pytest.mark.parametrize("option", [["--prefix", "100"], ["--ranges", "0:100"], ["--lod", "0"]])
def test_validate_of_a_mesh_with_a_reader_option_says_what_to_run(tmp_path, option):
    """``validate mesh.obj`` said which command reads a mesh; with --prefix, --ranges or --lod it listed
    "SWPM_HEADER_BAD_MAGIC @0: magic is 232323230a230a23" alone."""
    from click.testing import CliRunner

    from swpm_usd.cli import main

    mesh = tmp_path / "mesh.obj"
    mesh.write_text("# a mesh, not an SWPM file\n" * 8 + "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    result = CliRunner().invoke(main, ["validate", str(mesh), *option])
    assert result.exit_code == 1, result.output
    assert f"hint: {mesh} is a mesh file (.obj), not an SWPM file: swpm-pipeline encode" in result.output
