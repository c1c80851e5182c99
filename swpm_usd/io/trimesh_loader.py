"""Load OBJ / PLY / STL / OFF / glTF / GLB files through trimesh into a cleaned :class:`~swpm_usd.mesh.Mesh`.

trimesh is asked not to process anything (``process=False``): no vertex welding, so UV and normal seams stay
split. ``maintain_order`` is deliberately *not* used for OBJ: in trimesh it keeps one vertex per ``v`` line
and picks the median ``vt`` / ``vn`` index for it, which silently destroys UV and normal seams. Every
triangle geometry of the scene is taken with its scene-graph transform applied and the parts are
concatenated; per-vertex ``normal``, ``uv`` and ``color`` (RGBA float in [0, 1]) are kept when every part
has them. Any trimesh failure becomes a :class:`~swpm_usd.errors.MeshLoadError` naming the file.

STL files are checked before trimesh reads them (:func:`.stl.check_stl`): trimesh takes a binary STL whose
length disagrees with its header for ASCII, and drops an ASCII solid without its ``endsolid``, so a cut file
would load as "no triangles" (or as part of its triangles) instead of being reported as truncated. An ASCII
PLY is counted against its header likewise (:func:`.ply.ply_problem`), and a binary PLY, a .glb or a .gltf's
buffers, views, accessors and primitives are looked at once trimesh has refused them, so the error says what
is cut or wrong (:mod:`.gltf_checks`; a .glb's chunk lengths before: :func:`.gltf_checks.glb_chunk_problem`).
A glTF's features trimesh reads wrongly or drops (sparse and normalized accessors, triangle fans, a uv without
a material, no scene) are rewritten first (:mod:`.gltf_prepare`). An OFF file's vertex and face colours,
which trimesh's OFF reader drops, are read by :func:`.off._off_colours`.

This module is :func:`load_trimesh`, the order of those checks around trimesh's read, and the counts a file
declares before it is parsed (:func:`declared_triangle_count`). What it knows of each format is in a module
of its own: :mod:`.stl`, :mod:`.ply`, :mod:`.obj`, :mod:`.off`, :mod:`.gltf_checks` (their shared text
helpers in :mod:`.text_rows`), and what it takes from the scene trimesh read in :mod:`.trimesh_scene`.
"""

from __future__ import annotations

import contextlib
import io
import re
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MeshLoadError
from ..mesh import Mesh
from . import over_budget
from .clean import clean_mesh, concatenate_parts, transform_instances, transform_part
from .gltf_checks import (
    _glb_json_problem,
    _glb_length_problem,
    _gltf_buffer_problem,
    _gltf_document,
    _gltf_json_problem,
    _gltf_shape_problem,
    _gltf_structure_problem,
    glb_chunk_problem,
)
from .gltf_prepare import (
    INSTANCING,
    InstancingUnread,
    check_glb_json,
    gltf_triangle_count,
    prepare_gltf,
    uri_resolver,
)
from .obj import (
    _OBJ_FACE_LINE,
    _obj_faces_in_numpy,
    _obj_problem,
    _obj_text,
    _obj_zero_corner,
    _report_dropped_obj_attributes,
)
from .off import (
    _off_colours,
    _off_fanned,
    _off_problem,
    _off_short,
)
from .ply import (
    _ply_ascii_problem,
    _ply_header_problem,
    ply_ascii_short,
    ply_polygons_as_triangles,
    ply_problem,
)
from .stl import _STL_HEADER_BYTES, _STL_TRIANGLE_BYTES, _stl_ascii_problem, check_stl
from .text_rows import _cr_only, _off_lines, _text_lines, _without_bom
from .trimesh_scene import _geometry_part, _geometry_transforms, _node_instances

_TEXT_TYPES = ("obj", "off")


#: the check of a file's header (or a .glb's JSON chunk), by type, asked once trimesh has failed on it
_HEADER_PROBLEMS: dict[str, Callable[[bytes], str | None]] = {
    "glb": _glb_json_problem,
    "ply": _ply_header_problem,
}


#: how the loader and the checks asked after a failure read a file's bytes, by type (any other text file's:
#: :func:`.text_rows._text_lines`): an OBJ's as :func:`.obj._obj_text`, an OFF's as
#: :func:`.text_rows._off_lines`, a PLY without its byte-order mark, its CRs kept (its rows may be bytes),
#: a .glb's as they are
_READS: dict[str, Callable[[bytes], bytes]] = {
    "obj": _obj_text,
    "off": _off_lines,
    "ply": _without_bom,
    "glb": bytes,
}


#: the check of a text file's rows, by type, asked once trimesh has failed on it
_ROW_PROBLEMS: dict[str, Callable[[bytes], str | None]] = {
    "obj": _obj_problem,
    "off": _off_problem,
    "stl": _stl_ascii_problem,
    "ply": _ply_ascii_problem,
}


def _ply_format_problem(data: bytes) -> str | None:
    """:func:`_ply_header_problem` of a PLY file trimesh read as holding nothing, or None."""
    try:
        return _ply_header_problem(data)
    except Exception:  # noqa: BLE001 - (a look for the message: "no triangles" is said without it)
        return None


def _off_counts_problem(data: bytes) -> str | None:
    """:func:`_off_problem` of an OFF file trimesh read as holding nothing, when it is its counts line's."""
    try:
        problem = _off_problem(data)
    except Exception:  # noqa: BLE001 - (a look for the message: "no triangles" is said without it)
        return None
    return f"not a valid OFF file: {problem}" if problem and "the counts line" in problem else None


#: the check of a file trimesh read as holding no triangles, by type: a header it took as one of no rows
_NO_ROWS_PROBLEMS: dict[str, Callable[[bytes], str | None]] = {
    "ply": _ply_format_problem,
    "off": _off_counts_problem,
}


def _read_problem(
    path: Path, check: Callable[[bytes], str | None], read: Callable[[bytes], bytes] = _text_lines
) -> str | None:
    """``check`` of the bytes of ``path`` as the loader reads them (``read`` of them: a text format's without
    a byte-order mark, its lines ended by LF; a PLY's without the mark; a .glb's as they are), or None when
    it cannot be read again."""
    try:
        return check(read(path.read_bytes()))
    except (OSError, MemoryError):
        return None


def declared_triangle_count(path: Path, file_type: str, data: bytes = b"") -> tuple[int, bool, str] | None:
    """(count, exact, how) of the triangles the file ``path`` of ``file_type`` tells before trimesh parses
    anything: a binary STL's header count and a glTF's primitives times their nodes (exact: the count before
    cleaning), or its OBJ face lines of 3 or more corners (a lower bound: each is at least a triangle; the
    file's bytes are ``data``, read when not given). None for the others: a PLY's or OFF's header face
    count is no lower bound (a face of 2 corners or none is no triangle, and trimesh keeps the file), an
    ASCII STL declares none."""
    if file_type == "stl":
        size = path.stat().st_size
        with open(path, "rb") as f:
            head = f.read(_STL_HEADER_BYTES)
        count = int.from_bytes(head[80:84], "little") if len(head) == _STL_HEADER_BYTES else -1
        if size == _STL_HEADER_BYTES + _STL_TRIANGLE_BYTES * count:  # (binary: check_stl's test)
            return count, True, " (declared by its binary STL header)"
    elif file_type == "obj":
        n = len(_OBJ_FACE_LINE.findall(_obj_text(data or path.read_bytes())))
        return n, False, f" (at least: it has {n} face lines of 3 or more corners)"
    elif file_type in ("gltf", "glb"):
        n = gltf_triangle_count(path)
        if n is not None:
            return n, True, " (declared by its primitives' accessors, times their nodes)"
    return None


def _budget_before_parsing(path: Path, file_type: str, data: bytes, max_triangles: int) -> None:
    """Raise a :class:`MeshLoadError` when the count the file declares before it is parsed
    (:func:`declared_triangle_count`) is over ``max_triangles``; the others are checked once parsed."""
    declared = declared_triangle_count(path, file_type, data)
    if declared is not None:
        over_budget(path, declared[0], max_triangles, declared[2])


class _TrimeshImportFailed(Exception):
    """trimesh's own import failed inside :func:`load_trimesh`'s ``try``: the installation's fault, not the
    file's, so it is raised as the import error it was (as when trimesh was imported before the ``try``)."""


def _trimesh() -> Any:
    """trimesh, imported when a file is first handed to it: its import (scipy's) takes 2-3 s, which a file
    our own checks refuse first (a cut PLY or STL, a .glb's chunk, a budget) does not wait for."""
    try:
        import trimesh
    except ImportError as e:
        raise _TrimeshImportFailed from e
    return trimesh


def load_trimesh(path: Path, *, max_triangles: int | None = None, data: bytes = b"") -> Mesh:
    """Load an OBJ, PLY, STL, OFF, glTF or GLB file as one cleaned mesh (``max_triangles``: see
    :func:`swpm_usd.io.load_mesh`); ``data``, when not empty, the OBJ's bytes already read (a dry run's
    planner, which counted its face lines)."""
    file_type = path.suffix.lower().lstrip(".")
    given, data = (data if file_type == "obj" else b""), b""
    instances: dict[int, np.ndarray] = {}  # (a glTF's EXT_mesh_gpu_instancing nodes: their transforms)
    try:
        if max_triangles is not None and file_type not in ("ply", "obj", "off"):  # (obj: once read)
            if file_type != "glb" or glb_chunk_problem(path) is None:  # (not read(a chunk's length))
                _budget_before_parsing(path, file_type, data, max_triangles)
        if file_type == "stl":
            check_stl(path)  # (its start and end: trimesh reads the file)
            try:
                scene = _trimesh().load_scene(str(path), file_type=file_type, process=False)
            except Exception:
                # (an ASCII STL of lines ended by CR alone: trimesh read it as one line. Asked only then)
                data = _without_bom(path.read_bytes())
                if not _cr_only(data) or data.lstrip()[:5].lower() != b"solid":
                    raise
                scene = _trimesh().load_scene(io.BytesIO(_text_lines(data)), file_type="stl", process=False)
                data = b""
        elif file_type == "ply":
            # (a byte-order mark before 'ply': trimesh read past it, our checks found no header and said
            # nothing of a cut file or mixed polygons. Both read the file without it)
            data = _without_bom(path.read_bytes())
            problem = ply_problem(data, ascii_only=True) or ply_ascii_short(data)
            if problem is not None:
                raise MeshLoadError(path, problem)
            # (trimesh parses the bytes checked, not the file read again: once from the disk, and a file
            # changed between the two reads is not parsed unchecked)
            triangulated = ply_polygons_as_triangles(data)
            stream = io.BytesIO(data if triangulated is None else triangulated)
            data = triangulated = b""  # (the stream's bytes alone: a large scan is not held twice)
            resolver = _trimesh().resolvers.FilePathResolver(str(path))
            scene = _trimesh().load_scene(stream, file_type=file_type, resolver=resolver, process=False)
            del stream
        elif file_type in _TEXT_TYPES:
            # trimesh needs the optional charset_normalizer to guess the encoding of non-UTF-8 text and fails
            # without it: hand it UTF-8 (non-UTF-8 bytes are read as Latin-1, which only occurs in comments
            # and names of a valid file)
            data = given or path.read_bytes()
            # (before the decoding: a Latin-1 file's mark would be other bytes. An OFF's: its header word
            # '\ufeffCOFF' was no COFF to the colours' reader)
            data = _READS.get(file_type, _text_lines)(data)
            try:
                data.decode("utf-8")
            except UnicodeDecodeError:
                data = data.decode("latin-1").encode("utf-8")
            if max_triangles is not None and file_type == "obj":
                _budget_before_parsing(path, file_type, data, max_triangles)
            resolver = _trimesh().resolvers.FilePathResolver(str(path))
            # (an OFF's comments left out as our checks leave them: trimesh's comment_strip repeats the text
            # before the first '#' from its second line on, so a comment past the counts line read the counts
            # as a vertex, silently)
            text = re.sub(rb"#[^\n]*", b"", data) if file_type == "off" and b"#" in data else data
            with _obj_faces_in_numpy() if file_type == "obj" else contextlib.nullcontext():
                try:
                    scene = _trimesh().load_scene(
                        io.BytesIO(text), file_type=file_type, resolver=resolver, process=False
                    )
                except Exception:
                    # (an OFF of polygons of 5+ corners beside other faces: trimesh reads their fans)
                    fanned = _off_fanned(text) if file_type == "off" else None
                    if fanned is None:
                        raise
                    scene = _trimesh().load_scene(
                        io.BytesIO(fanned), file_type=file_type, resolver=resolver, process=False
                    )
                    del fanned
            # (a cut OFF loaded as a smaller mesh; an OBJ's index 0 as its first vertex. The OFF's text
            # without comments, its lines the file's: the numpy check, not the loop a '#' needs)
            problem = _off_short(text) if file_type == "off" else _obj_zero_corner(data)
            del text
            if problem is not None:
                raise MeshLoadError(path, f"not a valid {file_type.upper()} file: {problem}")
        elif file_type == "glb" and (problem := glb_chunk_problem(path)) is not None:
            check_glb_json(path)  # (its JSON's problem first, when its chunk is whole: as a whole file's)
            raise MeshLoadError(path, _glb_length_problem(path) or problem)  # ("truncated" when it is)
        elif file_type in ("gltf", "glb") and (prepared := prepare_gltf(path)) is not None:
            scene = _trimesh().load_scene(  # (trimesh imported before the resolver's import of it)
                io.BytesIO(prepared.data), file_type="gltf", resolver=uri_resolver(path), process=False
            )
            instances = prepared.instances
        elif file_type in ("gltf", "glb"):  # (its buffers' and images' uris percent-decoded)
            scene = _trimesh().load_scene(
                str(path), file_type=file_type, resolver=uri_resolver(path), process=False
            )
        else:
            scene = _trimesh().load_scene(str(path), file_type=file_type, process=False)
        import trimesh  # (imported by now: the scene is trimesh's)

        parts = []
        placed = _geometry_transforms(scene.graph)
        instanced = _node_instances(scene.graph, placed, instances)
        if max_triangles is not None:  # (parsed: the exact count, before anything is transformed or cleaned)
            n = sum(
                len(getattr(scene.geometry.get(g), "faces", ())) * len(instanced.get(k, (None,)))
                for k, (_, g) in placed.items()
            )
            over_budget(path, n, max_triangles)
        for node, (matrix, geom_name) in placed.items():
            geom = scene.geometry[geom_name]
            colours = None
            if file_type == "off" and isinstance(geom, trimesh.Trimesh):
                vertex_colours, face_colours, lost = _off_colours(data, np.asarray(geom.faces))
                colours = (vertex_colours, face_colours)
                if lost:
                    warnings.warn(
                        f"{path}: its {' and '.join(lost)} are not loaded (not 3 or 4 numbers, 0-255 or 0-1, "
                        "on every row, or faces trimesh triangulated otherwise)",
                        stacklevel=3,
                    )
            part = _geometry_part(geom, colours)
            if part is not None and node in instanced:
                if len(instanced[node]):  # (no instances: nothing drawn)
                    parts.append(transform_instances(part, matrix, instanced[node]))
            elif part is not None:
                parts.append(transform_part(part, matrix))
    except MeshLoadError:
        raise
    except _TrimeshImportFailed as e:
        raise e.__cause__ from None  # (not "trimesh could not read it": no file was handed to it)
    except ModuleNotFoundError as e:
        if e.name == "charset_normalizer":  # trimesh's last resort for bytes that are not UTF-8
            raise MeshLoadError(path, f"not a valid {file_type.upper()} file (binary garbage?)") from e
        raise MeshLoadError(path, f"trimesh could not read it ({type(e).__name__}: {e})") from e
    except Exception as e:
        problem = _gltf_json_problem(path) if file_type == "gltf" else None
        if problem is not None:
            raise MeshLoadError(path, f"not a glTF file ({problem})") from e
        problem = _gltf_buffer_problem(path) if file_type == "gltf" else None
        if problem is not None:
            raise MeshLoadError(path, f"not a valid glTF file: {problem}", code="INPUT_INCOMPLETE") from e
        problem = _read_problem(path, ply_problem, _READS["ply"]) if file_type == "ply" else None
        problem = _glb_length_problem(path) if file_type == "glb" else problem
        if problem is None and file_type in _HEADER_PROBLEMS:
            try:
                problem = _read_problem(path, _HEADER_PROBLEMS[file_type], _READS[file_type])
            except Exception:  # noqa: BLE001 - (a look for the message: trimesh's is given without it)
                problem = None
        if problem is None and file_type in ("gltf", "glb"):
            try:
                problem = _gltf_structure_problem(path)
                read = _gltf_document(path) if problem is None else None
                problem = problem if read is None else _gltf_shape_problem(read[0])
            except Exception:  # noqa: BLE001 - (a look for the message: trimesh's is given without it)
                problem = None
            problem = None if problem is None else f"not a valid {file_type.upper()} file: {problem}"
        if problem is None and file_type in _ROW_PROBLEMS:
            try:
                problem = _read_problem(path, _ROW_PROBLEMS[file_type], _READS.get(file_type, _text_lines))
            except Exception:  # noqa: BLE001 - (a look for the message: trimesh's is given without it)
                problem = None
            problem = None if problem is None else f"not a valid {file_type.upper()} file: {problem}"
        if problem is not None:
            raise MeshLoadError(path, problem) from e
        if isinstance(e, InstancingUnread):
            raise MeshLoadError(path, f"its {INSTANCING} nodes could not be read ({e})") from e
        raise MeshLoadError(path, f"trimesh could not read it ({type(e).__name__}: {e})") from e
    if not parts:
        # (a header trimesh read as one of no rows: 'format weird 1.0', a count of -3)
        problem = (
            _read_problem(path, _NO_ROWS_PROBLEMS[file_type], _READS.get(file_type, _text_lines))
            if file_type in _NO_ROWS_PROBLEMS
            else None
        )
        if problem is not None:
            raise MeshLoadError(path, problem)
        raise MeshLoadError(path, "no triangles: the file holds no triangle geometry", code="INPUT_EMPTY")
    if file_type == "obj":
        _report_dropped_obj_attributes(path, data, parts)
    points, triangles, attrs = concatenate_parts(parts, path)
    return clean_mesh(points, triangles, attrs, str(path))
