"""glTF ``EXT_mesh_gpu_instancing``: a node's mesh placed at each of its instances (node world transform x
translation x rotation x scale), counted in the triangle budget, and its bad accessors named; a file that
requires an extension the loader does not read is refused.

The files are written here (numpy and json); the expected points come from trimesh.transformations'
matrices, not from the loader's."""

from __future__ import annotations

import base64
import json
import struct
from pathlib import Path

import numpy as np
import pytest
import trimesh
from trimesh import transformations as tf

from swpm_usd.errors import MeshLoadError
from swpm_usd.io import load_mesh
from swpm_usd.io.gltf_prepare import gltf_triangle_count, prepare_gltf

#: a tetrahedron: 4 points, 4 triangles, a normal a point
POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.uint16)
NORMALS = (POINTS - 0.25) / np.linalg.norm(POINTS - 0.25, axis=1, keepdims=True)
#: the instances: translations, rotations (x y z w; the last not of length 1), scales (the last mirrors)
T = np.array([[0, 0, 0], [5, 0, 0], [0, 7, -3]], np.float32)
R = np.array([[0, 0, 0, 1], [0, 0, np.sqrt(0.5), np.sqrt(0.5)], [0.1, 0.2, -0.3, 0.9]], np.float32)
S = np.array([[1, 1, 1], [2, 1, 0.5], [1, -1, 1]], np.float32)
#: the instanced node's parent's and its own transform (TRS of each)
PARENT = {"translation": [1.0, 2.0, 3.0], "rotation": [0.0, 0.6, 0.0, 0.8], "scale": [2.0, 2.0, 2.0]}
NODE = {"translation": [0.0, -1.0, 0.0], "rotation": [0.6, 0.0, 0.0, 0.8]}


class Builder:
    """A glTF document and its one binary buffer, written as .gltf (inline) or .glb."""

    def __init__(self) -> None:
        self.blob = bytearray()
        self.doc: dict = {
            "asset": {"version": "2.0"},
            "buffers": [{"byteLength": 0}],
            "bufferViews": [],
            "accessors": [],
            "meshes": [],
            "nodes": [],
            "scenes": [{"nodes": []}],
            "scene": 0,
        }

    def view(self, values: np.ndarray) -> int:
        """A new bufferView of ``values``' bytes, its index."""
        self.blob.extend(b"\0" * (-len(self.blob) % 4))
        data = np.ascontiguousarray(values).tobytes()
        self.doc["bufferViews"].append({"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)})
        self.blob.extend(data)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, values: np.ndarray, kind: str, component: int, **extra: object) -> int:
        count = values.shape[0] if values.ndim else 1
        self.doc["accessors"].append(
            {"bufferView": self.view(values), "componentType": component, "count": count}
            | {"type": kind}
            | extra
        )
        return len(self.doc["accessors"]) - 1

    def mesh(self, primitives: int = 1, normals: bool = True) -> int:
        prims = []
        for k in range(primitives):
            attrs = {"POSITION": self.accessor(POINTS + 10 * k, "VEC3", 5126)}
            if normals:
                attrs["NORMAL"] = self.accessor(NORMALS.astype(np.float32), "VEC3", 5126)
            prims.append({"attributes": attrs, "indices": self.accessor(FACES.reshape(-1), "SCALAR", 5123)})
        self.doc["meshes"].append({"primitives": prims})
        return len(self.doc["meshes"]) - 1

    def write(self, path: Path) -> Path:
        self.blob.extend(b"\0" * (-len(self.blob) % 4))
        doc = json.loads(json.dumps(self.doc))
        doc["buffers"][0]["byteLength"] = len(self.blob)
        if path.suffix == ".gltf":
            doc["buffers"][0]["uri"] = (
                "data:application/octet-stream;base64," + base64.b64encode(bytes(self.blob)).decode()
            )
            path.write_text(json.dumps(doc))
            return path
        text = json.dumps(doc).encode()
        text += b" " * (-len(text) % 4)
        chunks = struct.pack("<II", len(text), 0x4E4F534A) + text
        chunks += struct.pack("<II", len(self.blob), 0x004E4942) + bytes(self.blob)
        path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks)
        return path


def _instanced(attributes: dict[str, int], primitives: int = 1, normals: bool = True) -> Builder:
    """A builder whose scene is PARENT -> NODE (the tetrahedron's mesh, instanced by ``attributes``, each
    a function of the builder giving an accessor) beside a plain node of the same mesh."""
    b = Builder()
    mesh = b.mesh(primitives, normals)
    ext = {"attributes": {name: make(b) for name, make in attributes.items()}}
    b.doc["nodes"] = [
        {"children": [1], **PARENT},
        {"mesh": mesh, "name": "trees", **NODE, "extensions": {"EXT_mesh_gpu_instancing": ext}},
        {"mesh": mesh, "translation": [0.0, 0.0, 100.0]},
    ]
    b.doc["scenes"][0]["nodes"] = [0, 2]
    b.doc["extensionsUsed"] = ["EXT_mesh_gpu_instancing"]
    return b


def _trs(node: dict) -> np.ndarray:
    q = node.get("rotation", [0, 0, 0, 1])
    return (
        tf.translation_matrix(node.get("translation", [0, 0, 0]))
        @ tf.quaternion_matrix([q[3], q[0], q[1], q[2]])
        @ np.diag([*node.get("scale", [1, 1, 1]), 1.0])
    )


def _expected(translation: np.ndarray | None, rotation: np.ndarray | None, scale: np.ndarray | None):
    """(triangles' corners (T, 3, 3), their normals (T, 3, 3)) of the scene of :func:`_instanced`, in the
    loader's order: the instanced node's copies, instance by instance, then the plain node."""
    n = next(len(a) for a in (translation, rotation, scale) if a is not None)
    world = _trs(PARENT) @ _trs(NODE)
    matrices = []
    for i in range(n):
        q = None if rotation is None else rotation[i] / np.linalg.norm(rotation[i])
        inst = _trs(
            {
                "translation": [0, 0, 0] if translation is None else translation[i],
                "rotation": [0, 0, 0, 1] if q is None else q,
                "scale": [1, 1, 1] if scale is None else scale[i],
            }
        )
        matrices.append(world @ inst)
    matrices.append(tf.translation_matrix([0, 0, 100]))
    corners, normals = [], []
    for m in matrices:
        faces = FACES[:, ::-1] if np.linalg.det(m[:3, :3]) < 0 else FACES  # (a mirror keeps front faces)
        corners.append(trimesh.transform_points(POINTS, m)[faces])
        nrm = NORMALS @ np.linalg.inv(m[:3, :3])
        normals.append((nrm / np.linalg.norm(nrm, axis=1, keepdims=True))[faces])
    return np.concatenate(corners), np.concatenate(normals)


def _translation(b: Builder) -> int:
    return b.accessor(T, "VEC3", 5126)


def _rotation(b: Builder) -> int:
    return b.accessor(R, "VEC4", 5126)


def _scale(b: Builder) -> int:
    return b.accessor(S, "VEC3", 5126)


def _byte_rotation(b: Builder) -> int:
    return b.accessor(np.round(R * 127).astype(np.int8), "VEC4", 5120, normalized=True)


def _short_rotation(b: Builder) -> int:
    return b.accessor(np.round(R * 32767).astype(np.int16), "VEC4", 5122, normalized=True)


def _read_rotation(component: int) -> np.ndarray:
    """ROTATION as the file of ``component`` holds it (normalized integers are rounded)."""
    top = {5126: None, 5120: 127, 5122: 32767}[component]
    return R.astype(np.float64) if top is None else np.maximum(np.round(R * top) / top, -1.0)


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
@pytest.mark.parametrize(
    "attributes",
    [
        {"TRANSLATION": _translation},
        {"ROTATION": _rotation},
        {"SCALE": _scale},
        {"TRANSLATION": _translation, "ROTATION": _rotation, "SCALE": _scale},
        {"TRANSLATION": _translation, "ROTATION": _byte_rotation},
        {"ROTATION": _short_rotation, "SCALE": _scale},
    ],
    ids=["T", "R", "S", "TRS", "T-R-byte", "R-short-S"],
)
def test_an_instanced_node_places_its_mesh_at_each_instance(tmp_path: Path, suffix: str, attributes) -> None:
    """trimesh read the node as one copy of its mesh (4 triangles of 16): the instances are applied first,
    then the node's world transform; a mirroring instance keeps its front faces front."""
    path = _instanced(attributes).write(tmp_path / f"forest{suffix}")
    component = {_byte_rotation: 5120, _short_rotation: 5122}.get(attributes.get("ROTATION"), 5126)
    corners, normals = _expected(
        T if "TRANSLATION" in attributes else None,
        _read_rotation(component) if "ROTATION" in attributes else None,
        S if "SCALE" in attributes else None,
    )
    mesh = load_mesh(path)
    assert mesh.triangle_count == 16
    got = _canonical(mesh.points[mesh.triangles], mesh.attributes["normal"][mesh.triangles])
    for a, b in zip(got, _canonical(corners, normals), strict=True):
        np.testing.assert_allclose(a, b, atol=1e-5)


def _canonical(corners: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The triangles (and their corners' normals) in an order of their own: each rotated to start at its
    least corner (its winding kept), the triangles sorted."""
    key = np.round(corners, 4)
    start = np.array([min(range(3), key=lambda c, t=t: tuple(t[c])) for t in key])
    turn = (start[:, None] + np.arange(3)) % 3
    rows = np.arange(len(key))[:, None]
    corners, normals, key = corners[rows, turn], normals[rows, turn], key[rows, turn]
    order = np.lexsort(key.reshape(len(key), 9).T[::-1])
    return corners[order], normals[order]


def test_each_primitive_of_an_instanced_mesh_is_placed(tmp_path: Path) -> None:
    path = _instanced({"TRANSLATION": _translation}, primitives=2, normals=False).write(tmp_path / "two.glb")
    mesh = load_mesh(path)
    assert mesh.triangle_count == (3 + 1) * 2 * 4
    world = _trs(PARENT) @ _trs(NODE)
    for k in range(2):  # (each primitive's points at each instance: among the loaded points)
        for t in T:
            expected = trimesh.transform_points(POINTS + 10 * k, world @ tf.translation_matrix(t))
            gap = np.abs(mesh.points[None, :, :] - expected[:, None, :]).max(axis=2).min(axis=1)
            assert gap.max() < 1e-5


def test_no_instances_draw_nothing_of_the_node(tmp_path: Path) -> None:
    path = _instanced({"TRANSLATION": lambda b: b.accessor(np.zeros((0, 3), np.float32), "VEC3", 5126)})
    mesh = load_mesh(path.write(tmp_path / "none.gltf"))
    assert mesh.triangle_count == 4  # (the plain node alone)
    assert mesh.points[:, 2].min() == 100


def test_instances_are_counted_in_the_budget_once_parsed(tmp_path: Path) -> None:
    path = _instanced({"TRANSLATION": _translation, "SCALE": _scale}).write(tmp_path / "forest.glb")
    assert load_mesh(path, max_triangles=16).triangle_count == 16
    with pytest.raises(MeshLoadError, match=r"16 triangles.*max_triangles=15"):
        load_mesh(path, max_triangles=15)


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_a_million_instances_are_refused_from_the_json_alone(
    tmp_path: Path, suffix: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The instances' accessor declares 1,000,000 elements of a buffer file that is not there: the budget
    counts them before any buffer is read or trimesh parses anything."""
    b = _instanced({"TRANSLATION": _translation})
    b.doc["bufferViews"].append({"buffer": 1, "byteLength": 12_000_000})
    b.doc["buffers"].append({"uri": "instances.bin", "byteLength": 12_000_000})
    translation = b.doc["nodes"][1]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["TRANSLATION"]
    b.doc["accessors"][translation].update(bufferView=len(b.doc["bufferViews"]) - 1, count=1_000_000)
    path = b.write(tmp_path / f"forest{suffix}")

    def refused(*args: object, **kwargs: object) -> None:
        raise AssertionError("trimesh parsed the file before the budget was checked")

    monkeypatch.setattr(trimesh, "load_scene", refused)
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path, max_triangles=1_000_000)
    assert str(path) in str(e.value) and "4000004 triangles" in str(e.value)


def _retyped(kind: str, component: int, normalized: bool = False):
    def make(b: Builder) -> int:
        values = np.zeros(
            (3, {"VEC3": 3, "VEC4": 4}[kind]),
            np.dtype({5126: "f4", 5121: "u1", 5122: "i2", 5123: "u2"}[component]),
        )
        return b.accessor(values, kind, component, **({"normalized": True} if normalized else {}))

    return make


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
@pytest.mark.parametrize(
    ("attributes", "says"),
    [
        (
            {"TRANSLATION": _retyped("VEC4", 5126)},
            r"TRANSLATION \(accessor 3\) is VEC4 of FLOAT \(5126\), not VEC3 of FLOAT \(5126\)",
        ),
        (
            {"SCALE": _retyped("VEC3", 5122)},
            r"SCALE \(accessor 3\) is VEC3 of SHORT \(5122\), not VEC3",
        ),
        (
            {"ROTATION": _retyped("VEC4", 5121, True)},
            r"ROTATION \(accessor 3\) is VEC4 of normalized UNSIGNED_BYTE \(5121\),",
        ),
        (
            {"ROTATION": _retyped("VEC4", 5122)},
            r"ROTATION .* SHORT \(5122\), not VEC4 of FLOAT \(5126\) or normalized BYTE",
        ),
        (
            {"ROTATION": _retyped("VEC4", 5123, True)},
            r"ROTATION \(accessor 3\) is VEC4 of normalized UNSIGNED_SHORT \(5123\), not VEC4 of FLOAT "
            r"\(5126\) or normalized BYTE \(5120\) or normalized SHORT \(5122\)",
        ),
        (
            {"ROTATION": _retyped("VEC4", 5126, True)},
            r"ROTATION \(accessor 3\) is VEC4 of normalized FLOAT \(5126\),",
        ),
        ({"TRANSLATION": lambda b: 99}, r"TRANSLATION is accessor 99, the file has 3"),
        (
            {"TRANSLATION": _translation, "SCALE": lambda b: b.accessor(S[:2], "VEC3", 5126)},
            r"attributes differ in count \(TRANSLATION 3, SCALE 2\)",
        ),
        (
            {
                "TRANSLATION": lambda b: b.accessor(
                    np.array([[0, 0, 0], [1, np.nan, 0]], np.float32), "VEC3", 5126
                )
            },
            r"TRANSLATION of instance 1 is \[1.0, nan, 0.0\], not finite",
        ),
        (
            {"ROTATION": lambda b: b.accessor(np.zeros((2, 4), np.float32), "VEC4", 5126)},
            r"ROTATION of instance 0 is a quaternion of length 0",
        ),
        (
            {"TRANSLATION": "past"},
            r"TRANSLATION \(accessor 3\): bufferView 3 holds 36 bytes, accessor 3 reads",
        ),
        ({"TRANSLATION": "count"}, r"TRANSLATION \(accessor 3\) has count -2, not a count"),
    ],
    ids=[
        "T-vec4",
        "S-short",
        "R-ubyte",
        "R-short-not-normalized",
        "R-ushort",
        "R-float-normalized",
        "ref",
        "counts",
        "nan",
        "zero-q",
        "past",
        "count",
    ],
)
def test_a_bad_instance_accessor_is_named_with_its_node(
    tmp_path: Path, suffix: str, attributes, says
) -> None:
    special = {name: v for name, v in attributes.items() if isinstance(v, str)}
    b = _instanced({name: (_translation if name in special else v) for name, v in attributes.items()})
    for name, how in special.items():
        a = b.doc["accessors"][b.doc["nodes"][1]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"][name]]
        a["count"] = 5 if how == "past" else -2
    path = b.write(tmp_path / f"bad{suffix}")
    with pytest.raises(MeshLoadError, match=rf"node 1 \('trees'\): its EXT_mesh_gpu_instancing {says}") as e:
        load_mesh(path)
    assert e.value.path == str(path)


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_a_required_extension_the_loader_does_not_read_is_refused(tmp_path: Path, suffix: str) -> None:
    """trimesh read the file whatever it required (a glTF loader must refuse it): KHR_gaussian_splatting's
    points, say, loaded as what the file's own accessors hold."""
    b = _instanced({"TRANSLATION": _translation})
    b.doc["extensionsRequired"] = ["EXT_mesh_gpu_instancing", "KHR_materials_unlit", "KHR_gaussian_splatting"]
    path = b.write(tmp_path / f"needs{suffix}")
    with pytest.raises(MeshLoadError, match=r"requires the glTF extension 'KHR_gaussian_splatting'") as e:
        load_mesh(path)
    assert e.value.path == str(path)
    b.doc["extensionsRequired"] = ["EXT_mesh_gpu_instancing", "KHR_materials_unlit", "KHR_texture_transform"]
    assert load_mesh(b.write(tmp_path / f"reads{suffix}")).triangle_count == 16


def test_a_required_quantization_is_read(tmp_path: Path) -> None:
    """KHR_mesh_quantization, which the loader reads (integer positions, normalized normals), is not
    refused: its points come out as the node's scale makes them."""
    b = Builder()
    points = b.accessor((POINTS * 1000).astype(np.uint16), "VEC3", 5123)
    normals = b.accessor(np.round(NORMALS * 127).astype(np.int8), "VEC3", 5120, normalized=True)
    b.doc["meshes"] = [
        {
            "primitives": [
                {
                    "attributes": {"POSITION": points, "NORMAL": normals},
                    "indices": b.accessor(FACES.reshape(-1), "SCALAR", 5123),
                }
            ]
        }
    ]
    b.doc["nodes"] = [{"mesh": 0, "scale": [0.001, 0.001, 0.001]}]
    b.doc["scenes"][0]["nodes"] = [0]
    b.doc["extensionsRequired"] = b.doc["extensionsUsed"] = ["KHR_mesh_quantization"]
    mesh = load_mesh(b.write(tmp_path / "quantized.glb"))
    np.testing.assert_allclose(mesh.points[mesh.triangles], POINTS[FACES], atol=1e-6)
    np.testing.assert_allclose(mesh.attributes["normal"][mesh.triangles], NORMALS[FACES], atol=0.02)


def test_instances_without_a_buffer_view_are_placed_once_each_where_they_differ(tmp_path: Path) -> None:
    """A TRANSLATION of zeros but its sparse values: the 998 instances at no sparse index are one
    transform, placed once (2^24 of them asked for 5.7 GiB); the mesh is the one of every instance written
    out, whose copies at the origin cleaning drops as duplicates."""
    n, where, moved = 1000, np.array([3, 7], np.uint16), np.array([[5, 0, 0], [0, 5, 0]], np.float32)
    sparse = _instanced({"TRANSLATION": _translation})
    ref = sparse.doc["nodes"][1]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["TRANSLATION"]
    a = sparse.doc["accessors"][ref]
    del a["bufferView"]
    a["count"] = n
    a["sparse"] = {
        "count": 2,
        "indices": {"bufferView": sparse.view(where), "componentType": 5123},
        "values": {"bufferView": sparse.view(moved)},
    }
    dense_values = np.zeros((n, 3), np.float32)
    dense_values[where] = moved
    dense = _instanced({"TRANSLATION": lambda b: b.accessor(dense_values, "VEC3", 5126)})
    got = load_mesh(sparse.write(tmp_path / "sparse.gltf"))
    assert got.triangle_count == 4 * 3 + 4
    expected = load_mesh(dense.write(tmp_path / "dense.glb"))
    np.testing.assert_array_equal(got.points[got.triangles], expected.points[expected.triangles])
    with pytest.raises(MeshLoadError, match="4004 triangles"):  # (the budget counts every instance)
        load_mesh(tmp_path / "sparse.gltf", max_triangles=4003)


@pytest.mark.parametrize(
    "extension",
    [
        "MSFT_texture_dds",
        "EXT_texture_webp",
        "KHR_texture_basisu",
        "MSFT_packing_occlusionRoughnessMetallic",
        "ADOBE_materials_thin_transparency",
        "KHR_animation_pointer",
        "EXT_structural_metadata",
        "EXT_mesh_features",
        "CESIUM_primitive_outline",
    ],
)
def test_a_required_extension_about_what_is_not_loaded_is_left_aside(tmp_path: Path, extension: str) -> None:
    """A texture format, a material packing, animation or metadata leaves the triangles as they are: main
    loaded and drew such a file, and it is not refused for requiring one."""
    b = Builder()
    b.doc["nodes"] = [{"mesh": b.mesh(normals=False)}]
    b.doc["scenes"][0]["nodes"] = [0]
    b.doc["extensionsRequired"] = b.doc["extensionsUsed"] = [extension]
    mesh = load_mesh(b.write(tmp_path / "required.glb"))
    np.testing.assert_array_equal(mesh.points[mesh.triangles], POINTS[FACES])


def test_instances_without_a_buffer_view_are_not_written_out_for_each_node(tmp_path: Path) -> None:
    """Four nodes reading one TRANSLATION of 2^24 zeros (no bufferView) and a sparse value: each node's
    instances are read at the kept rows alone. Each node's read wrote out the 2^24 zeros (192 MiB, a second
    of work: a 4.5 kB file of 40 such nodes took 33 s, against 1.8 s on main); the rewrite's peak is now
    below 32 MiB."""
    import tracemalloc

    b = Builder()
    mesh = b.mesh(normals=False)
    b.doc["accessors"].append(
        {
            "componentType": 5126,
            "count": 1 << 24,
            "type": "VEC3",
            "sparse": {
                "count": 1,
                "indices": {"bufferView": b.view(np.array([9], np.uint32)), "componentType": 5125},
                "values": {"bufferView": b.view(np.array([[5, 0, 0]], np.float32))},
            },
        }
    )
    ext = {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": len(b.doc["accessors"]) - 1}}}
    b.doc["nodes"] = [{"mesh": mesh, "translation": [0, 0, 10.0 * k], "extensions": ext} for k in range(4)]
    b.doc["scenes"][0]["nodes"] = [0, 1, 2, 3]
    path = b.write(tmp_path / "zeros.gltf")
    tracemalloc.start()
    try:  # (the rewrite's: trimesh then reads the accessor's zeros once, for the file)
        prepared = prepare_gltf(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert prepared is not None and [len(m) for m in prepared.instances.values()] == [2] * 4
    mesh = load_mesh(path)
    assert mesh.triangle_count == 4 * 2 * 4  # (each node: the copy at 0, the one at the sparse value)
    assert np.isclose(mesh.points[:, 0].max(), 6) and np.isclose(mesh.points[:, 2].max(), 31)
    assert peak < 32 << 20, f"{peak / 2**20:.0f} MiB"


def test_an_instanced_file_whose_buffer_file_is_missing_names_it(tmp_path: Path) -> None:
    """trimesh names a missing buffer file ("FileNotFoundError: forest.bin"); the instances' read said its
    accessor "does not read from its bufferView"."""
    b = _instanced({"TRANSLATION": _translation})
    path = b.write(tmp_path / "forest.gltf")
    doc = json.loads(path.read_text())
    doc["buffers"][0]["uri"] = "forest.bin"
    path.write_text(json.dumps(doc))
    with pytest.raises(MeshLoadError, match=r"FileNotFoundError.*forest\.bin") as e:
        load_mesh(path)
    assert e.value.path == str(path)


@pytest.mark.parametrize("component", [5120, 5122])
def test_the_most_negative_normalized_rotation_component_is_minus_one(tmp_path: Path, component: int) -> None:
    """EXT_mesh_gpu_instancing allows ROTATION as normalized BYTE or SHORT, decoded as glTF 2.0's
    max(c / 127, -1) and max(c / 32767, -1): -128 and -32768 are -1, so (0 0 0 -128) is no rotation,
    (0 0 -128 0) half a turn about z and (-128 0 0 0) half a turn about x."""
    low = {5120: np.int8, 5122: np.int16}[component]
    stored = np.array([[0, 0, 0, 1], [0, 0, 1, 0], [1, 0, 0, 0]]) * np.iinfo(low).min
    path = _instanced(
        {"ROTATION": lambda b: b.accessor(stored.astype(low), "VEC4", component, normalized=True)}
    )
    mesh = load_mesh(path.write(tmp_path / "turned.glb"))
    corners, normals = _expected(None, -np.abs(stored / np.iinfo(low).min).astype(np.float64), None)
    got = _canonical(mesh.points[mesh.triangles], mesh.attributes["normal"][mesh.triangles])
    for a, b in zip(got, _canonical(corners, normals), strict=True):
        np.testing.assert_allclose(a, b, atol=1e-5)


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_an_instanced_skinned_node_is_refused_with_its_name(tmp_path: Path, suffix: str) -> None:
    """EXT_mesh_gpu_instancing places a node's mesh by the node's world transform x each instance's, and
    glTF 2.0 ignores a skinned node's transform (its joints place the mesh): the extension says nothing of a
    node with both (KhronosGroup/glTF#2404 proposed "should not"; three.js does not draw it). Drawn as a
    plain instanced node, its skin left out, it was neither; now refused, naming the file and the node."""
    b = _instanced({"TRANSLATION": _translation})
    b.doc["nodes"][1]["skin"] = 0
    b.doc["skins"] = [{"joints": [0]}]
    path = b.write(tmp_path / f"army{suffix}")
    with pytest.raises(
        MeshLoadError, match=r"node 1 \('trees'\) has both a skin and EXT_mesh_gpu_instancing"
    ) as e:
        load_mesh(path)
    assert e.value.path == str(path) and e.value.code == "INPUT_UNSUPPORTED"


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_an_instanced_skinned_node_is_refused_for_what_it_is_not_its_instances_count(
    tmp_path: Path, suffix: str
) -> None:
    """The budget counted before the buffers are read leaves out a node the load refuses (a skin and
    instances): its million instances said "over max_triangles" of a file refused for its skin."""
    b = _instanced({"TRANSLATION": _translation})
    b.doc["nodes"][1]["skin"] = 0
    b.doc["skins"] = [{"joints": [0]}]
    translation = b.doc["nodes"][1]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["TRANSLATION"]
    b.doc["accessors"][translation]["count"] = 1_000_000
    path = b.write(tmp_path / f"army{suffix}")
    assert gltf_triangle_count(path) == 4  # (the plain node's tetrahedron)
    with pytest.raises(MeshLoadError, match=r"node 1 \('trees'\) has both a skin and EXT_mesh_gpu") as e:
        load_mesh(path, max_triangles=100)
    assert e.value.path == str(path) and e.value.code == "INPUT_UNSUPPORTED"


def test_an_instance_rotation_normalized_1_is_refused_naming_the_accessor(tmp_path: Path) -> None:
    """Its ``normalized`` is a JSON boolean: 1 was read as true (the bytes decoded as normalized)."""
    rotation = np.round(R * 127).astype(np.int8)
    b = _instanced({"ROTATION": lambda b: b.accessor(rotation, "VEC4", 5120, normalized=1)})
    path = b.write(tmp_path / "forest.glb")
    with pytest.raises(MeshLoadError, match=r"accessor 3 has normalized 1, not true or false") as e:
        load_mesh(path)
    assert e.value.path == str(path) and e.value.code == "INPUT_MALFORMED"


def test_an_instance_accessor_whose_type_is_not_a_string_is_named(tmp_path: Path) -> None:
    """Its ``type`` as the file holds it: an array is no glTF type name (nor a key to look one up by)."""
    b = _instanced({"TRANSLATION": _translation})
    translation = b.doc["nodes"][1]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["TRANSLATION"]
    b.doc["accessors"][translation]["type"] = ["VEC3"]
    path = b.write(tmp_path / "forest.gltf")
    with pytest.raises(MeshLoadError, match=r"TRANSLATION \(accessor 3\) is \['VEC3'\] of FLOAT \(5126\)"):
        load_mesh(path)
