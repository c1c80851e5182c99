"""Corrupt files the loaders refused in trimesh's words ("trimesh could not read it (JSONDecodeError:
Expecting ',' delimiter: line 1 column 35)", "Not a ply file!", "'utf-8' codec can't decode byte 0xec in
position 0", "no field of name z", "not enough values to unpack"), found by a corruption campaign
(``benchmarks/corrupt_campaign.py``): each is named in our words, with where it is (a byte offset or a
line)."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
import trimesh

from swpm_usd.errors import MeshLoadError
from swpm_usd.io import load_mesh

POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def _export(file_type: str, **kwargs: object) -> bytes:
    data = trimesh.Trimesh(POINTS, FACES, process=False).export(file_type=file_type, **kwargs)
    return data.encode() if isinstance(data, str) else data


def _refused(path: Path, data: bytes, says: str) -> str:
    path.write_bytes(data)
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path)
    assert e.value.path == str(path)
    assert "trimesh could not read it" not in e.value.problem
    assert says in e.value.problem, e.value.problem
    return e.value.problem


def _glb_json(edit) -> bytes:
    """The tetrahedron's .glb with its JSON chunk's text edited by ``edit`` (bytes -> bytes of the same
    length)."""
    data = _export("glb")
    n = struct.unpack_from("<I", data, 12)[0]
    text = edit(data[20 : 20 + n])
    assert len(text) == n
    return data[:20] + text + data[20 + n :]


def test_a_glb_json_chunk_that_is_not_json_is_named_with_its_byte_offset(tmp_path: Path) -> None:
    def comma(text: bytes) -> bytes:
        at = text.index(b":")
        return text[:at] + b"," + text[at + 1 :]

    at = 20 + _glb_json(lambda t: t)[20:].index(b":")
    problem = _refused(tmp_path / "m.glb", _glb_json(comma), "its JSON chunk is not JSON: Expecting ':'")
    assert f"at byte offset {at} (line 1 of the chunk)" in problem


def test_a_glb_json_chunk_that_is_not_utf8_is_named_with_its_byte_offset(tmp_path: Path) -> None:
    def bad(text: bytes) -> bytes:
        return text[:30] + b"\xff" + text[31:]

    _refused(
        tmp_path / "m.glb",
        _glb_json(bad),
        "its JSON chunk: byte 0xff at byte offset 50 (line 1) is not UTF-8",
    )


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (lambda d: b"solid" + d[5:], "not a GLB file: it starts with b'soli', not b'glTF'"),
        (lambda d: d[:4] + struct.pack("<I", 1) + d[8:], "its header says version 1, not 2"),
        (lambda d: d[:16] + b"ABCD" + d[20:], "its first chunk is of type 0x44434241, not JSON"),
    ],
    ids=["magic", "version", "chunk-type"],
)
def test_a_glb_header_trimesh_refuses_is_named(tmp_path: Path, edit, says: str) -> None:
    _refused(tmp_path / "m.glb", edit(_export("glb")), says)


@pytest.mark.parametrize("encoding", ["binary", "ascii"])
def test_a_ply_header_that_is_not_ascii_is_named_with_its_byte_offset(tmp_path: Path, encoding: str) -> None:
    data = _export("ply", encoding=encoding)
    at = data.index(b"element vertex")
    data = data[:at] + b"\xc3(" + data[at:]
    line = data[:at].count(b"\n") + 1
    _refused(
        tmp_path / "m.ply", data, f"its header's byte 0xc3 at byte offset {at} (line {line}) is not ASCII"
    )


@pytest.mark.parametrize("encoding", ["binary", "ascii"])
@pytest.mark.parametrize(
    ("old", "new", "says"),
    [
        (b"property float z", b"property float binary_big_endian", "its element vertex has no property 'z'"),
        (b"property float y", b"property nan y", "'property nan y': 'nan' is not a PLY type"),
        (b"property float x", b"4294967295 float x", "'4294967295 float x' is not a PLY header line"),
        (b"property float x", b"property float", "'property float': not 'property TYPE NAME'"),
        (b"end_header", b"end_heade", "no 'end_header' line"),
        (b"ply\n", b"OFF\n", "not a PLY file: it starts with b'OFF"),
    ],
    ids=["no-z", "type", "line", "short-property", "no-end", "magic"],
)
def test_a_ply_header_trimesh_refuses_is_named_with_its_line(
    tmp_path: Path, encoding: str, old: bytes, new: bytes, says: str
) -> None:
    data = _export("ply", encoding=encoding)
    assert old in data
    _refused(tmp_path / "m.ply", data.replace(old, new, 1), says)


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (lambda d: b"x" + d[3:], "line 1: 'x' is not 'OFF'"),
        (lambda d: d.replace(b"4 4 0", b"4 4 nan", 1), "line 2: the counts line '4 4 nan' is not vertices"),
    ],
    ids=["magic", "edges"],
)
def test_an_off_header_trimesh_refuses_is_named_with_its_line(tmp_path: Path, edit, says: str) -> None:
    data = _export("off")
    assert data.startswith(b"OFF\n4 4 0\n"), data[:20]
    _refused(tmp_path / "m.off", edit(data), says)


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (lambda d: d[: d.index(b"3 0 3 2")], "the header declares 4 faces, the file has 2"),
        (lambda d: d[: d.index(b"3 0 3 2") + 5], "line 9: face 2 declares 3 corners and lists 2 values"),
        (lambda d: d.replace(b"3 0 2 1", b"4 0 2 1", 1), "line 7: face 0 declares 4 corners and lists 3"),
        (lambda d: d.replace(b"3 0 2 1", b"2000000000 0 2 1", 1), "face 0 declares 2000000000 corners"),
    ],
    ids=["cut-at-a-row", "cut-in-a-row", "corner-missing", "huge-corner-count"],
)
def test_an_off_file_cut_in_its_faces_is_refused(tmp_path: Path, edit, says: str) -> None:
    """trimesh reads the face rows there are, and of each the indices there are: a file cut in its faces
    loaded as a smaller mesh (2 triangles of 4), no word said, where a cut PLY or STL is refused."""
    data = _export("off")
    assert data.endswith(b"3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"), data[-40:]
    _refused(tmp_path / "m.off", edit(data), says)
    assert load_mesh_ok(tmp_path / "whole.off", data).triangle_count == 4


def load_mesh_ok(path: Path, data: bytes):
    path.write_bytes(data)
    return load_mesh(path)


@pytest.mark.parametrize("encoding", ["binary", "ascii"])
def test_a_ply_comment_holding_end_header_is_named(tmp_path: Path, encoding: str) -> None:
    """trimesh ends the header at any line holding the word (and then misreads the rest: "PLY is unexpected
    length!", or "no field of name x")."""
    data = _export("ply", encoding=encoding)
    at = data.index(b"\n", data.index(b"format ")) + 1
    data = data[:at] + b"comment end_header\n" + data[at:]
    _refused(
        tmp_path / "m.ply", data, "line 3: 'comment end_header' holds 'end_header' before the header's end"
    )


def test_an_ascii_ply_row_that_is_not_utf8_is_named_with_its_line(tmp_path: Path) -> None:
    """A control character in a comment (a line end to ``splitlines``, not to trimesh) had the header not
    read here, and a byte that is not UTF-8 in a row was trimesh's UnicodeDecodeError."""
    data = _export("ply", encoding="ascii").replace(b"ply\n", b"ply\ncomment a\x1db\n", 1)
    at = data.index(b"end_header\n") + len(b"end_header\n")
    row = data[at:].index(b" ")
    data = data[: at + row] + b"\xe9" + data[at + row :]
    line = data[:at].count(b"\n") + 1
    _refused(tmp_path / "m.ply", data, f"line {line}: vertex 0 holds")


@pytest.mark.parametrize("part", ["nodes", "meshes"])
def test_a_gltf_name_that_is_not_a_string_is_named(tmp_path: Path, part: str) -> None:
    """trimesh said "TypeError: object of type 'int' has no len()"."""
    import json

    files = trimesh.Trimesh(POINTS, FACES, process=False).export(file_type="gltf")
    doc = json.loads(files["model.gltf"])
    doc[part][0]["name"] = -1
    for name, data in files.items():
        if name != "model.gltf":
            (tmp_path / name).write_bytes(data)
    _refused(tmp_path / "m.gltf", json.dumps(doc).encode(), f"{part}[0].name is a number, not a string")


@pytest.mark.parametrize(
    ("asset", "says"),
    [({"version": "1.0"}, "its asset.version is '1.0'"), (5, "its asset is a number")],
    ids=["version", "not-object"],
)
def test_a_gltf_asset_that_is_not_gltf_2_is_named(tmp_path: Path, asset: object, says: str) -> None:
    """trimesh said "NotImplementedError: only GLTF 2 is supported not `1`", or "'int' object has no
    attribute 'get'"."""
    import json

    files = trimesh.Trimesh(POINTS, FACES, process=False).export(file_type="gltf")
    doc = json.loads(files["model.gltf"])
    doc["asset"] = asset
    for name, data in files.items():
        if name != "model.gltf":
            (tmp_path / name).write_bytes(data)
    _refused(tmp_path / "m.gltf", json.dumps(doc).encode(), f"{says}, not glTF 2's")


def test_an_ascii_ply_face_list_of_another_name_is_named(tmp_path: Path) -> None:
    """trimesh said "UnboundLocalError: cannot access local variable 'faces'"."""
    data = _export("ply", encoding="ascii").replace(b"vertex_indices", b"corners", 1)
    _refused(
        tmp_path / "m.ply", data, "its element face has no property 'vertex_indices' (nor 'vertex_index')"
    )


def test_an_obj_line_of_f_and_more_is_named_with_its_line(tmp_path: Path) -> None:
    """trimesh reads a line starting 'f5 ...' as a face and said "string or file could not be read to its
    end due to unmatched data"."""
    data = _export("obj")
    lines = data.split(b"\n")
    k = next(i for i, line in enumerate(lines) if line.startswith(b"v "))
    lines[k] = b"f5" + lines[k][1:]
    _refused(tmp_path / "m.obj", b"\n".join(lines), f"line {k + 1}: 'f5 ")


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
@pytest.mark.parametrize("asset", [True, False])
def test_a_gltf_primitive_without_position_is_named(tmp_path: Path, suffix: str, asset: bool) -> None:
    """trimesh said "KeyError: 'POSITION'". glTF 2.0 draws no such primitive: it is named in a warning, and
    the file, with nothing else, has no triangles. A file without its ``asset`` (which trimesh reads) is
    named for the primitive too, not for the asset."""
    import json

    data = _export("glb")
    n = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20 : 20 + n])
    if not asset:
        del doc["asset"]
    prim = doc["meshes"][0]["primitives"][0]
    prim["attributes"] = {"POS]TION": prim["attributes"]["POSITION"]}
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    rest = data[20 + n :]
    if suffix == ".gltf":
        import base64

        blob = rest[8 : 8 + struct.unpack_from("<I", rest)[0]]
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
        out = json.dumps(doc).encode()
    else:
        body = struct.pack("<II", len(text), 0x4E4F534A) + text + rest
        out = struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body
    with pytest.warns(UserWarning, match=r"meshes\[0\]\.primitives\[0\] without a POSITION attribute"):
        _refused(tmp_path / f"m{suffix}", out, "no triangles")


@pytest.mark.parametrize(
    ("face", "says"),
    [
        (b"f 0 3 2", "line 8: face corner '0' refers to vertex 0, the file has 4"),
        (b"f 1 3 00", "line 8: face corner '00' refers to vertex 0, the file has 4"),
        (b"f 1/1 -0/2 2/3", "line 8: face corner '-0/2' refers to vertex 0, the file has 4"),
    ],
    ids=["zero", "zeros", "minus-zero"],
)
def test_an_obj_face_corner_of_vertex_index_0_is_refused(tmp_path: Path, face: bytes, says: str) -> None:
    """OBJ counts vertices from 1 (and back from -1); trimesh read an index 0 as the first vertex, so
    ``f 0 3 2`` loaded as the triangle of vertices 1, 3, 2, no word said."""
    head = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\n"
    slash = b"/" in face
    fine, rest = (b"f 1/1 3/2 2/3", b"f 1/1 2/2 4/3\n") if slash else (b"f 1 3 2", b"f 1 2 4\n")
    _refused(tmp_path / "m.obj", head + face + b"\n" + rest, says)
    # the same file with index 1: the zeros of its v and vt rows and of a comment are no vertex index
    ok = head + b"# f 0 1 2\n" + fine + b"\n" + rest + rest.replace(b"1", b"3", 1)
    assert load_mesh_ok(tmp_path / "ok.obj", ok).triangle_count == 3


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (lambda d: d[:-4], "line 18: face 3 declares 3 values and lists 1"),
        (lambda d: d.replace(b"\n3 0 2 1", b"\n4 0 2 1", 1), "line 15: face 0 declares 4 values and lists 3"),
        (lambda d: d.replace(b"\n3 0 1 3", b"\n3", 1), "line 16: face 1 declares 3 values and lists 0"),
    ],
    ids=["cut-in-the-last-row", "corner-missing", "corners-missing"],
)
def test_an_ascii_ply_face_row_short_of_its_count_is_refused(tmp_path: Path, edit, says: str) -> None:
    """trimesh reads an ASCII PLY a row a line and takes the values there are: ``4 0 2 1`` loaded as the
    triangle 0 2 1, and a file cut inside its last row (as many lines as rows) without that face, silently."""
    data = _export("ply", encoding="ascii")
    assert data.endswith(b"\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"), data[-40:]
    problem = _refused(tmp_path / "m.ply", edit(data), says)
    assert problem.startswith("not a valid PLY file: ")
    assert load_mesh_ok(tmp_path / "whole.ply", data).triangle_count == 4


def test_the_numpy_gate_of_the_off_check_never_passes_what_its_loop_refuses() -> None:
    """``_off_whole`` (numpy) lets a file through only when ``_off_short``'s loop finds nothing: every cut of
    an OFF file of triangles and a quad, and every face row's count changed, blank lines and CRLF too."""
    from swpm_usd.io.off import _off_problem, _off_short, _off_whole

    whole = b"OFF\n\n5 3 0\n0 0 0\n1 0 0\n0 1 0\r\n1 1 0\n\n0 0 1\n3 0 1 2\n4 1 3 2 4 255 0 0\n3 0 2 4\n"
    assert _off_whole(whole) and _off_short(whole) is None and _off_problem(whole) is None
    variants = [whole[:n] for n in range(len(whole))]
    rows = whole.split(b"\n")
    for i, r in enumerate(rows):
        if r[:1] in (b"3", b"4"):
            for c in (b"2", b"4", b"5", b"40", b"x", b"-3", b"+3", b"999999999999"):
                variants.append(b"\n".join([*rows[:i], c + r[1:], *rows[i + 1 :]]))
    refused = 0
    for v in variants:
        if _off_whole(v):
            assert _off_short(v) is None, v
        refused += _off_short(v) is not None
    assert refused > len(whole) // 2  # (the loop refuses most: the gate did not hide them)


@pytest.mark.parametrize(
    "comment",
    [
        (b"1 0 0\n", b"1 0 0\n# a comment among the vertices\n"),
        (b"3 0 2 1\n", b"3 0 2 1 # the first face\n"),
        (b"0 0 1\n", b"0 0 1\n\n# the faces\n"),
    ],
    ids=["line-among-vertices", "after-a-face", "before-the-faces"],
)
def test_an_off_file_with_a_comment_past_its_second_line_loads_whole(tmp_path: Path, comment) -> None:
    """trimesh 5.2's comment_strip repeats the text before a file's first '#' (from its second line on):
    an OFF file whose first comment came after its counts line loaded, no word said, as the counts line
    read as a vertex and one triangle (3 vertices, 1 triangle of the tetrahedron's 4 and 4)."""
    path = tmp_path / "t.off"
    whole = b"OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"
    path.write_bytes(whole)
    expected = load_mesh(path)
    path.write_bytes(whole.replace(*comment))
    mesh = load_mesh(path)
    assert (mesh.vertex_count, mesh.triangle_count) == (4, 4)
    assert np.array_equal(mesh.points, expected.points) and np.array_equal(mesh.triangles, expected.triangles)


def _grid_rows(n: int) -> list[bytes]:
    """The vertex rows, then the face rows ('3 a b c'), of an n x n grid of quads split in two triangles, its
    heights varied: the body of an ASCII PLY or an OFF file of 2 n^2 triangles."""
    rows = [b"%d %d %.1f" % (x, y, (x * y) % 3 * 0.1) for y in range(n + 1) for x in range(n + 1)]
    for y in range(n):
        for x in range(n):
            a = y * (n + 1) + x
            rows += [b"3 %d %d %d" % (a, a + 1, a + n + 2), b"3 %d %d %d" % (a, a + n + 2, a + n + 1)]
    return rows


def test_the_ascii_ply_check_splits_the_file_without_a_copy_of_its_body() -> None:
    """``ply_ascii_short`` split ``data[at:]``, a copy of the body, for its rows: its peak 4.5 times a
    100,000-triangle grid's file (1.1 MB), 3.9 splitting the file itself (the rows' list and bytes)."""
    import tracemalloc

    from swpm_usd.io.ply import ply_ascii_short

    n = 150
    rows = [b"ply", b"format ascii 1.0", b"element vertex %d" % ((n + 1) ** 2)]
    rows += [b"property float x", b"property float y", b"property float z", b"element face %d" % (2 * n * n)]
    rows += [b"property list uchar int vertex_indices", b"end_header", *_grid_rows(n)]
    data = b"\n".join(rows) + b"\n"
    tracemalloc.start()
    try:
        assert ply_ascii_short(data) is None
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4.2 * len(data), (peak, len(data))
    cut = data[: data.rindex(b" ")]  # (in the last row, before its last index)
    says = f"line {len(rows)}: face {2 * n * n - 1} declares 3 values and lists 2"  # (its line, as before)
    assert ply_ascii_short(cut) == f"not a valid PLY file: {says}"


def test_the_off_check_holds_a_few_times_the_file_not_eight_bytes_a_byte() -> None:
    """``_off_whole`` took each token's line from a cumsum over the file's bytes, an int64 a byte: its peak
    was 20 times the file (nefertiti as OFF, 4.1 MB: 83 MB), a 100 MB scan's 2 GB on top of trimesh's
    read. The newlines' places and a search hold a few times the file (25 MB)."""
    import tracemalloc

    from swpm_usd.io.off import _off_short

    n = 150
    rows = [b"OFF", b"%d %d 0" % ((n + 1) ** 2, 2 * n * n), *_grid_rows(n)]
    data = b"\n".join(rows) + b"\n"
    tracemalloc.start()
    try:
        assert _off_short(data) is None
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 10 * len(data), (peak, len(data))


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (
            lambda d: d.replace(b"v 1 0 0\n", b"v 1 0 0 # x\n", 1),
            "line 2: a comment after a 'v' row's values ('# x')",
        ),
        (lambda d: d + b"f 1 2 3 # the last\n", "line 9: a comment after a 'f' row's values ('# the last')"),
    ],
    ids=["vertex", "face"],
)
def test_an_obj_comment_after_a_rows_values_is_named_with_its_line(tmp_path: Path, edit, says: str) -> None:
    """trimesh fails on it ("string or file could not be read to its end due to unmatched data"), and the
    row check, which leaves comments out, found nothing: the message was trimesh's."""
    data = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    assert load_mesh_ok(tmp_path / "whole.obj", b"# a comment line\n" + data).triangle_count == 4
    _refused(tmp_path / "m.obj", edit(data), says)


def _gltf_doc(indices: list[int] | None, mode: int | None = None) -> bytes:
    """A glTF of the tetrahedron's points (embedded buffer), with ``indices`` (None: none) and ``mode``."""
    import base64
    import json

    pb = POINTS.astype(np.float32).tobytes()
    ib = b"" if indices is None else np.array(indices, np.uint32).tobytes()
    buf = pb + ib
    prim: dict = {"attributes": {"POSITION": 0}}
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0] * 3, "max": [1] * 3}
    ]
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": len(pb)}]
    if indices is not None:
        prim["indices"] = 1
        accessors.append({"bufferView": 1, "componentType": 5125, "count": len(indices), "type": "SCALAR"})
        views.append({"buffer": 0, "byteOffset": len(pb), "byteLength": len(ib)})
    if mode is not None:
        prim["mode"] = mode
    uri = "data:application/octet-stream;base64," + base64.b64encode(buf).decode()
    doc = {
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [prim]}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(buf), "uri": uri}],
    }
    return json.dumps(doc).encode()


def test_a_gltf_triangle_list_of_a_count_not_a_multiple_of_3_is_named(tmp_path: Path) -> None:
    """trimesh's words were "cannot reshape array of size 5 into shape (3)"."""
    assert load_mesh_ok(tmp_path / "whole.gltf", _gltf_doc(FACES.ravel().tolist())).triangle_count == 4
    _refused(
        tmp_path / "m.gltf",
        _gltf_doc(FACES.ravel().tolist()[:5]),
        "meshes[0].primitives[0]: its 5 indices (accessors[1]) are not a whole number of triangles",
    )
    _refused(
        tmp_path / "n.gltf",
        _gltf_doc(None),
        "meshes[0].primitives[0]: its 4 POSITION values (no indices) (accessors[0]) are not a whole number",
    )


@pytest.mark.parametrize(
    ("file_type", "edit", "says"),
    [
        (
            "ply",
            lambda d: b"ply\nformat weird 1.0\nend_header\n",
            "line 2: 'format weird 1.0' is not a PLY",
        ),
        (
            "off",
            lambda d: d.replace(b"4 4 0", b"-4 4 0", 1),
            "line 2: the counts line '-4 4 0' holds a negative count",
        ),
        (
            "off",
            lambda d: d.replace(b"4 4 0", b"-4 0 0", 1)[:10],
            "line 2: the counts line '-4 0 0' holds a negative",
        ),
        (
            "off",
            lambda d: d.replace(b"4 4 0", b"4 -4 0", 1),
            "line 2: the counts line '4 -4 0' holds a negative count",
        ),
    ],
    ids=["ply-format", "off-vertices", "off-vertices-only", "off-faces"],
)
def test_a_header_trimesh_reads_as_holding_nothing_is_named(
    tmp_path: Path, file_type: str, edit, says: str
) -> None:
    """trimesh read these headers as ones of no rows: the error was "no triangles: the file holds no triangle
    geometry" (INPUT_EMPTY), or the header's face count against none found."""
    data = _export(file_type, **({"encoding": "ascii"} if file_type == "ply" else {}))
    problem = _refused(tmp_path / f"m.{file_type}", edit(data), says)
    assert problem.startswith(f"not a valid {file_type.upper()} file: "), problem
