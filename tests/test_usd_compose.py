"""USD composition as a pipeline TD uses it: LOD layers, override layers over animated meshes, crowds of
instances, pipeline outputs of USD inputs, and errors located in the layer that broke the buffers."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pxr import Sdf, Usd, UsdGeom, Vt

import swpm_usd
from swpm_usd import usd
from swpm_usd.usd.reader import UsdReadError

MESHES = Path(__file__).resolve().parents[2] / "shared" / "meshes"
if not MESHES.exists():
    MESHES = Path("/work/shared/meshes")


@pytest.fixture(scope="module")
def spot_pm():
    return swpm_usd.build(swpm_usd.load_mesh(MESHES / "spot.obj"), "vanilla")


def _fresh(code: str) -> str:
    """Run ``code`` in a fresh interpreter (no layer of this process's registry in memory); its stdout."""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout


# -- UsdLod layer ------------------------------------------------------------------------------------------
def test_usdlod_items_each_draw_their_own_lod(spot_pm, tmp_path):
    """Each LOD item draws its discrete LOD, in a fresh process and when the LOD layer is referenced many
    times (opinions under an instanceable prim are ignored: the selection must reach the prototype)."""
    asset = usd.write(spot_pm, tmp_path / "spot.usda", lods=4)
    layer = usd.write_usdlod(asset, tmp_path / "spot_lod.usda")
    expected = [3 * spot_pm.triangle_count_at(int(k)) for k in usd.select_lods(spot_pm, 4)]
    code = f"""
from pxr import Usd, UsdGeom
from swpm_usd import usd
from swpm_usd.usd.reader import UsdReadError
def counts(stage, root):
    meshes = [UsdGeom.Mesh(stage.GetPrimAtPath(f"{{root}}/lod/LOD{{i}}/mesh")) for i in range(4)]
    return [len(m.GetFaceVertexIndicesAttr().Get()) for m in meshes]
stage = Usd.Stage.Open({str(layer)!r})
print(counts(stage, "/SpotLOD"))
scene = Usd.Stage.CreateInMemory()
for j in range(3):
    scene.DefinePrim(f"/W/a{{j}}").GetReferences().AddReference({str(layer)!r})
print(counts(scene, "/W/a0"), counts(scene, "/W/a2"), len(scene.GetPrototypes()))
print(sorted(str(p.GetPath()) for p in usd.find_encoded(stage)))
"""
    lines = _fresh(code).splitlines()
    assert lines[0] == str(expected)
    assert lines[1] == f"{expected} {expected} 4"  # three references share the four LOD prototypes
    assert lines[2] == str([f"/SpotLOD/lod/LOD{i}/mesh" for i in range(4)])
    assert usd.validate_stage(layer) == []


# -- override layers over animated meshes ------------------------------------------------------------------
def _deforming_stage(path: Path, *, default: bool, topology_changes: bool = False) -> None:
    """A 12 x 12 quad grid whose points are time-sampled (1, 5, 10: scaled by 1, 1.5, 2), a vertex primvar
    ``height`` sampled with them (each point's y), velocities (half each point), its extent sampled too, a
    point GeomSubset ``pins`` (the points at x = 0); ``default``: a default value of the points besides
    (what a renderer never sees once there are samples)."""
    n = 12
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, "Z")
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    xs, ys = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
    pts = np.stack([xs.ravel(), ys.ravel(), np.sin(xs.ravel() * 0.7) * np.cos(ys.ravel() * 0.5)], 1)
    pts = pts.astype(np.float32)
    a = (np.arange(n)[None, :] + (n + 1) * np.arange(n)[:, None]).ravel()
    faces = np.stack([a, a + 1, a + n + 2, a + n + 1], 1).astype(np.int32)
    mesh = UsdGeom.Mesh.Define(stage, "/World/sheet")
    mesh.GetFaceVertexCountsAttr().Set(Vt.IntArray.FromNumpy(np.full(len(faces), 4, np.int32)))
    mesh.GetFaceVertexIndicesAttr().Set(Vt.IntArray.FromNumpy(faces.ravel()))
    height = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("height", Sdf.ValueTypeNames.FloatArray, "vertex")
    if default:
        mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(pts * 7))
    for t, k in ((1.0, 1.0), (5.0, 1.5), (10.0, 2.0)):
        p = pts * np.float32(k)
        mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(p), t)
        height.Set(Vt.FloatArray.FromNumpy(np.ascontiguousarray(p[:, 1])), t)
        mesh.GetVelocitiesAttr().Set(Vt.Vec3fArray.FromNumpy(p * np.float32(0.5)), t)
        mesh.GetExtentAttr().Set(Vt.Vec3fArray.FromNumpy(np.stack([p.min(0), p.max(0)])), t)
    pins = np.flatnonzero(pts[:, 0] == 0).astype(np.int32)  # the left edge's points
    UsdGeom.Subset.CreateGeomSubset(mesh, "pins", UsdGeom.Tokens.point, Vt.IntArray.FromNumpy(pins))
    if topology_changes:
        mesh.GetFaceVertexIndicesAttr().Set(Vt.IntArray.FromNumpy(faces.ravel()), 1.0)
        mesh.GetFaceVertexIndicesAttr().Set(Vt.IntArray.FromNumpy(faces[:, ::-1].ravel()), 10.0)
    stage.Save()


@pytest.mark.parametrize("default", [False, True])
def test_overrides_of_a_deforming_mesh_keep_its_animation(default, tmp_path):
    src = tmp_path / "anim.usda"
    _deforming_stage(src, default=default)
    result = usd.write_overrides(src, tmp_path / "anim_swpm.usda", "vanilla")
    assert list(result) == ["/World/sheet"]
    stage = Usd.Stage.Open(str(tmp_path / "anim_swpm.usda"))
    prim = stage.GetPrimAtPath("/World/sheet")
    mesh = UsdGeom.Mesh(prim)
    pm = usd.read(prim)
    assert mesh.GetPointsAttr().GetTimeSamples() == [1.0, 5.0, 10.0]
    first = np.asarray(mesh.GetPointsAttr().Get(1.0))
    np.testing.assert_array_equal(first, pm.points)  # the encoding is of the first sample, what is drawn
    for t, k in ((1.0, 1.0), (5.0, 1.5), (10.0, 2.0)):
        pts = np.asarray(mesh.GetPointsAttr().Get(t))
        np.testing.assert_allclose(pts, first * k, rtol=1e-6)  # the same vertex order at every sample
        height = np.asarray(UsdGeom.PrimvarsAPI(prim).GetPrimvar("height").ComputeFlattened(t))
        np.testing.assert_array_equal(height, pts[:, 1])
        np.testing.assert_array_equal(np.asarray(mesh.GetVelocitiesAttr().Get(t)), pts * np.float32(0.5))
        np.testing.assert_array_equal(np.asarray(mesh.GetExtentAttr().Get(t)), [pts.min(0), pts.max(0)])
    pins = UsdGeom.Subset(stage.GetPrimAtPath("/World/sheet/pins")).GetIndicesAttr().Get()
    assert sorted(pins) == np.flatnonzero(first[:, 0] == 0).tolist() and len(pins) == 13
    fvi = np.asarray(mesh.GetFaceVertexIndicesAttr().Get(5.0))
    np.testing.assert_array_equal(fvi, pm.triangles_at(0).ravel())
    assert usd.validate_stage(stage) == []


@pytest.mark.parametrize("mode", ["sublayer", "reference"])
def test_overrides_of_a_deforming_mesh_keep_its_timing(mode, tmp_path):
    """The override layer is the stage's root layer: it takes the source's timeCodesPerSecond, frame rate and
    time range. Without them a source at 48 time codes a second had its samples 1, 5, 10 scaled into the
    new layer's 24 (re-authored at 0.5, 2.5, 5: frame 10 drew the source's last frame at 5) and no range."""
    src = tmp_path / "anim.usda"
    _deforming_stage(src, default=False)
    stage = Usd.Stage.Open(str(src))
    stage.SetTimeCodesPerSecond(48)
    stage.SetFramesPerSecond(48)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(10)
    stage.Save()
    usd.write_overrides(src, tmp_path / "anim_swpm.usda", "vanilla", mode=mode)
    out = Usd.Stage.Open(str(tmp_path / "anim_swpm.usda"))
    timing = (
        out.GetTimeCodesPerSecond(),
        out.GetFramesPerSecond(),
        out.GetStartTimeCode(),
        out.GetEndTimeCode(),
    )
    assert timing == (48.0, 48.0, 1.0, 10.0)
    mesh = UsdGeom.Mesh(out.GetPrimAtPath("/World/sheet"))
    assert mesh.GetPointsAttr().GetTimeSamples() == [1.0, 5.0, 10.0]
    assert UsdGeom.PrimvarsAPI(mesh).GetPrimvar("height").GetTimeSamples() == [1.0, 5.0, 10.0]
    source = UsdGeom.Mesh(stage.GetPrimAtPath("/World/sheet"))
    for t in (1.0, 5.0, 10.0):  # each frame the source's shape (its extent: the points, reordered)
        np.testing.assert_array_equal(mesh.GetExtentAttr().Get(t), source.GetExtentAttr().Get(t))


def test_overrides_of_a_mesh_whose_topology_changes_over_time_say_so(tmp_path):
    from swpm_usd.usd.overrides import UsdOverrideError

    src = tmp_path / "anim.usda"
    _deforming_stage(src, default=False, topology_changes=True)
    with pytest.raises(UsdOverrideError, match=r"anim\.usda: /World/sheet\.faceVertexIndices: the topology"):
        usd.write_overrides(src, tmp_path / "anim_swpm.usda", "vanilla")
    assert not (tmp_path / "anim_swpm.usda").exists()


# -- crowds of instances -----------------------------------------------------------------------------------
def _crowd(folder: Path, asset: Path, n: int) -> Path:
    stage = Usd.Stage.CreateNew(str(folder / f"crowd_{asset.stem}.usda"))
    UsdGeom.SetStageUpAxis(stage, "Y")
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    for i in range(n):
        x = UsdGeom.Xform.Define(stage, f"/World/c{i}")
        x.AddTranslateOp().Set((float(i), 0.0, 0.0))
        x.GetPrim().GetReferences().AddReference(f"./{asset.name}")
        x.GetPrim().SetInstanceable(True)
    stage.Save()
    return folder / f"crowd_{asset.stem}.usda"


def test_validate_checks_a_crowd_once_per_prototype(spot_pm, tmp_path, monkeypatch):
    """Each instance proxy of a prototype has its values: the buffers are read once, not once a proxy, nor
    once a worker thread (usd-core runs the validator on one per core: those starting together each read
    them, as many reads as cores; a slow read, as a big asset's, makes sure they start together)."""
    import time

    from swpm_usd.usd import reader

    crowd = _crowd(tmp_path, usd.write(spot_pm, tmp_path / "spot.usdc"), 40)
    reads = []
    real_read = reader.read

    def slow_read(prim, *args, **kwargs):
        reads.append(prim.GetPath())
        time.sleep(0.5)
        return real_read(prim)

    monkeypatch.setattr(reader, "read", slow_read)
    assert usd.validate_stage(crowd) == []
    assert len(reads) == 1
    assert len(usd.find_encoded(Usd.Stage.Open(str(crowd)))) == 40


def test_validate_names_every_instance_of_a_broken_asset(spot_pm, tmp_path):
    """Checked once per prototype, a problem is still reported at each instance proxy, under its own path."""
    asset = usd.write(spot_pm, tmp_path / "spot.usda")
    layer = Sdf.Layer.FindOrOpen(str(asset))
    pool = layer.GetAttributeAtPath("/Spot/mesh.swpm:indices")
    pool.default = Vt.UIntArray.FromNumpy(np.asarray(pool.default)[:-3].copy())
    layer.Save()
    crowd = _crowd(tmp_path, asset, 3)
    findings = [f for f in usd.validate_stage(crowd) if f.code.startswith("SWPM_")]
    assert [f.prim for f in findings] == [f"/World/c{i}/mesh" for i in range(3)]
    assert {f.code for f in findings} == {"SWPM_USD_REBUILD"}
    for i, f in enumerate(findings):  # (the message names the stage and the prim, each its own)
        assert f"crowd_spot.usda: /World/c{i}/mesh: " in f.message and "SWPM_RECORD_BAD_COUNTS" in f.message
    assert usd.validate_stage(crowd, builtin=False) == usd.validate_stage(crowd)


# -- pipeline outputs of USD inputs ------------------------------------------------------------------------
def test_pipeline_layers_keep_the_up_axis_and_units_of_a_usd_input(tmp_path):
    """The loader keeps a stage's coordinates, so the asset layer says what they are: Z-up centimetres stay
    Z-up centimetres; a stage that authors neither has USD's fallbacks (Y, centimetres); an OBJ the
    defaults."""
    from swpm_usd.pipeline import run

    (tmp_path / "in").mkdir()
    _deforming_stage(tmp_path / "in" / "sheet.usda", default=True)  # Z-up, metersPerUnit 0.01
    bare = Usd.Stage.CreateNew(str(tmp_path / "in" / "bare.usda"))
    UsdGeom.Mesh.Define(bare, "/m").GetPrim().GetReferences().AddReference("./sheet.usda", "/World/sheet")
    bare.Save()
    (tmp_path / "in" / "spot.obj").write_bytes((MESHES / "spot.obj").read_bytes())
    cfg = tmp_path / "p.yaml"
    cfg.write_text(
        'version: 1\nassets:\n  - glob: "in/*"\noutput:\n  dir: out\n  usd: true\n  swpm: false\n'
        "defaults:\n  encoding: vanilla\n"
    )
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 0 and res.built == 3
    got = {}
    for stem in ("sheet", "bare", "spot"):
        stage = Usd.Stage.Open(str(tmp_path / "out" / f"{stem}.usdc"))
        got[stem] = (str(UsdGeom.GetStageUpAxis(stage)), UsdGeom.GetStageMetersPerUnit(stage))
    assert got == {"sheet": ("Z", 0.01), "bare": (str(UsdGeom.GetFallbackUpAxis()), 0.01), "spot": ("Y", 1.0)}


def _world_range(stage: Usd.Stage, path: str) -> np.ndarray:
    """The world-space bounds (2, 3) of the prim at ``path``."""
    cache = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_])
    box = cache.ComputeWorldBound(stage.GetPrimAtPath(path)).ComputeAlignedRange()
    return np.array([box.GetMin(), box.GetMax()], np.float64)


def _cow_and_zcow(tmp_path: Path) -> tuple[Path, np.ndarray]:
    """A pipeline config (its path) building the cow twice into ``out``, with a scene: as the OBJ (Y-up
    metres) and as a Z-up centimetre stage ``in/zcow.usda``; and the cow's points (Y-up metres)."""
    (tmp_path / "in").mkdir()
    cow = swpm_usd.load_mesh(MESHES / "cow.obj")
    (tmp_path / "in" / "cow.obj").write_bytes((MESHES / "cow.obj").read_bytes())
    src = Usd.Stage.CreateNew(str(tmp_path / "in" / "zcow.usda"))
    UsdGeom.SetStageUpAxis(src, "Z")
    UsdGeom.SetStageMetersPerUnit(src, 0.01)
    UsdGeom.Xform.Define(src, "/World")
    src.SetDefaultPrim(src.GetPrimAtPath("/World"))
    mesh = UsdGeom.Mesh.Define(src, "/World/cow")
    p = np.asarray(cow.points, np.float64)
    zup_cm = (np.stack([p[:, 0], -p[:, 2], p[:, 1]], 1) * 100).astype(np.float32)  # Y-up m -> Z-up cm
    mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(zup_cm))
    tris = np.asarray(cow.triangles, np.int32)
    mesh.GetFaceVertexCountsAttr().Set(Vt.IntArray.FromNumpy(np.full(len(tris), 3, np.int32)))
    mesh.GetFaceVertexIndicesAttr().Set(Vt.IntArray.FromNumpy(tris.ravel()))
    src.Save()
    cfg = tmp_path / "p.yaml"
    cfg.write_text(
        'version: 1\nassets:\n  - glob: "in/*"\noutput:\n  dir: out\n  usd: true\n  swpm: false\n'
        "  scene: true\ndefaults:\n  encoding: vanilla\n"
    )
    return cfg, p


def test_scene_corrects_each_asset_to_its_units_and_up_axis(tmp_path):
    """USD converts neither up axis nor units across a reference: a Z-up centimetre asset in the Y-up metre
    scene stood 100 times too large, on its side. The same cow as an OBJ (Y-up metres) and as a Z-up
    centimetre stage must have the same world bounds in scene.usda, also once the scene is rewritten from
    the manifest on a rerun that builds nothing."""
    from swpm_usd.pipeline import run

    cfg, p = _cow_and_zcow(tmp_path)
    res = run(cfg, echo=lambda m: None)
    assert res.failed == 0 and res.built == 2
    out = tmp_path / "out"
    for rerun in (False, True):
        if rerun:  # the scene rewritten from the records alone (the layers' units are in the manifest)
            (out / "scene.usda").unlink()
            assert run(cfg, echo=lambda m: None).built == 0
        stage = Usd.Stage.Open(str(out / "scene.usda"))
        assert UsdGeom.GetStageUpAxis(stage) == "Y" and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
        plain, corrected = _world_range(stage, "/Scene/cow"), _world_range(stage, "/Scene/zcow")
        np.testing.assert_allclose(plain, [p.min(0), p.max(0)], atol=1e-6)
        np.testing.assert_allclose(corrected, plain, atol=1e-5)  # not 100 times larger, nor on its side
        zcow = stage.GetPrimAtPath("/Scene/zcow")
        assert zcow.GetCustomDataByKey("swpm:assetUpAxis") == "Z"
        assert zcow.GetCustomDataByKey("swpm:assetMetersPerUnit") == 0.01
        # the Y-up metre asset gets no transform, and the asset's own root authors none for ours to replace
        assert not UsdGeom.Xformable(stage.GetPrimAtPath("/Scene/cow")).GetOrderedXformOps()
        asset = Usd.Stage.Open(str(out / "zcow.usdc"))
        assert not UsdGeom.Xformable(asset.GetDefaultPrim()).GetOrderedXformOps()
    records = json.loads((out / "manifest.json").read_text())["assets"]
    units = {
        Path(k).stem: (r["outputs"]["usd"]["up_axis"], r["outputs"]["usd"]["meters_per_unit"])
        for k, r in records.items()
    }
    assert units == {"cow": ("Y", 1.0), "zcow": ("Z", 0.01)}


@pytest.mark.parametrize("rebuild", ["none", "failed"])
def test_scene_corrects_the_assets_of_records_written_before_their_units(rebuild, tmp_path, monkeypatch):
    """A manifest whose USD records hold no units (written by 0.7.2 before they were recorded: the same tool
    version, so its builds are up to date) beside the scene that version wrote, with no correction: a rerun
    kept that scene, the Z-up centimetre cow 100 times too large and on its side (a rewrite of it corrected
    nothing either), as did one whose rebuilds failed, keeping the previous builds. The units are read from
    each such layer's metadata, once, and recorded."""
    from swpm_usd.pipeline import run, runner, scene
    from swpm_usd.pipeline.worker import output_record

    cfg, p = _cow_and_zcow(tmp_path)
    assert run(cfg, echo=lambda m: None).built == 2
    out = tmp_path / "out"
    # the output folder as that version left it: records without units, the scene without corrections
    manifest = runner._read_manifest(out / "manifest.json")
    for rec in manifest["assets"].values():
        for key in ("up_axis", "meters_per_unit"):
            del rec["outputs"]["usd"][key]
    with monkeypatch.context() as m:
        m.setattr(scene, "_author_units_correction", lambda *args: None)
        runner._write_scene(out, manifest["assets"])
    manifest[runner.RUN_OUTPUTS]["scene"] = {**output_record(out / "scene.usda"), runner.CURRENT: True}
    runner._write_manifest(out / "manifest.json", manifest)
    stage = Usd.Stage.Open(str(out / "scene.usda"))
    assert not np.allclose(_world_range(stage, "/Scene/zcow"), _world_range(stage, "/Scene/cow"), atol=1e-3)
    del stage
    if rebuild == "failed":  # (stricter budgets: rebuilt, each fails them, its previous build kept)
        cfg.write_text(cfg.read_text() + "budgets: {global_bytes: 1}\n")
    for again in (False, True):  # (once recorded, the layers are not read again)
        if again:
            monkeypatch.setattr(scene, "recorded_layer_units", lambda path: pytest.fail(f"read {path}"))
        res = run(cfg, echo=lambda m: None)
        assert res.built == 0 and res.failed == (2 if rebuild == "failed" else 0)
        assert all(f["kept_previous"] for f in res.failures.values())
        stage = Usd.Stage.Open(str(out / "scene.usda"))
        plain, corrected = _world_range(stage, "/Scene/cow"), _world_range(stage, "/Scene/zcow")
        np.testing.assert_allclose(plain, [p.min(0), p.max(0)], atol=1e-6)
        np.testing.assert_allclose(corrected, plain, atol=1e-5)
        records = json.loads((out / "manifest.json").read_text())["assets"]
        units = {
            Path(k).stem: (r["outputs"]["usd"]["up_axis"], r["outputs"]["usd"]["meters_per_unit"])
            for k, r in records.items()
        }
        assert units == {"cow": ("Y", 1.0), "zcow": ("Z", 0.01)}


# -- located problems on composed stages -------------------------------------------------------------------
def _overridden_scene(folder: Path, asset: Path, edit) -> Path:
    """``shot.usda``: sublayers ``fix.usda`` (where ``edit(prim)`` authors its overrides) over ``set.usda``,
    which references ``asset`` at /World/spot (a prim of another name and path than the asset's)."""
    base = Usd.Stage.CreateNew(str(folder / "set.usda"))
    UsdGeom.SetStageUpAxis(base, "Y")
    UsdGeom.SetStageMetersPerUnit(base, 1.0)
    UsdGeom.Xform.Define(base, "/World")
    base.SetDefaultPrim(base.GetPrimAtPath("/World"))
    spot = UsdGeom.Xform.Define(base, "/World/spot")
    spot.AddTranslateOp().Set((5.0, 0.0, 0.0))
    spot.GetPrim().GetReferences().AddReference(f"./{asset.name}")
    base.Save()
    Sdf.Layer.CreateNew(str(folder / "fix.usda")).Save()
    shot = Sdf.Layer.CreateNew(str(folder / "shot.usda"))
    shot.subLayerPaths.append("./fix.usda")
    shot.subLayerPaths.append("./set.usda")
    shot.Save()
    stage = Usd.Stage.Open(str(folder / "shot.usda"))
    stage.SetEditTarget(Usd.EditTarget(Sdf.Layer.FindOrOpen(str(folder / "fix.usda"))))
    edit(stage.GetPrimAtPath("/World/spot/mesh"))
    stage.GetEditTarget().GetLayer().Save()
    return folder / "shot.usda"


def test_a_broken_override_is_named_with_its_layer(spot_pm, tmp_path):
    """An override of the buffers in a sublayer: read and validate name the stage, the composed prim, and
    the layer that holds the override (the one to fix), not only the asset it overrides."""
    asset = usd.write(spot_pm, tmp_path / "spot.usdc")

    def cut_indices(prim):
        a = prim.GetAttribute("swpm:indices")
        a.Set(Vt.UIntArray.FromNumpy(np.asarray(a.Get())[:-3].copy()))

    shot = _overridden_scene(tmp_path, asset, cut_indices)
    stage = Usd.Stage.Open(str(shot))
    fix = str(tmp_path / "fix.usda")
    with pytest.raises(UsdReadError) as e:
        usd.read(stage.GetPrimAtPath("/World/spot"))
    assert str(e.value).startswith(f"{shot}: /World/spot/mesh: ")
    assert str(e.value).endswith(f"; overridden over {asset}: swpm:indices in {fix}")
    [finding] = [f for f in usd.validate_stage(shot) if f.code.startswith("SWPM_")]
    assert finding.prim == "/World/spot/mesh" and f"swpm:indices in {fix}" in finding.message
    # the buffers themselves, untouched, read as written through the same composition
    base = Usd.Stage.Open(str(tmp_path / "set.usda"))
    ok = usd.read_buffers(base.GetPrimAtPath("/World/spot"))
    assert all(ok[k].tobytes() == v.tobytes() for k, v in spot_pm.buffers().items())


def test_a_blocked_attribute_is_named_with_the_layer_that_blocks_it(spot_pm, tmp_path):
    """A value block in an override: with the schema registered the attribute still HasValue() (its
    fallback), so validate found nothing at all while read failed."""
    asset = usd.write(spot_pm, tmp_path / "spot.usdc")
    shot = _overridden_scene(tmp_path, asset, lambda prim: prim.GetAttribute("swpm:lodErrors").Block())
    stage = Usd.Stage.Open(str(shot))
    with pytest.raises(UsdReadError, match=f"^{shot}: /World/spot/mesh: attribute swpm:lodErrors"):
        usd.read(stage.GetPrimAtPath("/World"))
    [finding] = [f for f in usd.validate_stage(shot) if f.code.startswith("SWPM_")]
    assert finding.code == "SWPM_USD_MISSING"
    assert finding.message == (
        f"swpm:lodErrors has no value (it is blocked) (swpm:lodErrors in {tmp_path / 'fix.usda'})"
    )


def test_read_errors_name_the_stage(spot_pm, tmp_path):
    stage = Usd.Stage.Open(str(_overridden_scene(tmp_path, usd.write(spot_pm, tmp_path / "s.usdc"), id)))
    UsdGeom.Xform.Define(stage, "/World/empty")
    with pytest.raises(UsdReadError, match=f"^{tmp_path / 'shot.usda'}: /World/empty: no SwpmMeshAPI"):
        usd.read(stage.GetPrimAtPath("/World/empty"))


# -- the schema in other USD applications ------------------------------------------------------------------
def test_the_schema_plugin_found_through_the_environment(spot_pm, tmp_path):
    """What README and plugin.py tell other USD applications to do: PXR_PLUGINPATH_NAME set before pxr is
    imported (this package never imported). The stage opens, the schema is applied and known."""
    from swpm_usd.usd.plugin import PLUGIN_PATH

    asset = usd.write(spot_pm, tmp_path / "spot.usdc")
    code = f"""
from pxr import Usd, UsdGeom
stage = Usd.Stage.Open({str(asset)!r})
prim = stage.GetPrimAtPath("/Spot/mesh")
t = Usd.SchemaRegistry.GetTypeFromSchemaTypeName("SwpmMeshAPI")
xf = UsdGeom.Xform.Define(stage, "/x").GetPrim()
print(prim.HasAPI("SwpmMeshAPI"), Usd.SchemaRegistry.IsAppliedAPISchema(t), prim.CanApplyAPI(t)[0],
      xf.CanApplyAPI(t)[0], prim.GetAttribute("swpm:encoding").Get())
import sys
print("swpm_usd" in sys.modules)
"""
    env = dict(os.environ, PXR_PLUGINPATH_NAME=PLUGIN_PATH)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split("\n")[:2] == ["True True True False vanilla", "False"]


def test_overrides_of_an_encoded_stage_leave_no_buffer_of_the_old_encoding(tmp_path):
    """Re-encoding an asset (skip-strip with discrete LODs -> sliding window): the old buffers and
    swpm:discreteLods, authored in the weaker layer, are blocked, not left beside the new ones."""
    pm = swpm_usd.build(swpm_usd.load_mesh(MESHES / "fandisk.obj"), "skip-strip")
    asset = usd.write(pm, tmp_path / "fan.usda", lods=3)
    usd.write_overrides(asset, tmp_path / "fan_sw.usda", "sliding-window")
    stage = Usd.Stage.Open(str(tmp_path / "fan_sw.usda"))
    prim = stage.GetPrimAtPath("/Fan/mesh")
    new = usd.read(prim)
    assert new.encoding == "sliding-window"
    from swpm_usd.usd.writer import swpm_values

    names = {a.GetName() for a in prim.GetAttributes() if a.GetName().startswith("swpm:")}
    with_values = {n for n in names if prim.GetAttribute(n).HasAuthoredValue()}
    assert with_values == set(swpm_values(new)) and "swpm:levelIndices" in names
    assert "swpm:levelIndices" not in with_values and "swpm:discreteLods" not in with_values
    assert usd.validate_stage(stage) == []


# -- model hierarchy ---------------------------------------------------------------------------------------
def test_assets_are_models_in_the_scene_and_the_lod_layer(spot_pm, tmp_path):
    """An asset's root is a component; a component is a model only when every ancestor is a group model
    (assembly, group): /Scene of scene.usda and the LOD root of a UsdLod layer must be ones."""
    from swpm_usd.pipeline import run

    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "spot.obj").write_bytes((MESHES / "spot.obj").read_bytes())
    cfg = tmp_path / "p.yaml"
    cfg.write_text(
        'version: 1\nassets:\n  - glob: "in/*.obj"\noutput:\n  dir: out\n  usd: true\n  scene: true\n'
        "defaults:\n  encoding: vanilla\n"
    )
    assert run(cfg, echo=lambda m: None).built == 1
    scene = Usd.Stage.Open(str(tmp_path / "out" / "scene.usda"))
    assert scene.GetPrimAtPath("/Scene").IsGroup()
    assert scene.GetPrimAtPath("/Scene/spot").IsComponent()
    asset = usd.write(spot_pm, tmp_path / "spot_lods.usdc", lods=3)
    lod = Usd.Stage.Open(str(usd.write_usdlod(asset, tmp_path / "spot_lod.usda")))
    assert all(lod.GetPrimAtPath(f"/Spot_lodsLOD/lod/LOD{i}").IsComponent() for i in range(3))


# -- composition a set dresser uses ------------------------------------------------------------------------
def test_read_through_a_variant_of_encodings_a_mesh_reference_and_a_moved_prim(spot_pm, tmp_path):
    """A variant set holding two encodings of one asset, a reference to the Mesh prim itself (no default
    prim), and a reference that targets the asset's root under another name: each reads its own buffers."""
    sw = swpm_usd.build(swpm_usd.load_mesh(MESHES / "spot.obj"), "sliding-window")
    v_asset = usd.write(spot_pm, tmp_path / "spot_v.usdc")
    sw_asset = usd.write(sw, tmp_path / "spot_sw.usda")
    stage = Usd.Stage.CreateNew(str(tmp_path / "set.usda"))
    dressed = UsdGeom.Xform.Define(stage, "/Set/cow").GetPrim()
    vset = dressed.GetVariantSets().AddVariantSet("encoding")
    for name, path in (("vanilla", v_asset), ("window", sw_asset)):
        vset.AddVariant(name)
        vset.SetVariantSelection(name)
        with vset.GetVariantEditContext():
            dressed.GetReferences().AddReference(f"./{path.name}")
    stage.DefinePrim("/Set/bare").GetReferences().AddReference(f"./{sw_asset.name}", "/Spot_sw/mesh")
    stage.DefinePrim("/Set/moved").GetReferences().AddReference(f"./{v_asset.name}", "/Spot_v")
    stage.Save()
    for name, pm in (("vanilla", spot_pm), ("window", sw)):
        vset.SetVariantSelection(name)
        got = usd.read(dressed)
        assert got.encoding == pm.encoding
        assert all(got.buffers()[k].tobytes() == v.tobytes() for k, v in pm.buffers().items())
        assert usd.validate_stage(stage, builtin=False) == []
    assert usd.read(stage.GetPrimAtPath("/Set/bare")).encoding == "sliding-window"
    assert usd.read(stage.GetPrimAtPath("/Set/moved")).encoding == "vanilla"
    assert sorted(str(p.GetPath()) for p in usd.find_encoded(stage)) == [
        "/Set/bare",
        "/Set/cow/mesh",
        "/Set/moved/mesh",
    ]


def test_overrides_of_a_set_of_instances_say_why_nothing_is_encoded(tmp_path):
    """A set whose meshes are all in instances (USD ignores overrides of instance proxies) wrote an override
    layer that encoded nothing and returned {}: an error that says so, and nothing written."""
    from swpm_usd.usd.overrides import UsdOverrideError

    _deforming_stage(tmp_path / "sheet.usda", default=True)
    crowd = _crowd(tmp_path, tmp_path / "sheet.usda", 3)
    out = tmp_path / "crowd_swpm.usda"
    with pytest.raises(
        UsdOverrideError, match=r"crowd_sheet\.usda: no Mesh prim to encode: the 3 Mesh prims are in"
    ):
        usd.write_overrides(crowd, out)
    with pytest.raises(UsdOverrideError, match=r"crowd_sheet\.usda: no prim at /World/nope$"):
        usd.write_overrides(crowd, out, prims=["/World/c0", "/World/nope"])
    empty = Usd.Stage.CreateNew(str(tmp_path / "empty.usda"))
    UsdGeom.Xform.Define(empty, "/World")
    empty.Save()
    with pytest.raises(UsdOverrideError, match=r"empty\.usda: no Mesh prim to encode$"):
        usd.write_overrides(tmp_path / "empty.usda", out)
    assert not out.exists()
    assert list(usd.write_overrides(tmp_path / "sheet.usda", out)) == ["/World/sheet"]  # the asset itself


def test_reading_an_unloaded_payload_says_it_is_not_loaded(spot_pm, tmp_path):
    """A stage opened with LoadNone (as a set dresser opens a big set): the encoded mesh sits in a payload
    not loaded; the error says so instead of only finding no SwpmMeshAPI prim."""
    asset = usd.write(spot_pm, tmp_path / "spot.usdc")
    stage = Usd.Stage.CreateNew(str(tmp_path / "set.usda"))
    UsdGeom.Xform.Define(stage, "/World/a").GetPrim().GetPayloads().AddPayload(f"./{asset.name}")
    stage.Save()
    lazy = Usd.Stage.Open(str(tmp_path / "set.usda"), Usd.Stage.LoadNone)
    message = (
        f"{tmp_path / 'set.usda'}: /World: no SwpmMeshAPI Mesh prims at or under it (need exactly one); "
    )
    with pytest.raises(
        UsdReadError, match=re.escape(message + "payloads at or under it not loaded (1): /World/a")
    ):
        usd.read(lazy.GetPrimAtPath("/World"))
    lazy.Load("/World/a")
    assert usd.read(lazy.GetPrimAtPath("/World")).lod_count == spot_pm.lod_count
    UsdGeom.Xform.Define(lazy, "/World/b")
    with pytest.raises(
        UsdReadError, match=r"/World/b: no SwpmMeshAPI Mesh prims at or under it \(need exactly one\)$"
    ):
        usd.read(lazy.GetPrimAtPath("/World/b"))


def test_validate_gives_no_stale_findings_while_another_validation_runs(spot_pm, tmp_path, monkeypatch):
    """The prototype memo is one validate_stage call's: a stage validated, edited, validated again (while
    another thread's validation runs, as in a tool that validates in the background) is checked as it is
    now, not answered with its findings from before the edit (a broken asset reported clean)."""
    import threading

    from swpm_usd.usd import validate as v

    asset = usd.write(spot_pm, tmp_path / "spot.usda")
    other_asset = usd.write(spot_pm, tmp_path / "other.usdc")
    stage = Usd.Stage.Open(str(_crowd(tmp_path, asset, 3)))
    started, release = threading.Event(), threading.Event()
    real = v._validate_into

    def held(*args, **kwargs):
        if threading.current_thread().name == "background":
            started.set()
            release.wait(120)
        return real(*args, **kwargs)

    monkeypatch.setattr(v, "_validate_into", held)
    background = threading.Thread(target=usd.validate_stage, args=(other_asset,), name="background")
    background.start()
    try:
        assert started.wait(120)
        assert usd.validate_stage(stage, builtin=False) == []
        layer = Sdf.Layer.FindOrOpen(str(asset))
        pool = layer.GetAttributeAtPath("/Spot/mesh.swpm:indices")
        written = np.asarray(pool.default).copy()
        pool.default = Vt.UIntArray.FromNumpy(written[:-3].copy())
        findings = usd.validate_stage(stage, builtin=False)
        expected = [(f"/World/c{i}/mesh", "SWPM_USD_REBUILD") for i in range(3)]
        assert [(f.prim, f.code) for f in findings] == expected
        pool.default = Vt.UIntArray.FromNumpy(written)  # fixed: clean again
        assert usd.validate_stage(stage, builtin=False) == []
    finally:
        release.set()
        background.join(120)
    assert not background.is_alive() and not v._memos
