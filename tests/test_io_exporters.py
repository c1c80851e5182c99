"""Files common exporters write, which each loader must read as the same mesh as their plain form: a UTF-8
byte-order mark (Windows tools), tab-separated or indented rows, CRLF lines, polygons of mixed corner
counts; or refuse with a clear MeshLoadError naming the file."""

from __future__ import annotations

import struct
import warnings
from pathlib import Path

import numpy as np
import pytest

from swpm_usd.errors import MeshLoadError
from swpm_usd.io import load_mesh

BOM = b"\xef\xbb\xbf"
#: 8 points (no two the same, none on a symmetry: a misread shows) and a quad's two triangles twice
POINTS = [(0, 0, 0), (1, 0, 0.5), (1, 1, 0.25), (0, 1, 0), (0, 0, 1), (1, 0, 1.5), (1, 1, 1), (0.5, 1, 1)]
TRIANGLES = [(0, 1, 2), (0, 2, 3), (4, 5, 6), (4, 6, 7)]


def _obj(sep: str = " ", indent: str = "", nl: str = "\n") -> bytes:
    rows = [f"{indent}v{sep}{sep.join(map(str, p))}" for p in POINTS]
    rows += [f"{indent}f{sep}{sep.join(str(i + 1) for i in t)}" for t in TRIANGLES]
    return (nl.join(rows) + nl).encode()


def _load(tmp_path: Path, name: str, data: bytes):
    path = tmp_path / name
    path.write_bytes(data)
    return load_mesh(path)


def _same(a, b) -> None:
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.triangles, b.triangles)
    assert sorted(a.attributes) == sorted(b.attributes)
    for k in a.attributes:
        np.testing.assert_array_equal(a.attributes[k], b.attributes[k])


# --- OBJ


def test_obj_with_a_byte_order_mark_loads_as_without(tmp_path: Path) -> None:
    # (the first 'v' line was lost behind the mark: "face corner '8' refers to vertex 8, the file has 7")
    plain = _load(tmp_path, "plain.obj", _obj())
    _same(_load(tmp_path, "bom.obj", BOM + _obj()), plain)
    _same(_load(tmp_path, "bom_crlf.obj", BOM + _obj(nl="\r\n")), plain)


def test_obj_with_a_byte_order_mark_keeps_its_line_numbers_and_counts(tmp_path: Path) -> None:
    from swpm_usd.io import early_triangle_count

    zero = BOM + _obj().replace(b"f 1 2 3", b"f 0 2 3")
    said = r"zero\.obj.*line 9: face corner '0' refers to vertex 0, the file has 8"
    with pytest.raises(MeshLoadError, match=said):
        _load(tmp_path, "zero.obj", zero)
    path = tmp_path / "face_first.obj"  # (its first line a face: counted for the budget)
    path.write_bytes(BOM + b"f 1 2 3\n" + _obj())
    assert early_triangle_count(path) == (5, False)


@pytest.mark.parametrize(
    "text",
    [_obj("\t"), _obj(" ", "  "), _obj(" ", "\t"), _obj("\t", "\t", "\r\n"), BOM + _obj("\t", nl="\r\n")],
    ids=["tabs", "indented", "tab-indented", "tabs-crlf", "bom-tabs-crlf"],
)
def test_obj_with_tabs_or_indented_rows_loads_as_plain(tmp_path: Path, text: bytes) -> None:
    # (trimesh finds rows by '\nv ' and '\nf ': "no triangles")
    _same(_load(tmp_path, "x.obj", text), _load(tmp_path, "plain.obj", _obj()))


def test_obj_with_some_indented_faces_loads_them_all(tmp_path: Path) -> None:
    # (the indented faces were dropped, no word said: 2 triangles of 4)
    mixed = _obj().replace(b"\nf 5", b"\n   f 5").replace(b"\nv 2", b"\n\tv 2")
    _same(_load(tmp_path, "mixed.obj", mixed), _load(tmp_path, "plain.obj", _obj()))


def test_obj_with_tab_separated_uvs_and_normals_keeps_them(tmp_path: Path) -> None:
    rows = ["v 0 0 0", "v 1 0 0", "v 1 1 0", "vt 0 0", "vt 1 0", "vt 1 1", "vn 0 0 1", "f 1/1/1 2/2/1 3/3/1"]
    plain = _load(tmp_path, "plain.obj", ("\n".join(rows) + "\n").encode())
    assert sorted(plain.attributes) == ["normal", "uv"]
    tabbed = "\n".join("\t" + r.replace(" ", "\t") for r in rows) + "\n"
    _same(_load(tmp_path, "tabs.obj", tabbed.encode()), plain)


def test_obj_indented_rows_are_checked_and_counted(tmp_path: Path) -> None:
    from swpm_usd.io import early_triangle_count

    with pytest.raises(MeshLoadError, match=r"zero\.obj.*line 9: face corner '0' refers to vertex 0"):
        _load(tmp_path, "zero.obj", _obj(" ", "  ").replace(b"f 1 2 3", b"f 0 2 3"))
    with pytest.raises(
        MeshLoadError, match=r"far\.obj.*line 10: face corner '9' refers to vertex 9, the file has 8"
    ):
        _load(tmp_path, "far.obj", _obj("\t").replace(b"f\t1\t3\t4", b"f\t1\t3\t9"))
    path = tmp_path / "count.obj"
    path.write_bytes(_obj("\t", "  "))
    assert early_triangle_count(path) == (4, False)


def test_obj_continued_lines_keep_their_blanks(tmp_path: Path) -> None:
    # a line ended by '\' continues on the next: its blanks are not a row's indentation
    quad = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    one = _load(tmp_path, "one.obj", quad + b"f 1 2 3 4\n")
    _same(_load(tmp_path, "continued.obj", quad + b"f 1 2 \\\n   3 4\n"), one)
    _same(_load(tmp_path, "continued_crlf.obj", (quad + b"f 1 2 \\\n\t3 4\n").replace(b"\n", b"\r\n")), one)


# --- OFF


def _off(faces: list[tuple[int, ...]], extra: list[str] | None = None) -> bytes:
    rows = [f"OFF\n{len(POINTS)} {len(faces)} 0"] + [" ".join(map(str, p)) for p in POINTS]
    for k, f in enumerate(faces):
        rows.append(f"{len(f)} {' '.join(map(str, f))}" + (f" {extra[k]}" if extra else ""))
    return ("\n".join(rows) + "\n").encode()


def _canonical(triangles: np.ndarray) -> list[tuple[int, ...]]:
    """The triangles each rotated to start at its least index (its orientation kept), sorted."""
    t = np.asarray(triangles)
    rolled = [tuple(np.roll(r, -int(np.argmin(r))).tolist()) for r in t]
    return sorted(rolled)


@pytest.mark.parametrize(
    "faces",
    [
        [(0, 1, 2, 3), (4, 5, 6, 7, 0)],
        [(0, 1, 2, 3), (4, 5, 6, 7, 0), (1, 5, 6)],
        [(1, 5, 6), (0, 4, 5, 6, 7, 3)],
    ],
    ids=["4-5", "4-5-3", "3-6"],
)
def test_off_of_polygons_of_mixed_corner_counts_loads_them_as_fans(tmp_path: Path, faces: list) -> None:
    # (trimesh failed: "The 'out' kwarg is necessary when using the string multiply ufunc directly")
    m = _load(tmp_path, "mixed.off", _off(faces))
    fans = [(f[0], f[k], f[k + 1]) for f in faces for k in range(1, len(f) - 1)]
    want = _load(tmp_path, "fans.off", _off(fans))
    np.testing.assert_array_equal(m.points, want.points)
    assert m.triangle_count == len(fans) and _canonical(m.triangles) == _canonical(want.triangles)


def test_off_of_mixed_polygons_keeps_each_face_colour(tmp_path: Path) -> None:
    faces = [(0, 1, 2, 3), (4, 5, 6, 7, 0), (1, 5, 6)]
    colours = ["255 0 0", "0 255 0", "0 0 255"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # (no "face colours are not loaded")
        m = _load(tmp_path, "coloured.off", _off(faces, colours))
    assert m.triangle_count == 2 + 3 + 1
    for tri in m.triangles:
        ids = {POINTS.index(tuple(float(c) for c in m.points[v])) for v in tri}
        (face,) = [k for k, f in enumerate(faces) if ids <= set(f)]
        want = [float(c) / 255 for c in colours[face].split()] + [1.0]
        np.testing.assert_allclose(m.attributes["color"][tri], [want] * 3, atol=1e-6)


def test_off_of_mixed_polygons_cut_short_says_where(tmp_path: Path) -> None:
    short = _off([(0, 1, 2, 3), (4, 5, 6, 7, 0)]).replace(b"5 4 5 6 7 0", b"5 4 5 6 7")
    with pytest.raises(
        MeshLoadError, match=r"short\.off.*line 12: face 1 declares 5 corners and lists 4 values"
    ):
        _load(tmp_path, "short.off", short)
    far = _off([(0, 1, 2, 3), (4, 5, 6, 7, 9)])
    with pytest.raises(MeshLoadError, match=r"far\.off.*line 12: face 1 refers to vertex 9, the file has 8"):
        _load(tmp_path, "far.off", far)


def test_off_of_mixed_polygons_with_its_counts_on_the_header_line_and_comments(tmp_path: Path) -> None:
    faces = [(0, 1, 2, 3), (4, 5, 6, 7, 0)]
    text = _off(faces).replace(b"OFF\n", b"OFF ").replace(b"\n5 ", b"\n# a pentagon\n5 ", 1)
    assert text.startswith(b"OFF 8 2 0\n")
    _same(_load(tmp_path, "one_line.off", text), _load(tmp_path, "plain.off", _off(faces)))


def test_off_with_a_byte_order_mark_loads_as_without(tmp_path: Path) -> None:
    coff = b"COFF\n4 2 0\n0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 255 255 255\n3 0 1 2\n3 0 2 3\n"
    plain = _load(tmp_path, "plain.off", coff)
    assert "color" in plain.attributes
    _same(_load(tmp_path, "bom.off", BOM + coff), plain)  # (its vertex colours were dropped, no word said)
    mixed = _off([(0, 1, 2, 3), (4, 5, 6, 7, 0)])
    _same(_load(tmp_path, "bom_mixed.off", BOM + mixed), _load(tmp_path, "mixed.off", mixed))
    bad = BOM + _off(TRIANGLES).replace(b"\n1 0 0.5\n", b"\n1 0 x\n")
    with pytest.raises(MeshLoadError, match=r"bad\.off: not a valid OFF file: line 4: vertex 1 holds 'x'"):
        _load(tmp_path, "bad.off", bad)


# --- PLY


def _ply(fmt: str = "ascii", nl: str = "\n", sep: str = " ", faces: list | None = None) -> bytes:
    faces = faces or [(0, 1, 2, 3), (4, 5, 6, 7, 0), (1, 5, 6)]
    head = ["ply", f"format {fmt} 1.0", f"element vertex {len(POINTS)}"]
    head += [f"property float {c}" for c in "xyz"]
    head += [f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    out = (nl.join(head) + nl).encode()
    if fmt == "ascii":
        out += "".join(sep.join(map(str, p)) + nl for p in POINTS).encode()
        return out + "".join(sep.join(map(str, [len(f), *f])) + nl for f in faces).encode()
    out += b"".join(struct.pack("<3f", *p) for p in POINTS)
    return out + b"".join(struct.pack(f"<B{len(f)}i", len(f), *f) for f in faces)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
def test_ply_with_a_byte_order_mark_loads_as_without(tmp_path: Path, fmt: str) -> None:
    # (the checks and the polygons' triangulation looked for 'ply' at byte 0: an ASCII file's mixed faces
    # came out other triangles, a binary one's "vertex index 50331648 out of range")
    plain = _load(tmp_path, "plain.ply", _ply(fmt))
    assert plain.triangle_count == 2 + 3 + 1
    _same(_load(tmp_path, "bom.ply", BOM + _ply(fmt)), plain)
    triangles = [(0, 1, 2), (0, 2, 3), (4, 5, 6), (4, 6, 7)]
    _same(
        _load(tmp_path, "bom3.ply", BOM + _ply(fmt, faces=triangles)),
        _load(tmp_path, "p3.ply", _ply(fmt, faces=triangles)),
    )


def test_ply_with_a_byte_order_mark_cut_short_is_refused(tmp_path: Path) -> None:
    # (its rows were loaded as a smaller mesh, no word said)
    with pytest.raises(
        MeshLoadError, match=r"cut\.ply: truncated ASCII PLY: element face declares 3, found 1"
    ):
        _load(tmp_path, "cut.ply", (BOM + _ply())[:-20])
    with pytest.raises(MeshLoadError, match=r"cut_bin\.ply: truncated binary PLY: element face declares 3"):
        _load(tmp_path, "cut_bin.ply", (BOM + _ply("binary_little_endian"))[:-5])


@pytest.mark.parametrize(
    "nl, sep", [("\r\n", " "), ("\n", "\t"), ("\r\n", "\t")], ids=["crlf", "tabs", "crlf-tabs"]
)
def test_ply_with_crlf_lines_or_tabs_loads_as_plain(tmp_path: Path, nl: str, sep: str) -> None:
    _same(_load(tmp_path, "x.ply", _ply(nl=nl, sep=sep)), _load(tmp_path, "plain.ply", _ply()))
    binary = _ply("binary_little_endian", nl=nl)  # (a CRLF header before binary rows)
    _same(_load(tmp_path, "x_bin.ply", binary), _load(tmp_path, "plain.ply", _ply()))


# --- STL (found sound: these guard it)


def _stl(name: str = "cube", nl: str = "\n", sep: str = " ", indent: str = "  ") -> bytes:
    rows = [f"solid {name}".rstrip()]
    for t in TRIANGLES:
        rows += [f"{indent}facet normal 0 0 1", f"{indent * 2}outer loop"]
        rows += [f"{indent * 3}vertex{sep}{sep.join(map(str, POINTS[i]))}" for i in t]
        rows += [f"{indent * 2}endloop", f"{indent}endfacet"]
    return (nl.join([*rows, f"endsolid {name}".rstrip()]) + nl).encode()


def _stl_binary(header: bytes) -> bytes:
    body = b"".join(
        struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *POINTS[i]) for i in t) + b"\0\0"
        for t in TRIANGLES
    )
    return header.ljust(80, b" ") + struct.pack("<I", len(TRIANGLES)) + body


@pytest.mark.parametrize(
    "text",
    [
        BOM + _stl(),
        _stl(sep="\t", indent="\t"),
        BOM + _stl("part v2 (final)", "\r\n", "\t", "\t"),
        _stl(""),
        _stl().upper(),
        _stl_binary(b"solid exported by a CAD tool"),  # (binary, its header starting with 'solid')
        _stl_binary(b"solid x\nfacet normal 0 0 1\nendsolid x\n"),
    ],
    ids=["bom", "tabs", "bom-name-crlf-tabs", "no-name", "upper", "binary-solid", "binary-solid-text"],
)
def test_stl_as_exporters_write_it_loads_as_plain(tmp_path: Path, text: bytes) -> None:
    _same(_load(tmp_path, "x.stl", text), _load(tmp_path, "plain.stl", _stl()))


# --- lines ended by CR alone (classic Mac OS)


def test_text_files_of_cr_lines_load_as_plain(tmp_path: Path) -> None:
    # (OBJ: "line 1: a 'v' row holds 'v', not a number"; ASCII STL: "trimesh could not read it"; a COFF's
    # colours dropped)
    _same(_load(tmp_path, "cr.obj", _obj(nl="\r")), _load(tmp_path, "plain.obj", _obj()))
    _same(_load(tmp_path, "cr.stl", _stl(nl="\r")), _load(tmp_path, "plain.stl", _stl()))
    _same(
        _load(tmp_path, "cr.off", _off(TRIANGLES).replace(b"\n", b"\r")),
        _load(tmp_path, "p.off", _off(TRIANGLES)),
    )
    coff = b"COFF\n4 2 0\n0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 255 255 255\n3 0 1 2\n3 0 2 3\n"
    plain = _load(tmp_path, "coff.off", coff)
    _same(_load(tmp_path, "coff_cr.off", coff.replace(b"\n", b"\r")), plain)
    with pytest.raises(MeshLoadError, match=r"zero\.obj.*line 9: face corner '0' refers to vertex 0"):
        _load(tmp_path, "zero.obj", _obj(nl="\r").replace(b"f 1 2 3", b"f 0 2 3"))


def test_ply_of_cr_lines_says_so(tmp_path: Path) -> None:
    with pytest.raises(MeshLoadError, match=r"cr\.ply: not a valid PLY file: its lines end in CR alone"):
        _load(tmp_path, "cr.ply", _ply(nl="\r"))


def _mixed_line_ends(data: bytes) -> bytes:
    """``data`` with every other line ended by CR alone, the rest by LF (a file pieced from two systems')."""
    lines = data.split(b"\n")
    return b"".join(line + (b"\r" if k % 2 else b"\n") for k, line in enumerate(lines[:-1])) + lines[-1]


def test_off_of_lf_and_cr_lines_loads_as_plain(tmp_path: Path) -> None:
    # trimesh's OFF reader splits lines at CR, LF and CRLF (str.splitlines); the checks after it split at LF
    # alone: 'the header declares 4 faces, the file has 2' of a file trimesh read whole, and colours lost
    plain = _load(tmp_path, "p.off", _off(TRIANGLES))
    _same(_load(tmp_path, "mixed.off", _mixed_line_ends(_off(TRIANGLES))), plain)
    one_cr = _off(TRIANGLES).replace(b"3 0 1 2\n", b"3 0 1 2\r")  # (refused: 'declares 4 faces, ... has 3')
    _same(_load(tmp_path, "one_cr.off", one_cr), plain)
    _same(_load(tmp_path, "mixed_crlf.off", _mixed_line_ends(_off(TRIANGLES)).replace(b"\n", b"\r\n")), plain)
    colours = ["255 0 0", "0 255 0", "0 0 255", "255 255 255"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # (no "face colours are not loaded")
        _same(
            _load(tmp_path, "c.off", _mixed_line_ends(_off(TRIANGLES, colours))),
            _load(tmp_path, "cp.off", _off(TRIANGLES, colours)),
        )
    coff = b"COFF\n4 2 0\n0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 255 255 255\n3 0 1 2\n3 0 2 3\n"
    _same(_load(tmp_path, "coff_mixed.off", _mixed_line_ends(coff)), _load(tmp_path, "coff.off", coff))
    mixed = _mixed_line_ends(_off([(0, 1, 2, 3), (4, 5, 6, 7, 0)]))
    _same(
        _load(tmp_path, "fan_mixed.off", mixed),
        _load(tmp_path, "fan.off", _off([(0, 1, 2, 3), (4, 5, 6, 7, 0)])),
    )
    with pytest.raises(
        MeshLoadError, match=r"cut\.off: not a valid OFF file: the header declares 4 faces, the file has 3"
    ):
        _load(tmp_path, "cut.off", _mixed_line_ends(_off(TRIANGLES)).rsplit(b"3 ", 1)[0])
