"""``load_mesh(..., max_triangles=N)``: a file over the triangle budget is refused, as early as its format
tells the count (before trimesh parses anything where the header or the glTF JSON tells it)."""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from pxr import Usd, UsdGeom, Vt

from swpm_usd.errors import MeshLoadError
from swpm_usd.io import early_triangle_count, load_mesh

#: a tetrahedron: 4 points, 4 triangles
POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def _instanced_gltf(path: Path, copies: int) -> Path:
    """The tetrahedron's mesh placed by ``copies`` nodes (each 1 apart in x) of a .gltf."""
    files = trimesh.Trimesh(POINTS, FACES, process=False).export(file_type="gltf")
    doc = json.loads(files["model.gltf"])
    for b in doc["buffers"]:
        b["uri"] = "data:application/octet-stream;base64," + base64.b64encode(files[b["uri"]]).decode()
    mesh = next(n["mesh"] for n in doc["nodes"] if "mesh" in n)
    doc["nodes"] = [{"children": list(range(1, copies + 1))}]
    doc["nodes"] += [{"mesh": mesh, "translation": [2.0 * i, 0, 0]} for i in range(copies)]
    doc["scenes"], doc["scene"] = [{"nodes": [0]}], 0
    path.write_text(json.dumps(doc))
    return path


def _write(path: Path) -> Path:
    """The tetrahedron exported to ``path`` (type by suffix)."""
    data = trimesh.Trimesh(POINTS, FACES, process=False).export(file_type=path.suffix[1:])
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def _no_parsing(monkeypatch: pytest.MonkeyPatch) -> None:
    """trimesh's loading fails the test: the budget must be checked before it."""

    def refused(*args: object, **kwargs: object) -> None:
        raise AssertionError("trimesh parsed the file before the budget was checked")

    monkeypatch.setattr(trimesh, "load_scene", refused)


def test_instanced_gltf_over_budget_is_refused_before_trimesh_reads_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _instanced_gltf(tmp_path / "forest.gltf", 500)
    _no_parsing(monkeypatch)
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path, max_triangles=1999)
    message = str(e.value)
    assert str(path) in message and "2000 triangles" in message and "max_triangles=1999" in message


def test_instanced_gltf_at_its_budget_loads(tmp_path: Path) -> None:
    path = _instanced_gltf(tmp_path / "forest.gltf", 50)
    assert load_mesh(path, max_triangles=200).triangle_count == 200
    with pytest.raises(MeshLoadError, match="200 triangles"):
        load_mesh(path, max_triangles=199)


def test_glb_over_budget_is_refused_before_trimesh_reads_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _write(tmp_path / "tet.glb")
    assert load_mesh(path, max_triangles=4).triangle_count == 4
    _no_parsing(monkeypatch)
    with pytest.raises(MeshLoadError, match="4 triangles.*max_triangles=3"):
        load_mesh(path, max_triangles=3)


@pytest.mark.parametrize("ext", ["obj", "stl"])
def test_header_or_face_lines_over_budget_are_refused_before_trimesh_parses(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, ext: str
) -> None:
    path = _write(tmp_path / f"tet.{ext}")
    assert load_mesh(path, max_triangles=4).triangle_count == 4
    _no_parsing(monkeypatch)
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path, max_triangles=3)
    assert str(path) in str(e.value) and "4 triangles" in str(e.value) and "max_triangles=3" in str(e.value)


@pytest.mark.parametrize("ext", ["ply", "off"])
def test_ply_and_off_over_budget_are_refused_once_parsed(tmp_path: Path, ext: str) -> None:
    path = _write(tmp_path / f"tet.{ext}")
    assert load_mesh(path, max_triangles=4).triangle_count == 4
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path, max_triangles=3)
    assert str(path) in str(e.value) and "4 triangles" in str(e.value) and "max_triangles=3" in str(e.value)


_SQUARE = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
_PLY_HEAD = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"


@pytest.mark.parametrize(
    "name, text",
    [
        ("short.obj", _SQUARE + "f 1 2 3\n" + "f 1 2\n" * 5),
        ("empty.obj", _SQUARE + "f 1 2 3\n" + "f \n" * 5),
        ("indented.obj", _SQUARE + "f 1 2 3\n" + "  f 2 4\n" * 3),
        ("tab.obj", _SQUARE + "f 1 2 3\n" + "f\t2\t4\n" * 3),
        (
            "two.ply",
            _PLY_HEAD
            + "element face 4\nproperty list uchar int vertex_indices\nend_header\n"
            + "0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n2 0 1\n2 1 2\n2 2 3\n",
        ),
        ("two.off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n2 0 1\n2 1 2\n2 2 3\n"),
    ],
)
def test_a_file_within_budget_is_not_refused_by_a_lower_bound(tmp_path: Path, name: str, text: str) -> None:
    """Face lines or header faces that trimesh reads as no triangle (fewer than 3 corners, an indented or
    tab-led OBJ 'f' line) are no part of the early count: one triangle loads under a budget of 1."""
    path = tmp_path / name
    path.write_text(text)
    assert load_mesh(path).triangle_count == 1
    assert load_mesh(path, max_triangles=1).triangle_count == 1


@pytest.mark.parametrize("face", ["  f 2 4 3\n", "f\t2\t4\t3\n", "\tf 2 4 3\n"])
def test_indented_or_tab_led_obj_faces_count_early_and_once_parsed(tmp_path: Path, face: str) -> None:
    """An indented or tab-separated OBJ face line is a face (trimesh dropped it: helper-233): counted in the
    early lower bound as in the parsed count, 4 triangles (2 once duplicates are cleaned)."""
    path = tmp_path / "faces.obj"
    path.write_text(_SQUARE + "f 1 2 3\n" + face * 3)
    assert early_triangle_count(path) == (4, False)
    with pytest.raises(MeshLoadError, match="4 triangles"):
        load_mesh(path, max_triangles=3)
    assert load_mesh(path, max_triangles=4).triangle_count == 2


def test_polygons_are_counted_as_their_triangles_once_parsed(tmp_path: Path) -> None:
    """Two face lines under a budget of 3, but a pentagon and a triangle: 4 triangles, over it."""
    path = tmp_path / "poly.obj"
    angles = np.linspace(0, 2 * np.pi, 6)[:-1]
    rows = [f"v {np.cos(a):.6f} {np.sin(a):.6f} 0" for a in angles] + ["v 0 0 1", "f 1 2 3 4 5", "f 1 2 6"]
    path.write_text("\n".join(rows) + "\n")
    assert load_mesh(path, max_triangles=4).triangle_count == 4
    with pytest.raises(
        MeshLoadError, match="over the triangle budget: 4 triangles, more than max_triangles=3"
    ):
        load_mesh(path, max_triangles=3)


def test_usd_instances_are_counted_from_face_vertex_counts(tmp_path: Path) -> None:
    """A quad prototype drawn at 3 instances: 6 triangles."""
    path = tmp_path / "scatter.usda"
    stage = Usd.Stage.CreateNew(str(path))
    inst = UsdGeom.PointInstancer.Define(stage, "/Scatter")
    quad = UsdGeom.Mesh.Define(stage, "/Scatter/Protos/Quad")
    quad.CreatePointsAttr(
        Vt.Vec3fArray.FromNumpy(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], "f4"))
    )
    quad.CreateFaceVertexCountsAttr(Vt.IntArray([4]))
    quad.CreateFaceVertexIndicesAttr(Vt.IntArray([0, 1, 2, 3]))
    inst.CreatePrototypesRel().AddTarget(quad.GetPath())
    inst.CreateProtoIndicesAttr(Vt.IntArray([0, 0, 0]))
    inst.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(np.array([[0, 0, 0], [5, 0, 0], [10, 0, 0]], "f4")))
    stage.Save()
    assert load_mesh(path, max_triangles=6).triangle_count == 6
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path, max_triangles=5)
    assert str(path) in str(e.value) and "6 triangles" in str(e.value) and "max_triangles=5" in str(e.value)


@pytest.mark.parametrize(("value", "error"), [(-1, ValueError), ("9", TypeError), (True, TypeError)])
def test_a_budget_that_is_not_a_count_is_refused(tmp_path: Path, value: object, error: type) -> None:
    path = _write(tmp_path / "tet.obj")
    with pytest.raises(error, match="max_triangles must be"):
        load_mesh(path, max_triangles=value)  # type: ignore[arg-type]


def test_early_count_of_an_obj_is_one_implementation_with_the_bytes_it_read(tmp_path):
    """The dry run counted an OBJ's face lines with a copy of early_triangle_count's OBJ part (to keep the
    bytes for the load): the copy said None for an empty OBJ (its load says "empty"), early_triangle_count
    a lower bound of 0. One implementation now, which also hands back the bytes it read."""
    from swpm_usd.io import early_triangle_count

    empty = tmp_path / "empty.obj"
    empty.write_bytes(b"")
    assert early_triangle_count(empty) is None
    from swpm_usd.io import early_triangle_count_and_data

    assert early_triangle_count_and_data(empty) == (None, b"")
    text = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3 4\nf 1 2 3\nf 1 2\n"
    quad = tmp_path / "quad.obj"
    quad.write_bytes(text)
    assert early_triangle_count(quad) == (2, False)  # (face lines of 3 or more corners: a lower bound)
    assert early_triangle_count_and_data(quad) == ((2, False), text)
    assert early_triangle_count_and_data(quad, prim_path="/a") == (None, b"")  # (a prim: USD only)
    assert early_triangle_count_and_data(tmp_path / "gone.obj") == (None, b"")  # (its load says why)
    gltf = _instanced_gltf(tmp_path / "t.gltf", 3)
    assert early_triangle_count_and_data(gltf) == ((12, True), b"")  # (other types: no bytes kept)
