"""Worst cases of the mesh loaders found by an adversarial campaign (header and structure mutations of each
format): each is a clear MeshLoadError naming the file, or a load, without a long wait or an allocation far
beyond the file's size."""

from __future__ import annotations

import base64
import json
import re
import struct
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import trimesh

from swpm_usd.errors import MeshLoadError
from swpm_usd.io import load_mesh
from swpm_usd.io.trimesh_scene import _geometry_transforms

#: a tetrahedron: 4 points, 4 triangles
POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def _gltf_doc() -> dict:
    """The tetrahedron as a .gltf document, its buffers as data URIs."""
    files = trimesh.Trimesh(POINTS, FACES, process=False).export(file_type="gltf")
    doc = json.loads(files["model.gltf"])
    for b in doc["buffers"]:
        b["uri"] = "data:application/octet-stream;base64," + base64.b64encode(files[b["uri"]]).decode()
    return doc


def _glb() -> tuple[bytes, int]:
    """The tetrahedron as a .glb, and the offset of its second chunk's header."""
    data = trimesh.Trimesh(POINTS, FACES, process=False).export(file_type="glb")
    return data, 20 + struct.unpack_from("<I", data, 12)[0]


def _glb_of(doc: dict) -> bytes:
    """The .gltf document ``doc`` (buffers as data URIs) as a .glb: its buffers one binary chunk."""
    doc = json.loads(json.dumps(doc))
    binary = b""
    starts = []
    for b in doc["buffers"]:
        starts.append(len(binary))
        binary += base64.b64decode(b["uri"].split(",", 1)[1])
        binary += b"\0" * (-len(binary) % 4)
    for view in doc["bufferViews"]:  # (a view of a buffer that is not there keeps its index)
        b = view.get("buffer")
        if isinstance(b, int) and 0 <= b < len(starts):
            view.update(buffer=0, byteOffset=starts[b] + view.get("byteOffset", 0))
    doc["buffers"] = [{"byteLength": len(binary)}]
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    body = (
        struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(binary), b"BIN\0") + binary
    )
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def _load_peak(path: Path) -> tuple[str, int]:
    """(the MeshLoadError's message, the peak of memory traced while loading ``path``)."""
    tracemalloc.start()
    try:
        with pytest.raises(MeshLoadError) as e:
            load_mesh(path)
        return str(e.value), tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_a_deep_chain_of_nodes_loads_in_linear_time(tmp_path: Path) -> None:
    """1,500 glTF nodes in a chain, each holding the mesh: each node's transform was looked up from the root
    anew (trimesh's ``graph[node]``: a path search and a product per node), so 3,000 nodes (98 KB) took
    174 s and 1,000 took 7 s; now one pass down the tree."""
    doc = _gltf_doc()
    n = 1500
    doc["nodes"] = [{"mesh": 0, "children": [i + 1]} for i in range(n)] + [{"mesh": 0}]
    doc["scenes"] = [{"nodes": [0]}]
    path = tmp_path / "chain.gltf"
    path.write_text(json.dumps(doc))
    # (a load first, untimed: the first glTF in an xdist worker imports trimesh's loaders)
    (tmp_path / "one.gltf").write_text(json.dumps(_gltf_doc()))
    assert load_mesh(tmp_path / "one.gltf").triangle_count == 4
    start = time.perf_counter()
    mesh = load_mesh(path)
    assert time.perf_counter() - start < 5.0
    assert mesh.triangle_count == 4  # (the 1,501 copies in one place are welded by cleaning)


def _ours_and_trimeshs_transforms(path: Path, doc: dict) -> list[tuple[np.ndarray, np.ndarray]]:
    """``doc`` written to ``path`` and loaded by trimesh: per node with a mesh, the one-pass transform
    (:func:`_geometry_transforms`) and trimesh's own ``graph[node]``, checked to name the same nodes and
    geometry."""
    path.write_text(json.dumps(doc))
    scene = trimesh.load_scene(str(path), process=False)
    ours = _geometry_transforms(scene.graph)
    assert sorted(map(str, ours)) == sorted(map(str, scene.graph.nodes_geometry))
    pairs = []
    for node, (m, geometry) in ours.items():
        want, want_geometry = scene.graph[node]
        assert geometry == want_geometry
        pairs.append((m, want))
    return pairs


def test_transforms_down_the_tree_are_trimeshs(tmp_path: Path) -> None:
    """The transforms computed in one pass are those trimesh's ``graph[node]`` gives, node by node, in a tree
    of translations, rotations, scales and matrices; and the loaded points are moved by them."""
    doc = _gltf_doc()
    rotation = [0.0, np.sin(0.3), 0.0, np.cos(0.3)]
    matrix = np.diag([2.0, 1.0, 0.5, 1.0])
    matrix[:3, 3] = [1, 2, 3]
    doc["nodes"] = [
        {"children": [1, 2], "translation": [1.0, 0.0, 0.0]},
        {"mesh": 0, "rotation": rotation, "children": [3]},
        {"mesh": 0, "scale": [1.0, 2.0, 3.0], "children": [4]},
        {"mesh": 0, "matrix": matrix.T.reshape(-1).tolist()},  # (glTF: column-major)
        {"children": [5], "translation": [0.0, 5.0, 0.0]},
        {"mesh": 0, "translation": [0.0, 0.0, 7.0]},
    ]
    doc["scenes"] = [{"nodes": [0]}]
    path = tmp_path / "tree.gltf"
    for m, want in _ours_and_trimeshs_transforms(path, doc):
        np.testing.assert_allclose(m, want, rtol=0, atol=1e-12)
    mesh = load_mesh(path)
    assert mesh.triangle_count == 16
    # the last node: the root's translation, node 2's scale, node 4's and its own translations
    last = POINTS * [1.0, 2.0, 3.0] + [1.0, 10.0, 21.0]
    for p in last:
        assert np.abs(mesh.points - p).max(axis=1).min() < 1e-6


def test_transforms_leave_out_near_identities_as_trimesh_does(tmp_path: Path) -> None:
    """trimesh's ``graph[node]`` leaves an edge's matrix within 1e-8 of the identity out of a path's product
    (and takes a child of the base frame's edge as it is): the one-pass transforms do the same, so a file of
    such nodes (an exporter's 1e-9 noise) loads with the same bits as before. With the near identities
    multiplied in, 98 of 150 random trees of such nodes loaded other float32 points than before, and a
    transform here was 5e-9 off; up to two matrices on a path, the bits are trimesh's."""
    doc = _gltf_doc()
    rotation = [0.0, float(np.sin(0.3)), 0.0, float(np.cos(0.3))]
    near = [
        {"translation": [5e-9, 0.0, -3e-9]},
        {"scale": [1.0 + 3e-9, 1.0, 1.0]},
        {"matrix": np.eye(4).ravel().tolist()},
    ]
    doc["nodes"] = [
        {"children": [1, 4], **near[0]},
        {"rotation": rotation, "children": [2], "mesh": 0},
        {"children": [3], **near[1]},
        {"mesh": 0, "translation": [1.0, -2.0, 0.5], "scale": [2.0, 1.0, 1.0]},
        {"mesh": 0, "children": [5], **near[2]},
        {"mesh": 0, "rotation": [0.0, 0.0, 1.0, 0.0]},  # (a half turn: -0.0 in its matrix)
        {"mesh": 0, **near[1], "children": [7]},
        {"mesh": 0, "rotation": rotation, "translation": [0.0, 1.0, 0.0]},
    ]
    doc["scenes"] = [{"nodes": [0, 6]}]
    for m, want in _ours_and_trimeshs_transforms(tmp_path / "near.gltf", doc):
        assert m.tobytes() == np.asarray(want, np.float64).tobytes(), m - want


@pytest.mark.parametrize("chunk", [0, 1, 2, 5002])
def test_a_glb_chunk_longer_than_the_file_is_refused_before_it_is_read(tmp_path: Path, chunk: int) -> None:
    """A chunk length of 2^32 - 1 in a 1 KB .glb: its JSON chunk was read with ``read(length)`` (by the glTF
    rewrite's look at it, then by trimesh), which asks for 4.3 GB before finding fewer bytes; a third chunk
    likewise, and one after 5,000 empty chunks (a walk stopped after 4,096 let trimesh ask for the 4.3 GB).
    Now the chunks are walked first and the file refused, naming the chunk."""
    data, second = _glb()
    if chunk == 0:
        data = data[:12] + struct.pack("<I", 0xFFFFFFFF) + data[16:]
    elif chunk == 1:
        data = data[:second] + struct.pack("<I", 0xFFFFFFFF) + data[second + 4 :]
    else:
        data = data + struct.pack("<I4s", 0, b"XTRA") * (chunk - 2) + struct.pack("<I4s", 0xFFFFFFFF, b"XTRA")
        data = data[:8] + struct.pack("<I", len(data)) + data[12:]
    path = tmp_path / "lying.glb"
    path.write_bytes(data)
    message, peak = _load_peak(path)
    assert str(path) in message and f"chunk {chunk}" in message and "declares 4294967295 bytes" in message
    assert peak < 50 * len(data) + (1 << 20)


@pytest.mark.parametrize("count", [10**12, 2**53])
@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_an_accessor_without_a_buffer_view_is_not_allocated_from_its_count(
    tmp_path: Path, count: int, suffix: str
) -> None:
    """An accessor without a bufferView (zeros, by glTF) of 10^12 or 2^53 elements: trimesh allocated its
    zeros from the count alone (11.2 GiB for 10^9 in an 871-byte file), a MemoryError at best
    ("trimesh could not read it"); now refused by its count before trimesh reads the file."""
    doc = _gltf_doc()
    position = doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
    del doc["accessors"][position]["bufferView"]
    doc["accessors"][position]["count"] = count
    path = tmp_path / ("zeros" + suffix)
    if suffix == ".gltf":
        path.write_text(json.dumps(doc))
    else:
        path.write_bytes(_glb_of(doc))
    message, peak = _load_peak(path)
    assert str(path) in message and f"accessor {position} has no bufferView and {count} elements" in message
    assert peak < (16 << 20)


def _set(doc: dict, where: str, value: object) -> None:
    *path, last = where.split(".")
    obj = doc
    for key in path:
        obj = obj[int(key)] if isinstance(obj, list) else obj[key]
    obj[last] = value


@pytest.mark.parametrize(
    "where, value, problem",
    [
        (
            "bufferViews.0.byteOffset",
            2**31 - 1,
            r"bufferView 0 ends at byte \d+, past buffer 0's (48|96) bytes",
        ),
        (
            "bufferViews.0.byteLength",
            10**9,
            r"bufferView 0 ends at byte 1000000000, past buffer 0's (48|96) bytes",
        ),
        ("bufferViews.0.byteLength", -1, r"bufferView 0 has byteOffset 0 and byteLength -1, not both counts"),
        ("bufferViews.1.buffer", 7, r"bufferView 1 refers to buffer 7, the file has [12]"),
        ("bufferViews.1.byteStride", -4, r"bufferView 1 has byteStride -4, not 4 to 252"),
        ("accessors.0.bufferView", 2**31 - 1, r"accessor 0 refers to bufferView 2147483647, the file has 2"),
        ("accessors.0.componentType", 9999, r"accessor 0 has componentType 9999, not a glTF component type"),
        ("accessors.0.componentType", [], r"accessor 0 has componentType \[\], not a glTF component type"),
        ("accessors.1.type", {}, r"accessor 1 has type \{\}, not a glTF accessor type"),
        ("accessors.1.count", 2**31, r"accessor 1 reads \d+ bytes of bufferView 1, which holds 48"),
        ("accessors.1.byteOffset", 2**63, r"accessor 1 reads \d+ bytes of bufferView 1, which holds 48"),
        (
            "meshes.0.primitives.0.indices",
            5,
            r"mesh 0 primitive 0: its indices refers to accessor 5, the file has 2",
        ),
    ],
)
@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_a_gltf_structure_trimesh_refuses_is_named(
    tmp_path: Path, where: str, value: object, problem: str, suffix: str
) -> None:
    """A bufferView past its buffer, an accessor past its view or of an unknown type, an index to nothing:
    trimesh said "AssertionError: ", "IndexError: list index out of range", "KeyError: 9999" or "cannot
    reshape array of size 0 into shape (4,3)"; now what is wrong, with the numbers."""
    doc = _gltf_doc()
    _set(doc, where, value)
    path = tmp_path / ("bad" + suffix)
    if suffix == ".gltf":
        path.write_text(json.dumps(doc))
    else:
        path.write_bytes(_glb_of(doc))
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path)
    kind = suffix[1:].upper()
    assert re.fullmatch(re.escape(f"{path}: not a valid {kind} file: ") + problem, str(e.value)), str(e.value)


def test_a_glb_structure_is_looked_at_in_its_binary_chunk_wherever_it_is(tmp_path: Path) -> None:
    """A .glb with a chunk of an unknown type between its JSON and binary chunks (which a reader ignores, and
    trimesh does): the structure's look took the chunk after the JSON one for the binary one, so a file
    trimesh refused for an unknown componentType was said to have a bufferView past "buffer 0's 8 bytes"."""
    doc = _gltf_doc()
    _set(doc, "accessors.0.componentType", 9999)
    data = _glb_of(doc)
    second = 20 + struct.unpack_from("<I", data, 12)[0]
    data = data[:second] + struct.pack("<I4s", 8, b"XTRA") + b"01234567" + data[second:]
    data = data[:8] + struct.pack("<I", len(data)) + data[12:]
    path = tmp_path / "extra.glb"
    path.write_bytes(data)
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path)
    want = f"{path}: not a valid GLB file: accessor 0 has componentType 9999, not a glTF component type"
    assert str(e.value) == want


def test_obj_faces_of_differing_lengths_are_read_as_trimesh_reads_them() -> None:
    """OBJ face lines of differing lengths (trimesh's per-corner Python fallback) read in numpy: the same
    triangles, texture and normal indices as trimesh's own reading, random lines of each corner form (a few
    corners of another form, short lines, negative and zero indices among them)."""
    import random

    import trimesh.exchange.obj as obj

    from swpm_usd.io.obj import _obj_faces_fallback

    rng = random.Random(7)

    def index() -> str:
        return str(rng.choice([rng.randint(1, 50), -rng.randint(1, 5), 0]))

    def corner(form: str) -> str:
        return {"v": "{}", "vt": "{}/{}", "vn": "{}//{}", "all": "{}/{}/{}"}[form].format(
            index(), index(), index()
        )

    original = obj._parse_faces_fallback
    if hasattr(original, "__wrapped__"):
        original = original.__wrapped__
    for _ in range(400):
        form = rng.choice(["v", "vt", "vn", "all"])
        lines = []
        for _ in range(rng.randint(1, 8)):
            n = rng.choice([1, 2, 3, 3, 4, 4, 5, 7, 12])
            odd = lambda: rng.random() < 0.03  # noqa: E731
            corners = [corner(rng.choice(["v", "vt", "vn", "all"]) if odd() else form) for _ in range(n)]
            lines.append(" ".join(corners) + rng.choice(["", " ", "\n", "\nv 1 2 3"]))
        want = original(lines)
        got = _obj_faces_fallback(lines, original)
        for w, g in zip(want, got, strict=True):
            assert (w is None and g is None) or (g is not None and np.array_equal(w, g)), lines


def test_a_long_polygon_beside_triangles_is_not_read_corner_by_corner(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 20,000-corner polygon beside a triangle: trimesh read every corner in Python (200,000 corners: 4.5 s
    of a load); now in numpy, with the fan trimesh made."""
    import trimesh.exchange.obj as obj

    def per_corner(lines: list[str]) -> tuple:
        raise AssertionError("trimesh's per-corner reading was used")

    monkeypatch.setattr(obj, "_parse_faces_fallback", per_corner)
    n = 20_000
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    rows = [f"v {np.cos(a):.6f} {np.sin(a):.6f} 0" for a in angles] + ["v 0 0 1", "f 1 2 20001"]
    rows.append("f " + " ".join(str(i) for i in range(1, n + 1)))
    path = tmp_path / "polygon.obj"
    path.write_text("\n".join(rows) + "\n")
    m = load_mesh(path)
    assert m.triangle_count == 1 + (n - 2)
    fan = np.stack([np.zeros(n - 2, int), np.arange(1, n - 1), np.arange(2, n)], axis=1)
    got = {tuple(t) for t in np.asarray(m.points, np.float32)[m.triangles].reshape(-1, 9).tolist()}
    pts = np.array([[float(x) for x in r.split()[1:]] for r in rows[:n]], np.float32)  # (as written)
    want = {tuple(t) for t in pts[fan].reshape(-1, 9).tolist()}
    assert want <= got


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
@pytest.mark.parametrize("camera_holds", ["children", "mesh"])
def test_a_camera_node_over_geometry_loads_it_as_an_empty_node_would(
    tmp_path: Path, suffix: str, camera_holds: str
) -> None:
    """A node holding a camera and children (or a mesh): trimesh left it out of the scene ("No path from
    world->1") or dropped its mesh; its geometry loads where the same file with an empty node puts it."""
    doc = _gltf_doc()
    mesh = next(n["mesh"] for n in doc["nodes"] if "mesh" in n)
    doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]
    child = {"mesh": mesh, "translation": [0, 2, 0], "scale": [2, 2, 2]}
    if camera_holds == "children":
        top = {"camera": 0, "translation": [5, 0, 0], "rotation": [0, 0, 0.6, 0.8], "children": [1]}
        doc["nodes"] = [top, child]
    else:
        doc["nodes"] = [{"camera": 0, "translation": [5, 0, 0], "rotation": [0, 0, 0.6, 0.8], "mesh": mesh}]
    doc["scenes"], doc["scene"] = [{"nodes": [0]}], 0
    empty = json.loads(json.dumps(doc))
    del empty["nodes"][0]["camera"]
    paths = []
    for name, d in (("camera", doc), ("empty", empty)):
        path = tmp_path / f"{name}{suffix}"
        path.write_bytes(_glb_of(d) if suffix == ".glb" else json.dumps(d).encode())
        paths.append(path)
    with_camera, without = (load_mesh(p) for p in paths)
    assert with_camera.triangle_count == without.triangle_count == 4
    np.testing.assert_array_equal(with_camera.points, without.points)
    np.testing.assert_array_equal(with_camera.triangles, without.triangles)
    # (moved by the node's transforms: a rotation of (0, 0, 0.6, 0.8) about z, cos 0.28, sin 0.96)
    local = POINTS * 2 + [0, 2, 0] if camera_holds == "children" else POINTS
    rotation = np.array([[0.28, -0.96, 0], [0.96, 0.28, 0], [0, 0, 1]])
    want = local @ rotation.T + [5, 0, 0]
    np.testing.assert_allclose(np.sort(without.points, axis=0), np.sort(want, axis=0), atol=1e-5)


_STL_FACET = (
    "facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex {}\n endloop\nendfacet\n"
)
_PLY_HEAD = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
_PLY_HEAD += "element face 1\nproperty list uchar int vertex_indices\nend_header\n"


@pytest.mark.parametrize(
    ("name", "text", "says"),
    [
        ("a.obj", "v 0 0 0\nv 1 0 x\nv 0 1 0\nf 1 2 3\n", "line 2: a 'v' row holds 'x', not a number"),
        (
            "b.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
            "line 4: face corner '9' refers to vertex 9, the file has 3",
        ),
        (
            "c.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3.5\n",
            "line 4: face corner '3.5': its vertex index is not a",
        ),
        ("a.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1\n3 0 1 2\n", "line 5: vertex 2 holds 2 values, not 3"),
        (
            "b.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2.5\n",
            "line 6: face 0: '3 0 1 2.5' are not whole numbers",
        ),
        (
            "a.stl",
            "solid s\n" + _STL_FACET.format("0 1 x") + "endsolid s\n",
            "line 6: a 'vertex' row holds 'x', not",
        ),
        (
            "b.stl",
            "solid s\n" + _STL_FACET.format("0 1") + "endsolid s\n",
            "line 6: a 'vertex' row holds 2 values, not 3",
        ),
        ("a.ply", _PLY_HEAD + "0 0 0\n1 0 0\n0 1 x\n3 0 1 2\n", "line 12: vertex 2 holds 'x', not a number"),
    ],
)
def test_a_text_row_trimesh_cannot_read_is_named_by_its_line(
    tmp_path: Path, name: str, text: str, says: str
) -> None:
    """A row of a text file that trimesh fails on ("string or file could not be read to its end due to
    unmatched data", "index 8 is out of bounds", "invalid literal for int()") is named by its line and what
    is wrong with it (a mutation campaign of 3,000 files: 919 messages in trimesh's words, 91 after)."""
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path)
    message = str(e.value)
    assert message.startswith(f"{path}: not a valid {path.suffix[1:].upper()} file: "), message
    assert says in message, message


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
@pytest.mark.parametrize(
    ("change", "says"),
    [
        (lambda d: d["meshes"][0].update(primitives=3), "meshes[0].primitives is not an array of objects"),
        (lambda d: d["nodes"][0].update(children="1"), "nodes[0].children is not an array of indices"),
        (
            lambda d: d["scenes"][0].update(nodes=[7]),
            "scenes[0].nodes is not an array of indices of its 1 nodes",
        ),
        (lambda d: d["nodes"][0].update(translation=[1, 2]), "nodes[0].translation is not 3 numbers"),
    ],
)
def test_a_gltf_part_of_the_wrong_type_is_named(tmp_path: Path, suffix: str, change, says: str) -> None:
    """A glTF part of the wrong JSON type (an array that is a number, children that are not node indices)
    made trimesh fail in its own words ("'int' object is not iterable", "KeyError: 0"); the message names
    the part."""
    doc = _gltf_doc()
    change(doc)
    path = tmp_path / f"bad{suffix}"
    path.write_bytes(_glb_of(doc) if suffix == ".glb" else json.dumps(doc).encode())
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path)
    assert str(e.value).startswith(f"{path}: not a valid {suffix[1:].upper()} file: "), str(e.value)
    assert says in str(e.value)


def test_a_users_own_trimesh_obj_reads_run_trimeshs_code(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Our numpy reading of OBJ faces of differing lengths is for our loads only: after load_mesh, and from
    another thread while one of ours is reading, trimesh's own loads run its own face reading."""
    import threading

    import trimesh

    from swpm_usd.io import obj

    path = tmp_path / "mixed.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\nf 1 2 3\nf 2 4 5 3\n")
    assert load_mesh(path).triangle_count == 3  # (ours: the wrapper is in place from here)

    def refused(lines: list[str], original: object) -> tuple:
        raise AssertionError("a user's trimesh load took swpm_usd's face reading")

    monkeypatch.setattr(obj, "_obj_faces_fallback", refused)
    want = [[0, 1, 2], [1, 3, 4], [4, 2, 1]]
    assert trimesh.load(str(path), process=False).faces.tolist() == want
    seen: list[object] = []
    with obj._obj_faces_in_numpy():  # (one of ours reading, in this thread)
        thread = threading.Thread(target=lambda: seen.append(trimesh.load(str(path), process=False).faces))
        thread.start()
        thread.join()
    assert len(seen) == 1 and np.asarray(seen[0]).tolist() == want
