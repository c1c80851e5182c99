"""USD schema and I/O: SwpmMeshAPI registration, writer / reader, composition, overrides, LODs, validation."""

from __future__ import annotations

import json
import math
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
from swpm_usd.encode import BUILDERS
from swpm_usd.mesh import Mesh
from swpm_usd.usd import schema
from swpm_usd.usd.reader import UsdReadError
from swpm_usd.usd.schema import PROPERTY_TYPES
from swpm_usd.usd.validate import CODES, validate_prim, validate_stage

MESHES = Path(__file__).resolve().parents[2] / "shared" / "meshes"
if not MESHES.exists():
    MESHES = Path("/work/shared/meshes")
SUZANNE = MESHES / "suzanne.obj"


def _attributed_mesh() -> Mesh:
    m = swpm_usd.load_mesh(SUZANNE)
    p = m.points
    n = p / np.maximum(np.linalg.norm(p, axis=1, keepdims=True), 1e-6)
    return Mesh(
        p,
        m.triangles,
        {
            "normal": n.astype(np.float32),
            "uv": (p[:, :2] * 0.5 + 0.5).astype(np.float32),
            "color": np.c_[np.abs(n), np.full(len(p), 0.5)].astype(np.float32),
            "weight": p[:, 2:3].astype(np.float32),
        },
    )


@pytest.fixture(scope="module")
def mesh() -> Mesh:
    return _attributed_mesh()


@pytest.fixture(scope="module")
def pm(mesh):
    return swpm_usd.build(mesh, "vanilla")


@pytest.fixture(scope="module")
def asset(pm, tmp_path_factory) -> Path:
    return usd.write(pm, tmp_path_factory.mktemp("asset") / "suzanne.usdc")


def _expected_buffers(pm, tmp: Path) -> dict[str, np.ndarray]:
    """The .swpm file's buffers (the format codec stores every encoding, mixed included)."""
    from swpm_usd import format as fmt

    path = fmt.save(pm, tmp / f"{pm.encoding}.swpm")
    loaded = fmt.load(path).buffers()
    return {k: np.asarray(loaded[k]).astype(v.dtype) for k, v in pm.buffers().items()}


def _assert_same(bufs: dict[str, np.ndarray], expected: dict[str, np.ndarray]) -> None:
    assert list(bufs) == list(expected)
    for k, v in expected.items():
        assert bufs[k].dtype == v.dtype and bufs[k].shape == v.shape, k
        assert bufs[k].tobytes() == v.tobytes(), k


# -- schema ------------------------------------------------------------------------------------------------
def test_resources_match_the_property_table():
    for name, text in schema.resource_texts().items():
        assert (schema.RESOURCES / name).read_text(encoding="utf-8") == text, f"regenerate {name}"


def test_spec_attribute_table_is_the_schema_a_usd_tool_reads():
    """spec/usd.md's attribute table says what generatedSchema.usda documents (what usdview or a DCC shows):
    swpm:params' rules (META's: no NaN, no duplicate key, 128 deep) were in the spec alone."""
    spec = (Path(__file__).resolve().parents[1] / "spec" / "usd.md").read_text(encoding="utf-8")
    rows = dict(
        (m.group(1), (m.group(2), m.group(3)))
        for m in re.finditer(r"^\| `(swpm:\w+)` \| `([^`]+)` \| (.*) \|$", spec, re.M)
    )
    assert list(rows) == [p.name for p in schema.PROPERTIES]
    for p in schema.PROPERTIES:
        assert rows[p.name] == (p.type, p.doc), p.name


def test_schema_registered_with_documented_properties():
    defn = Usd.SchemaRegistry().FindAppliedAPIPrimDefinition(schema.SCHEMA_NAME)
    assert defn is not None
    names = set(defn.GetPropertyNames())
    for required in (
        "formatVersion",
        "encoding",
        "indexPool",
        "windowRecords",
        "collapseRecords",
        "lodErrors",
    ):
        assert f"swpm:{required}" in names
    for p in schema.PROPERTIES:
        assert defn.GetAttributeDefinition(p.name).GetDocumentation()
    tokens = defn.GetAttributeDefinition("swpm:encoding").GetMetadata("allowedTokens")
    assert set(tokens) == set(schema.ENCODING_TOKENS)


def test_schema_only_applies_to_meshes(pm):
    stage = Usd.Stage.CreateInMemory()
    xf = UsdGeom.Xform.Define(stage, "/x").GetPrim()
    t = Usd.SchemaRegistry.GetTypeFromSchemaTypeName(schema.SCHEMA_NAME)
    assert not xf.CanApplyAPI(t)[0]
    assert UsdGeom.Mesh.Define(stage, "/m").GetPrim().CanApplyAPI(t)[0]
    from swpm_usd.usd.writer import UsdWriteError, author_swpm

    with pytest.raises(UsdWriteError, match="Mesh"):
        author_swpm(xf, pm)


def test_camel_case_names():
    assert schema.attr_name("index_pool") == "swpm:indexPool"
    assert schema.attr_name("window_records") == "swpm:windowRecords"
    assert schema.attr_name("level_collapsed_indices") == "swpm:levelCollapsedIndices"


# -- writer / reader ---------------------------------------------------------------------------------------
def test_asset_layout(pm, asset):
    stage = Usd.Stage.Open(str(asset))
    assert Sdf.Layer.FindOrOpen(str(asset)).GetFileFormat().formatId == "usdc"
    root = stage.GetDefaultPrim()
    assert root.IsA(UsdGeom.Xform) and root.GetName() == "Suzanne"
    assert UsdGeom.GetStageUpAxis(stage) == "Y" and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    prim = root.GetChild("mesh")
    assert prim.HasAPI(schema.SCHEMA_NAME) or schema.SCHEMA_NAME in prim.GetAppliedSchemas()
    mesh = UsdGeom.Mesh(prim)
    np.testing.assert_array_equal(np.asarray(mesh.GetPointsAttr().Get()), pm.points)
    np.testing.assert_array_equal(
        np.asarray(mesh.GetFaceVertexIndicesAttr().Get()), pm.triangles_at(0).ravel()
    )
    assert set(np.asarray(mesh.GetFaceVertexCountsAttr().Get()).tolist()) == {3}
    assert mesh.GetSubdivisionSchemeAttr().Get() == "none"
    ext = np.asarray(mesh.GetExtentAttr().Get())
    np.testing.assert_allclose(ext, [pm.points.min(0), pm.points.max(0)])
    api = UsdGeom.PrimvarsAPI(prim)
    assert mesh.GetNormalsInterpolation() == "vertex"
    assert api.GetPrimvar("st").GetTypeName() == Sdf.ValueTypeNames.TexCoord2fArray
    assert api.GetPrimvar("displayOpacity").HasValue() and api.GetPrimvar("weight").HasValue()
    for p in schema.PROPERTIES[:3]:
        assert prim.GetAttribute(p.name).HasAuthoredValue()


def test_asset_info_names_the_asset_and_its_layer(pm, asset, tmp_path):
    stage = Usd.Stage.Open(str(asset))
    model = Usd.ModelAPI(stage.GetDefaultPrim())
    assert model.GetAssetName() == "Suzanne"
    ident = model.GetAssetIdentifier()
    assert ident.path == "./" + asset.name and Path(ident.resolvedPath) == asset.resolve()
    # file-relative: a moved layer still names itself, and a stage that references it reads it composed
    moved = tmp_path / "sub" / asset.name
    moved.parent.mkdir()
    moved.write_bytes(asset.read_bytes())
    top = Usd.Stage.CreateNew(str(tmp_path / "top.usda"))
    prim = top.DefinePrim("/Ref")
    prim.GetReferences().AddReference("./sub/" + asset.name)
    assert Path(Usd.ModelAPI(prim).GetAssetIdentifier().resolvedPath) == moved.resolve()
    assert Usd.ModelAPI(prim).GetAssetName() == "Suzanne"


@pytest.mark.parametrize(
    ("file", "prim"),
    [("caf\u00e9.usda", "Caf\u00e9"), ("\u65e5\u672c.usdc", "\u65e5\u672c"), ("3d-model.usda", "_d_model")],
)
def test_root_prim_of_a_non_ascii_file_keeps_its_name(pm, tmp_path, file, prim):
    # usd-core takes UTF-8 identifiers: the root prim is named as the pipeline's scene names the asset's prim
    # (ASCII's Tf.MakeValidIdentifier made caf\u00e9 Caf___); an ASCII name is as before
    from swpm_usd.pipeline.scene import _valid_identifier

    path = usd.write(pm, tmp_path / file)
    stage = Usd.Stage.Open(str(path))
    root = stage.GetDefaultPrim()
    assert root.GetName() == prim == _valid_identifier(prim)
    assert Usd.ModelAPI(root).GetAssetName() == prim


def test_read_equals_format_file(pm, asset, tmp_path):
    stage = Usd.Stage.Open(str(asset))
    prim = stage.GetDefaultPrim()
    back = usd.read(prim)
    _assert_same(usd.read_buffers(prim), _expected_buffers(pm, tmp_path))
    _assert_same(back.buffers(), pm.buffers())
    assert back.encoding == pm.encoding and back.params == pm.params
    np.testing.assert_array_equal(back.points, pm.points)
    for name, a in pm.attributes.items():
        np.testing.assert_array_equal(back.attributes[name], a)
    for k in (0, pm.lod_count // 2, pm.lod_count - 1):
        np.testing.assert_array_equal(back.triangles_at(k), pm.triangles_at(k))


@pytest.mark.parametrize("dtype", ["u1", "<u2"])
def test_unsigned_colour_is_normalised_and_read_back_exactly(dtype, tmp_path):
    """A u8 / u16 colour is stored as display colour in [0, 1] (value / (2^bits - 1)); read() restores the
    attribute's element type and values exactly, and other attributes keep their dtype (swpm:attributeDtypes).
    """
    from swpm_usd.format import encode_bytes, load_bytes
    from swpm_usd.format.vectors import fan_vanilla

    top = np.iinfo(dtype).max
    color = np.array([[top, 0, 0, top], [0, top, 0, 7], [0, 0, top, 0], [1, 2, 3, 4], [top, top, top, 1]])
    attrs = {"color": color.astype(dtype), "id": np.arange(5, dtype="<i2")[:, None] - 2}
    pm = load_bytes(encode_bytes(fan_vanilla(attributes=attrs)))  # type: ignore[arg-type]
    path = usd.write(pm, tmp_path / "colour.usda")
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetDefaultPrim().GetChild("mesh")
    api = UsdGeom.PrimvarsAPI(prim)
    rgb = np.asarray(api.GetPrimvar("displayColor").Get())
    alpha = np.asarray(api.GetPrimvar("displayOpacity").Get())
    assert rgb.min() >= 0.0 and rgb.max() == 1.0 and alpha.min() >= 0.0 and alpha.max() == 1.0
    np.testing.assert_allclose(rgb, color[:, :3] / top, rtol=1e-6)
    back = usd.read(prim)
    for name, a in attrs.items():
        assert back.attributes[name].dtype == a.dtype, name
        np.testing.assert_array_equal(back.attributes[name], a)
    assert validate_stage(path) == []


@pytest.mark.parametrize("dtype", ["u1", "<u2", "<f4"])
@pytest.mark.parametrize("k", [1, 2, 3, 4, 5])
def test_colour_of_every_component_count_round_trips(k, dtype, tmp_path):
    """A per-vertex "color" of 3 or 4 components is displayColor (+ displayOpacity), of 1, 2 or 5 components
    primvars:color (there is no display colour of that shape); read() finds either and gives back the
    attribute exactly, unsigned-integer components normalised to [0, 1] in the stage either way."""
    from swpm_usd.format import encode_bytes, load_bytes
    from swpm_usd.format.vectors import fan_vanilla

    unsigned = np.dtype(dtype).kind == "u"
    top = np.iinfo(dtype).max if unsigned else 8
    values = np.array([[top, 0, 0, top, 1], [0, top, 0, 7, 2], [0, 0, top, 0, 3], [1, 2, 3, 4, 5], [top] * 5])
    color = (values[:, :k] if unsigned else values[:, :k] / 8).astype(dtype)
    pm = load_bytes(encode_bytes(fan_vanilla(attributes={"color": color})))  # type: ignore[arg-type]
    path = usd.write(pm, tmp_path / "colour.usda")
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetDefaultPrim().GetChild("mesh")
    api = UsdGeom.PrimvarsAPI(prim)
    stored = api.GetPrimvar("displayColor" if k in (3, 4) else "color")
    assert stored and stored.GetInterpolation() == UsdGeom.Tokens.vertex
    assert api.GetPrimvar("color").HasAuthoredValue() is (k not in (3, 4))
    assert api.GetPrimvar("displayColor").HasAuthoredValue() is (k in (3, 4))
    assert np.asarray(stored.Get()).max() == 1.0  # u8, u16: value / (2^bits - 1); f32 as given
    back = usd.read(prim)
    assert back.attributes["color"].dtype == color.dtype
    np.testing.assert_array_equal(back.attributes["color"], color)
    assert validate_stage(path) == []


@pytest.mark.parametrize("dtype", ["bool", "<i8", "<u8"])
def test_an_attribute_the_writer_stores_is_read_back(dtype, tmp_path):
    """write stored a bool attribute (and an int64 / uint64 one) as a float primvar and its dtype in
    swpm:attributeDtypes, but read refused the stage: "swpm:attributeDtypes[0] = 'bool' is not one of ..."
    (and, for int64, the check said the arrays "do not form a valid vanilla mesh": a .swpm file cannot hold
    that type). read gives the attribute back, type and values."""
    from swpm_usd.encode.base import from_buffers
    from swpm_usd.format import encode_bytes, load_bytes
    from swpm_usd.format.vectors import fan_vanilla

    flags = np.array([[1, 0], [0, 0], [1, 1], [0, 1], [1, 0]]).astype(dtype)
    fan = load_bytes(encode_bytes(fan_vanilla()))  # type: ignore[arg-type]
    attrs = {"flag": flags, "weight": np.arange(5, dtype=np.float32)[:, None]}
    pm = from_buffers(
        "vanilla", fan.points, attrs, fan.vertex_counts, fan.triangle_counts, fan.lod_errors, fan.buffers()
    )
    path = usd.write(pm, tmp_path / "flags.usda")
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetDefaultPrim().GetChild("mesh")
    assert list(prim.GetAttribute("swpm:attributeDtypes").Get()) == [np.dtype(dtype).name, "float32"]
    back = usd.read(prim)
    assert back.attributes["flag"].dtype == np.dtype(dtype)
    np.testing.assert_array_equal(back.attributes["flag"], flags)
    np.testing.assert_array_equal(back.triangles_at(0), pm.triangles_at(0))
    assert validate_stage(path) == []


@pytest.mark.parametrize("dtype", ["<i8", "<u8"])
def test_a_64_bit_attribute_keeps_its_extremes(dtype, tmp_path):
    """A 64-bit integer attribute is a float32 primvar: its maximum is written as 2^63 (2^64), which read
    cast to the type unchecked (2^63 - 1 came back as -2^63, 2^64 - 1 as 0, with numpy's "invalid value
    encountered in cast"); the type's extremes come back as they were."""
    import warnings

    from swpm_usd.encode.base import from_buffers
    from swpm_usd.format import encode_bytes, load_bytes
    from swpm_usd.format.vectors import fan_vanilla

    info = np.iinfo(dtype)
    ids = np.array([info.max, info.min, 0, 5, 2**40], dtype=dtype)[:, None]
    fan = load_bytes(encode_bytes(fan_vanilla()))  # type: ignore[arg-type]
    pm = from_buffers(
        "vanilla",
        fan.points,
        {"id": ids},
        fan.vertex_counts,
        fan.triangle_counts,
        fan.lod_errors,
        fan.buffers(),
    )
    path = usd.write(pm, tmp_path / "ids.usda")
    stage = Usd.Stage.Open(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back = usd.read(stage.GetDefaultPrim().GetChild("mesh")).attributes["id"]
    assert back.dtype == np.dtype(dtype)
    np.testing.assert_array_equal(back, ids)


def _float32_holds(v: np.ndarray) -> np.ndarray:
    return v.astype(np.float32).astype(np.float64) == v.astype(np.float64)


def test_32_bit_attributes_keep_24_bits_as_spec_usd_md_says(tmp_path):
    """spec/usd.md "Attribute values" on vector attributes-32bit: the .swpm file keeps every bit of a u32
    color and an i32 attribute; through a stage, a u32 color component round-trips if v <= 2^24 or
    v = 2^32 - 1, an i32 value if float32 holds it or it is the type's maximum, and every other value comes
    back within 2^(k-24) of v (2^k <= |v| < 2^(k+1)); some do not round-trip (no exact path exists)."""
    from swpm_usd.format import load
    from swpm_usd.format.vectors import COLOR_U32, ID_I32

    vector = Path(__file__).resolve().parents[1] / "spec" / "vectors" / "valid" / "attributes-32bit.swpm"
    pm = load(vector)
    for name, want in (("color", COLOR_U32), ("id", ID_I32)):
        assert pm.attributes[name].dtype == want.dtype
        np.testing.assert_array_equal(pm.attributes[name], want)  # the file: every bit
    path = usd.write(pm, tmp_path / "wide.usda")
    stage = Usd.Stage.Open(str(path))
    back = usd.read(stage.GetDefaultPrim().GetChild("mesh"))
    for name, v, exact in (
        ("color", COLOR_U32, (COLOR_U32 <= 2**24) | (COLOR_U32 == 2**32 - 1)),
        ("id", ID_I32, _float32_holds(ID_I32) | (ID_I32 == 2**31 - 1)),
    ):
        got = back.attributes[name]
        assert got.dtype == v.dtype
        v, err = v.astype(np.int64), np.abs(got.astype(np.int64) - v.astype(np.int64))
        np.testing.assert_array_equal(err[exact], 0, err_msg=name)
        k = np.floor(np.log2(np.maximum(np.abs(v), 1))).astype(np.int64)
        assert np.all(err <= np.where(k >= 24, 2.0 ** (k - 24), 0)), (name, err)
        if name == "id":  # not a color: exact exactly when float32 holds it (or it is the maximum)
            np.testing.assert_array_equal(err == 0, exact, err_msg=name)
    assert np.any(back.attributes["color"] != COLOR_U32) and np.any(back.attributes["id"] != ID_I32)


@pytest.mark.parametrize("k", [24, 25, 30, 31])
def test_u32_colour_round_trips_one_value_in_2_to_the_k_minus_23(k, tmp_path):
    """spec/usd.md: above 2^24 a u32 color component round-trips for one value in 2^(k-23) of
    [2^k, 2^(k+1)); sampled on 5 c consecutive values (5 vertices of c components) from a multiple of
    2^(k-23) inside the binade."""
    from swpm_usd.format import encode_bytes, load_bytes
    from swpm_usd.format.vectors import fan_vanilla

    step = 2 ** (k - 23)
    c = min(step, 128)
    start = 2**k + 3 * 2**20
    values = np.arange(start, start + 5 * c, dtype=np.uint64).astype("<u4").reshape(5, c)
    pm = load_bytes(encode_bytes(fan_vanilla(attributes={"color": values})))  # type: ignore[arg-type]
    path = usd.write(pm, tmp_path / "c.usda")
    stage = Usd.Stage.Open(str(path))
    back = usd.read(stage.GetDefaultPrim().GetChild("mesh")).attributes["color"]
    assert back.dtype == values.dtype
    assert int(np.count_nonzero(back == values)) == 5 * c // step


@pytest.mark.parametrize(("name", "k"), [("normal", 2), ("normal", 4), ("uv", 1), ("uv", 3)])
def test_normal_and_uv_of_another_shape_round_trip(name, k, tmp_path):
    """A normal that is not 3 components or a uv that is not 2 is primvars:<name>, and read() finds it there
    (it looked for normals / primvars:st only)."""
    from swpm_usd.format import encode_bytes, load_bytes
    from swpm_usd.format.vectors import fan_vanilla

    a = (np.arange(5 * k, dtype=np.float32).reshape(5, k) / 7).astype(np.float32)
    pm = load_bytes(encode_bytes(fan_vanilla(attributes={name: a})))  # type: ignore[arg-type]
    path = usd.write(pm, tmp_path / "shape.usda")
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetDefaultPrim().GetChild("mesh")
    assert UsdGeom.PrimvarsAPI(prim).GetPrimvar(name).HasAuthoredValue()
    np.testing.assert_array_equal(usd.read(prim).attributes[name], a)


def test_prim_of_a_freed_stage_is_a_clear_error(asset):
    """A stage opened inline and never held is freed at once: its prim is invalid, and the error says why."""
    with pytest.raises(UsdReadError, match="keep the Usd.Stage in a variable"):
        usd.read(Usd.Stage.Open(str(asset)).GetDefaultPrim())
    with pytest.raises(UsdReadError, match="invalid prim"):
        usd.read(Usd.Prim())


def test_usda_on_request_and_round_trip_is_stable(pm, tmp_path):
    a = usd.write(pm, tmp_path / "a", fmt="usda")
    assert a.suffix == ".usda" and a.read_text().startswith("#usda")
    stage = Usd.Stage.Open(str(a))
    back = usd.read(stage.GetDefaultPrim())
    # (the same file name elsewhere: assetInfo's identifier names the layer's own file)
    (tmp_path / "again").mkdir()
    b = usd.write(back, tmp_path / "again" / "a.usda")
    assert a.read_text() == b.read_text()


@pytest.mark.parametrize("encoding", sorted((set(BUILDERS) | {"sliding-window"}) - {"vanilla"}))
def test_other_encodings_round_trip(encoding, mesh, tmp_path):
    if encoding in BUILDERS:
        pm = swpm_usd.build(mesh, encoding)
    else:
        import swpm_usd.encode.slidingwindow as sw

        pm = sw.build_sliding_window(mesh)
    path = usd.write(pm, tmp_path / f"{encoding}.usdc")
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetDefaultPrim()
    _assert_same(usd.read_buffers(prim), _expected_buffers(pm, tmp_path))
    back = usd.read(prim)
    np.testing.assert_array_equal(back.triangles_at(back.lod_count - 1), pm.triangles_at(pm.lod_count - 1))
    assert validate_stage(path) == []


# -- composition -------------------------------------------------------------------------------------------
def _scene(asset: Path, folder: Path, n: int = 100) -> Path:
    stage = Usd.Stage.CreateNew(str(folder / "scene.usda"))
    UsdGeom.SetStageUpAxis(stage, "Y")
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    for i in range(n):
        x = UsdGeom.Xform.Define(stage, f"/World/inst_{i:03d}")
        x.AddTranslateOp().Set((float(i % 10) * 3, 0.0, float(i // 10) * 3))
        x.GetPrim().GetReferences().AddReference(asset.name)
        x.GetPrim().SetInstanceable(True)
    payload = UsdGeom.Xform.Define(stage, "/World/payloaded").GetPrim()
    payload.GetPayloads().AddPayload(asset.name)
    stage.Save()
    return folder / "scene.usda"


def test_instances_and_payload_read_back_the_file(pm, asset, tmp_path):
    scene = _scene(asset, asset.parent)
    expected = _expected_buffers(pm, tmp_path)
    stage = Usd.Stage.Open(str(scene))
    assert len(stage.GetPrototypes()) == 1
    found = usd.find_encoded(stage)
    assert len(found) == 101 and sum(p.IsInstanceProxy() for p in found) == 100
    for prim in found:
        _assert_same(usd.read_buffers(prim), expected)
    _assert_same(usd.read(stage.GetPrimAtPath("/World/payloaded")).buffers(), expected)
    unloaded = Usd.Stage.Open(str(scene), Usd.Stage.LoadNone)
    assert len(usd.find_encoded(unloaded)) == 100
    unloaded.Load("/World/payloaded")
    _assert_same(usd.read_buffers(unloaded.GetPrimAtPath("/World/payloaded")), expected)
    assert validate_stage(scene) == []


def test_stage_reads_without_the_plugin(pm, asset, tmp_path):
    np.savez(tmp_path / "expected.npz", **pm.buffers())
    code = f"""
import numpy as np
from pxr import Usd
stage = Usd.Stage.Open({str(asset)!r})
prim = stage.GetPrimAtPath("/Suzanne/mesh")
# (spec/usd.md: HasAPI and GetAppliedSchemas() forget the schema, the prim's type info keeps it)
assert not prim.HasAPI("SwpmMeshAPI") and list(prim.GetAppliedSchemas()) == []
assert list(prim.GetPrimTypeInfo().GetAppliedAPISchemas()) == ["SwpmMeshAPI"]
assert prim.GetAttribute("swpm:encoding").Get() == "vanilla"
from swpm_usd.usd.reader import read_buffers, read   # registers the plugin too late for this stage
exp = np.load({str(tmp_path / "expected.npz")!r})
got = read_buffers(prim)
assert all(got[k].tobytes() == exp[k].tobytes() for k in exp.files)
print(read(prim).lod_count)
"""
    env = {k: v for k, v in os.environ.items() if k != "PXR_PLUGINPATH_NAME"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env)
    assert out.returncode == 0, out.stderr
    assert int(out.stdout.strip()) == pm.lod_count


# -- overrides ---------------------------------------------------------------------------------------------
def _grid_stage(path: Path, n: int = 10) -> None:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, "Z")
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    xs, ys = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
    pts = np.stack([xs.ravel(), ys.ravel(), np.sin(xs.ravel() * 0.7) * np.cos(ys.ravel() * 0.5)], 1)
    a = (np.arange(n)[None, :] + (n + 1) * np.arange(n)[:, None]).ravel()
    faces = np.stack([a, a + 1, a + n + 2, a + n + 1], 1)
    mesh = UsdGeom.Mesh.Define(stage, "/World/grid")
    mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(pts.astype(np.float32)))
    mesh.GetFaceVertexCountsAttr().Set(Vt.IntArray.FromNumpy(np.full(len(faces), 4, np.int32)))
    mesh.GetFaceVertexIndicesAttr().Set(Vt.IntArray.FromNumpy(faces.ravel().astype(np.int32)))
    api = UsdGeom.PrimvarsAPI(mesh)
    # faceVarying, indexed st with a real seam at x = n / 2 (corner values differ per face side)
    corner_pts = pts[faces.ravel()]
    face_x = np.repeat(pts[faces[:, 0], 0], 4)
    st_vals = np.c_[corner_pts[:, 0] / n + (face_x >= n / 2), corner_pts[:, 1] / n].astype(np.float32)
    uniq, inv = np.unique(st_vals, axis=0, return_inverse=True)
    st = api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set(Vt.Vec2fArray.FromNumpy(uniq))
    st.SetIndices(Vt.IntArray.FromNumpy(inv.ravel().astype(np.int32)))
    api.CreatePrimvar("height", Sdf.ValueTypeNames.FloatArray, "vertex").Set(
        Vt.FloatArray.FromNumpy(pts[:, 2].astype(np.float32))
    )
    api.CreatePrimvar("faceId", Sdf.ValueTypeNames.IntArray, "uniform").Set(
        Vt.IntArray.FromNumpy(np.arange(len(faces), dtype=np.int32))
    )
    api.CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, "constant").Set([(1, 0, 0)])
    left = [int(f) for f in range(len(faces)) if pts[faces[f, 0], 0] < n / 2]
    UsdGeom.Subset.CreateGeomSubset(mesh, "left", "face", Vt.IntArray(left))
    stage.Save()


@pytest.mark.parametrize("mode", ["sublayer", "reference"])
def test_overrides_reindex_primvars_and_subsets(mode, tmp_path):
    n = 10
    src = tmp_path / "src.usda"
    _grid_stage(src, n)
    before = src.read_bytes()
    out = tmp_path / f"ovr_{mode}.usda"
    result = usd.write_overrides(src, out, mode=mode)
    assert src.read_bytes() == before and list(result) == ["/World/grid"]
    stage = Usd.Stage.Open(str(out))
    prim = stage.GetPrimAtPath("/World/grid")
    _assert_same(usd.read_buffers(prim), result["/World/grid"].buffers())
    mesh = UsdGeom.Mesh(prim)
    pts = np.asarray(mesh.GetPointsAttr().Get())
    tri = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
    api = UsdGeom.PrimvarsAPI(prim)
    assert pts.shape[0] == (n + 1) ** 2 + (n + 1)  # the seam column is split once
    np.testing.assert_allclose(np.asarray(api.GetPrimvar("height").Get()), pts[:, 2])
    st = api.GetPrimvar("st")
    assert st.GetInterpolation() == "vertex" and not st.IsIndexed()
    stv = np.asarray(st.Get())
    centre = pts[tri].mean(axis=1)
    right = centre[:, 0] >= n / 2
    np.testing.assert_allclose(stv[tri][:, :, 0], pts[tri][:, :, 0] / n + right[:, None], atol=1e-6)
    face = np.floor(centre[:, 0]).astype(int) + n * np.floor(centre[:, 1]).astype(int)
    np.testing.assert_array_equal(np.asarray(api.GetPrimvar("faceId").Get()), face)
    subset = np.asarray(UsdGeom.Subset(stage.GetPrimAtPath("/World/grid/left")).GetIndicesAttr().Get())
    np.testing.assert_array_equal(subset, np.flatnonzero(centre[:, 0] < n / 2))
    assert UsdGeom.GetStageUpAxis(stage) == "Z"
    assert validate_stage(out) == []


def _grid_mesh(stage: Usd.Stage) -> tuple[UsdGeom.Mesh, np.ndarray, np.ndarray]:
    """The grid of :func:`_grid_stage` in ``stage``: its mesh, points and quads (as the source has them)."""
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/grid"))
    pts = np.asarray(mesh.GetPointsAttr().Get(), np.float64)
    quads = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 4)
    return mesh, pts, quads


def _point_normal(pts: np.ndarray) -> np.ndarray:
    """A normal that is a function of the point (so a re-indexed one can be checked against the points)."""
    v = np.c_[pts[:, 0] - 3.0, pts[:, 1] + 1.0, np.full(len(pts), 7.0)]
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)


def test_overrides_reindex_the_normals_attribute_beside_primvars_normals(tmp_path):
    """A mesh with both a ``normals`` attribute and ``primvars:normals``: only the primvar (which USD uses)
    was re-indexed; the attribute kept the source's order and length beside the new points (invalid)."""
    n = 10
    src = tmp_path / "src.usda"
    _grid_stage(src, n)
    stage = Usd.Stage.Open(str(src))
    mesh, pts, quads = _grid_mesh(stage)
    mesh.GetNormalsAttr().Set(Vt.Vec3fArray.FromNumpy(_point_normal(pts)))  # vertex interpolation
    # faceVarying primvars:normals: up on the left half, tilted on the right (a seam at x = n / 2)
    right = np.repeat(pts[quads[:, 0], 0] >= n / 2, 4)
    fv = np.where(right[:, None], [0.0, 0.6, 0.8], [0.0, 0.0, 1.0]).astype(np.float32)
    pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("normals", Sdf.ValueTypeNames.Normal3fArray, "faceVarying")
    pv.Set(Vt.Vec3fArray.FromNumpy(fv))
    stage.Save()
    out = tmp_path / "ovr.usda"
    usd.write_overrides(src, out)
    stage = Usd.Stage.Open(str(out))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/grid"))
    new_pts = np.asarray(mesh.GetPointsAttr().Get(), np.float64)
    tri = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
    assert new_pts.shape[0] == (n + 1) ** 2 + (n + 1)  # split along the primvar's seam
    attr = np.asarray(mesh.GetNormalsAttr().Get())
    assert mesh.GetNormalsInterpolation() == "vertex" and attr.shape == new_pts.shape
    np.testing.assert_allclose(attr, _point_normal(new_pts), atol=1e-6)  # each its own point's
    prim_normals = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("normals")
    assert prim_normals.GetInterpolation() == "vertex"
    got = np.asarray(prim_normals.Get())
    assert got.shape == new_pts.shape
    centre_right = new_pts[tri].mean(axis=1)[:, 0] >= n / 2
    expected = np.where(centre_right[:, None, None], [0.0, 0.6, 0.8], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(got[tri], np.broadcast_to(expected, (len(tri), 3, 3)), atol=1e-6)
    assert validate_stage(out) == []


@pytest.mark.parametrize("blocked", [5.0, 1.0])
def test_overrides_keep_a_blocked_time_sample_blocked(blocked, tmp_path):
    """A value-blocked time sample of a primvar (its first included) failed with "0 values at time t": it
    stays blocked, and the other samples are re-indexed."""
    n = 6
    src = tmp_path / "src.usda"
    _grid_stage(src, n)
    stage = Usd.Stage.Open(str(src))
    mesh, pts, _ = _grid_mesh(stage)
    heat = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("heat", Sdf.ValueTypeNames.FloatArray, "vertex")
    vel = mesh.GetVelocitiesAttr()
    for t in (1.0, 5.0, 10.0):
        if t == blocked:
            heat.GetAttr().Set(Sdf.ValueBlock(), t)
            vel.Set(Sdf.ValueBlock(), t)
        else:
            heat.Set(Vt.FloatArray.FromNumpy((pts[:, 0] * 10 + pts[:, 1] + t).astype(np.float32)), t)
            vel.Set(Vt.Vec3fArray.FromNumpy((pts * t).astype(np.float32)), t)
    stage.Save()
    out = tmp_path / "ovr.usda"
    usd.write_overrides(src, out)
    stage = Usd.Stage.Open(str(out))
    mesh, new_pts, _ = _grid_mesh(stage)
    heat = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("heat")
    vel = mesh.GetVelocitiesAttr()
    assert heat.GetAttr().GetTimeSamples() == vel.GetTimeSamples() == [1.0, 5.0, 10.0]
    for t in (1.0, 5.0, 10.0):
        if t == blocked:
            assert heat.Get(t) is None and vel.Get(t) is None
        else:
            np.testing.assert_allclose(np.asarray(heat.Get(t)), new_pts[:, 0] * 10 + new_pts[:, 1] + t)
            np.testing.assert_allclose(np.asarray(vel.Get(t)), new_pts * t, rtol=1e-6)


def test_overrides_reindex_edge_subsets_and_time_sampled_subsets(tmp_path):
    """Edge GeomSubsets (pairs of point indices) and time-sampled subset indices kept the source's order: an
    edge subset now names the new mesh's edges between the new vertices of its points (both sides of a
    split seam), and every time sample of a subset is re-indexed (a blocked one stays blocked)."""
    n = 10
    src = tmp_path / "src.usda"
    _grid_stage(src, n)
    stage = Usd.Stage.Open(str(src))
    mesh, pts, quads = _grid_mesh(stage)
    # the seam column x = n / 2 (split by st) from y = 0 to 3, and one edge along the bottom row
    col = [int(i) for i in np.flatnonzero(pts[:, 0] == n / 2) if pts[i, 1] <= 3]
    col.sort(key=lambda i: pts[i, 1])
    pairs = [(col[k + 1], col[k]) for k in range(len(col) - 1)] + [(0, 1)]
    UsdGeom.Subset.CreateGeomSubset(
        mesh, "crease", "edge", Vt.IntArray([i for p in pairs for i in p]), "creases"
    )
    moving = UsdGeom.Subset.CreateGeomSubset(mesh, "moving", "face", Vt.IntArray([0]))
    moving.GetIndicesAttr().Set(Vt.IntArray([0, 1]), 1.0)
    moving.GetIndicesAttr().Set(Sdf.ValueBlock(), 5.0)
    moving.GetIndicesAttr().Set(Vt.IntArray([len(quads) - 1]), 10.0)
    stage.Save()
    out = tmp_path / "ovr.usda"
    usd.write_overrides(src, out)
    stage = Usd.Stage.Open(str(out))
    mesh, new_pts, _ = _grid_mesh(stage)
    tri = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
    crease = UsdGeom.Subset(stage.GetPrimAtPath("/World/grid/crease"))
    edges = np.asarray(crease.GetIndicesAttr().Get()).reshape(-1, 2)
    # every pair an edge of the new mesh, between the new vertices of a source pair's points
    key = {tuple(p) for p in np.sort(pts[np.array(pairs)], axis=1).reshape(len(pairs), -1).round(6)}
    got = {tuple(p) for p in np.sort(new_pts[edges], axis=1).reshape(len(edges), -1).round(6)}
    assert got == key
    tri_edges = {tuple(sorted(e)) for t in tri for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    assert all(tuple(sorted(e)) in tri_edges for e in edges.tolist())
    assert len(edges) == 2 * (len(col) - 1) + 1  # the seam's edges on both of its sides, the bottom one once
    ok, why = UsdGeom.Subset.ValidateFamily(mesh, "edge", "creases")  # (each pair an edge of the mesh)
    assert ok, why
    moving = UsdGeom.Subset(stage.GetPrimAtPath("/World/grid/moving")).GetIndicesAttr()
    assert moving.GetTimeSamples() == [1.0, 5.0, 10.0] and moving.Get(5.0) is None
    centre = new_pts[tri].mean(axis=1)
    face = np.floor(centre[:, 0]).astype(int) + n * np.floor(centre[:, 1]).astype(int)
    np.testing.assert_array_equal(np.asarray(moving.Get(1.0)), np.flatnonzero(np.isin(face, [0, 1])))
    np.testing.assert_array_equal(np.asarray(moving.Get(10.0)), np.flatnonzero(face == len(quads) - 1))
    # an edge subset of an odd number of indices names no pairs: a located error
    from swpm_usd.usd.overrides import UsdOverrideError

    stage = Usd.Stage.Open(str(src))
    UsdGeom.Subset(stage.GetPrimAtPath("/World/grid/crease")).GetIndicesAttr().Set(Vt.IntArray([0, 1, 2]))
    stage.Save()
    with pytest.raises(
        UsdOverrideError, match=r"src\.usda: /World/grid/crease: an edge GeomSubset holds pairs"
    ):
        usd.write_overrides(src, tmp_path / "bad.usda")


@pytest.mark.parametrize(
    ("kwargs", "problem"),
    [
        ({"up_axis": "X"}, "up_axis must be 'Y' or 'Z', not 'X'"),
        ({"up_axis": ""}, "up_axis must be 'Y' or 'Z', not ''"),
        ({"meters_per_unit": -1.0}, "meters_per_unit must be a finite number above 0, not -1.0"),
        ({"meters_per_unit": 0}, "meters_per_unit must be a finite number above 0, not 0"),
        ({"meters_per_unit": float("nan")}, "meters_per_unit must be a finite number above 0, not nan"),
    ],
)
def test_write_rejects_stage_metadata_usd_does_not_define(pm, tmp_path, kwargs, problem):
    """up_axis "X" (or any typo) was written as "Y" without a word, and a metersPerUnit of -1, 0 or NaN was
    written as is: the asset then came in mirrored, rotated or scaled by nonsense."""
    from swpm_usd.usd.writer import UsdWriteError

    with pytest.raises(UsdWriteError, match=re.escape(problem)):
        usd.write(pm, tmp_path / "a.usda", **kwargs)
    assert not (tmp_path / "a.usda").exists()
    stage = Usd.Stage.Open(str(usd.write(pm, tmp_path / "z.usda", up_axis="z", meters_per_unit=0.01)))
    assert UsdGeom.GetStageUpAxis(stage) == "Z" and UsdGeom.GetStageMetersPerUnit(stage) == 0.01


def test_write_to_a_folder_is_an_error_not_a_sibling_file(pm, tmp_path):
    """usd.write(pm, "out") with "out" a folder wrote "out.usdc" beside the folder (the suffix added to
    whatever the path was)."""
    from swpm_usd.usd.writer import UsdWriteError

    (tmp_path / "out").mkdir()
    with pytest.raises(UsdWriteError, match=r"out: is a folder"):
        usd.write(pm, tmp_path / "out")
    (tmp_path / "out.usda").mkdir()
    with pytest.raises(UsdWriteError, match=r"out\.usda: is a folder"):
        usd.write(pm, tmp_path / "out.usda")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "out.usda"]
    assert usd.write(pm, tmp_path / "out" / "a") == tmp_path / "out" / "a.usdc"  # a file name: as before


def test_usd_writers_raise_typed_errors_naming_the_file(pm, tmp_path):
    """A source that is missing or not USD, or an output folder that cannot be written, is a SwpmError
    naming the file (usd-core's Tf.ErrorException, with C++ file and line noise, escaped before)."""
    from swpm_usd.usd.overrides import UsdOverrideError
    from swpm_usd.usd.writer import UsdWriteError

    garbage = tmp_path / "garbage.usda"
    garbage.write_bytes(b"not usd {{{")
    for source, problem in [
        (tmp_path / "nope.usda", "file not found"),
        (garbage, "USD could not open it: .*not a valid usda layer"),
    ]:
        with pytest.raises(UsdOverrideError, match=re.escape(str(source)) + ": " + problem) as exc:
            usd.write_overrides(source, tmp_path / "ovr.usda")
        assert "Error in" not in str(exc.value)
    assert not (tmp_path / "ovr.usda").exists()
    blocker = tmp_path / "file"
    blocker.write_bytes(b"")
    with pytest.raises(UsdWriteError, match=re.escape(str(blocker / "a.usda")) + ": could not write"):
        usd.write(pm, blocker / "a.usda")  # its folder is a file
    source = usd.write(pm, tmp_path / "source.usda")
    with pytest.raises(UsdOverrideError, match=re.escape(str(blocker / "a.usda")) + ": could not write"):
        usd.write_overrides(source, blocker / "a.usda")


@pytest.mark.parametrize(
    ("name", "problem"),
    [
        ("ovr.usdz", "a .usdz package cannot be written as a layer"),
        ("ovr.txt", "'.txt' is not a USD layer suffix"),
        ("ovr", "'' is not a USD layer suffix"),
    ],
)
def test_write_overrides_to_a_path_that_is_no_layer_says_why(pm, tmp_path, name, problem):
    """Since the layer is written under a temporary name, a .usdz output said 'Cannot create new layer
    '.../.ovr.1a2b3c4d.tmp.usdz'' (the temporary file, not the output) and a .txt one 'Failed verification:
    ' fileFormat'."""
    from swpm_usd.usd.overrides import UsdOverrideError

    source = usd.write(pm, tmp_path / "source.usda")
    out = tmp_path / name
    with pytest.raises(UsdOverrideError, match=re.escape(f"{out}: could not write: {problem}")) as exc:
        usd.write_overrides(source, out)
    assert ".tmp" not in str(exc.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["source.usda"]


def test_overrides_an_edge_subset_pair_outside_the_points_names_no_edge(tmp_path):
    """An edge GeomSubset's pair with an index outside the points (``(0, n + 2)``, ``(-1, n + 1)``, n
    points) was keyed as another pair, ``(1, 2)``, ``(0, 1)``: it named a real edge of the new mesh. It names
    none, as a face or point subset's index outside its elements names none."""
    src = tmp_path / "src.usda"
    _grid_stage(src, 4)
    stage = Usd.Stage.Open(str(src))
    mesh, pts, _ = _grid_mesh(stage)
    n = len(pts)
    UsdGeom.Subset.CreateGeomSubset(mesh, "bad", "edge", Vt.IntArray([0, n + 2, -1, n + 1]))
    UsdGeom.Subset.CreateGeomSubset(mesh, "good", "edge", Vt.IntArray([0, 1, 0, n + 2]))
    stage.Save()
    out = tmp_path / "ovr.usda"
    usd.write_overrides(src, out)
    stage = Usd.Stage.Open(str(out))
    _, new_pts, _ = _grid_mesh(stage)
    bad = UsdGeom.Subset(stage.GetPrimAtPath("/World/grid/bad")).GetIndicesAttr().Get()
    assert len(bad) == 0, np.asarray(bad)
    good = np.asarray(UsdGeom.Subset(stage.GetPrimAtPath("/World/grid/good")).GetIndicesAttr().Get())
    got = {tuple(p) for p in np.sort(new_pts[good.reshape(-1, 2)], axis=1).reshape(-1, 6).round(6)}
    assert got == {tuple(np.sort(pts[[0, 1]], axis=0).reshape(-1).round(6))}  # (0, 1) alone


def test_a_failed_write_overrides_keeps_the_previous_layer(tmp_path):
    """write_overrides created its output at once (Sdf.Layer.CreateNew) and saved it at the end: a run that
    failed in between (a bad parameter, a prim that cannot be encoded) left an empty layer in place of the
    good one written before (or cleared it in memory, when it was open). It writes a temporary layer beside
    it and renames it into place."""
    src = tmp_path / "src.usda"
    _grid_stage(src, 4)
    out = tmp_path / "ovr.usda"
    usd.write_overrides(src, tmp_path / "first.usda")  # (a layer this process never opened at out)
    before = (tmp_path / "first.usda").read_bytes()
    (tmp_path / "first.usda").unlink()
    out.write_bytes(before)
    names = ["ovr.usda", "src.usda"]
    for opened in (False, True):
        layer = Sdf.Layer.FindOrOpen(str(out)) if opened else None  # open in this process too
        with pytest.raises(swpm_usd.BuildError, match="seam_weight"):
            usd.write_overrides(src, out, seam_weight=-5.0)
        assert out.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == names
    assert layer.GetPrimAtPath("/World/grid") is not None  # the open layer was not cleared either
    usd.write_overrides(src, out, "skip-strip")  # and a later run replaces it (the open layer reloaded)
    stage = Usd.Stage.Open(str(out))
    assert stage.GetPrimAtPath("/World/grid").GetAttribute("swpm:encoding").Get() == "skip-strip"
    assert layer.GetPrimAtPath("/World/grid").attributes["swpm:encoding"].default == "skip-strip"
    assert sorted(p.name for p in tmp_path.iterdir()) == names


def test_a_failed_reload_after_a_write_is_reported_as_written(pm, tmp_path, monkeypatch):
    """write_usdlod reported an error of usd-core reloading the layer open in this process, after the file
    was written and renamed into place, as "could not write" (and write_overrides and write raised the raw
    Tf.ErrorException): the file is written, and the error says so, typed."""
    from swpm_usd.usd.overrides import UsdOverrideError
    from swpm_usd.usd.writer import UsdWriteError

    asset = usd.write(pm, tmp_path / "a.usda", lods=3)
    src = tmp_path / "src.usda"
    _grid_stage(src, 4)
    lod, ovr, plain = tmp_path / "lod.usda", tmp_path / "ovr.usda", tmp_path / "plain.usda"
    usd.write_usdlod(asset, lod, pixel_error=1.0)
    usd.write_overrides(src, ovr, "vanilla")
    usd.write(pm, plain)
    layers = [Sdf.Layer.FindOrOpen(str(p)) for p in (lod, ovr, plain)]  # open in this process

    def failing_reload(self, force=False):
        Sdf.Layer.CreateNew("")  # (a real usd-core error: "cannot use empty identifier")

    monkeypatch.setattr(Sdf.Layer, "Reload", failing_reload)
    calls = [
        (lod, UsdWriteError, lambda: usd.write_usdlod(asset, lod, pixel_error=4.0)),
        (ovr, UsdOverrideError, lambda: usd.write_overrides(src, ovr, "skip-strip")),
        (plain, UsdWriteError, lambda: usd.write(pm, plain, up_axis="Z")),
    ]
    for path, error, call in calls:
        with pytest.raises(error) as exc:
            call()
        message = str(exc.value)
        assert "could not write" not in message, message
        assert message.startswith(
            f"{path}: written, but the layer of that name open in this process could not"
        )
        assert "cannot use empty identifier" in message
        reload_error = exc.value if error is UsdWriteError else exc.value.__cause__
        assert type(reload_error).__name__ == "LayerReloadError"  # (a UsdWriteError, for callers to tell)
    monkeypatch.undo()
    # each file is the new one (what the message says)
    fresh = [Sdf.Layer.OpenAsAnonymous(str(p)) for p in (lod, ovr, plain)]
    heuristic = fresh[0].GetAttributeAtPath("/ALOD/heuristics/distance.thresholds")
    old = layers[0].GetAttributeAtPath("/ALOD/heuristics/distance.thresholds")
    np.testing.assert_allclose(np.asarray(heuristic.default) * 4.0, np.asarray(old.default), rtol=1e-6)
    assert fresh[1].GetAttributeAtPath("/World/grid.swpm:encoding").default == "skip-strip"
    assert fresh[2].pseudoRoot.GetInfo("upAxis") == "Z"


def test_usd_layers_written_over_a_file_keep_its_mode(pm, tmp_path):
    """write_overrides (and write_usdlod) rename a temporary layer over the output: it took the umask's mode
    (0o644) instead of the replaced file's (0o600: a private layer became readable by everyone). usd.write
    exports through usd-core, which keeps it too."""
    import os
    import stat

    src = tmp_path / "src.usda"
    _grid_stage(src, 4)
    asset = usd.write(pm, tmp_path / "a.usda", lods=2)
    outs = {
        "ovr.usda": lambda p: usd.write_overrides(src, p),
        "a_lod.usda": lambda p: usd.write_usdlod(asset, p),
        "a.usda": lambda p: usd.write(pm, p, lods=2),
    }
    old = os.umask(0o022)
    try:
        for name, write in outs.items():
            write(tmp_path / name)
            assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o644, name  # a new file: umask's
            os.chmod(tmp_path / name, 0o600)
            write(tmp_path / name)
            assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o600, name
    finally:
        os.umask(old)


def test_overrides_leave_meshes_without_faces_to_encode(tmp_path):
    """A Mesh prim whose holeIndices list every face (or an empty placeholder Mesh) made write_overrides
    raise a bare ValueError ("cannot reshape array of size 0"); it is left as it is, as the loader leaves
    it out, and a source with nothing else is a UsdOverrideError naming the file and why."""
    from swpm_usd.usd.overrides import UsdOverrideError

    src = tmp_path / "src.usda"
    stage = Usd.Stage.CreateNew(str(src))
    for name in ("solid", "holes"):
        m = UsdGeom.Mesh.Define(stage, f"/World/{name}")
        m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)])
        m.CreateFaceVertexCountsAttr([3, 3])
        m.CreateFaceVertexIndicesAttr([0, 1, 2, 1, 3, 2])
    UsdGeom.Mesh(stage.GetPrimAtPath("/World/holes")).CreateHoleIndicesAttr([1, 0])
    UsdGeom.Mesh.Define(stage, "/World/empty")
    stage.Save()
    out = tmp_path / "ovr.usda"
    assert list(usd.write_overrides(src, out)) == ["/World/solid"]
    encoded = Usd.Stage.Open(str(out))
    assert [str(p.GetPath()) for p in usd.find_encoded(encoded)] == ["/World/solid"]
    with pytest.raises(
        UsdOverrideError, match=r"src\.usda: no Mesh prim with faces to encode: /World/empty "
    ):
        usd.write_overrides(src, tmp_path / "none.usda", prims=["/World/empty", "/World/holes"])
    with pytest.raises(UsdOverrideError, match=r"/World/holes \(every face is a hole\)"):
        usd.write_overrides(src, tmp_path / "none.usda", prims=["/World/holes"])
    assert not (tmp_path / "none.usda").exists()


def test_overrides_leave_hole_faces_out(tmp_path):
    """Faces in the source's holeIndices are not encoded, and the source's hole face numbers (which would
    name other faces of the new triangle list) are not kept on the override."""
    n = 6
    src = tmp_path / "src.usda"
    _grid_stage(src, n)
    stage = Usd.Stage.Open(str(src))
    holes = [14, 15, 20, 21]  # a 2 x 2 hole in the middle: x and y in [2, 4]
    UsdGeom.Mesh(stage.GetPrimAtPath("/World/grid")).CreateHoleIndicesAttr(Vt.IntArray(holes))
    stage.Save()
    out = tmp_path / "ovr.usda"
    result = usd.write_overrides(src, out)
    stage = Usd.Stage.Open(str(out))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/grid"))
    pts = np.asarray(mesh.GetPointsAttr().Get())
    tri = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
    assert tri.shape[0] == 2 * (n * n - len(holes)) == result["/World/grid"].triangle_count_at(0)
    assert list(mesh.GetHoleIndicesAttr().Get() or []) == []
    centre = pts[tri].mean(axis=1)[:, :2]
    assert not np.any(np.all((centre > 2) & (centre < 4), axis=1))  # nothing drawn in the hole
    subset = np.asarray(UsdGeom.Subset(stage.GetPrimAtPath("/World/grid/left")).GetIndicesAttr().Get())
    np.testing.assert_array_equal(subset, np.flatnonzero(centre[:, 0] < n / 2))
    assert validate_stage(out) == []


def test_overrides_of_a_mesh_with_bad_topology_are_override_errors(tmp_path):
    """A hole index out of range (and any other topology the loader refuses) raised the loader's private
    ValueError out of write_overrides, outside SwpmError and without naming the source file."""
    from swpm_usd.usd.overrides import UsdOverrideError

    src = tmp_path / "src.usda"
    _grid_stage(src, 4)
    stage = Usd.Stage.Open(str(src))
    UsdGeom.Mesh(stage.GetPrimAtPath("/World/grid")).CreateHoleIndicesAttr(Vt.IntArray([3, 99]))
    stage.Save()
    out = tmp_path / "ovr.usda"
    problem = r": /World/grid: holeIndices\[1\] = 99 out of range for 16 faces"
    with pytest.raises(UsdOverrideError, match=re.escape(str(src)) + problem):
        usd.write_overrides(src, out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["src.usda"]


# -- discrete LODs -----------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "problem"),
    [
        ({"pixel_error": 0}, "pixel_error must be a finite number above 0, not 0"),
        ({"pixel_error": -1.0}, "pixel_error must be a finite number above 0, not -1.0"),
        ({"pixel_error": float("nan")}, "pixel_error must be a finite number above 0, not nan"),
        ({"viewport_px": 0}, "viewport_px must be at least 1, not 0"),
        ({"fov_degrees": 0}, "fov_degrees must be in (0, 180), not 0"),
        ({"fov_degrees": 180}, "fov_degrees must be in (0, 180), not 180"),
    ],
)
def test_write_usdlod_rejects_arguments_that_make_no_thresholds(pm, tmp_path, kwargs, problem):
    """pixel_error 0, -1 or NaN and viewport_px 0 wrote inf / NaN / negative-derived LOD thresholds, and
    fov_degrees 0 raised ZeroDivisionError."""
    from swpm_usd.usd.writer import UsdWriteError

    asset = usd.write(pm, tmp_path / "a.usda", lods=3)
    with pytest.raises(UsdWriteError, match=re.escape(problem)):
        usd.write_usdlod(asset, tmp_path / "a_lod.usda", **kwargs)
    assert not (tmp_path / "a_lod.usda").exists()


def test_write_usdlod_errors_name_the_file(pm, tmp_path):
    """A missing asset raised usd-core's raw Tf.ErrorException; the asset's own path as the output cleared
    the asset's open layer and died in a RuntimeError ("Accessed invalid expired prim")."""
    from swpm_usd.usd.writer import UsdWriteError

    with pytest.raises(UsdWriteError, match=r"nope\.usda: USD could not open it"):
        usd.write_usdlod(tmp_path / "nope.usda", tmp_path / "x.usda")
    asset = usd.write(pm, tmp_path / "a.usda", lods=3)
    before = asset.read_bytes()
    with pytest.raises(UsdWriteError, match="the LOD layer must not be the asset"):
        usd.write_usdlod(asset, asset)
    assert asset.read_bytes() == before
    assert usd.read(Usd.Stage.Open(str(asset)).GetDefaultPrim()).lod_count == pm.lod_count


def test_write_usdlod_failure_leaves_the_previous_layer(pm, tmp_path, monkeypatch):
    """write_usdlod created its layer at the output path (Sdf.Layer.CreateNew writes an empty layer at once)
    and authored it there: a failure while authoring left an empty layer in place of the previous one. It
    writes a temporary layer beside it and renames it into place; a layer of it open in this process is
    reloaded once replaced, and a replaced layer keeps its mode."""
    import os
    import stat

    from swpm_usd.usd import writer

    asset = usd.write(pm, tmp_path / "a.usda", lods=3)
    out = usd.write_usdlod(asset, tmp_path / "a_lod.usda")
    os.chmod(out, 0o640)
    before = out.read_bytes()

    def fail(*args, **kwargs):
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(writer, "_thresholds", fail)
    with pytest.raises(RuntimeError, match="disk on fire"):
        usd.write_usdlod(asset, out, pixel_error=2.0)
    assert out.read_bytes() == before  # (it was an empty layer, 11 bytes)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.usda", "a_lod.usda"]  # no temporary left
    open_layer = Sdf.Layer.FindOrOpen(str(out))
    with pytest.raises(RuntimeError, match="disk on fire"):
        usd.write_usdlod(asset, out, pixel_error=2.0)
    assert not open_layer.dirty and open_layer.ExportToString() == before.decode()  # (it was cleared)
    monkeypatch.undo()

    usd.write_usdlod(asset, out, pixel_error=2.0)
    assert out.read_bytes() != before
    assert stat.S_IMODE(out.stat().st_mode) == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.usda", "a_lod.usda"]
    assert not open_layer.dirty and open_layer.ExportToString() == out.read_text()  # (reloaded)


def test_lod_variants_and_usdlod(pm, tmp_path):
    asset = usd.write(pm, tmp_path / "lods.usdc", lods=4)
    stage = Usd.Stage.Open(str(asset))
    prim = stage.GetPrimAtPath("/Lods/mesh")
    lods = np.asarray(prim.GetAttribute("swpm:discreteLods").Get())
    assert len(lods) == 4 and lods[0] == 0 and np.all(np.diff(lods) > 0)
    vset = prim.GetVariantSets().GetVariantSet("LOD")
    assert vset.GetVariantSelection() == "LOD0"
    for i, k in enumerate(lods):
        vset.SetVariantSelection(f"LOD{i}")
        fvi = np.asarray(UsdGeom.Mesh(prim).GetFaceVertexIndicesAttr().Get())
        np.testing.assert_array_equal(fvi, pm.triangles_at(int(k)).ravel())
    assert usd.select_lods(pm, 3, by="error")[0] == 0
    layer = usd.write_usdlod(asset, tmp_path / "lods_lod.usda")
    lstage = Usd.Stage.Open(str(layer))
    from pxr import UsdLod

    root = lstage.GetPrimAtPath("/LodsLOD/lod")
    assert root.HasAPI(UsdLod.RootAPI)
    assert [c.GetName() for c in root.GetChildren()] == [f"LOD{i}" for i in range(4)]
    dist = np.asarray(
        UsdLod.DistanceHeuristic(lstage.GetPrimAtPath("/LodsLOD/heuristics/distance"))
        .GetThresholdsAttr()
        .Get()
    )
    size = np.asarray(
        UsdLod.ScreenSizeHeuristic(lstage.GetPrimAtPath("/LodsLOD/heuristics/screenSize"))
        .GetThresholdsAttr()
        .Get()
    )
    assert len(dist) == len(size) == 3 and np.all(np.diff(dist) > 0) and np.all(np.diff(size) < 0)
    coarse = lstage.GetPrimAtPath("/LodsLOD/lod/LOD3/mesh")
    assert len(UsdGeom.Mesh(coarse).GetFaceVertexIndicesAttr().Get()) == 3 * pm.triangle_count_at(
        int(lods[3])
    )
    _assert_same(usd.read_buffers(coarse), pm.buffers())
    assert validate_stage(asset) == [] and validate_stage(layer) == []


# -- validation --------------------------------------------------------------------------------------------
def _corrupt(src: Path, dst: Path, edit) -> Path:
    stage = Usd.Stage.Open(str(src))
    edit(stage.GetPrimAtPath(stage.GetDefaultPrim().GetPath().AppendChild("mesh")))
    stage.GetRootLayer().Export(str(dst))
    return dst


def test_write_usdlod_references_the_asset_file_relative(pm, tmp_path):
    """The LOD layer's sources reference the asset as scene.usda does, ``./spot.usda`` (``../a/spot.usda``
    from another folder): it wrote ``spot.usda``, a search path to USD, which a studio's resolver may look
    up in its search paths instead of beside the layer."""
    asset = usd.write(pm, tmp_path / "a" / "spot.usda", lods=2)
    for out, expected in (
        (tmp_path / "a" / "lod.usda", "./spot.usda"),
        (tmp_path / "b" / "lod.usda", "../a/spot.usda"),
    ):
        layer = Sdf.Layer.FindOrOpen(str(usd.write_usdlod(asset, out)))
        spec = layer.GetPrimAtPath("/SpotLOD/sources/LOD1")
        assert [r.assetPath for r in spec.referenceList.GetAddedOrExplicitItems()] == [expected]
        stage = Usd.Stage.Open(layer)
        assert usd.read(stage.GetPrimAtPath("/SpotLOD/lod/LOD1")).lod_count == pm.lod_count


def test_select_lods_names_a_ratio_that_is_negative_or_nan(pm):
    """lod_for_triangles refuses a negative or NaN target (helper-138): a ratio that made one is named as
    the ratio, not as a "target" the caller never passed (main: a negative ratio's odd levels were the
    coarsest LOD, NaN "cannot convert float NaN to integer")."""
    from swpm_usd.usd.writer import UsdWriteError

    for bad in (-0.5, float("nan"), math.inf):
        with pytest.raises(UsdWriteError, match="ratio"):
            usd.select_lods(pm, 3, ratio=bad)
    assert usd.select_lods(pm, 3, ratio=0.0) == [0, pm.lod_for_triangles(0)]  # (0**0 is 1: LOD 0 first)
    assert usd.select_lods(pm, 3, ratio=1.0) == [0]


def _retype(prim, name, type_name, value):
    """Author ``name`` with another type at the layer level (the Usd API would refuse it)."""
    spec = prim.GetStage().GetRootLayer().GetPrimAtPath(prim.GetPath())
    spec.RemoveProperty(spec.properties[name])
    attr = Sdf.AttributeSpec(spec, name, type_name, Sdf.VariabilityUniform)
    attr.default = value


def test_corruptions_are_reported_with_path_and_code(mesh, asset, tmp_path):
    import swpm_usd.encode.slidingwindow as sw

    sw_asset = usd.write(sw.build_sliding_window(mesh), tmp_path / "sw.usdc")
    sw_stage = Usd.Stage.Open(str(sw_asset))
    pool_len = len(sw_stage.GetPrimAtPath("/Sw/mesh").GetAttribute("swpm:indexPool").Get())

    def window_out(prim):
        w = np.asarray(prim.GetAttribute("swpm:windowRecords").Get()).copy()
        w[0] = pool_len  # first index offset past the pool
        prim.GetAttribute("swpm:windowRecords").Set(Vt.UIntArray.FromNumpy(w))

    cases = {
        "SWPM_USD_WINDOW_RANGE": (sw_asset, window_out),
        "SWPM_USD_TYPE": (
            asset,
            lambda p: _retype(
                p, "swpm:indices", Sdf.ValueTypeNames.FloatArray, Vt.FloatArray([0.5, 1.5, 2.5])
            ),
        ),
        "SWPM_USD_ENCODING": (asset, lambda p: p.GetAttribute("swpm:encoding").Set("quantum")),
        "SWPM_USD_INDEX_RANGE": (
            asset,
            lambda p: p.GetAttribute("swpm:indices").Set(
                Vt.UIntArray.FromNumpy(np.r_[np.asarray(p.GetAttribute("swpm:indices").Get())[:-1], 10**6])
            ),
        ),
        "SWPM_USD_STRIDE": (
            asset,
            lambda p: p.GetAttribute("swpm:collapseRecords").Set(
                Vt.UIntArray.FromNumpy(np.asarray(p.GetAttribute("swpm:collapseRecords").Get())[:-1].copy())
            ),
        ),
    }
    for code, (src, edit) in cases.items():
        assert code in CODES
        bad = _corrupt(src, tmp_path / f"{code}.usdc", edit)
        findings = validate_stage(bad)
        ours = [f for f in findings if f.code == code]
        assert ours, (code, findings)
        assert ours[0].prim.endswith("/mesh") and ours[0].severity == "error"
        json.dumps([f.to_dict() for f in findings])


@pytest.mark.parametrize(
    "params",
    ['{"a": NaN}', '{"a": 1e400}', '{"a": 1, "a": 2}', '{"a": ' + "[" * 140 + "]" * 140 + "}"],
    ids=["nan", "infinite", "duplicate-key", "140-deep"],
)
def test_params_follow_the_swpm_meta_rules_in_a_stage_too(asset, tmp_path, params):
    # swpm:params was read with plain json.loads: a stage could hold params its .swpm twin's reader rejects
    # (spec/format.md 3.1), and validate, read and the writer each answered otherwise
    bad = _corrupt(asset, tmp_path / "bad.usdc", lambda p: p.GetAttribute("swpm:params").Set(params))
    assert [f.code for f in validate_stage(bad) if f.code == "SWPM_USD_PARAMS"] == ["SWPM_USD_PARAMS"]
    stage = Usd.Stage.Open(str(bad))
    with pytest.raises(UsdReadError, match="bad.usdc"):
        usd.read(stage.GetPrimAtPath(stage.GetDefaultPrim().GetPath().AppendChild("mesh")))


def test_the_writer_refuses_params_a_reader_rejects(pm, tmp_path):
    import copy

    from swpm_usd.usd.writer import UsdWriteError

    def with_params(extra: dict):
        out = copy.copy(pm)
        out.params = {**pm.params, **extra}
        return out

    deep: list = []
    for _ in range(140):
        deep = [deep]
    for bad in ({"tolerance": float("nan")}, {"n": 10**400}, {"deep": deep}):
        with pytest.raises(UsdWriteError, match="swpm:params"):
            usd.write(with_params(bad), tmp_path / "out.usdc")
        assert not (tmp_path / "out.usdc").exists()
    for _ in range(20):  # 120 deep in an object: within the 128 levels a reader takes
        deep = deep[0]
    ok = usd.write(with_params({"deep": deep}), tmp_path / "ok.usdc")
    assert validate_stage(ok) == []
    stage = Usd.Stage.Open(str(ok))
    assert usd.read(stage.GetDefaultPrim()).params["deep"] == deep


def test_cli_reports_json_and_exit_code(asset, tmp_path):
    from click.testing import CliRunner

    from swpm_usd.usd.cli import validate_usd

    ok = CliRunner().invoke(validate_usd, [str(asset), "--json"])
    assert ok.exit_code == 0 and json.loads(ok.output)["errors"] == 0
    bad = _corrupt(asset, tmp_path / "bad.usda", lambda p: p.GetAttribute("swpm:encoding").Set("nope"))
    res = CliRunner().invoke(validate_usd, [str(bad)])
    assert res.exit_code == 1 and "SWPM_USD_ENCODING /Suzanne/mesh" in res.output


def _remove(name):
    return lambda p: p.RemoveProperty(name)


@pytest.mark.parametrize("name", ["swpm:encoding", "swpm:formatVersion", "swpm:indices", "points"])
def test_an_attribute_left_out_is_missing_not_its_schema_fallback(asset, tmp_path, name):
    """A required attribute removed from the layer: with the schema registered ``Get()`` gave its fallback
    (``vanilla``, 1, ``[]``), so a prim without ``swpm:encoding`` or ``swpm:formatVersion`` validated and
    read (a tool without the plugin reads no value there), one without ``swpm:indices`` was
    ``SWPM_USD_REBUILD`` and one without points ``SWPM_USD_INDEX_RANGE``."""
    bad = _corrupt(asset, tmp_path / "bad.usdc", _remove(name))
    findings = [f for f in validate_stage(bad) if f.code.startswith("SWPM_")]
    assert [(f.code, f.prim) for f in findings] == [("SWPM_USD_MISSING", "/Suzanne/mesh")]
    assert findings[0].message == f"{name} has no value"
    stage = Usd.Stage.Open(str(bad))
    with pytest.raises(UsdReadError, match=f"^{bad}: /Suzanne/mesh: attribute {name} is missing$"):
        usd.read(stage.GetDefaultPrim())


def test_an_optional_attribute_left_out_is_not_checked_as_its_fallback(asset, tmp_path):
    """swpm:indexWidth is optional: left out, validate checked its schema fallback 4 against the 2 the
    indices need and said ``swpm:indexWidth is 4`` of a stage that authors none."""
    bad = _corrupt(asset, tmp_path / "bad.usdc", _remove("swpm:indexWidth"))
    assert validate_stage(bad) == []


def test_a_uniform_attribute_with_only_time_samples_has_no_value(asset, tmp_path):
    def sampled(p):
        a = p.GetAttribute("swpm:lodErrors")
        value = a.Get()
        a.Clear()
        a.Set(value, 1.0)

    bad = _corrupt(asset, tmp_path / "bad.usdc", sampled)
    [finding] = [f for f in validate_stage(bad) if f.code.startswith("SWPM_")]
    assert finding.code == "SWPM_USD_MISSING"
    assert finding.message.startswith("swpm:lodErrors has no value (it has only time samples)")
    stage = Usd.Stage.Open(str(bad))
    with pytest.raises(UsdReadError, match="swpm:lodErrors is missing \\(it has only time samples\\)"):
        usd.read(stage.GetDefaultPrim())


@pytest.mark.parametrize(
    ("name", "type_name", "value", "authored"),
    [
        ("swpm:indices", Sdf.ValueTypeNames.FloatArray, None, "float[]"),
        ("swpm:indices", Sdf.ValueTypeNames.IntArray, None, "int[]"),
        ("swpm:vertexCounts", Sdf.ValueTypeNames.IntArray, None, "int[]"),
        ("swpm:encoding", Sdf.ValueTypeNames.String, "vanilla", "string"),
    ],
)
def test_read_refuses_an_attribute_of_another_type_as_validate_does(
    asset, tmp_path, name, type_name, value, authored
):
    """The same values under another type: validate's SWPM_USD_TYPE, which read passed, casting them (a
    float index 1.5 read as 1, an int -1 as 4294967295)."""

    def retype(p):
        v = value if value is not None else type_name.type.pythonClass(list(p.GetAttribute(name).Get()))
        _retype(p, name, type_name, v)

    bad = _corrupt(asset, tmp_path / "bad.usda", retype)
    assert "SWPM_USD_TYPE" in [f.code for f in validate_stage(bad)]
    expected = PROPERTY_TYPES[name]
    stage = Usd.Stage.Open(str(bad))
    with pytest.raises(
        UsdReadError,
        match=f"^{bad}: /Suzanne/mesh: {name} is authored as {re.escape(authored)}, "
        f"expected {re.escape(expected)}$",
    ):
        usd.read(stage.GetDefaultPrim())


def test_usd_core_type_mismatch_is_reported_at_its_prim(asset, tmp_path):
    """usdValidation:AttributeTypeMismatch names the attribute's spec in a layer, not a stage object: its
    finding was at ``/`` beside ours at /Suzanne/mesh; in the stage's own layers a spec's path is the
    prim's (through a reference it is the layer's own path: still ``/``)."""
    bad = _corrupt(
        asset,
        tmp_path / "bad.usda",
        lambda p: _retype(p, "swpm:indices", Sdf.ValueTypeNames.IntArray, Vt.IntArray([0, 1, 2])),
    )
    found = {f.code: f.prim for f in validate_stage(bad)}
    assert found["usdValidation:AttributeTypeMismatch.AttributeTypeMismatch"] == "/Suzanne/mesh"
    assert found["SWPM_USD_TYPE"] == "/Suzanne/mesh"
    shot = tmp_path / "shot.usda"
    stage = Usd.Stage.CreateNew(str(shot))
    stage.DefinePrim("/World/a").GetReferences().AddReference(f"./{bad.name}")
    stage.GetRootLayer().Save()
    found = {f.code: f.prim for f in validate_stage(shot)}
    assert found["usdValidation:AttributeTypeMismatch.AttributeTypeMismatch"] == "/"
    assert found["SWPM_USD_TYPE"] == "/World/a/mesh"


def test_read_refuses_a_format_version_it_does_not_read(asset, tmp_path):
    """swpm:formatVersion 2 (a later layout): validate's SWPM_USD_VERSION, which read passed, reading the
    buffers as version 1's."""
    bad = _corrupt(asset, tmp_path / "bad.usdc", lambda p: p.GetAttribute("swpm:formatVersion").Set(2))
    assert [f.code for f in validate_stage(bad)] == ["SWPM_USD_VERSION"]
    stage = Usd.Stage.Open(str(bad))
    for fn in (usd.read, usd.read_buffers):
        stage = Usd.Stage.Open(str(bad))
        with pytest.raises(
            UsdReadError, match="swpm:formatVersion 2 is not supported \\(this reader reads 1\\)"
        ):
            fn(stage.GetDefaultPrim())


def test_read_names_the_attribute_of_bad_params_and_a_bad_row_width(tmp_path, mesh):
    """read's errors name the attribute: params [1, 2] was "the stored arrays do not form a progressive
    mesh: cannot convert dictionary update sequence element #0 to a sequence", windowRecords of 5 entries
    "cannot reshape array of size 5 into shape (3)"."""
    import swpm_usd.encode.slidingwindow as sw

    src = usd.write(sw.build_sliding_window(mesh), tmp_path / "sw.usdc")
    bad = _corrupt(src, tmp_path / "params.usdc", lambda p: p.GetAttribute("swpm:params").Set("[1, 2]"))
    stage = Usd.Stage.Open(str(bad))
    with pytest.raises(UsdReadError, match="/Sw/mesh: swpm:params is not a JSON object .* a JSON list"):
        usd.read(stage.GetDefaultPrim())

    def cut(p):
        p.GetAttribute("swpm:windowRecords").Set(Vt.UIntArray([0, 1, 2, 3, 4]))

    bad = _corrupt(src, tmp_path / "rows.usdc", cut)
    stage = Usd.Stage.Open(str(bad))
    with pytest.raises(
        UsdReadError, match="/Sw/mesh: swpm:windowRecords has 5 entries, not a multiple of its row width 3"
    ):
        usd.read_buffers(stage.GetDefaultPrim())


@pytest.mark.parametrize("name", ["swpm:indices", "normals"])
def test_a_value_usd_core_cannot_read_is_a_usd_read_error(pm, tmp_path, monkeypatch, name):
    """A value of a corrupt .usdc that does not decompress (usd-core: "Failed to decompress data, possibly
    corrupt? LZ4 error code: -464", found flipping bytes of a written asset) reached the caller of read as
    pxr's Tf.ErrorException; it is a UsdReadError naming the prim (and the swpm: attribute)."""
    path = usd.write(pm, tmp_path / "suzanne.usdc")
    real = Usd.Attribute.Get

    def corrupt(attr, *args):
        if attr.GetName() == name:
            from pxr import Tf

            Tf.RaiseRuntimeError("Failed to decompress data, possibly corrupt? LZ4 error code: -464")
        return real(attr, *args)

    stage = Usd.Stage.Open(str(path))
    monkeypatch.setattr(Usd.Attribute, "Get", corrupt)
    what = name if name.startswith("swpm:") else "a value"
    with pytest.raises(
        UsdReadError, match=f"^{path}: /Suzanne/mesh: usd-core cannot read {what}: .*LZ4 error"
    ):
        usd.read(stage.GetDefaultPrim())


@pytest.mark.parametrize("encoding", sorted(BUILDERS))
def test_an_edited_stage_is_rejected_before_the_runtime(encoding, mesh, tmp_path):
    """Every swpm: uint[] array of a written prim, one element set out of range or off by one: ``read``
    raises a UsdReadError naming the file and the prim, or returns a mesh whose every LOD indexes inside
    its vertex prefix and whose runtime instance walks the LODs. Before the check, a collapse record
    pointing outside the index buffer crashed the process in ``set_lod``."""
    pm = swpm_usd.build(mesh, encoding)
    path = usd.write(pm, tmp_path / "suzanne.usdc")
    stage = Usd.Stage.Open(str(path))
    prim = usd.find_encoded(stage)[0]
    arrays = [
        a
        for a in prim.GetAttributes()
        if a.GetName().startswith("swpm:") and a.GetTypeName() == Sdf.ValueTypeNames.UIntArray and a.Get()
    ]
    assert len(arrays) >= 4
    rejected = 0
    for attr in arrays:
        original = np.array(attr.Get(), np.int64)
        for i, value in (
            (original.size // 2, 2**32 - 1),
            (original.size // 3, original[original.size // 3] + 1),
        ):
            edited = original.copy()
            edited[i] = value
            attr.Set(Vt.UIntArray.FromNumpy(edited.astype(np.uint32)))
            try:
                back = usd.read(prim)
            except UsdReadError as e:
                assert str(e).startswith(f"{path}: {prim.GetPath()}: "), e
                rejected += 1
                continue
            for k in range(back.lod_count):
                t = back.triangles_at(k)
                assert t.size == 0 or t.max() < back.vertex_count_at(k), (attr.GetName(), i, k)
            if hasattr(back, "instance"):
                inst = back.instance()
                for k in (back.lod_count - 1, back.lod_count // 2, 0):
                    inst.set_lod(k)
        attr.Set(Vt.UIntArray.FromNumpy(original.astype(np.uint32)))
    assert rejected >= len(arrays)  # every out-of-range value at least
    usd.read(prim)  # restored: reads again


def test_read_flattens_indexed_primvars(pm, tmp_path):
    """A DCC that re-saves an asset may store primvars indexed (distinct values + indices); read returned the
    distinct values as if they were per vertex (wrong uvs and colours, or a length error)."""
    path = usd.write(pm, tmp_path / "a.usda")
    stage = Usd.Stage.Open(str(path))
    prim = usd.find_encoded(stage)[0]
    api = UsdGeom.PrimvarsAPI(prim)
    for name, values in (("st", pm.attributes["uv"]), ("displayColor", pm.attributes["color"][:, :3])):
        unique, inverse = np.unique(values, axis=0, return_inverse=True)
        pv = api.GetPrimvar(name)
        pv.Set(pv.GetAttr().Get().__class__.FromNumpy(unique[::-1].copy()))
        pv.SetIndices(Vt.IntArray.FromNumpy((len(unique) - 1 - inverse.ravel()).astype(np.int32)))
        assert len(unique) < len(values)
    back = usd.read(prim)
    for name in ("uv", "color", "normal", "weight"):
        np.testing.assert_array_equal(back.attributes[name], pm.attributes[name])
    assert validate_prim(prim) == []


@pytest.mark.parametrize("name", ["st", "displayColor", "displayOpacity", "normals", "weight"])
def test_read_of_an_indexed_primvar_with_indices_out_of_range_says_so(pm, tmp_path, name):
    """usd-core's ComputeFlattened gives None for indices out of range: read said the attribute 'has no
    stored primvar' (displayOpacity: a bare ValueError out of numpy)."""
    path = usd.write(pm, tmp_path / "a.usda")
    stage = Usd.Stage.Open(str(path))
    prim = usd.find_encoded(stage)[0]
    api = UsdGeom.PrimvarsAPI(prim)
    if name == "normals":  # (the writer stores the normals attribute: a DCC may re-save it as a primvar)
        api.CreatePrimvar("normals", Sdf.ValueTypeNames.Normal3fArray, "vertex").Set(
            UsdGeom.Mesh(prim).GetNormalsAttr().Get()
        )
    elif name == "displayOpacity":
        api.CreatePrimvar("displayOpacity", Sdf.ValueTypeNames.FloatArray, "vertex").Set(
            Vt.FloatArray.FromNumpy(np.ones(pm.vertex_count, np.float32))
        )
    pv = api.GetPrimvar(name)
    n = len(pv.Get())
    pv.SetIndices(Vt.IntArray([0] * (n - 1) + [n]))
    problem = f"{prim.GetPath()}: primvar '{name}' has indices out of range for its {n} values"
    with pytest.raises(UsdReadError, match=re.escape(problem)):
        usd.read(prim, check=False)
    (finding,) = validate_prim(prim)
    assert finding.code == "SWPM_USD_REBUILD" and problem in finding.message


@pytest.mark.parametrize("encoding", ["vanilla", "mixed"])
@pytest.mark.parametrize("dtype", ["V1000000000", "object", "complex128", "datetime64", "float16", "S4"])
def test_a_hostile_dtype_token_is_rejected_before_anything_is_allocated(encoding, dtype, mesh, tmp_path):
    """swpm:bufferDtypes / swpm:attributeDtypes name what the arrays are cast to: a dtype the writer never
    stores was cast to as given. "V1000000000" allocated 1 GB per element (a validate of the stage was
    killed by the OOM killer at 24 GB), "datetime64" raised a TypeError out of read, and "float16" index
    buffers passed read's check to crash the runtime (draw_stream: "slice indices must be integers"; float16
    attributes are fine)."""
    import resource

    path = usd.write(swpm_usd.build(mesh, encoding), tmp_path / "a.usda")
    for name in ("swpm:bufferDtypes", "swpm:attributeDtypes")[: 1 if dtype == "float16" else 2]:
        stage = Usd.Stage.Open(str(path))
        prim = usd.find_encoded(stage)[0]
        attr = prim.GetAttribute(name)
        attr.Set(Vt.TokenArray([dtype] * len(attr.Get())))
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        with pytest.raises(UsdReadError, match=rf"{prim.GetPath()}: {name}\[0\] = '{dtype}' is not"):
            usd.read(prim)
        (finding,) = validate_prim(prim)
        assert finding.code == "SWPM_USD_TYPE" and repr(dtype) in finding.message
        assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 100_000  # KiB
        Sdf.Layer.Find(str(path)).Reload(force=True)


def test_validate_reports_a_usd_file_that_does_not_open_as_a_coded_error(tmp_path):
    from click.testing import CliRunner

    from swpm_usd.cli import main

    cases = {
        "truncated.usda": b'#usda 1.0\n(\n    defaultPrim = "W"\n)\ndef Mesh "W" {\n    point3f[] p = [(0, 0',
        "empty.usda": b"",
        "random.usdc": bytes(range(256)) * 8,
        "renamed.usda": b"SWPM\r\n\x1a\n" + b"\0" * 64,
    }
    for name, data in cases.items():
        path = tmp_path / name
        path.write_bytes(data)
        (finding,) = validate_stage(path)
        assert finding.code == "SWPM_USD_OPEN" and finding.code in CODES and finding.severity == "error"
        assert name in finding.message
        result = CliRunner().invoke(main, ["validate", str(path), "--json"])
        assert result.exit_code == 1
        rep = json.loads(result.output)
        assert rep["errors"] == 1 and rep["findings"][0]["code"] == "SWPM_USD_OPEN"
        result = CliRunner().invoke(main, ["validate", str(path)])
        assert result.exit_code == 1 and "SWPM_USD_OPEN" in result.output
    assert "empty" in validate_stage(tmp_path / "empty.usda")[0].message
    assert "SWPM file" in validate_stage(tmp_path / "renamed.usda")[0].message


def test_validate_json_of_a_missing_usd_file_is_a_report(tmp_path):
    """``validate --json`` prints a report for a USD path that does not exist, as it does for a missing .swpm
    file (stdout was empty: a script reading it got no JSON)."""
    from click.testing import CliRunner

    from swpm_usd.cli import main

    path = tmp_path / "nope.usda"
    result = CliRunner().invoke(main, ["validate", str(path), "--json"])
    assert result.exit_code == 1
    rep = json.loads(result.stdout)
    assert rep["stage"] == str(path) and rep["errors"] == 1
    assert rep["findings"][0]["code"] == "SWPM_USD_OPEN" and "nope.usda" in rep["findings"][0]["message"]
    # (in the words of the line on stderr: usd-core's were "... (No such file or directory): Failed to ...")
    assert (
        rep["findings"][0]["message"] == f"{path}: file not found"
        and result.stderr == f"error: {path}: file not found\n"
    )
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 1 and "nope.usda: file not found" in result.stderr


def test_validate_reports_a_value_usd_core_cannot_read_as_a_coded_error(tmp_path, monkeypatch):
    """A bit flipped in a .usdc's compressed values (found flipping bytes of a written asset) opens, then
    makes usd-core's validation raise ("Failed to decompress data, possibly corrupt? LZ4 error code: -464",
    "Corrupt asset ...: exception thrown unpacking a value"): ``validate`` printed a traceback. It is a
    coded error naming the file (SWPM_USD_READ), the findings made before it kept."""
    from click.testing import CliRunner

    from swpm_usd.cli import main
    from swpm_usd.usd import validate as validate_module

    path = tmp_path / "v.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Mesh.Define(stage, "/M")
    stage.GetRootLayer().Save()

    class Corrupt:
        def __init__(self, validators):
            pass

        def Validate(self, stage):  # noqa: N802 - usd-core's name
            raise RuntimeError(
                "\n\tError in 'pxrInternal_v0_26_11__pxrReserved__::TfFastCompression::DecompressFromBuffer'"
                " at line 102 in file /opt/USD/pxr/base/tf/fastCompression.cpp : 'Failed to decompress data, "
                "possibly corrupt? LZ4 error code: -464'\n"
            )

    monkeypatch.setattr(validate_module.UsdValidation, "ValidationContext", Corrupt)
    (finding,) = validate_stage(path)
    assert finding.code == "SWPM_USD_READ" and finding.code in CODES and finding.severity == "error"
    assert finding.message == (
        f"{path}: usd-core cannot read it: Failed to decompress data, possibly corrupt? LZ4 error code: -464"
    )
    result = CliRunner().invoke(main, ["validate", str(path), "--json"])
    assert result.exit_code == 1 and isinstance(result.exception, SystemExit | None)
    assert json.loads(result.stdout)["findings"][0]["code"] == "SWPM_USD_READ"
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 1 and "SWPM_USD_READ" in result.output and "Traceback" not in result.output


def test_validate_does_not_report_a_bug_of_its_own_as_a_file_usd_core_cannot_read(tmp_path, monkeypatch):
    """SWPM_USD_READ is usd-core's Tf.ErrorException (a RuntimeError) on a corrupt value; a Python error of
    the validator itself (here a TypeError) was reported as "usd-core cannot read it", blaming the file."""
    from swpm_usd.usd import validate as validate_module

    path = tmp_path / "v.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Mesh.Define(stage, "/M")
    stage.GetRootLayer().Save()

    def broken(prim):
        raise TypeError("a bug")

    monkeypatch.setattr(validate_module, "validate_prim", broken)
    with pytest.raises(TypeError, match="a bug"):
        validate_stage(path, builtin=False)


def test_a_failed_reload_kept_by_the_caller_does_not_keep_the_temporary_layer(pm, tmp_path, monkeypatch):
    """write_usdlod and write_overrides author a layer at a temporary name, renamed over the output, then
    reload the layer of that name open in this process: a reload that failed raised an error whose traceback
    held the temporary layer (the frames of the write and of fileio.new_layer_replacing), so a caller that
    kept the error (a log, a notebook's last error) kept that layer, all its meshes, in memory and in
    usd-core's registry of loaded layers, named after a file that no longer exists."""
    import gc

    from swpm_usd.usd.overrides import UsdOverrideError
    from swpm_usd.usd.writer import UsdWriteError

    asset = usd.write(pm, tmp_path / "a.usda", lods=3)
    src = tmp_path / "src.usda"
    _grid_stage(src, 4)
    lod, ovr = tmp_path / "lod.usda", tmp_path / "ovr.usda"
    usd.write_usdlod(asset, lod, pixel_error=1.0)
    usd.write_overrides(src, ovr, "vanilla")
    opened = [Sdf.Layer.FindOrOpen(str(p)) for p in (lod, ovr)]  # open in this process

    def failing_reload(self, force=False):
        Sdf.Layer.CreateNew("")  # (a real usd-core error: "cannot use empty identifier")

    def temporary_layers() -> list[str]:
        gc.collect()
        return [
            layer.identifier
            for layer in Sdf.Layer.GetLoadedLayers()
            if Path(layer.identifier).parent == tmp_path and ".tmp." in Path(layer.identifier).name
        ]

    kept = []
    with monkeypatch.context() as m:
        m.setattr(Sdf.Layer, "Reload", failing_reload)
        for error, call in (
            (UsdWriteError, lambda: usd.write_usdlod(asset, lod, pixel_error=4.0)),
            (UsdOverrideError, lambda: usd.write_overrides(src, ovr, "skip-strip")),
        ):
            with pytest.raises(error) as exc:
                call()
            assert "written, but the layer of that name open in this process could not" in str(exc.value)
            kept.append(exc)  # (the error kept, with its traceback and cause)
    assert temporary_layers() == []
    assert all(layer.rootPrims for layer in opened)  # (their previous content: not reloaded)
    # each file is the new one, and written again in this process
    assert Sdf.Layer.OpenAsAnonymous(str(ovr)).GetAttributeAtPath("/World/grid.swpm:encoding").default == (
        "skip-strip"
    )
    usd.write_overrides(src, ovr, "vanilla")
    assert len(kept) == 2 and temporary_layers() == []
