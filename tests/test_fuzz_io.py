"""Fuzzing the mesh loaders: mutated valid files load as a valid mesh or fail with a MeshLoadError naming the
file, never another exception.

Every format :func:`load_mesh` reads gets a small valid file (200 triangles of spot); the mutations are
truncations, byte replacements, inserted and repeated chunks and, in text formats, numbers replaced by
extreme ones (huge counts and indices, NaN, infinities).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pxr import Usd, UsdGeom, Vt

from swpm_usd.errors import MeshLoadError
from swpm_usd.io import load_mesh
from swpm_usd.mesh import Mesh

SAMPLES = Path(__file__).resolve().parents[1] / "samples"
SETTINGS = settings(
    max_examples=400, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck), database=None
)
#: the valid files mutated, one per format and encoding (trimesh writes the first seven, usd-core the rest)
SEEDS = ["seed.obj", "seed.ply", "seed_ascii.ply", "seed.stl", "seed_ascii.stl", "seed.off", "seed.glb"]
SEEDS += ["seed.usda", "seed.usdc"]
EXTREME = [b"1e400", b"nan", b"-inf", b"999999999999", b"-5", b"0", b"4294967295", b"2147483648", b"1e-320"]


@pytest.fixture(scope="module")
def seeds(tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    d = tmp_path_factory.mktemp("seeds")
    spot = load_mesh(SAMPLES / "spot.obj")
    sub = trimesh.Trimesh(spot.points, spot.triangles, process=False).submesh([np.arange(200)], append=True)
    for name in ("seed.obj", "seed.ply", "seed.stl", "seed.off", "seed.glb"):
        sub.export(d / name)
    sub.export(d / "seed_ascii.ply", encoding="ascii")
    sub.export(d / "seed_ascii.stl", file_type="stl_ascii")
    for name in ("seed.usda", "seed.usdc"):
        stage = Usd.Stage.CreateNew(str(d / name))
        mesh = UsdGeom.Mesh.Define(stage, "/m")
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(sub.vertices, np.float32)))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(sub.faces), 3, np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.asarray(sub.faces, np.int32).reshape(-1)))
        stage.GetRootLayer().Save()
    return {name: (d / name).read_bytes() for name in SEEDS}


@st.composite
def mutations(draw: st.DrawFn) -> tuple[str, int, int, int, int]:
    return (
        draw(st.sampled_from(SEEDS)),
        draw(st.integers(0, 4)),  # kind
        draw(st.integers(0, 2**31)),  # position
        draw(st.integers(1, 2000)),  # length / count
        draw(st.integers(0, 255)),  # byte / choice
    )


def _mutate(data: bytes, kind: int, pos: int, length: int, value: int) -> bytes:
    i = pos % len(data)
    if kind == 0:  # truncate
        return data[:i]
    if kind == 1:  # replace a run of bytes
        return data[:i] + bytes([value]) * min(length % 17 + 1, len(data) - i) + data[i + length % 17 + 1 :]
    if kind == 2:  # repeat a chunk
        j = min(len(data), i + length)
        return data[:j] + data[i:j] * (value % 8 + 1) + data[j:]
    if kind == 3:  # insert bytes
        return data[:i] + bytes((value + k * 37) % 256 for k in range(length % 64 + 1)) + data[i:]
    # replace a number by an extreme one (text formats; binary ones get the bytes of its text)
    numbers = list(re.finditer(rb"-?\d+(\.\d+)?", data))
    if not numbers:
        return data
    m = numbers[pos % len(numbers)]
    return data[: m.start()] + EXTREME[value % len(EXTREME)] + data[m.end() :]


@SETTINGS
@given(case=mutations())
def test_mutated_files_load_or_fail_with_the_file_named(
    seeds: dict[str, bytes], tmp_path_factory: pytest.TempPathFactory, case: tuple[str, int, int, int, int]
) -> None:
    name, kind, pos, length, value = case
    path = tmp_path_factory.mktemp("case") / ("case." + name.rsplit(".", 1)[1])
    path.write_bytes(_mutate(seeds[name], kind, pos, length, value))
    try:
        mesh = load_mesh(path)
    except MeshLoadError as e:
        assert e.path == str(path) and str(path) in str(e)
        return
    assert isinstance(mesh, Mesh) and mesh.triangle_count > 0
    assert np.isfinite(mesh.points).all()
    assert int(mesh.triangles.max()) < mesh.vertex_count and int(mesh.triangles.min()) >= 0


def test_the_seeds_load(seeds: dict[str, bytes], tmp_path: Path) -> None:
    """The unmutated files are valid: a failure above is the mutation's."""
    for name, data in seeds.items():
        path = tmp_path / name
        path.write_bytes(data)
        assert load_mesh(path).triangle_count == 200, name
