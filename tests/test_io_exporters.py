"""Files common exporters write, which each loader must read as the same mesh as their plain form: a UTF-8
byte-order mark (Windows tools), tab-separated or indented rows, CRLF lines, polygons of mixed corner
counts; or refuse with a clear MeshLoadError naming the file."""

from __future__ import annotations

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
