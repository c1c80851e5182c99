"""No vertex id 0xFFFF in u16 (spec/format.md 1): from 65,536 vertices on the file is u32 and every width an
engine is told or counted at (``layout.draw_index_width``: the memory figures, ``swpm:indexWidth``, the
pipeline's coarsest-LOD bytes, inspect's ``index_values_width``) is 4, even when every stored value fits u16:
u16's 0xFFFF is the restart index WebGL 2 always applies (and any strip draw with restart on), which would
drop vertex 65,535's triangles. A grid of 256 x 256 vertices through ``build`` (vanilla) and a fan around
vertex 65,535 whose buffers all fit u16 (the one case the rule alone decides)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import swpm_usd
from swpm_usd.format import layout as L
from swpm_usd.format.reader import load_bytes, validate_bytes
from swpm_usd.format.writer import choose_index_width, encode_bytes
from swpm_usd.mesh import Mesh

sys.path.insert(0, str(Path(__file__).resolve().parent))
import engine_model as em  # noqa: E402


def _fan_around(V: int) -> swpm_usd.ProgressiveMesh:
    """Vanilla: four triangles around vertex V - 1 among ``V`` points (the rest unused), one record binning
    it onto vertex 0 (the fan vector of spec/vectors with vertex 4 renamed V - 1): every stored value is at
    most V - 1, so the buffers alone fit u16 up to V = 65,536."""
    c = V - 1
    points = np.zeros((V, 3), np.float32)
    points[:4] = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    points[c] = [0.5, 0.5, 0.25]
    bufs = {
        "indices": np.array([1, 2, c, 2, 3, c, 0, 1, c, 3, 0, c], np.uint32),
        "collapse_kept": np.array([0], np.uint32),
        "collapse_tris_removed": np.array([2], np.uint32),
        "collapse_change_count": np.array([2], np.uint32),
        "collapse_prev_change_count": np.array([0], np.uint32),
        "collapse_change_offsets": np.array([2, 5], np.uint32),
        "lod_record_counts": np.array([0, 1], np.uint32),
    }
    return swpm_usd.from_buffers(
        "vanilla", points, {}, np.array([V, V - 1]), np.array([4, 2]), np.array([0.0, 0.5], np.float32), bufs
    )


def _header_width(data: bytes) -> int:
    features = int(np.frombuffer(data[: L.HEADER_SIZE], L.HEADER)[0]["features"])
    return 4 if features & L.FEATURE_INDEX32 else 2


@pytest.mark.parametrize(("V", "width"), [(0xFFFF, 2), (0x10000, 4)])
def test_vertex_65535_makes_the_file_u32(V: int, width: int) -> None:
    """65,535 vertices (ids up to 0xFFFE) stay u16; at 65,536 vertex 0xFFFF makes the file u32, though every
    value the buffers store fits u16 (a writer before this rule wrote u16)."""
    pm = _fan_around(V)
    assert choose_index_width(pm.buffers()) == 2  # the values alone
    assert choose_index_width(pm.buffers(), pm.vertex_count) == width
    assert L.draw_index_width(V) == width and L.vertex_ids_fit_u16(V) == (width == 2)
    data = encode_bytes(pm)
    assert _header_width(data) == width
    rep = validate_bytes(data)
    assert rep.valid and not rep.problems, rep.format()
    assert rep.summary["index_width"] == rep.summary["index_values_width"] == width
    back = load_bytes(data)
    assert np.asarray(back.indices).dtype.itemsize == width
    for k in range(pm.lod_count):
        assert np.array_equal(back.triangles_at(k), pm.triangles_at(k)), k
    # an engine uploads the file's indices as they are: u32 holds vertex 0xFFFF, and no all-ones value
    f, eng = em.load(data)
    assert f.W == width and eng.pool.dtype.itemsize == width and eng.notes == []
    assert (eng.pool == np.iinfo(eng.pool.dtype).max).sum() == 0
    # the memory figures count the same width: the index buffer (shared and private) and records (8 + 2 x 2)
    n = pm.indices.shape[0]
    assert pm.instance_bytes == width * n + 12
    assert pm.global_bytes == pm.vertex_bytes() + width * n + 8 * 1 + 2 * 2 + 8 * pm.lod_count


def test_an_engine_model_notes_vertex_0xffff_in_u16() -> None:
    """The check above can fail: a u16 list holding 0xFFFF (what the old rule wrote at 65,536 vertices) is
    what WebGL 2 restarts at, and the engine model says so."""
    notes: list[str] = []
    em.upload_indices(None, np.array([1, 2, 0xFFFF], np.uint16), None, notes)  # type: ignore[arg-type]
    assert notes and "all-ones" in notes[0]


@pytest.fixture(scope="module")
def grid() -> swpm_usd.ProgressiveMesh:
    """A 256 x 256 grid: exactly 65,536 vertices, built vanilla."""
    n = 256
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    pts = np.stack([i.ravel(), j.ravel(), np.zeros(n * n)], axis=1).astype(np.float32)
    a = (i[:-1, :-1] * n + j[:-1, :-1]).ravel()
    tris = np.concatenate([np.stack([a, a + n, a + n + 1], 1), np.stack([a, a + n + 1, a + 1], 1)])
    return swpm_usd.build(Mesh(pts, tris), encoding="vanilla")


def test_a_grid_of_65536_vertices_counts_4_bytes_an_index(grid, tmp_path) -> None:
    """A built mesh of 65,536 vertices: a u32 file, memory figures at 4 bytes an index (they counted 2 from
    the largest vertex id, 65,535), the USD width 4 (it was 2), the pipeline's coarsest-LOD bytes at 4."""
    from pxr import Usd

    from swpm_usd import usd
    from swpm_usd.pipeline.worker import check_streaming
    from swpm_usd.usd.validate import validate_stage

    pm = grid
    assert pm.vertex_count == 0x10000 and int(pm.indices.max()) == 0xFFFF
    data = encode_bytes(pm)
    assert _header_width(data) == 4
    rep = validate_bytes(data)
    assert rep.valid, rep.format()
    assert rep.summary["index_values_width"] == 4
    n = pm.indices.shape[0]
    assert pm.instance_bytes == 4 * n + 12
    records = 8 * pm.record_count + 4 * int(pm.collapse_change_offsets.shape[0])
    assert pm.global_bytes == pm.vertex_bytes() + 4 * n + records + 8 * pm.lod_count
    path = usd.write(pm, tmp_path / "grid.usdc")
    assert validate_stage(path, builtin=False) == []
    stage = Usd.Stage.Open(str(path))
    prim = usd.find_encoded(stage)[0]
    assert prim.GetAttribute("swpm:indexWidth").Get() == 4
    prim.GetAttribute("swpm:indexWidth").Set(2)  # the old derivation: now a finding
    assert [f.code for f in validate_stage(stage, builtin=False)] == ["SWPM_USD_INDEX_WIDTH"]
    last = pm.lod_count - 1
    stride = pm.vertex_bytes() // pm.vertex_count
    need = pm.vertex_count_at(last) * stride + 3 * pm.triangle_count_at(last) * 4
    assert check_streaming(pm, {"coarsest_lod_bytes": need}) == []
    assert "coarsest LOD needs" in check_streaming(pm, {"coarsest_lod_bytes": need - 1})[0]
