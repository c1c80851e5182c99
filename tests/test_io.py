"""Tests of mesh loading (swpm_usd.io): shared test meshes, seams, trimesh formats, USD, cleaning, errors."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh
from pxr import Gf, Sdf, Usd, UsdGeom, UsdUtils, Vt

from swpm_usd.errors import MeshLoadError
from swpm_usd.io import clean_mesh, load_mesh
from swpm_usd.mesh import Mesh

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "meshes"

# README T is the count after fan triangulation; differences must be explained by what cleaning dropped.
EXPECTED_DROPS = {"suzanne.obj": {"duplicate_dropped": 1}}  # quads 142/143 share a triangle, opposite winding
# loaded vertex counts: seams split spot/bob/beetle, teapot's patch-seam duplicates weld, bunny has 1113 `v`
# lines no face uses (trimesh's OBJ reader already leaves them out), suzanne has normal seams
EXPECTED_V = {
    "stanford-bunny.obj": 34834,
    "spot.obj": 3225,
    "bob.obj": 5647,
    "teapot.obj": 3241,
    "beetle.obj": 1254,
}
EXPECTED_MERGED = {"teapot.obj": 403}


def _readme_table() -> dict[str, tuple[int, int]]:
    rows = {}
    for line in (SHARED / "README.md").read_text().splitlines():
        m = re.match(r"\|\s*([\w.-]+\.obj)\s*\|\s*(\d+)\s*\|\s*(\d+)\s*\|", line)
        if m:
            rows[m.group(1)] = (int(m.group(2)), int(m.group(3)))
    return rows


README = _readme_table()


def test_readme_lists_every_shared_mesh() -> None:
    assert sorted(README) == sorted(p.name for p in SHARED.glob("*.obj"))


@pytest.mark.parametrize("name", sorted(README))
def test_shared_mesh_counts(name: str) -> None:
    readme_v, readme_t = README[name]
    m = load_mesh(SHARED / name)
    drops = EXPECTED_DROPS.get(name, {})
    assert m.stats["degenerate_dropped"] == drops.get("degenerate_dropped", 0)
    assert m.stats["duplicate_dropped"] == drops.get("duplicate_dropped", 0)
    assert m.stats["unreferenced_dropped"] == 0
    assert m.stats["vertices_merged"] == EXPECTED_MERGED.get(name, 0)
    assert m.triangle_count + m.stats["degenerate_dropped"] + m.stats["duplicate_dropped"] == readme_t
    assert m.vertex_count == EXPECTED_V.get(name, readme_v)
    assert m.points.dtype == np.float32 and m.triangles.dtype == np.int32
    assert m.triangles.min() == 0 and m.triangles.max() == m.vertex_count - 1
    assert m.source == str(SHARED / name)


def _parse_obj(path: Path) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Tiny independent OBJ reader for triangle files: v / vt / vn arrays and (F, 3, 3) 1-based corner ids."""
    data: dict[str, list] = {"v": [], "vt": [], "vn": []}
    faces = []
    for line in path.read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] in data:
            data[parts[0]].append([float(x) for x in parts[1:]])
        elif parts[0] == "f":
            assert len(parts) == 4
            faces.append([[int(x) if x else 0 for x in (c.split("/") + ["", ""])[:3]] for c in parts[1:]])
    arrays = {k: np.array(v, dtype=np.float32) for k, v in data.items() if v}
    return arrays, np.array(faces)


@pytest.mark.parametrize("name", ["spot.obj", "bob.obj"])
def test_obj_seams_survive(name: str) -> None:
    m = load_mesh(SHARED / name)
    arrays, corners = _parse_obj(SHARED / name)
    assert "uv" in m.attributes
    assert m.attributes["uv"].dtype == np.float32 and m.attributes["uv"].shape == (m.vertex_count, 2)
    n_positions = len(np.unique(m.points, axis=0))
    assert n_positions == len(arrays["v"]) < m.vertex_count
    # triangle order is the file's: every corner has exactly the position / uv / normal the file gives it
    assert m.triangle_count == len(corners)
    np.testing.assert_array_equal(m.points[m.triangles], arrays["v"][corners[:, :, 0] - 1])
    np.testing.assert_array_equal(
        m.attributes["uv"][m.triangles], arrays["vt"][corners[:, :, 1] - 1][..., :2]
    )
    if "vn" in arrays:
        np.testing.assert_array_equal(m.attributes["normal"][m.triangles], arrays["vn"][corners[:, :, 2] - 1])
        key = corners.reshape(-1, 3)
    else:
        assert "normal" not in m.attributes
        key = corners.reshape(-1, 3)[:, :2]
    # one vertex per distinct (v, vt[, vn]) combination: seams split, nothing more
    assert m.vertex_count == len(np.unique(key, axis=0))


# ---------------------------------------------------------------- trimesh formats


def _canonical(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Triangles as position rows, each rotated to start at its smallest corner (winding kept), sorted.

    Positions are rounded to 4 decimals first so float32 / float64 copies of one mesh compare equal.
    """
    corners = np.round(np.asarray(points, dtype=np.float64)[triangles], 4) + 0.0  # (T, 3, 3), no -0.0
    keys = corners[:, :, 0] * 1e6 + corners[:, :, 1] * 1e3 + corners[:, :, 2]
    start = np.argmin(keys, axis=1)
    idx = (start[:, None] + np.arange(3)) % 3
    rows = np.take_along_axis(corners, idx[:, :, None], axis=1).reshape(-1, 9)
    return rows[np.lexsort(rows.T[::-1])]


def _colored_sphere() -> trimesh.Trimesh:
    m = trimesh.creation.icosphere(subdivisions=2)
    rng = np.random.default_rng(0)
    m.visual.vertex_colors = (rng.random((len(m.vertices), 4)) * 255).astype(np.uint8)
    _ = m.vertex_normals  # computed now so exporters write them
    return m


@pytest.mark.parametrize("ext", ["ply", "off", "glb", "obj"])
def test_trimesh_round_trip_keeps_order_and_attributes(tmp_path: Path, ext: str) -> None:
    src = _colored_sphere()
    path = tmp_path / f"sphere.{ext}"
    src.export(path)
    m = load_mesh(path)
    np.testing.assert_allclose(m.points, src.vertices, atol=1e-7)  # OBJ writes 8 decimals
    np.testing.assert_array_equal(m.triangles, src.faces)
    assert dict(m.stats) == {
        "degenerate_dropped": 0,
        "duplicate_dropped": 0,
        "unreferenced_dropped": 0,
        "vertices_merged": 0,
    }
    if ext != "off":  # trimesh writes neither normals nor colors to OFF
        np.testing.assert_allclose(m.attributes["normal"], src.vertex_normals, atol=1e-6)
        assert m.attributes["color"].dtype == np.float32 and m.attributes["color"].shape == (
            len(src.vertices),
            4,
        )
        channels = 3 if ext == "obj" else 4  # OBJ vertex colors are RGB: alpha comes back as 1
        np.testing.assert_allclose(
            m.attributes["color"][:, :channels] * 255, src.visual.vertex_colors[:, :channels], atol=1e-3
        )


def test_stl_round_trip_welds_split_corners(tmp_path: Path) -> None:
    src = _colored_sphere()
    path = tmp_path / "sphere.stl"
    src.export(path)
    m = load_mesh(path)
    # STL stores three corners per triangle; identical positions weld back to the original vertex count
    assert m.vertex_count == len(src.vertices)
    assert m.stats["vertices_merged"] == 3 * len(src.faces) - len(src.vertices)
    np.testing.assert_allclose(
        _canonical(m.points, m.triangles), _canonical(src.vertices, src.faces), atol=1e-4
    )
    assert dict(m.attributes) == {}


@pytest.mark.parametrize("ext", ["ply", "glb", "obj"])
def test_uv_seams_round_trip(tmp_path: Path, ext: str) -> None:
    box = trimesh.creation.box()
    box.unmerge_vertices()  # 36 vertices at 8 positions
    uv = np.random.default_rng(1).random((len(box.vertices), 2))
    # a material without an image: trimesh's default material needs Pillow to export
    box.visual = trimesh.visual.TextureVisuals(
        uv=uv, material=trimesh.visual.material.PBRMaterial(baseColorFactor=[255, 0, 0, 255])
    )
    path = tmp_path / f"box.{ext}"
    box.export(path)
    m = load_mesh(path)
    assert m.vertex_count == 36 and len(np.unique(m.points, axis=0)) == 8
    np.testing.assert_allclose(m.attributes["uv"], uv, atol=1e-6)


def test_glb_scene_concatenated_with_transforms(tmp_path: Path) -> None:
    a = trimesh.creation.box()
    b = trimesh.creation.icosphere(subdivisions=1)
    for geom in (a, b):
        _ = geom.vertex_normals  # computed now so the exporter writes them
    ta = trimesh.transformations.translation_matrix([10.0, 0.0, 0.0])
    tb = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 0, 1]) @ np.diag([2.0, 2.0, 2.0, 1.0])
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])
    scene = trimesh.Scene()
    scene.add_geometry(a, node_name="a", geom_name="a", transform=ta)
    scene.add_geometry(b, node_name="b", geom_name="b", transform=tb)
    scene.add_geometry(b, node_name="b2", geom_name="b", transform=mirror)  # instanced + mirrored
    path = tmp_path / "scene.glb"
    scene.export(path)
    m = load_mesh(path)
    assert m.triangle_count == len(a.faces) + 2 * len(b.faces)
    expected = []
    for geom, t in ((a, ta), (b, tb), (b, mirror)):
        faces = geom.faces[:, ::-1] if np.linalg.det(t[:3, :3]) < 0 else geom.faces
        expected.append(_canonical(trimesh.transform_points(geom.vertices, t), faces))
    expected_rows = np.concatenate(expected)
    expected_rows = expected_rows[np.lexsort(expected_rows.T[::-1])]
    np.testing.assert_allclose(_canonical(m.points, m.triangles), expected_rows, atol=1e-5)
    # the mirrored sphere still faces outwards: normals agree with the winding everywhere
    tri = m.points[m.triangles].astype(np.float64)
    geometric = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    shading = m.attributes["normal"][m.triangles].sum(axis=1)
    assert (np.einsum("ij,ij->i", geometric, shading) > 0).all()


def test_multi_object_obj_concatenated(tmp_path: Path) -> None:
    (tmp_path / "two.mtl").write_text("newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n")
    path = tmp_path / "two.obj"
    path.write_text(
        "mtllib two.mtl\n"
        "o first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl red\nf 1/1 2/2 3/3\n"
        "o second\nv 5 0 0\nv 6 0 0\nv 6 1 0\nv 5 1 0\nusemtl blue\nf 4 5 6 7\n"
    )
    with pytest.warns(UserWarning, match="uv"):  # only the first object has UVs
        m = load_mesh(path)
    assert m.triangle_count == 3 and m.vertex_count == 7
    assert "uv" not in m.attributes
    assert sorted(np.unique(m.points[:, 0]).tolist()) == [0.0, 1.0, 5.0, 6.0]


@pytest.mark.parametrize(
    ("faces", "dropped"),
    [
        ("f 1/1/1 2/2/1 3/3/1\nf 2/2/1 4/9/1 3/3/1\n", "uv"),  # vt index 9 of 4
        ("f 1/1/1 2/2/1 3/3/1\nf 2/2/1 4/4/7 3/3/1\n", "normal"),  # vn index 7 of 1
        ("f 1/1/1 2/2/1 3/3/1\nf 2 4 3\n", "normal, uv"),  # a face without them
    ],
)
def test_obj_texture_coordinates_or_normals_trimesh_drops_are_reported(
    tmp_path: Path, faces: str, dropped: str
) -> None:
    """trimesh drops every vt (or vn) of an OBJ when one face refers to none or to one out of range: the
    mesh loaded without its UVs and nothing said so."""
    path = tmp_path / "q.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvn 0 0 1\n" + faces)
    with pytest.warns(UserWarning, match=rf"q\.obj: its faces refer to {dropped} .*dropped") as record:
        m = load_mesh(path)
    assert len(record) == 1
    for name in dropped.split(", "):
        assert name not in m.attributes
    path.write_text(path.read_text().replace("4/9/1", "4/4/1").replace("4/4/7", "4/4/1"))
    if "f 2 4 3" not in faces:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert sorted(load_mesh(path).attributes) == ["normal", "uv"]


def test_obj_dropped_attribute_check_is_linear_in_a_long_face_line(tmp_path: Path) -> None:
    """The face patterns of the check for dropped vt/vn backtracked over every digit run of a face line for
    every position in it: a 100 kB OBJ that trimesh loads in under a second (an index written with 100 000
    leading zeros) took about 40 s, a 1 MB one over an hour."""
    import time

    path = tmp_path / "long.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 " + b"0" * 100_000 + b"3\n")
    # (a load first, untimed: the first in an xdist worker imports trimesh and its loaders, 1.5 s measured
    # at a load of 9, 3 ms for this file after it)
    short = tmp_path / "short.obj"
    short.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert load_mesh(short).triangle_count == 1
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_mesh(path).triangle_count == 1
    assert time.perf_counter() - start < 10


@pytest.mark.parametrize(
    ("line", "refers"),
    [
        ("f 1 2 3", ""),
        ("f 1/1 2/2 3/3", "uv"),
        ("f 1//1 2//1 3//1", "normal"),
        ("f 1/1/1 2/2/1 3/3/1", "normal uv"),
        ("f -3/-3/-1 -2/-2/-1 -1/-1/-1", "normal uv"),
        ("f 1//-1 2//-1 3//-1", "normal"),
        ("  f\t1 2/2 3", "uv"),
        ("fo 1/1/1 2/2/2", ""),
    ],
)
def test_obj_face_patterns(line: str, refers: str) -> None:
    from swpm_usd.io.obj import _OBJ_FACE_NORMAL, _OBJ_FACE_UV

    data = ("v 0 0 0\n" + line + "\n").encode()
    found = [n for n, p in (("normal", _OBJ_FACE_NORMAL), ("uv", _OBJ_FACE_UV)) if p.search(data)]
    assert " ".join(found) == refers


def test_obj_degenerate_and_duplicates_dropped(tmp_path: Path) -> None:
    path = tmp_path / "dirty.obj"
    path.write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 0 0\nv 1 1 0\n"  # v4 repeats v2's position
        "f 1 2 3\n"
        "f 2 3 1\n"  # same triangle, rotated
        "f 3 2 1\n"  # opposite winding
        "f 1 1 2\n"  # repeated index
        "f 1 4 2\n"  # v4 == v2 after the weld
        "f 2 5 3\n"
        "f 4 5 3\n"  # duplicate of the previous one once v4 is welded to v2
    )
    m = load_mesh(path)
    assert m.triangles.tolist() == [[0, 1, 2], [1, 3, 2]]
    assert dict(m.stats) == {
        "degenerate_dropped": 2,
        "duplicate_dropped": 3,
        "unreferenced_dropped": 0,
        "vertices_merged": 1,
    }
    np.testing.assert_array_equal(m.points, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])


# ---------------------------------------------------------------- USD


def _define_mesh(
    stage: Usd.Stage,
    path: str,
    points: np.ndarray,
    counts: list[int],
    indices: list[int],
    orientation: str | None = None,
) -> UsdGeom.Mesh:
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(points, dtype=np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray(counts))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray(indices))
    if orientation is not None:
        mesh.CreateOrientationAttr(orientation)
    return mesh


# two unit quads side by side in the z=0 plane, counter-clockwise seen from +z
STRIP_POINTS = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [1, 1, 0], [2, 1, 0]], dtype=np.float32)
STRIP_COUNTS = [4, 4]
STRIP_INDICES = [0, 1, 4, 3, 1, 2, 5, 4]


def _geometric_normals(m: Mesh) -> np.ndarray:
    tri = m.points[m.triangles].astype(np.float64)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def test_usd_polygons_fan_triangulated(tmp_path: Path) -> None:
    path = tmp_path / "poly.usda"
    stage = Usd.Stage.CreateNew(str(path))
    angles = np.linspace(0, 2 * np.pi, 6)[:-1]
    pentagon = np.stack([np.cos(angles) + 5, np.sin(angles), np.zeros(5)], axis=1)
    points = np.concatenate([STRIP_POINTS, pentagon])
    _define_mesh(stage, "/M", points, [4, 4, 5, 3], STRIP_INDICES + [6, 7, 8, 9, 10, 0, 1, 3])
    stage.Save()
    m = load_mesh(path)
    assert m.triangle_count == 2 + 2 + 3 + 1
    assert m.vertex_count == 11
    np.testing.assert_allclose(_geometric_normals(m), np.tile([0, 0, 1], (8, 1)), atol=1e-6)
    # fan from the first corner of each face, in face order
    assert m.triangles[4:7].tolist() == [[6, 7, 8], [6, 8, 9], [6, 9, 10]]


@pytest.mark.parametrize("orientation", [UsdGeom.Tokens.rightHanded, UsdGeom.Tokens.leftHanded])
def test_usd_orientation(tmp_path: Path, orientation: str) -> None:
    path = tmp_path / "o.usda"
    stage = Usd.Stage.CreateNew(str(path))
    _define_mesh(stage, "/M", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES, orientation=orientation)
    stage.Save()
    m = load_mesh(path)
    z = 1.0 if orientation == UsdGeom.Tokens.rightHanded else -1.0
    np.testing.assert_allclose(_geometric_normals(m), np.tile([0, 0, z], (4, 1)), atol=1e-6)


def test_usd_hole_faces_are_not_loaded(tmp_path: Path) -> None:
    """Faces listed in holeIndices are not rendered: they are not part of the mesh (face-varying st of the
    other faces still lines up)."""
    path = tmp_path / "holes.usda"
    stage = Usd.Stage.CreateNew(str(path))
    mesh = _define_mesh(stage, "/M", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES)
    mesh.CreateHoleIndicesAttr(Vt.IntArray([0]))
    pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
        "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying
    )
    pv.Set(Vt.Vec2fArray.FromNumpy(_strip_corner_uv(seam=True)))
    stage.Save()
    m = load_mesh(path)
    assert m.triangle_count == 2
    assert m.points[m.triangles][..., 0].min() == 1.0  # only the second quad, x in [1, 2]
    pos = m.points[m.triangles]
    np.testing.assert_allclose(m.attributes["uv"][m.triangles][..., 0], pos[..., 0] / 2 + 0.25)
    mesh.CreateHoleIndicesAttr(Vt.IntArray([0, 1]))
    stage.Save()
    with pytest.raises(MeshLoadError, match=r"holes\.usda: no triangles.*hole"):
        load_mesh(path)
    mesh.CreateHoleIndicesAttr(Vt.IntArray([2]))
    stage.Save()
    with pytest.raises(
        MeshLoadError, match=r"holes\.usda: /M: holeIndices\[0\] = 2 out of range for 2 faces"
    ):
        load_mesh(path)


def test_usd_mesh_of_only_holes_is_not_rendered_like_an_invisible_one(tmp_path: Path) -> None:
    """A Mesh whose holeIndices list every face renders nothing: beside other meshes it is left out (as an
    invisible one; the pipeline then makes no asset of it), alone it is a MeshLoadError naming the file that
    says every face is a hole (it said "have no faces (or only holes)")."""
    path = tmp_path / "allholes.usda"
    stage = Usd.Stage.CreateNew(str(path))
    holes = _define_mesh(stage, "/A/holes", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES)
    holes.CreateHoleIndicesAttr(Vt.IntArray([1, 0, 1]))  # (a repeated index: still every face)
    _define_mesh(stage, "/A/solid", STRIP_POINTS + [0, 0, 1], STRIP_COUNTS, STRIP_INDICES)
    stage.Save()
    m = load_mesh(path)
    assert m.triangle_count == 4 and np.all(m.points[:, 2] == 1)
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path, prim_path="/A/holes")
    assert e.value.path == str(path)
    assert "/A/holes (every face is a hole: holeIndices lists all 2 faces)" in str(e.value)
    stage.RemovePrim("/A/solid")
    stage.Save()
    with pytest.raises(MeshLoadError, match=r"allholes\.usda: no triangles.*every face is a hole"):
        load_mesh(path)
    holes.CreateHoleIndicesAttr(Vt.IntArray([1]))  # (one face left: loaded)
    stage.Save()
    assert load_mesh(path).triangle_count == 2


def test_usd_unrendered_meshes_are_not_loaded(tmp_path: Path) -> None:
    """Meshes a renderer does not draw, invisible (also through an ancestor) or of purpose guide or proxy (a
    viewport stand-in beside the render mesh), were concatenated with the asset's surface."""
    path = tmp_path / "purpose.usda"
    stage = Usd.Stage.CreateNew(str(path))
    _define_mesh(stage, "/A/render", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES).CreatePurposeAttr("render")
    _define_mesh(stage, "/A/default", STRIP_POINTS + [0, 2, 0], STRIP_COUNTS, STRIP_INDICES)
    for name, z in (("proxy", 1), ("guide", 2)):
        _define_mesh(stage, f"/A/{name}", STRIP_POINTS + [0, 0, z], [3], [0, 1, 4]).CreatePurposeAttr(name)
    _define_mesh(stage, "/A/hidden", STRIP_POINTS + [0, 0, 3], [3], [0, 1, 4]).MakeInvisible()
    UsdGeom.Xform.Define(stage, "/A/off").MakeInvisible()
    _define_mesh(stage, "/A/off/child", STRIP_POINTS + [0, 0, 4], [3], [0, 1, 4])
    stage.Save()
    m = load_mesh(path)
    assert m.triangle_count == 8 and np.all(m.points[:, 2] == 0)
    with pytest.raises(MeshLoadError, match=r"/A/proxy .*1 of them not rendered: /A/proxy \(purpose proxy"):
        load_mesh(path, prim_path="/A/proxy")


@pytest.mark.parametrize(
    ("header", "problem"),
    [
        (
            '(\n    subLayers = [@gone.usda@]\n)\ndef Xform "X" (\n    references = @gone2.usda@\n)\n{\n}\n',
            r"2 composition errors, the stage is incomplete; first: Could not ",
        ),
        (
            'def Xform "X" (\n    references = @gone.usda@\n)\n{\n}\n',
            r"1 composition error, the stage is incomplete; first: Could not open asset @gone\.usda@",
        ),
    ],
)
def test_usd_composition_errors_are_load_errors(tmp_path: Path, header: str, problem: str) -> None:
    """A sublayer or reference that does not resolve dropped its meshes from the build without a word
    (usd-core only prints a warning): the mesh of the stage's other prims was encoded as the asset."""
    path = _write_usda(tmp_path / "c.usda", header + _mesh_usda(_TRIANGLE, *_ONE_FACE))
    with pytest.raises(MeshLoadError, match=r"c\.usda: " + problem):
        load_mesh(path)


def test_usd_composition_errors_the_load_does_not_use_are_ignored(tmp_path: Path) -> None:
    """A reference that does not resolve on a deactivated prim (how a broken reference is switched off), or
    outside the prim_path subtree that is loaded, drops nothing from the build: the stage loads as before."""
    off = 'def Xform "Off" (\n    active = false\n    references = @gone.usda@\n)\n{\n}\n'
    path = _write_usda(tmp_path / "c.usda", off + _mesh_usda(_TRIANGLE, *_ONE_FACE))
    assert load_mesh(path).triangles.shape == (1, 3)
    other = 'def Xform "Other" (\n    references = @gone.usda@\n)\n{\n}\n'
    world = 'def Xform "World"\n{\n' + _mesh_usda(_TRIANGLE, *_ONE_FACE) + "}\n"
    path = _write_usda(tmp_path / "d.usda", other + world)
    assert load_mesh(path, prim_path="/World").triangles.shape == (1, 3)
    assert load_mesh(path, prim_path="/World/M").triangles.shape == (1, 3)
    with pytest.raises(MeshLoadError, match=r"1 composition error, .*</Other>"):
        load_mesh(path)  # (the whole stage: Other's meshes would be missing)
    above = (
        'def Xform "World" (\n    references = @gone.usda@\n)\n{\n'
        + _mesh_usda(_TRIANGLE, *_ONE_FACE)
        + "}\n"
    )
    path = _write_usda(tmp_path / "e.usda", above)  # an arc above prim_path brings opinions into it
    with pytest.raises(MeshLoadError, match=r"1 composition error, .*</World>"):
        load_mesh(path, prim_path="/World/M")


def _strip_corner_uv(seam: bool) -> np.ndarray:
    """faceVarying st for the strip: u = x / 2 across both faces, or (with a seam) face 1 shifted by 0.25."""
    corners = STRIP_POINTS[STRIP_INDICES]
    uv = np.stack([corners[:, 0] / 2, corners[:, 1]], axis=1)
    if seam:
        uv[4:, 0] += 0.25
    return uv.astype(np.float32)


@pytest.mark.parametrize("seam", [True, False])
def test_usd_face_varying_st(tmp_path: Path, seam: bool) -> None:
    path = tmp_path / "fv.usda"
    stage = Usd.Stage.CreateNew(str(path))
    mesh = _define_mesh(stage, "/M", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES)
    pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
        "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying
    )
    pv.Set(Vt.Vec2fArray.FromNumpy(_strip_corner_uv(seam)))
    stage.Save()
    m = load_mesh(path)
    # the shared edge (points 1 and 4) splits only when the uvs differ there
    assert m.vertex_count == (8 if seam else 6)
    assert len(np.unique(m.points, axis=0)) == 6
    assert m.stats["vertices_merged"] == 0
    uv = m.attributes["uv"][m.triangles]  # (T, 3, 2)
    pos = m.points[m.triangles]
    face1 = pos[:, :, 0].mean(axis=1) > 1
    expected = np.stack([pos[..., 0] / 2 + np.where(seam & face1, 0.25, 0)[:, None], pos[..., 1]], axis=-1)
    np.testing.assert_allclose(uv, expected, atol=1e-7)


def test_usd_indexed_primvars(tmp_path: Path) -> None:
    path = tmp_path / "idx.usdc"
    stage = Usd.Stage.CreateNew(str(path))
    mesh = _define_mesh(stage, "/M", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES)
    api = UsdGeom.PrimvarsAPI(mesh)
    st = api.CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set(Vt.Vec2fArray([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)]))
    st.SetIndices(Vt.IntArray([0, 1, 2, 3, 0, 1, 2, 3]))  # each face gets the full square: a seam
    color = api.CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex)
    color.Set(Vt.Vec3fArray([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 0, 1)]))
    color.SetIndices(Vt.IntArray([0, 1, 0, 1, 0, 1]))
    stage.Save()
    m = load_mesh(path)
    assert m.vertex_count == 8  # points 1 and 4 carry u=1 for face 0 and u=0 for face 1
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32)
    # first triangle of each face: corners 0, 1, 2 of the face
    np.testing.assert_array_equal(m.attributes["uv"][m.triangles[[0, 2]]], [square[:3], square[:3]])
    red, blue = [1, 0, 0, 1], [0, 0, 1, 1]
    index_of_point = np.array([0, 1, 0, 1, 0, 1])
    expected = np.array([red, blue], dtype=np.float32)[index_of_point]
    # map each loaded vertex back to its USD point by position
    point_of_vertex = np.array([np.flatnonzero((STRIP_POINTS == p).all(axis=1))[0] for p in m.points])
    np.testing.assert_array_equal(m.attributes["color"], expected[point_of_vertex])


def test_usd_uniform_and_constant_colors(tmp_path: Path) -> None:
    path = tmp_path / "colors.usda"
    stage = Usd.Stage.CreateNew(str(path))
    a = _define_mesh(stage, "/A", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES)
    UsdGeom.PrimvarsAPI(a).CreatePrimvar(
        "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.uniform
    ).Set(Vt.Vec3fArray([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0)]))
    b = _define_mesh(stage, "/B", STRIP_POINTS + [0, 0, 5], STRIP_COUNTS, STRIP_INDICES)
    api = UsdGeom.PrimvarsAPI(b)
    api.CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant).Set(
        Vt.Vec3fArray([Gf.Vec3f(0.5, 2.0, 0.25)])  # HDR value: clipped to [0, 1]
    )
    api.CreatePrimvar("displayOpacity", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.constant).Set(
        Vt.FloatArray([0.5])
    )
    stage.Save()
    m = load_mesh(path)
    assert m.triangle_count == 8
    on_a = m.points[:, 2] == 0
    assert on_a.sum() == 8  # uniform colors split points 1 and 4 of /A
    color_of_tri = m.attributes["color"][m.triangles]
    assert (color_of_tri == color_of_tri[:, :1]).all()  # each face one color
    centroid_x = m.points[m.triangles][:, :, 0].mean(axis=1)
    tri_a = m.points[m.triangles][:, 0, 2] == 0
    np.testing.assert_array_equal(color_of_tri[tri_a & (centroid_x < 1), 0], [[1, 0, 0, 1]] * 2)
    np.testing.assert_array_equal(color_of_tri[tri_a & (centroid_x > 1), 0], [[0, 1, 0, 1]] * 2)
    np.testing.assert_array_equal(m.attributes["color"][~on_a], [[0.5, 1.0, 0.25, 0.5]] * 6)


def test_usd_transforms_and_normals(tmp_path: Path) -> None:
    path = tmp_path / "xf.usda"
    stage = Usd.Stage.CreateNew(str(path))
    moved = UsdGeom.Xform.Define(stage, "/World/Moved")
    moved.AddTranslateOp().Set(Gf.Vec3d(10, 0, 0))
    moved.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
    a = _define_mesh(stage, "/World/Moved/A", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES)
    mirrored = UsdGeom.Xform.Define(stage, "/World/Mirrored")
    mirrored.AddScaleOp().Set(Gf.Vec3f(-1, 1, 1))
    b = _define_mesh(stage, "/World/Mirrored/B", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES)
    for mesh in (a, b):
        mesh.CreateNormalsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 1)] * 6))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    stage.Save()
    m = load_mesh(path)
    assert m.triangle_count == 8 and m.vertex_count == 12
    xs = sorted(np.unique(m.points[:, 0]).tolist())
    assert xs == [-2.0, -1.0, 0.0, 10.0, 12.0, 14.0]
    assert sorted(np.unique(m.points[:, 1]).tolist()) == [0.0, 1.0, 2.0]
    # the mirrored quad keeps facing +z (winding flipped back), like its normals
    np.testing.assert_allclose(_geometric_normals(m), np.tile([0, 0, 1], (8, 1)), atol=1e-6)
    np.testing.assert_allclose(m.attributes["normal"], np.tile([0, 0, 1], (12, 1)), atol=1e-6)


def test_usd_two_meshes_and_prim_path(tmp_path: Path) -> None:
    path = tmp_path / "two.usd"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Xform.Define(stage, "/World")
    _define_mesh(stage, "/World/A", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES)
    _define_mesh(stage, "/World/B", STRIP_POINTS[:3] + [0, 0, 1], [3], [0, 1, 2])
    stage.Save()
    assert load_mesh(path).triangle_count == 5
    assert load_mesh(path, prim_path="/World").triangle_count == 5
    only_b = load_mesh(path, prim_path="/World/B")
    assert only_b.triangle_count == 1 and (only_b.points[:, 2] == 1).all()
    with pytest.raises(MeshLoadError, match=r"two\.usd.*no prim at /World/C"):
        load_mesh(path, prim_path="/World/C")
    with pytest.raises(MeshLoadError, match="two.usd"):
        load_mesh(path, prim_path="not a path")


def test_usd_instanced_reference(tmp_path: Path) -> None:
    proto_path = tmp_path / "proto.usda"
    proto = Usd.Stage.CreateNew(str(proto_path))
    root = UsdGeom.Xform.Define(proto, "/Geo")
    _define_mesh(proto, "/Geo/Strip", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES)
    proto.SetDefaultPrim(root.GetPrim())
    proto.Save()

    path = tmp_path / "scene.usda"
    stage = Usd.Stage.CreateNew(str(path))
    for i, x in enumerate((0.0, 5.0)):
        inst = UsdGeom.Xform.Define(stage, f"/World/I{i}")
        inst.AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
        inst.GetPrim().GetReferences().AddReference(proto_path.name)
        inst.GetPrim().SetInstanceable(True)
    stage.Save()
    assert Usd.Stage.Open(str(path)).GetPrimAtPath("/World/I1").IsInstance()

    m = load_mesh(path)
    assert m.triangle_count == 8 and m.vertex_count == 12
    assert sorted(np.unique(m.points[:, 0]).tolist()) == [0.0, 1.0, 2.0, 5.0, 6.0, 7.0]
    assert load_mesh(path, prim_path="/World/I1/Strip").points[:, 0].min() == 5.0


def test_usdz(tmp_path: Path) -> None:
    src = tmp_path / "src.usdc"
    stage = Usd.Stage.CreateNew(str(src))
    _define_mesh(stage, "/M", STRIP_POINTS, STRIP_COUNTS, STRIP_INDICES)
    stage.Save()
    path = tmp_path / "pkg.usdz"
    assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(str(src)), str(path))
    m = load_mesh(path)
    assert m.triangle_count == 4 and m.vertex_count == 6


def _write_usda(path: Path, body: str) -> Path:
    path.write_text("#usda 1.0\n" + body)
    return path


_TRIANGLE = "point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]"
_ONE_FACE = ("int[] faceVertexCounts = [3]", "int[] faceVertexIndices = [0, 1, 2]")


def _mesh_usda(*lines: str) -> str:
    return 'def Mesh "M"\n{\n' + "".join(f"    {line}\n" for line in lines) + "}\n"


@pytest.mark.parametrize(
    ("body", "problem"),
    [
        ('def Xform "X"\n{\n}\n', "no UsdGeom.Mesh prims"),
        (
            _mesh_usda(
                _TRIANGLE, "int[] faceVertexCounts = [3, 2]", "int[] faceVertexIndices = [0, 1, 2, 0, 1]"
            ),
            "/M: face 1 has 2 vertices",
        ),
        (
            _mesh_usda(_TRIANGLE, "int[] faceVertexCounts = [3]", "int[] faceVertexIndices = [0, 1, 7]"),
            r"faceVertexIndices\[2\] = 7 out of range for 3 points",
        ),
        (
            _mesh_usda(_TRIANGLE, "int[] faceVertexCounts = [4]", "int[] faceVertexIndices = [0, 1, 2]"),
            "faceVertexCounts sum to 4 but there are 3 faceVertexIndices",
        ),
        (
            _mesh_usda(
                _TRIANGLE,
                "int[] faceVertexCounts = [3]",
                "int[] faceVertexIndices = [0, 1, 2]",
                'texCoord2f[] primvars:st = [(0, 0), (1, 0)] (interpolation = "faceVarying")',
            ),
            r"primvar 'st' \(faceVarying\) has 2 values, expected 3",
        ),
        (
            _mesh_usda(
                _TRIANGLE,
                "int[] faceVertexCounts = [3]",
                "int[] faceVertexIndices = [0, 1, 2]",
                'texCoord2f[] primvars:st = [(0, 0), (1, 0)] (interpolation = "vertex")',
                "int[] primvars:st:indices = [0, 1, 5]",
            ),
            r"primvar 'st': indices\[2\] = 5 out of range for 2 values",
        ),
        (
            _mesh_usda(
                "point3f[] points = [(0, 0, 0), (1, 0, 0), (nan, 1, 0)]",
                "int[] faceVertexCounts = [3]",
                "int[] faceVertexIndices = [0, 1, 2]",
            ),
            "1 of 3 points have NaN",
        ),
        ("garbage {{{\n", "USD could not open it"),
    ],
)
def test_usd_bad_input(tmp_path: Path, body: str, problem: str) -> None:
    path = _write_usda(tmp_path / "bad.usda", body)
    with pytest.raises(MeshLoadError, match=r"bad\.usda: .*" + problem):
        load_mesh(path)


# ---------------------------------------------------------------- bad files


@pytest.mark.parametrize("ext", ["obj", "ply", "glb", "stl", "off", "usdc", "usdz"])
def test_garbage_bytes(tmp_path: Path, ext: str) -> None:
    path = tmp_path / f"garbage.{ext}"
    path.write_bytes(np.random.default_rng(7).integers(0, 256, 4000, dtype=np.uint8).tobytes())
    with pytest.raises(MeshLoadError) as err:
        load_mesh(path)
    assert "garbage." + ext in str(err.value)
    assert err.value.path == str(path)


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        (b"\x89garbage", "not UTF-8 JSON: byte 0x89 at byte offset 0"),
        (b'{"asset": {"version": "2.0"}, "buffers": [', "not JSON: Expecting value: line 1 column 43"),
        (b"[1, 2, 3]", "the JSON is a list, not an object"),
    ],
)
def test_gltf_that_is_not_a_json_object_says_so(tmp_path: Path, text: bytes, problem: str) -> None:
    """trimesh said "FileNotFoundError: model.gltf" (or gltf_buffer_0.bin, or "'list' object has no attribute
    'get'") for a .gltf that is not a JSON object."""
    path = tmp_path / "bad.gltf"
    path.write_bytes(text)
    with pytest.raises(MeshLoadError, match=r"bad\.gltf: not a glTF file \(" + problem):
        load_mesh(path)


@pytest.mark.parametrize(
    ("uri", "problem"),
    [
        ("data:application/octet-stream;base64,!!!", "buffer 0: its data URI is not valid base64"),
        ("HALF", "buffer 0: its data URI holds 480 bytes, fewer than its byteLength 960"),
        ("data:application/octet-stream;base64,", "buffer 0: its data URI holds 0 bytes, fewer than its"),
        ("data:application/octet-stream,abc", r"buffer 0: its data URI is not base64"),
        ("gone.bin", r"buffer 0: its file 'gone\.bin' is not found beside the \.gltf"),
        ("short.bin", r"buffer 0: its file 'short\.bin' holds 10 bytes, fewer than its byteLength 960"),
        # (outside the folder: trimesh refuses it; the file was looked at and its size told, "holds N bytes")
        (
            "../outside.bin",
            r"buffer 0: its file '\.\./outside\.bin' is outside the \.gltf's folder \(not read\)",
        ),
        (None, r"buffer 0 has no uri \(a \.gltf's buffer is a data URI or a file beside it\)$"),
    ],
)
def test_gltf_with_a_bad_buffer_names_it(tmp_path: Path, uri: str | None, problem: str) -> None:
    """A bad data URI (not base64, or shorter than the buffer's byteLength) was "trimesh could not read it
    (AssertionError: )", a buffer file missing "FileNotFoundError: gone.bin": the file and its buffer are
    named with what is wrong."""
    import json

    tree = json.loads(
        trimesh.exchange.gltf.export_gltf(trimesh.creation.icosphere(1), embed_buffers=True)["model.gltf"]
    )
    good = tree["buffers"][0]["uri"]
    head, body = good.split(",", 1)
    tree["buffers"][0]["uri"] = head + "," + body[: len(body) // 2] if uri == "HALF" else uri
    if uri is None:  # (a missing uri: trimesh's "KeyError: 'uri'")
        del tree["buffers"][0]["uri"]
    (tmp_path / "outside.bin").write_bytes(b"\0" * 10)
    tmp_path = tmp_path / "in"
    tmp_path.mkdir()
    (tmp_path / "short.bin").write_bytes(b"\0" * 10)
    path = tmp_path / "bad.gltf"
    path.write_text(json.dumps(tree))
    with pytest.raises(MeshLoadError, match=r"bad\.gltf: not a valid glTF file: " + problem) as e:
        load_mesh(path)
    assert e.value.path == str(path)
    tree["buffers"][0]["uri"] = good
    path.write_text(json.dumps(tree))
    assert load_mesh(path).triangle_count == 80


def test_off_face_and_vertex_colours_are_kept(tmp_path: Path) -> None:
    """trimesh's OFF reader keeps only positions and indices: face colours (values after a face's indices)
    and vertex colours (COFF) were dropped without a word. Each triangle of a face (triangles and quads,
    which trimesh triangulates in another order) gets its face's colour, as a PLY's face colours are kept;
    0-255 integers and 0-1 floats, RGB and RGBA."""
    xyz = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0), (3, 0.5, 0)]
    points = "".join(f"{x} {y} {z}\n" for x, y, z in xyz)
    faces = [[0, 1, 4, 3], [1, 2, 4], [2, 6, 5, 4]]
    lines = [f"{len(f)} {' '.join(map(str, f))}" for f in faces]
    int_colours = [(255, 0, 0), (0, 255, 0), (0, 0, 128)]
    float_colours = [(1.0, 0.0, 0.0, 0.5), (0.0, 1.0, 0.0, 1.0), (0.0, 0.0, 0.25, 1.0)]
    for name, colours, scale in (("ints.off", int_colours, 255.0), ("floats.off", float_colours, 1.0)):
        body = "".join(f"{f} {' '.join(map(str, c))}\n" for f, c in zip(lines, colours, strict=True))
        path = tmp_path / name
        path.write_text(f"OFF\n7 3 0\n{points}{body}")
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            m = load_mesh(path)
        assert m.triangle_count == 2 + 1 + 2
        index_of = {tuple(np.float32(c) for c in p): i for i, p in enumerate(xyz)}
        for tri in m.triangles:
            ids = {index_of[tuple(m.points[v])] for v in tri}
            (face,) = [i for i, f in enumerate(faces) if ids <= set(f)]
            want = np.ones(4, np.float32)
            want[: len(colours[face])] = np.array(colours[face]) / scale
            for v in tri:  # (each corner: the face's colour; vertices split where faces differ)
                np.testing.assert_allclose(m.attributes["color"][v], want, atol=1e-6)
    coff = tmp_path / "coff.off"
    vertices = "0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 128\n1 1 0 9 9 9 0\n"
    coff.write_text(f"COFF\n4 2 0\n{vertices}3 0 1 2\n3 1 3 2\n")
    m = load_mesh(coff)
    order = np.lexsort(m.points.T[::-1])  # (by x, then y)
    want = [[255, 0, 0, 255], [0, 0, 255, 128], [0, 255, 0, 255], [9, 9, 9, 0]]
    np.testing.assert_allclose(m.attributes["color"][order] * 255, want, atol=1e-4)
    odd = tmp_path / "index.off"  # (a colour-map index: not a colour this loader reads)
    odd.write_text(f"OFF\n7 3 0\n{points}" + "".join(f"{f} 7\n" for f in lines))
    with pytest.warns(UserWarning, match=re.escape(f"{odd}: its face colours are not loaded")):
        m = load_mesh(odd)
    assert m.triangle_count == 5 and "color" not in m.attributes


def test_off_of_triangles_keeps_each_face_colour(tmp_path: Path) -> None:
    """A triangles-only OFF's face colours (trimesh's triangles are its faces, in order: matched without the
    sort by vertices that took 0.6 s of 327,680 faces) stay each on its triangle."""
    xyz = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0), (2, 0, 0)]
    faces = [(0, 1, 2), (1, 3, 2), (1, 4, 3)]
    colours = [(255, 0, 0), (0, 255, 0), (0, 0, 255)]
    path = tmp_path / "tris.off"
    path.write_text(
        "OFF\n5 3 0\n"
        + "".join(f"{x} {y} {z}\n" for x, y, z in xyz)
        + "".join(
            f"3 {a} {b} {c} {r} {g} {bl}\n" for (a, b, c), (r, g, bl) in zip(faces, colours, strict=True)
        )
    )
    m = load_mesh(path)
    index_of = {tuple(np.float32(c) for c in p): i for i, p in enumerate(xyz)}
    got = {}
    for tri in m.triangles:
        ids = frozenset(index_of[tuple(m.points[v])] for v in tri)
        got[ids] = {tuple(np.round(m.attributes["color"][v] * 255).astype(int)) for v in tri}
    assert got == {frozenset(f): {(*c, 255)} for f, c in zip(faces, colours, strict=True)}


@pytest.mark.parametrize(
    ("keyword", "extra", "want"),
    [
        ("CNOFF", " 0 0 1 0 0 255 255", (0, 0, 255, 255)),  # (normal, then colour)
        ("STCOFF", " 0 255 0 128 0.5 0.5", (0, 255, 0, 128)),  # (colour, then texture coordinates)
        ("STCNOFF", " 0 0 1 255 0 0 255 0.5 0.5", (255, 0, 0, 255)),
        ("NOFF", " 0 0 1", None),  # (a normal: no colour)
        ("STOFF", " 0.5 0.5", None),
    ],
)
def test_off_variants_vertex_colours(tmp_path: Path, keyword: str, extra: str, want: tuple | None) -> None:
    """The OFF variants' vertex rows (x y z, [N] a normal, [C] a colour, [ST] texture coordinates): a CNOFF
    or STCOFF file's colours were dropped without a word (only OFF and COFF were looked at); the colour is
    read between the normal and the texture coordinates, and a NOFF / STOFF file has none."""
    xyz = ["0 0 0", "1 0 0", "1 1 0", "0 1 0"]
    path = tmp_path / "v.off"
    path.write_text(f"{keyword}\n4 2 0\n" + "".join(v + extra + "\n" for v in xyz) + "3 0 1 2\n3 0 2 3\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = load_mesh(path)
    assert m.triangle_count == 2
    if want is None:
        assert "color" not in m.attributes
    else:
        np.testing.assert_allclose(m.attributes["color"] * 255, [want] * 4, atol=1e-4)


def test_off_without_colours_is_not_split_into_lines() -> None:
    """Whether an OFF file may hold colours is looked at in its first vertex and last face: the last face was
    found by splitting the whole file into lines (a bytes object per line: 2 MB more for this 0.75 MB
    file, 40 ms of a 13 MB one's load); the lines are looked at from the end."""
    import tracemalloc

    from swpm_usd.io.off import _off_may_have_colours

    m = trimesh.creation.icosphere(5)  # (10242 vertices, 20480 faces: 0.8 MB)
    data = trimesh.exchange.off.export_off(m).encode().rstrip() + b"\n# the end\n\n"
    tracemalloc.start()
    try:
        assert not _off_may_have_colours(data)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < len(data) // 10, peak
    assert _off_may_have_colours(data.replace(b"\n# the end", b" 255 0 0\n# the end"))


def _stl_bytes(file_type: str = "stl") -> bytes | str:
    return trimesh.creation.icosphere(subdivisions=2).export(file_type=file_type)  # 320 triangles


@pytest.mark.parametrize(
    ("keep", "problem"),
    [
        (8042, r"truncated binary STL: header says 320 triangles \(16084 bytes\), the file has 8042 bytes"),
        (84 + 50 * 3 + 20, r"truncated binary STL: .*the file has 254 bytes"),  # inside a triangle record
        (84, r"truncated binary STL: header says 320 triangles \(16084 bytes\), the file has 84 bytes"),
        (60, r"truncated binary STL: 60 bytes, shorter than the 84-byte header"),
        (0, r"no triangles: the file is empty"),
    ],
)
def test_truncated_binary_stl_says_so(tmp_path: Path, keep: int, problem: str) -> None:
    # trimesh takes a binary STL whose length disagrees with its header for ASCII and found "no triangles"
    path = tmp_path / "cut.stl"
    path.write_bytes(_stl_bytes()[:keep])
    with pytest.raises(MeshLoadError, match=r"cut\.stl: " + problem) as err:
        load_mesh(path)
    assert err.value.path == str(path)


def test_binary_stl_longer_than_its_header_or_not_stl(tmp_path: Path) -> None:
    path = tmp_path / "long.stl"
    path.write_bytes(_stl_bytes() + b"xyz")
    with pytest.raises(MeshLoadError, match=r"long\.stl: not a valid binary STL: .*16087 bytes \(3 bytes"):
        load_mesh(path)
    path = tmp_path / "text.stl"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n" * 8)
    with pytest.raises(MeshLoadError, match=r"text\.stl: not an STL file: not ASCII STL \(no 'solid'"):
        load_mesh(path)


def test_binary_stl_whose_header_starts_with_solid_loads(tmp_path: Path) -> None:
    # some exporters write "solid" into a binary header: its length, not its first word, makes it binary
    data = _stl_bytes()
    path = tmp_path / "solid.stl"
    path.write_bytes(b"solid made by some exporter".ljust(80, b" ") + data[80:])
    assert load_mesh(path).triangle_count == 320


@pytest.mark.parametrize("cut", ["vertex", "endloop", "endfacet"])
def test_ascii_stl_cut_mid_facet_says_where(tmp_path: Path, cut: str) -> None:
    text = _stl_bytes("stl_ascii")
    at = text.index(cut, len(text) // 2) + 3  # inside the keyword, past the middle of the file
    path = tmp_path / "cut.stl"
    path.write_text(text[:at])
    facets = text[:at].count("endfacet")
    line = text[:at].count("\n") + 1
    with pytest.raises(
        MeshLoadError,
        match=rf"cut\.stl: truncated ASCII STL: the text stops at line {line} after {facets} complete facets,"
        r" without the closing 'endsolid'",
    ):
        load_mesh(path)
    path.write_text(text)  # the whole file loads
    assert load_mesh(path).triangle_count == 320


@pytest.mark.parametrize(
    "variant",
    ["byte-order mark", "crlf uppercase", "tabs", "name with facet", "nul padding", "comment first"],
)
def test_valid_ascii_stl_variants_load(tmp_path: Path, variant: str) -> None:
    # files trimesh reads were refused by the check (as not STL, or as cut before their endsolid)
    text = _stl_bytes("stl_ascii")
    data = {
        "byte-order mark": b"\xef\xbb\xbf" + text.encode(),
        "crlf uppercase": text.upper().replace("\n", "\r\n").encode(),
        "tabs": ("\n\t " + text.replace(" ", "\t")).encode(),
        "name with facet": text.replace("solid", "solid facet", 1)
        .replace("endsolid", "endsolid facet")
        .encode(),
        "nul padding": text.encode() + b"\x00" * 200,
        "comment first": b"# exported by a tool\n" + text.encode(),
    }[variant]
    path = tmp_path / "ok.stl"
    path.write_bytes(data)
    assert load_mesh(path).triangle_count == 320
    path.write_bytes(data[: data.lower().rindex(b"endsolid")])  # still reported when cut before endsolid
    with pytest.raises(MeshLoadError, match=r"ok\.stl: truncated ASCII STL: .* after 320 complete facets"):
        load_mesh(path)


def test_stl_check_reads_only_the_start_and_end_of_a_large_file(tmp_path: Path) -> None:
    # the check read the whole file (and an ASCII one twice more: a lowercase copy, a NUL scan) before
    # trimesh read it again: loading an ASCII STL took the file's size more memory than trimesh's own
    import tracemalloc

    from swpm_usd.io.stl import check_stl

    def peak(load) -> int:
        tracemalloc.start()
        try:
            load()
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    tri = trimesh.creation.icosphere(subdivisions=2)
    big = trimesh.util.concatenate([tri] * 100)  # 32,000 triangles
    files = {"binary": big.export(file_type="stl"), "ascii": big.export(file_type="stl_ascii").encode()}
    for kind, data in files.items():
        path = tmp_path / f"{kind}.stl"
        path.write_bytes(data)
        assert len(data) > 1_500_000
        assert peak(lambda p=path: check_stl(p)) < 500_000, kind
    path = tmp_path / "ascii.stl"
    load_mesh(path)  # (anything loaded once)
    extra = peak(lambda: load_mesh(path)) - peak(lambda: trimesh.load_scene(str(path), process=False))
    assert extra < 0.25 * path.stat().st_size
    cut = tmp_path / "cut.stl"  # a cut ASCII file is still counted through, across the chunks it is read in
    text = files["ascii"]
    at = text.rindex(b"endfacet") + 3
    cut.write_bytes(text[:at])
    lines, facets = text.count(b"\n", 0, at) + 1, text.count(b"endfacet") - 1
    with pytest.raises(
        MeshLoadError, match=rf"truncated ASCII STL: the text stops at line {lines} after {facets} complete"
    ):
        load_mesh(cut)


def _ply_cases() -> dict[str, tuple[bytes, str]]:
    """PLY files of a 42-vertex, 80-face sphere cut (or padded) somewhere, and the problem each is."""
    m = trimesh.creation.icosphere(1)
    text = trimesh.exchange.ply.export_ply(m, encoding="ascii")
    lines = text.splitlines(keepends=True)
    body = lines.index(b"end_header\n") + 1
    binary = trimesh.exchange.ply.export_ply(m, encoding="binary")
    start = binary.index(b"end_header\n") + len(b"end_header\n")
    face = 1 + 3 * 4  # (a uchar count, three int indices)
    return {
        "ascii, faces cut": (b"".join(lines[:-5]), "truncated ASCII PLY: element face declares 80, found 75"),
        "ascii, inside a face": (
            b"".join(lines[:-5]) + lines[-5][:3],
            "truncated ASCII PLY: element face declares 80, found 75",
        ),
        "ascii, vertices cut": (
            b"".join(lines[: body + 10]),
            "truncated ASCII PLY: element vertex declares 42, found 10",
        ),
        "ascii, header only": (
            b"".join(lines[:body]),
            "truncated ASCII PLY: element vertex declares 42, found 0",
        ),
        "binary, faces cut": (
            binary[: -3 * face - 2],  # (41 bytes)
            rf"truncated binary PLY: element face declares 80, found 76 \({len(binary) - 41} bytes\)",
        ),
        "binary, vertices cut": (
            binary[: start + 12 * 8 + 5],
            r"truncated binary PLY: element vertex declares 42, found 8",
        ),
        "binary, bytes after": (binary + b"\0" * 7, "not a valid binary PLY: 7 bytes after the elements"),
        # (one row short, the file ending at a line end: its lines were taken for one more than they are)
        "ascii, last face cut at its line end": (
            b"".join(lines[:-1]),
            "truncated ASCII PLY: element face declares 80, found 79",
        ),
        # (a list count that is no count: was a bare OverflowError)
        "ascii, a list count of 1e400": (
            b"".join(lines[:-5]) + b"1e400 0 1 2\n",
            "truncated ASCII PLY: element face declares 80, found 75",
        ),
        "ascii, a list count of inf": (
            b"".join(lines[:-5]) + b"inf 0 1 2\n",
            "truncated ASCII PLY: element face declares 80, found 75",
        ),
        # (a float list count of nan, inf: was a bare ValueError, OverflowError)
        "binary, a float list count of nan": (
            _float_count_ply(binary, start, np.nan),
            "truncated binary PLY: element face declares 80, found 1",
        ),
        "binary, a float list count of inf": (
            _float_count_ply(binary, start, np.inf),
            "truncated binary PLY: element face declares 80, found 1",
        ),
    }


def _float_count_ply(binary: bytes, start: int, count: float) -> bytes:
    """The binary PLY ``binary`` (a 42-vertex, 80-face sphere, elements from ``start``) with float list
    counts, the second face's ``count``."""
    faces = np.frombuffer(binary[start + 42 * 12 :], [("n", "u1"), ("i", "<i4", (3,))])
    floats = np.zeros(80, [("n", "<f4"), ("i", "<i4", (3,))])
    floats["n"], floats["i"] = faces["n"], faces["i"]
    floats["n"][1] = count
    header = binary[:start].replace(b"property list uchar int", b"property list float int")
    return header + binary[start : start + 42 * 12] + floats.tobytes()


@pytest.mark.parametrize("cut", [100, 1, 2100])
def test_truncated_glb_says_so(tmp_path: Path, cut: int) -> None:
    """A cut .glb said "trimesh could not read it (ValueError: chunk was not expected length!)" (or a JSON
    error, its JSON chunk cut): it says it is truncated, the length its header gives against the file's."""
    data = trimesh.creation.icosphere(1).export(file_type="glb")
    path = tmp_path / "cut.glb"
    path.write_bytes(data[: len(data) - cut])
    with pytest.raises(
        MeshLoadError,
        match=rf"cut\.glb: truncated GLB: its header says {len(data)} bytes, the file has {len(data) - cut}$",
    ):
        load_mesh(path)


@pytest.mark.parametrize("chunk", [0, 1])
def test_glb_chunk_longer_than_the_file_says_so(tmp_path: Path, chunk: int) -> None:
    """A .glb whose header length is its size but whose JSON (binary) chunk declares more bytes than follow
    it said "trimesh could not read it (JSONDecodeError: Extra data ...)" ("ValueError: chunk was not
    expected length!"): the chunk and its length are named."""
    import struct

    data = bytearray(trimesh.creation.icosphere(1).export(file_type="glb"))
    at = 12 if chunk == 0 else 12 + 8 + struct.unpack_from("<I", data, 12)[0]
    data[at : at + 4] = struct.pack("<I", 2**31)
    path = tmp_path / "bad.glb"
    path.write_bytes(bytes(data))
    kind = "JSON" if chunk == 0 else "binary"
    with pytest.raises(
        MeshLoadError,
        match=rf"bad\.glb: not a valid GLB: chunk {chunk} \({kind}\) declares 2147483648 bytes, "
        rf"{len(data) - at - 8} follow it$",
    ):
        load_mesh(path)


@pytest.mark.parametrize("case", list(_ply_cases()))
def test_truncated_ply_says_so(tmp_path: Path, case: str) -> None:
    """An ASCII PLY declaring more vertices than it holds said "no triangles", one with faces cut loaded the
    faces left without a word, and a cut binary PLY said "trimesh could not read it (ValueError: PLY is
    unexpected length!)": each says what is truncated, declared against found."""
    data, problem = _ply_cases()[case]
    path = tmp_path / "cut.ply"
    path.write_bytes(data)
    with pytest.raises(MeshLoadError, match=r"cut\.ply: " + problem) as e:
        load_mesh(path)
    assert e.value.path == str(path)


def test_files_our_checks_refuse_do_not_import_trimesh(tmp_path: Path) -> None:
    """trimesh's import (scipy's, 2-3 s) waited in every pipeline worker for a cut PLY or STL that our own
    checks refuse before trimesh reads anything: a fresh process refusing them leaves it unimported."""
    import subprocess
    import sys

    ply = tmp_path / "cut.ply"
    ply.write_bytes(_ply_cases()["ascii, vertices cut"][0])
    stl = tmp_path / "cut.stl"
    stl.write_bytes(b"\0" * 80 + (5).to_bytes(4, "little") + b"\0" * 60)  # (5 triangles declared, 1.2 held)
    code = (
        "import sys\nfrom swpm_usd.errors import MeshLoadError\nfrom swpm_usd.io import load_mesh\n"
        "for p in sys.argv[1:]:\n"
        "    try:\n        load_mesh(p)\n    except MeshLoadError as e:\n        print(e)\n"
        "print('trimesh' in sys.modules)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(ply), str(stl)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert "truncated ASCII PLY" in lines[0] and "cut.stl" in lines[1], lines
    assert lines[-1] == "False", lines


def test_a_failed_trimesh_import_is_not_blamed_on_the_file(tmp_path: Path, monkeypatch) -> None:
    """With trimesh imported lazily inside load_trimesh's ``try``, a broken installation (trimesh or scipy
    missing) said "<file>: trimesh could not read it (ModuleNotFoundError ...)" for every file: the import
    error is raised as it was when trimesh was imported first."""
    import sys

    path = tmp_path / "tri.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    monkeypatch.setitem(sys.modules, "trimesh", None)  # (import trimesh: ModuleNotFoundError)
    with pytest.raises(ModuleNotFoundError, match="trimesh"):
        load_mesh(path)


def test_truncated_binary_ply_rows_are_counted_at_once(tmp_path: Path, monkeypatch) -> None:
    """A cut binary PLY's list rows were walked one by one in Python up to 2,000,000 (3 s of a 2,500,000-face
    file, then no count: "trimesh could not read it"); rows whose lists have the first row's length are
    counted at once, and the walk (here allowed 10 rows) goes on from the first row whose length differs."""
    from swpm_usd.io import ply

    monkeypatch.setattr(ply, "_PLY_ROW_WALK", 10)
    m = trimesh.creation.icosphere(1)
    binary = trimesh.exchange.ply.export_ply(m, encoding="binary")
    start = binary.index(b"end_header\n") + len(b"end_header\n")
    path = tmp_path / "cut.ply"
    path.write_bytes(binary[:-20])
    with pytest.raises(
        MeshLoadError, match=r"cut\.ply: truncated binary PLY: element face declares 80, found 78 "
    ):
        load_mesh(path)
    # a quad among the triangles: the rows from it are walked (5 here)
    tri, quad = np.dtype([("n", "u1"), ("i", "<i4", (3,))]), np.dtype([("n", "u1"), ("i", "<i4", (4,))])
    faces = np.frombuffer(binary[start + 42 * 12 :], tri)
    q = np.zeros(1, quad)
    q["n"], q["i"] = 4, [[0, 1, 2, 3]]
    rows = faces[:75].tobytes() + q.tobytes() + faces[76:].tobytes()
    path.write_bytes(binary[: start + 42 * 12] + rows[:-20])
    with pytest.raises(
        MeshLoadError, match=r"cut\.ply: truncated binary PLY: element face declares 80, found 78 "
    ):
        load_mesh(path)


def test_missing_unsupported_and_directory(tmp_path: Path) -> None:
    with pytest.raises(MeshLoadError, match=r"nope\.obj: file not found"):
        load_mesh(tmp_path / "nope.obj")
    (tmp_path / "m.fbx").write_bytes(b"x")
    with pytest.raises(MeshLoadError, match=r"m\.fbx: unsupported file type '\.fbx'"):
        load_mesh(tmp_path / "m.fbx")
    (tmp_path / "dir.obj").mkdir()
    with pytest.raises(MeshLoadError, match=r"dir\.obj: not a regular file"):
        load_mesh(tmp_path / "dir.obj")
    obj = tmp_path / "t.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(MeshLoadError, match="prim_path only applies to USD"):
        load_mesh(obj, prim_path="/M")


@pytest.mark.parametrize("ext", ["obj", "ply", "stl", "off", "glb", "gltf", "usd", "usda", "usdc", "usdz"])
def test_empty_file_says_so(tmp_path: Path, ext: str) -> None:
    """A 0-byte file of every supported type is reported as empty (a .gltf said "FileNotFoundError:
    model.gltf", a .glb "IndexError: index 0 is out of bounds", a .off "not enough values to unpack")."""
    path = tmp_path / f"empty.{ext}"
    path.write_bytes(b"")
    with pytest.raises(MeshLoadError, match=rf"empty\.{ext}: no triangles: the file is empty \(0 bytes\)$"):
        load_mesh(path)


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("", "no triangles"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no triangles"),
        ("v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "1 of 3 points have NaN"),
        # (trimesh raises "IndexError: index 8 is out of bounds", which the message quoted)
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
            "line 4: face corner '9' refers to vertex 9, the file has 3",
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 1 2\n", "all 1 triangles are degenerate"),
    ],
)
def test_bad_obj(tmp_path: Path, text: str, problem: str) -> None:
    path = tmp_path / "bad.obj"
    path.write_text(text)
    with pytest.raises(MeshLoadError, match=r"bad\.obj: .*" + problem):
        load_mesh(path)


def test_latin1_obj_comment(tmp_path: Path) -> None:
    path = tmp_path / "latin.obj"
    path.write_bytes("# modèle créé\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".encode("latin-1"))
    assert load_mesh(path).triangle_count == 1


# ---------------------------------------------------------------- clean_mesh directly

TRI_POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=np.float64)


@pytest.mark.parametrize(
    ("points", "triangles", "attributes", "problem"),
    [
        (TRI_POINTS, np.zeros((0, 3), int), {}, "no triangles"),
        (TRI_POINTS[:, :2], [[0, 1, 2]], {}, r"points must have shape \(V, 3\), got \(4, 2\)"),
        (np.where(np.eye(4, 3) > 0, np.nan, TRI_POINTS), [[0, 1, 2]], {}, "3 of 4 points have NaN"),
        (TRI_POINTS + [[np.inf, 0, 0]] + [[0], [0], [0], [0]], [[0, 1, 2]], {}, "4 of 4 points have NaN/inf"),
        (TRI_POINTS, [[0, 1, 2], [1, 9, 2]], {}, "triangle 1 has vertex index 9 out of range for 4 vertices"),
        (TRI_POINTS, [[0, -1, 2]], {}, "vertex index -1 out of range"),
        (TRI_POINTS, [[0.0, 1.0, 2.0]], {}, "must be integers"),
        (TRI_POINTS, [0, 1, 2], {}, r"triangles must have shape \(T, 3\)"),
        (TRI_POINTS, [[0, 1, 2]], {"uv": np.zeros((3, 2))}, "attribute 'uv' has 3 rows for 4 points"),
        (TRI_POINTS, [[0, 1, 2]], {"uv": [[0, 0], [np.nan, 0], [0, 0], [0, 0]]}, "'uv' has NaN/inf values"),
        (TRI_POINTS, [[0, 0, 1], [3, 3, 3]], {}, "all 2 triangles are degenerate"),
    ],
)
def test_clean_mesh_rejects(points, triangles, attributes, problem: str) -> None:  # noqa: ANN001
    with pytest.raises(MeshLoadError, match=r"some/file\.obj: .*" + problem):
        clean_mesh(points, triangles, attributes, "some/file.obj")


def test_clean_mesh_welds_identical_vertices_only() -> None:
    # positions 0..3 of a quad, then copies: 4 == 1 exactly (welds), 5 == 2 in position but not uv (seam)
    points = np.concatenate([TRI_POINTS, TRI_POINTS[[1, 2]], [[5, 5, 5]]])
    uv = np.array([[0, 0], [1, 0], [0, 1], [1, 1], [1, 0], [0.5, 1], [9, 9]], dtype=np.float32)
    triangles = np.array([[0, 1, 2], [4, 3, 5]])
    m = clean_mesh(points, triangles, {"uv": uv}, None)
    assert m.vertex_count == 5  # 4 welded into 1, 6 unreferenced
    np.testing.assert_array_equal(m.points, points[[0, 1, 2, 3, 5]].astype(np.float32))
    np.testing.assert_array_equal(m.attributes["uv"], uv[[0, 1, 2, 3, 5]])
    assert m.triangles.tolist() == [[0, 1, 2], [1, 3, 4]]
    assert dict(m.stats) == {
        "degenerate_dropped": 0,
        "duplicate_dropped": 0,
        "unreferenced_dropped": 1,
        "vertices_merged": 1,
    }
    assert m.source is None


def test_clean_mesh_drops_degenerate_and_duplicates_in_order() -> None:
    points = np.concatenate([TRI_POINTS, TRI_POINTS[[1]]])  # vertex 4 at vertex 1's position
    uv = np.array([[0, 0], [1, 0], [0, 1], [1, 1], [7, 7]])  # ... but a different uv: not welded
    triangles = np.array(
        [
            [1, 3, 2],
            [0, 1, 2],
            [0, 4, 1],  # two corners at one position: degenerate although the indices differ
            [2, 1, 0],  # opposite winding of triangle 1: duplicate
            [3, 2, 1],  # rotation of triangle 0: duplicate
            [2, 2, 2],  # degenerate
        ]
    )
    m = clean_mesh(points, triangles, {"uv": uv}, "x.ply")
    assert m.triangles.tolist() == [[1, 3, 2], [0, 1, 2]]
    assert m.vertex_count == 4
    assert m.attributes["uv"].dtype == uv.dtype  # integer attributes keep their dtype
    assert dict(m.stats) == {
        "degenerate_dropped": 2,
        "duplicate_dropped": 2,
        "unreferenced_dropped": 1,
        "vertices_merged": 0,
    }


def test_clean_mesh_signed_zero_and_float32_weld() -> None:
    points = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [-0.0, 0, 0], [1 + 1e-12, 0, 0]])
    m = clean_mesh(points, [[0, 1, 2], [3, 4, 2]], {"normal": np.tile([0.0, -0.0, 1.0], (5, 1))}, None)
    # -0.0 == 0.0 and 1 + 1e-12 == 1 once stored as float32: the second triangle is the first one again
    assert m.vertex_count == 3 and m.triangle_count == 1
    assert m.stats["vertices_merged"] == 2 and m.stats["duplicate_dropped"] == 1
    assert m.attributes["normal"].dtype == np.float32


def test_mesh_from_arrays_cleans() -> None:
    m = Mesh.from_arrays(TRI_POINTS, [[0, 1, 2], [0, 1, 2]], source=Path("a/b.obj"))
    assert m.triangle_count == 1 and m.vertex_count == 3 and m.source == str(Path("a/b.obj"))
    assert not m.points.flags.writeable
    with pytest.raises(MeshLoadError, match="b.obj"):
        Mesh.from_arrays(TRI_POINTS, [[0, 1, 5]], source="b.obj")


def _quad_gltf(tmp_path: Path, name: str, edit, glb: bool = False) -> Path:
    """A quad (4 points, 2 triangles) with float and normalized-uint16 uvs in one buffer, edited by ``edit``
    (the document, then the buffer's bytes appended to), written as ``name`` (.gltf, or .glb)."""
    import base64
    import json
    import struct

    p = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    parts = [p.tobytes(), np.array([0, 1, 2, 0, 2, 3], np.uint16).tobytes(), uv.tobytes()]
    parts.append((uv * 65535).astype(np.uint16).tobytes())
    offsets = np.cumsum([0] + [len(b) for b in parts]).tolist()
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": 0}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": o, "byteLength": len(b)} for o, b in zip(offsets, parts, strict=False)
        ],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": 4,
                "type": "VEC3",
                "min": [0] * 3,
                "max": [1] * 3,
            },
            {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "normalized": True, "count": 4, "type": "VEC2"},
        ],
        "materials": [{}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 2}, "indices": 1, "material": 0}]}
        ],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    blob = bytearray(b"".join(parts))
    edit(doc, blob)
    blob.extend(b"\0" * (-len(blob) % 4))
    doc["buffers"][0]["byteLength"] = len(blob)
    path = tmp_path / name
    if not glb:
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
        path.write_text(json.dumps(doc))
        return path
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    chunks = (
        struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(blob), 0x004E4942) + blob
    )
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks)
    return path


def _sparse_position(doc: dict, blob: bytearray) -> None:
    """Point 2 moved to (5, 5, 0) by a sparse substitution."""
    at = len(blob)
    blob.extend(np.array([2, 0], np.uint16).tobytes() + np.array([5, 5, 0], np.float32).tobytes())
    doc["bufferViews"] += [
        {"buffer": 0, "byteOffset": at, "byteLength": 2},
        {"buffer": 0, "byteOffset": at + 4, "byteLength": 12},
    ]
    doc["accessors"][0]["sparse"] = {
        "count": 1,
        "indices": {"bufferView": 4, "componentType": 5123},
        "values": {"bufferView": 5},
    }


@pytest.mark.parametrize("glb", [False, True])
def test_gltf_sparse_accessor_is_applied(tmp_path: Path, glb: bool) -> None:
    """trimesh ignored an accessor's sparse substitutions: the quad loaded with its base points."""
    m = load_mesh(_quad_gltf(tmp_path, "quad.glb" if glb else "quad.gltf", _sparse_position, glb))
    np.testing.assert_array_equal(m.points, [[0, 0, 0], [1, 0, 0], [5, 5, 0], [0, 1, 0]])
    np.testing.assert_allclose(m.attributes["uv"], [[0, 1], [1, 1], [1, 0], [0, 0]])


def test_gltf_normalized_texcoords_are_scaled(tmp_path: Path) -> None:
    """A TEXCOORD_0 of normalized unsigned shorts (glTF core) came out as 0..65535 (v as 1 - v wrapped)."""

    def normalized(doc: dict, blob: bytearray) -> None:
        doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = 3

    m = load_mesh(_quad_gltf(tmp_path, "quad.gltf", normalized))
    np.testing.assert_allclose(m.attributes["uv"], [[0, 1], [1, 1], [1, 0], [0, 0]])


def test_gltf_texcoords_without_a_material_are_kept(tmp_path: Path) -> None:
    """trimesh read TEXCOORD_0 only for a primitive with a material: without one the uv was dropped."""

    def no_material(doc: dict, blob: bytearray) -> None:
        del doc["meshes"][0]["primitives"][0]["material"], doc["materials"]

    m = load_mesh(_quad_gltf(tmp_path, "quad.gltf", no_material))
    np.testing.assert_allclose(m.attributes["uv"], [[0, 1], [1, 1], [1, 0], [0, 0]])


def test_gltf_triangle_fan_is_loaded(tmp_path: Path) -> None:
    """A primitive of mode TRIANGLE_FAN (6) was dropped without a word: here the second, moved aside."""

    def fan(doc: dict, blob: bytearray) -> None:
        doc["meshes"].append({"primitives": [{"attributes": {"POSITION": 0}, "mode": 6}]})
        doc["nodes"].append({"mesh": 1, "translation": [0, 0, 2]})
        doc["scenes"][0]["nodes"].append(1)

    with pytest.warns(UserWarning, match="missing on some"):
        m = load_mesh(_quad_gltf(tmp_path, "quad.gltf", fan))
    assert m.triangles.shape == (4, 3)
    corners = m.points[m.triangles]
    fan_points = corners[corners[:, 0, 2] == 2]
    assert fan_points.shape == (2, 3, 3)
    np.testing.assert_array_equal(fan_points[:, :, 2], 2)
    np.testing.assert_allclose(np.cross(*(fan_points[:, 1:] - fan_points[:, :1]).transpose(1, 0, 2))[:, 2], 1)


def test_gltf_without_scenes_loads_its_root_nodes(tmp_path: Path) -> None:
    """A glTF without ``scenes`` (valid: its nodes in no scene) was "no triangles: the file holds no triangle
    geometry"; its root nodes are loaded, with their children's transforms."""

    def no_scenes(doc: dict, blob: bytearray) -> None:
        del doc["scenes"], doc["scene"]
        doc["nodes"] = [{"children": [1], "translation": [10, 0, 0]}, {"mesh": 0, "translation": [0, 0, 3]}]

    m = load_mesh(_quad_gltf(tmp_path, "quad.gltf", no_scenes))
    np.testing.assert_array_equal(m.points, [[10, 0, 3], [11, 0, 3], [11, 1, 3], [10, 1, 3]])


def test_gltf_sparse_index_out_of_range_is_named(tmp_path: Path) -> None:
    def bad(doc: dict, blob: bytearray) -> None:
        _sparse_position(doc, blob)
        blob[-16:-14] = np.array([9], np.uint16).tobytes()

    with pytest.raises(MeshLoadError, match=r"quad\.gltf: accessor 0: a sparse index \(9\) is past its 4"):
        load_mesh(_quad_gltf(tmp_path, "quad.gltf", bad))


def _mixed_ply(fmt: str) -> bytes:
    """A pyramid of a quad and four triangles, a colour per face after its list (red quad, green, blue...)."""
    import struct

    points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0.5, 0.5, 1)]
    faces = [(0, 3, 2, 1), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)]
    colours = [(255, 0, 0), (0, 255, 0), (0, 0, 255), (0, 255, 255), (255, 0, 255)]
    head = (
        f"ply\nformat {fmt} 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 5\nproperty list uchar int vertex_indices\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
    ).encode()
    if fmt == "ascii":
        rows = [" ".join(map(str, p)) for p in points]
        rows += [" ".join(map(str, (len(f), *f, *c))) for f, c in zip(faces, colours, strict=True)]
        return head + "\n".join(rows).encode() + b"\n"
    order = "<" if fmt == "binary_little_endian" else ">"
    body = b"".join(struct.pack(order + "3f", *p) for p in points)
    for f, c in zip(faces, colours, strict=True):
        body += struct.pack(f"{order}B{len(f)}i3B", len(f), *f, *c)
    return head + body


@pytest.mark.parametrize("fmt", ["binary_big_endian", "binary_little_endian", "ascii"])
def test_ply_faces_of_mixed_sizes_load_with_their_colours(tmp_path: Path, fmt: str) -> None:
    """A binary PLY of triangles and quads was "trimesh could not read it (PLY is unexpected length!)"
    (trimesh reads every list at the first one's length); an ASCII one loaded other colours than its faces'
    (read from the wrong columns)."""
    path = tmp_path / "pyramid.ply"
    path.write_bytes(_mixed_ply(fmt))
    m = load_mesh(path)
    assert m.triangle_count == 6
    corners = m.points[m.triangles]
    colour = m.attributes["color"][m.triangles[:, 0], :3]
    np.testing.assert_array_equal(
        m.attributes["color"][m.triangles][:, :, :3], np.repeat(colour[:, None], 3, 1)
    )
    base = corners[:, :, 2].max(axis=1) == 0
    assert base.sum() == 2
    np.testing.assert_array_equal(colour[base], [[1, 0, 0], [1, 0, 0]])
    np.testing.assert_array_equal(
        np.cross(*(corners[base][:, 1:] - corners[base][:, :1]).transpose(1, 0, 2))[:, 2], -1
    )
    # the side faces keep their own colour: the one of the face of those corners
    want = {(0, 1): (0, 1, 0), (1, 2): (0, 0, 1), (2, 3): (0, 1, 1), (0, 3): (1, 0, 1)}
    pts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    for tri, c in zip(corners[~base], colour[~base], strict=True):
        ids = tuple(sorted(pts.index(tuple(p)) for p in tri.tolist() if p[2] == 0))
        assert tuple(c.tolist()) == want[ids]


def test_ply_of_mixed_faces_cut_short_still_says_so(tmp_path: Path) -> None:
    path = tmp_path / "pyramid.ply"
    path.write_bytes(_mixed_ply("binary_big_endian")[:-20])
    with pytest.raises(
        MeshLoadError, match=r"pyramid\.ply: truncated binary PLY: element face declares 5, found 3"
    ):
        load_mesh(path)


_INSTANCER_USDA = """
def Xform "World"
{
    double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def PointInstancer "Scatter"
    {
        point3f[] positions = [(0, 0, 0), (10, 0, 0), (20, 0, 0)]
        float3[] scales = [(1, 1, 1), (2, 2, 2), (1, 1, 1)]
        int[] protoIndices = [0, 1, 0]
        int64[] invisibleIds = [2]
        rel prototypes = [</World/Scatter/Protos/A>, </Lib/B>]
        def Scope "Protos"
        {
            def Xform "A"
            {
                double3 xformOp:translate = (0, 1, 0)
                uniform token[] xformOpOrder = ["xformOp:translate"]
                def Mesh "Tri"
                {
                    %(tri)s
                }
            }
        }
    }
}
over "Lib"
{
    def Mesh "B"
    {
        %(tri)s
    }
}
"""


def test_usd_point_instancer_draws_its_prototypes_at_its_instances(tmp_path: Path) -> None:
    """A PointInstancer's prototype was loaded once, where it is defined (a scatter of leaves loaded one leaf
    at the origin); a renderer draws it at each instance and not as itself (Hydra culls the instancer's
    children). Instance 0: prototype A (with its own translate), 1: B (under an `over`) scaled by 2,
    2: invisible; everything under /World's translate."""
    tri = "\n".join([_TRIANGLE, *_ONE_FACE])
    path = _write_usda(tmp_path / "scatter.usda", _INSTANCER_USDA % {"tri": tri})
    m = load_mesh(path)
    got = sorted(map(tuple, m.points[m.triangles].reshape(-1, 9).tolist()))
    want = sorted(
        [
            (0, 1, 5, 1, 1, 5, 0, 2, 5),  # A at instance 0
            (10, 0, 5, 12, 0, 5, 10, 2, 5),  # B at instance 1, scale 2
        ]
    )
    assert got == want


def test_usd_point_instancer_bad_prototype_index_is_named(tmp_path: Path) -> None:
    tri = "\n".join([_TRIANGLE, *_ONE_FACE])
    body = (_INSTANCER_USDA % {"tri": tri}).replace("protoIndices = [0, 1, 0]", "protoIndices = [0, 7, 0]")
    path = _write_usda(tmp_path / "scatter.usda", body)
    with pytest.raises(MeshLoadError, match=r"/World/Scatter: protoIndices\[1\] = 7, it has 2 prototypes"):
        load_mesh(path)


def test_gltf_of_nothing_trimesh_misreads_is_not_rewritten(tmp_path: Path) -> None:
    """Only a glTF that needs it is rewritten (inline buffers cost a base64 copy): not one of float uvs and
    normalized unsigned-byte colours, which trimesh reads right."""
    from swpm_usd.io.gltf_prepare import prepared_gltf

    def colours(doc: dict, blob: bytearray) -> None:
        at = len(blob)
        blob.extend(bytes([200, 13, 255, 255, 1, 2, 3, 4, 254, 253, 127, 128, 77, 78, 79, 80]))
        doc["bufferViews"].append({"buffer": 0, "byteOffset": at, "byteLength": 16})
        doc["accessors"].append(
            {"bufferView": 4, "componentType": 5121, "normalized": True, "count": 4, "type": "VEC4"}
        )
        doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = 4

    for glb in (False, True):
        path = _quad_gltf(tmp_path, "quad.glb" if glb else "quad.gltf", colours, glb)
        assert prepared_gltf(path) is None
        m = load_mesh(path)
        np.testing.assert_array_equal(
            np.round(m.attributes["color"] * 255),
            [[200, 13, 255, 255], [1, 2, 3, 4], [254, 253, 127, 128], [77, 78, 79, 80]],
        )


@pytest.mark.parametrize("extension", ["EXT_meshopt_compression", "KHR_draco_mesh_compression"])
@pytest.mark.parametrize("glb", [False, True])
def test_gltf_compressed_by_an_extension_not_decoded_says_so(
    tmp_path: Path, extension: str, glb: bool
) -> None:
    """A geometry compressed by meshopt (or Draco, without DracoPy) loaded as trimesh's placeholder zeros:
    "all 2 triangles are degenerate (no area)"."""
    import importlib.util

    if extension == "KHR_draco_mesh_compression" and importlib.util.find_spec("DracoPy") is not None:
        pytest.skip("DracoPy decodes Draco here")

    def compressed(doc: dict, blob: bytearray) -> None:
        for a in doc["accessors"][:2]:
            del a["bufferView"]
        doc["extensionsUsed"] = doc["extensionsRequired"] = [extension]

    path = _quad_gltf(tmp_path, "quad.glb" if glb else "quad.gltf", compressed, glb)
    with pytest.raises(
        MeshLoadError,
        match=rf"quad\.gl[tfb]+: its geometry is compressed with the glTF extension {extension}",
    ):
        load_mesh(path)


def test_usd_point_instancer_matches_usd_core_and_ignores_what_is_above_its_prototype(tmp_path: Path) -> None:
    """Each instance's triangle is where usd-core's ComputeInstanceTransformsAtTime puts it (orientations as
    quath (real, imaginary), scales, ids with invisibleIds naming ids, not indices). Prototypes kept under an
    invisible scope of guide purpose (a common way to hide them as themselves) are still drawn at the
    instances: UsdImaging ignores visibility and purpose above a prototype's root; they were left out as
    "invisible" ("no triangles")."""
    path = tmp_path / "oracle.usda"
    stage = Usd.Stage.CreateNew(str(path))
    world = UsdGeom.Xform.Define(stage, "/World")
    world.AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))
    world.AddRotateZOp().Set(30.0)
    lib = UsdGeom.Scope.Define(stage, "/World/Lib")
    lib.GetVisibilityAttr().Set(UsdGeom.Tokens.invisible)
    lib.GetPurposeAttr().Set(UsdGeom.Tokens.guide)
    proto = UsdGeom.Xform.Define(stage, "/World/Lib/Leaf")
    proto.AddTranslateOp().Set(Gf.Vec3d(0, 1, 0))
    tri = UsdGeom.Mesh.Define(stage, "/World/Lib/Leaf/Tri")
    tri.AddScaleOp().Set(Gf.Vec3f(1, 2, 1))
    tri.GetPointsAttr().Set(Vt.Vec3fArray([(0, 0, 0), (1, 0, 0), (0, 1, 0)]))
    tri.GetFaceVertexCountsAttr().Set([3])
    tri.GetFaceVertexIndicesAttr().Set([0, 1, 2])
    inst = UsdGeom.PointInstancer.Define(stage, "/World/Scatter")
    inst.AddTranslateOp().Set(Gf.Vec3d(3, 0, 0))
    inst.CreatePrototypesRel().SetTargets([Sdf.Path("/World/Lib/Leaf")])
    inst.CreateProtoIndicesAttr([0, 0, 0, 0])
    inst.CreatePositionsAttr(Vt.Vec3fArray([(0, 0, 0), (10, 0, 0), (20, 0, 0), (30, 0, 0)]))
    quats = [Gf.Quath(1, 0, 0, 0), Gf.Quath(0.70710678, 0, 0, 0.70710678), Gf.Quath(0, 1, 0, 0)]
    quats.append(Gf.Quath(0.5, 0.5, 0.5, 0.5))
    inst.CreateOrientationsAttr(Vt.QuathArray(quats))
    inst.CreateScalesAttr(Vt.Vec3fArray([(1, 1, 1), (2, 2, 2), (1, 3, 1), (1, 1, 0.5)]))
    inst.CreateIdsAttr(Vt.Int64Array([10, 11, 2, 13]))
    inst.CreateInvisibleIdsAttr(Vt.Int64Array([2]))  # (id 2: the instance at index 2, not index 2's id)
    stage.GetRootLayer().Save()

    time = Usd.TimeCode.EarliestTime()
    xforms = inst.ComputeInstanceTransformsAtTime(time, time)  # (mask applied: index 2 left out)
    assert len(xforms) == 3
    to_world = UsdGeom.XformCache(time).GetLocalToWorldTransform(inst.GetPrim())
    tri_in_proto = Gf.Matrix4d().SetScale(Gf.Vec3d(1, 2, 1))
    want = []
    for x in xforms:
        m = tri_in_proto * x * to_world
        want.append(tuple(v for p in ((0, 0, 0), (1, 0, 0), (0, 1, 0)) for v in m.Transform(Gf.Vec3d(*p))))
    m = load_mesh(path)
    got = sorted(map(tuple, m.points[m.triangles].reshape(-1, 9).tolist()))
    np.testing.assert_allclose(got, sorted(want), atol=1e-3)


@pytest.mark.parametrize("glb", [False, True])
def test_gltf_rewrite_checks_counts_before_allocating(tmp_path: Path, glb: bool) -> None:
    """A small file whose accessor claims 10^10 elements: the rewrite made a 75 GiB index array for a
    TRIANGLE_FAN without indices (of its POSITION count) and a 112 GiB one for a sparse accessor without a
    bufferView before anything checked the count; a negative byteStride let a count past the data through."""

    def fan(doc: dict, blob: bytearray) -> None:
        p = doc["meshes"][0]["primitives"][0]
        p["mode"] = 6
        del p["indices"]
        doc["accessors"][0]["count"] = 10**10

    def sparse_zeros(doc: dict, blob: bytearray) -> None:
        at = len(blob)
        blob.extend(bytes(16))
        doc["bufferViews"] += [
            {"buffer": 0, "byteOffset": at, "byteLength": 4},
            {"buffer": 0, "byteOffset": at + 4, "byteLength": 12},
        ]
        sparse = {
            "count": 1,
            "indices": {"bufferView": 4, "componentType": 5125},
            "values": {"bufferView": 5},
        }
        doc["accessors"].append({"componentType": 5126, "count": 10**10, "type": "VEC3", "sparse": sparse})
        doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 4

    def stride(doc: dict, blob: bytearray) -> None:
        fan(doc, blob)
        doc["bufferViews"][0]["byteStride"] = -12

    ext = ".glb" if glb else ".gltf"
    cases = [
        (fan, r"bufferView 0 holds 48 bytes, accessor 0 reads 120000000000"),
        (sparse_zeros, r"accessor 4 has no bufferView and 10000000000 elements"),
        (stride, r"bufferView 0 has byteStride -12"),
    ]
    for edit, message in cases:
        path = _quad_gltf(tmp_path, edit.__name__ + ext, edit, glb)
        with pytest.raises(MeshLoadError, match=re.escape(path.name) + ": " + message):
            load_mesh(path)


def test_ply_triangulation_of_a_header_claiming_too_many_faces_allocates_nothing_for_them() -> None:
    """A binary PLY of mixed faces cut short, its header claiming 10^12 faces: the triangulation made two
    arrays of the header's count (16 TB: MemoryError) before walking the rows; it now sees at once that the
    bytes cannot hold them (trimesh then says the file is truncated)."""
    from swpm_usd.io.ply import ply_polygons_as_triangles

    header = (
        "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1000000000000\nproperty list uchar int vertex_indices\nend_header\n"
    )
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], "<f4").tobytes()
    faces = (
        bytes([3]) + np.array([0, 1, 2], "<i4").tobytes() + bytes([4]) + np.arange(4, dtype="<i4").tobytes()
    )
    assert ply_polygons_as_triangles(header.encode() + points + faces) is None


def test_load_mesh_parses_an_obj_s_bytes_given_with_a_path_s_checks(tmp_path, monkeypatch):
    # encode hashes an OBJ's bytes and parses them (one read): it called the OBJ loader itself, past
    # load_mesh's checks (its budget's, its suffix, the file's), a second entry point that could drift
    import builtins
    import io

    obj = tmp_path / "a.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    data = obj.read_bytes()
    by_path = load_mesh(obj)
    real_open = builtins.open

    def no_read_of_obj(file, *args, **kwargs):
        assert not (isinstance(file, (str, Path)) and Path(file) == obj), "read again"
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", no_read_of_obj)
    monkeypatch.setattr(io, "open", no_read_of_obj)
    given = load_mesh(obj, data=data)
    monkeypatch.undo()
    assert np.array_equal(given.points, by_path.points) and np.array_equal(given.triangles, by_path.triangles)
    with pytest.raises(MeshLoadError, match="more than max_triangles=1"):
        load_mesh(obj, max_triangles=1, data=data)
    with pytest.raises(ValueError, match="max_triangles must be >= 0"):
        load_mesh(obj, max_triangles=-1, data=data)
    with pytest.raises(MeshLoadError, match="unsupported file type"):
        load_mesh(tmp_path / "a.txt", data=data)
    ply = tmp_path / "a.ply"
    ply.write_bytes(b"ply\n")
    with pytest.raises(ValueError, match="OBJ's bytes"):
        load_mesh(ply, data=data)
