"""``swpm_usd.load`` of a USD stage: the stage's encoded prim read by ``swpm_usd.usd.read_file``, with typed
errors naming the file (a stage used to be read as a bad SWPM magic)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pxr import Usd, UsdGeom

import swpm_usd
from swpm_usd.usd.reader import UsdReadError

SUZANNE = Path(__file__).resolve().parents[2] / "shared" / "meshes" / "suzanne.obj"


@pytest.fixture(scope="module")
def built() -> swpm_usd.ProgressiveMesh:
    return swpm_usd.build(SUZANNE, encoding="vanilla")


def _same(a: swpm_usd.ProgressiveMesh, b: swpm_usd.ProgressiveMesh) -> None:
    assert a.encoding == b.encoding
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.triangle_counts, b.triangle_counts)
    ba, bb = a.buffers(), b.buffers()
    assert sorted(ba) == sorted(bb)
    for k in ba:
        np.testing.assert_array_equal(ba[k], bb[k], err_msg=k)


@pytest.mark.parametrize("suffix", [".usda", ".usdc", ".USD"])
def test_load_reads_the_stages_encoded_prim(tmp_path, built, suffix) -> None:
    path = swpm_usd.usd.write(built, tmp_path / f"suzanne{suffix}")
    _same(swpm_usd.load(path), built)
    _same(swpm_usd.load(str(path)), built)


def test_load_picks_a_prim_among_several(tmp_path, built) -> None:
    other = swpm_usd.build(SUZANNE, encoding="skip-strip")
    a = swpm_usd.usd.write(built, tmp_path / "a.usda", name="A")
    b = swpm_usd.usd.write(other, tmp_path / "b.usda", name="B")
    stage = Usd.Stage.CreateNew(str(tmp_path / "scene.usda"))
    for name, ref in (("A", a), ("B", b)):
        stage.DefinePrim(f"/World/{name}").GetReferences().AddReference(str(ref))
    stage.GetRootLayer().Save()
    with pytest.raises(UsdReadError, match=r"scene\.usda: 2 prims have SwpmMeshAPI applied .*/World/A/mesh"):
        swpm_usd.load(tmp_path / "scene.usda")
    _same(swpm_usd.usd.read_file(tmp_path / "scene.usda", prim="/World/B"), other)
    _same(swpm_usd.usd.read_file(tmp_path / "scene.usda", prim="/World/A/mesh"), built)
    with pytest.raises(UsdReadError, match=r"scene\.usda: no prim at '/World/C'"):
        swpm_usd.usd.read_file(tmp_path / "scene.usda", prim="/World/C")
    with pytest.raises(UsdReadError, match="no prim at 'not a path'"):
        swpm_usd.usd.read_file(tmp_path / "scene.usda", prim="not a path")


def test_load_of_a_stage_without_encoded_prims(tmp_path) -> None:
    stage = Usd.Stage.CreateNew(str(tmp_path / "plain.usda"))
    UsdGeom.Mesh.Define(stage, "/Plain")
    stage.GetRootLayer().Save()
    with pytest.raises(UsdReadError, match=r"plain\.usda: no prim has SwpmMeshAPI applied"):
        swpm_usd.load(tmp_path / "plain.usda")


def test_load_of_a_missing_or_corrupt_stage_names_the_file(tmp_path) -> None:
    with pytest.raises(UsdReadError, match=r"gone\.usdc") as missing:
        swpm_usd.load(tmp_path / "gone.usdc")
    assert missing.value.code == "INPUT_NOT_FOUND"
    (tmp_path / "dir.usda").mkdir()
    with pytest.raises(UsdReadError, match=r"dir\.usda: not a regular file"):
        swpm_usd.load(tmp_path / "dir.usda")
    (tmp_path / "bad.usda").write_text("#usda 1.0\n( this is not usd\n")
    with pytest.raises(UsdReadError, match=r"bad\.usda: usd-core cannot open it as a USD layer") as bad:
        swpm_usd.load(tmp_path / "bad.usda")
    assert bad.value.code == "INPUT_MALFORMED"


def test_load_of_an_edited_stage_fails_the_readers_checks(tmp_path, built) -> None:
    path = swpm_usd.usd.write(built, tmp_path / "edited.usda")
    stage = Usd.Stage.Open(str(path))
    (prim,) = swpm_usd.usd.find_encoded(stage)
    attr = prim.GetAttribute("swpm:vertexCounts")
    counts = np.asarray(attr.Get()).copy()
    counts[0] += 1
    attr.Set(counts.tolist())
    stage.GetRootLayer().Save()
    with pytest.raises(UsdReadError, match=r"edited\.usda"):
        swpm_usd.load(path)


def test_load_of_an_swpm_file_under_a_usd_name_says_so(tmp_path, built) -> None:
    swpm_usd.save(built, tmp_path / "fake.swpm")
    (tmp_path / "fake.swpm").rename(tmp_path / "fake.usda")
    with pytest.raises(UsdReadError, match=r"fake\.usda: .*SWPM file: give it a \.swpm name to read it"):
        swpm_usd.load(tmp_path / "fake.usda")
