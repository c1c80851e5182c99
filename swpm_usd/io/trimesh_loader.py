"""Load OBJ / PLY / STL / OFF / glTF / GLB files through trimesh into a cleaned :class:`~swpm_usd.mesh.Mesh`.

trimesh is asked not to process anything (``process=False``): no vertex welding, so UV and normal seams stay
split. ``maintain_order`` is deliberately *not* used for OBJ: in trimesh it keeps one vertex per ``v`` line
and picks the median ``vt`` / ``vn`` index for it, which silently destroys UV and normal seams. Every
triangle geometry of the scene is taken with its scene-graph transform applied and the parts are
concatenated; per-vertex ``normal``, ``uv`` and ``color`` (RGBA float in [0, 1]) are kept when every part
has them. Any trimesh failure becomes a :class:`~swpm_usd.errors.MeshLoadError` naming the file.

STL files are checked before trimesh reads them (:func:`check_stl`): trimesh takes a binary STL whose length
disagrees with its header for ASCII, and drops an ASCII solid without its ``endsolid``, so a cut file would
load as "no triangles" (or as part of its triangles) instead of being reported as truncated.
"""

from __future__ import annotations

import io
import json
import os
import re
import warnings
from pathlib import Path

import numpy as np

from ..errors import MeshLoadError
from ..mesh import Mesh
from .clean import clean_mesh, concatenate_parts, rgba_float, split_corners, transform_part

_TEXT_TYPES = ("obj", "off")
#: a binary STL: an 80-byte header, the triangle count (uint32), then 50 bytes per triangle
_STL_HEADER_BYTES = 84
_STL_TRIANGLE_BYTES = 50


#: how much of an STL's start and end the check looks at (a valid file is not read further)
_STL_PROBE_BYTES = 1 << 16
#: a facet's keywords (``outer loop``: ``outer``), as whole words
_STL_FACET_WORD = re.compile(rb"\b(?:facet|outer|vertex|endloop|endfacet)\b")
_STL_ENDSOLID = re.compile(rb"\bendsolid\b")


def check_stl(path: Path, data: bytes | None = None) -> None:
    """Raise a :class:`MeshLoadError` if the STL file ``path`` (or ``data``, its bytes) is cut short.

    A binary STL must be exactly 84 + 50 x (its header's triangle count) bytes (the test trimesh reads it
    by); anything else is taken for ASCII when its start holds ``solid`` (after a byte-order mark, blanks or
    a comment, in any case) and no NUL byte (trailing NUL padding aside). A file that is neither is reported
    with the sizes: expected by its header against actual. An ASCII STL must close its last facet with an
    ``endsolid``: text whose last facet keyword comes after its last ``endsolid`` line is reported with the
    line it stops at (a solid's name, on the ``endsolid`` line, may hold any word).

    Only the file's size and its first and last 64 KiB are read (a cut ASCII file is then read through, in
    chunks, for the message): a large valid file is not read into memory for the check.
    """
    if data is None:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            head = f.read(_STL_PROBE_BYTES)
            f.seek(max(size - _STL_PROBE_BYTES, 0))
            tail = f.read()
    else:
        size, head, tail = len(data), data[:_STL_PROBE_BYTES], data[-_STL_PROBE_BYTES:]
    _check_stl(path, size, head, tail, data)


def _stl_text_counts(path: Path, data: bytes | None) -> tuple[int, int]:
    """(lines, complete facets) of an ASCII STL, read in chunks."""
    if data is not None:
        return data.count(b"\n") + (not data.endswith(b"\n")), data.lower().count(b"endfacet")
    lines = facets = 0
    carry = last = b""
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            lines += chunk.count(b"\n")
            low = carry + chunk.lower()
            facets += low.count(b"endfacet")  # (carry is shorter than the word: none is counted twice)
            carry, last = low[-7:], chunk[-1:]
    return lines + (last != b"\n"), facets


def _check_stl(path: Path, size: int, head: bytes, tail: bytes, data: bytes | None) -> None:
    if size >= _STL_HEADER_BYTES:
        count = int.from_bytes(head[80:84], "little")
        expected = _STL_HEADER_BYTES + _STL_TRIANGLE_BYTES * count
        if size == expected:
            return
    head = head.rstrip(b"\x00\x1a \t\r\n")
    if b"solid" in head.lower() and b"\x00" not in head:
        tail = tail.rstrip(b"\x00\x1a \t\r\n").lower()
        ends = list(_STL_ENDSOLID.finditer(tail))
        after = tail
        if ends:
            line_end = tail.find(b"\n", ends[-1].end())
            after = b"" if line_end < 0 else tail[line_end:]
        if _STL_FACET_WORD.search(after):  # a facet after the last endsolid, or no endsolid at all
            lines, facets = _stl_text_counts(path, data)
            raise MeshLoadError(
                path,
                f"truncated ASCII STL: the text stops at line {lines} after {facets} "
                f"complete facets, without the closing 'endsolid'",
            )
        return
    if size == 0:
        raise MeshLoadError(path, "no triangles: the file is empty (0 bytes)")
    if size < _STL_HEADER_BYTES:
        raise MeshLoadError(
            path,
            f"truncated binary STL: {size} bytes, shorter than the {_STL_HEADER_BYTES}-byte header "
            f"(and not ASCII STL: it does not start with 'solid')",
        )
    what = f"header says {count} triangles ({expected} bytes), the file has {size} bytes"
    if b"\x00" not in head:  # text, but no 'solid'
        raise MeshLoadError(
            path, f"not an STL file: not ASCII STL (no 'solid' at the start) nor binary STL ({what})"
        )
    if size < expected:
        raise MeshLoadError(path, f"truncated binary STL: {what}")
    raise MeshLoadError(path, f"not a valid binary STL: {what} ({size - expected} bytes too many)")


def _geometry_part(geom: object) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]] | None:
    import trimesh

    if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
        return None
    points = np.asarray(geom.vertices, dtype=np.float64)
    faces = np.asarray(geom.faces, dtype=np.int64)
    v = points.shape[0]
    attrs: dict[str, np.ndarray] = {}
    # only normals the file provided (trimesh computes them on access otherwise)
    if "vertex_normals" in geom._cache:
        normals = np.asarray(geom._cache["vertex_normals"], dtype=np.float32)
        if normals.shape == (v, 3):
            attrs["normal"] = normals
    visual = geom.visual
    face_colors = None
    if isinstance(visual, trimesh.visual.TextureVisuals):
        uv = visual.uv
        if uv is not None and np.shape(uv) == (v, 2):
            attrs["uv"] = np.asarray(uv, dtype=np.float32)
        color = visual.vertex_attributes.get("color")
        if color is not None and len(color) == v:
            attrs["color"] = rgba_float(color)
    elif isinstance(visual, trimesh.visual.ColorVisuals):
        if visual.kind == "vertex":
            attrs["color"] = rgba_float(visual.vertex_colors)
        elif visual.kind == "face":
            face_colors = rgba_float(visual.face_colors)
    if face_colors is None:
        return points, faces, attrs
    # per-face colors: split vertices whose faces disagree in color
    vertex_point, triangles, corner = split_corners(faces, {"color": np.repeat(face_colors, 3, axis=0)})
    new_attrs = {name: a[vertex_point] for name, a in attrs.items()}
    new_attrs.update(corner)
    return points[vertex_point], triangles, new_attrs


def _gltf_json_problem(path: Path) -> str | None:
    """Why the .gltf file ``path`` is not a JSON object, or None if it is (asked once trimesh has failed on
    it: trimesh then reports a file it looked for instead, "FileNotFoundError: model.gltf")."""
    try:
        tree = json.loads(path.read_bytes())
    except UnicodeDecodeError:
        return "not UTF-8 JSON"
    except json.JSONDecodeError as e:
        return f"not JSON: {e}"
    except (OSError, ValueError, RecursionError) as e:
        return f"not JSON: {type(e).__name__}: {e}"
    if not isinstance(tree, dict):
        return f"the JSON is a {type(tree).__name__}, not an object"
    return None


def load_trimesh(path: Path) -> Mesh:
    """Load an OBJ, PLY, STL, OFF, glTF or GLB file as one cleaned mesh."""
    import trimesh

    file_type = path.suffix.lower().lstrip(".")
    data = b""
    try:
        if file_type == "stl":
            check_stl(path)  # (its start and end: trimesh reads the file)
            scene = trimesh.load_scene(str(path), file_type=file_type, process=False)
        elif file_type in _TEXT_TYPES:
            # trimesh needs the optional charset_normalizer to guess the encoding of non-UTF-8 text and fails
            # without it: hand it UTF-8 (non-UTF-8 bytes are read as Latin-1, which only occurs in comments
            # and names of a valid file)
            data = path.read_bytes()
            try:
                data.decode("utf-8")
            except UnicodeDecodeError:
                data = data.decode("latin-1").encode("utf-8")
            resolver = trimesh.resolvers.FilePathResolver(str(path))
            scene = trimesh.load_scene(
                io.BytesIO(data), file_type=file_type, resolver=resolver, process=False
            )
        else:
            scene = trimesh.load_scene(str(path), file_type=file_type, process=False)
        parts = []
        for node in scene.graph.nodes_geometry:
            matrix, geom_name = scene.graph[node]
            part = _geometry_part(scene.geometry[geom_name])
            if part is not None:
                parts.append(transform_part(part, matrix))
    except MeshLoadError:
        raise
    except ModuleNotFoundError as e:
        if e.name == "charset_normalizer":  # trimesh's last resort for bytes that are not UTF-8
            raise MeshLoadError(path, f"not a valid {file_type.upper()} file (binary garbage?)") from e
        raise MeshLoadError(path, f"trimesh could not read it ({type(e).__name__}: {e})") from e
    except Exception as e:
        problem = _gltf_json_problem(path) if file_type == "gltf" else None
        if problem is not None:
            raise MeshLoadError(path, f"not a glTF file ({problem})") from e
        raise MeshLoadError(path, f"trimesh could not read it ({type(e).__name__}: {e})") from e
    if not parts:
        raise MeshLoadError(path, "no triangles: the file holds no triangle geometry")
    if file_type == "obj":
        _report_dropped_obj_attributes(path, data, parts)
    points, triangles, attrs = concatenate_parts(parts, path)
    return clean_mesh(points, triangles, attrs, str(path))


#: an OBJ face corner that refers to a texture coordinate (v/vt, v/vt/vn) or a normal (v//vn, v/vt/vn); each
#: starts at a digit before a '/' (not '-?\d+', which the lazy scan would re-try over a whole digit run at
#: every position of it: quadratic in a long face line)
_OBJ_FACE_UV = re.compile(rb"(?m)^[ \t]*f[ \t][^\n]*?\d/-?\d")
_OBJ_FACE_NORMAL = re.compile(rb"(?m)^[ \t]*f[ \t][^\n]*?\d/-?\d*/-?\d")


def _report_dropped_obj_attributes(path: Path, data: bytes, parts: list) -> None:
    """Warn when the OBJ's faces refer to texture coordinates or normals that no part came out with: trimesh
    drops all of them when one face refers to none, or to one out of range."""
    dropped = [
        name
        for name, pattern in (("normal", _OBJ_FACE_NORMAL), ("uv", _OBJ_FACE_UV))
        if not any(name in attrs for _, _, attrs in parts) and pattern.search(data)
    ]
    if dropped:
        warnings.warn(
            f"{path}: its faces refer to {', '.join(dropped)} values (vt/vn), but trimesh dropped them all "
            "(a face that refers to none, or to one out of range?): loaded without them",
            stacklevel=4,
        )
