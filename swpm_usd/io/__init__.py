"""Mesh loading: :func:`load_mesh` reads a mesh file into a cleaned :class:`~swpm_usd.mesh.Mesh`.

OBJ / PLY / STL / OFF / glTF / GLB go through trimesh, USD (.usd / .usda / .usdc / .usdz) through usd-core;
both end in :func:`clean_mesh`. Every failure is a :class:`~swpm_usd.errors.MeshLoadError` naming the file.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import MeshLoadError
from ..mesh import Mesh
from .clean import clean_mesh

#: an SWPM file's first bytes (spec/format.md 2, ``format.layout.MAGIC``; not imported: io loads no codec)
SWPM_MAGIC = b"SWPM\r\n\x1a\n"

__all__ = ["clean_mesh", "load_mesh", "SUPPORTED_SUFFIXES"]

_TRIMESH_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")
_USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
SUPPORTED_SUFFIXES = _TRIMESH_SUFFIXES + _USD_SUFFIXES


#: a folder given as a mesh file (``swpm_usd.build("meshes")``): what builds a folder's meshes
_FOLDER_GIVEN = (
    "not a regular file: a folder; a pipeline config builds the meshes in one (assets: [{glob: "
    "'meshes/*.obj'}], as samples/pipeline.yaml)"
)


def load_mesh(
    path: str | os.PathLike[str],
    *,
    prim_path: str | None = None,
    max_triangles: int | None = None,
    data: bytes = b"",
) -> Mesh:
    """Load the mesh file at ``path`` (type chosen by suffix) as one cleaned triangle mesh.

    Several geometries (glTF nodes, OBJ objects, USD Mesh prims) are concatenated with their transforms
    applied (a glTF node's ``EXT_mesh_gpu_instancing`` instances each placed). ``prim_path`` (USD only)
    restricts loading to the Mesh prims at and under that prim. UV and normal seams are kept: vertices
    sharing a position but not their attributes stay distinct.

    ``max_triangles``: a file holding more triangles than this (counted before cleaning, each instance of a
    glTF mesh or USD prototype counted) is a :class:`MeshLoadError`, raised as early as the format tells the
    count: a glTF's or USD's from its declared counts before any geometry is read, a binary STL's triangle
    count from the header, an OBJ's face lines of 3 or more corners counted before parsing, and in any case
    (PLY, OFF: a face of fewer than 3 corners is no triangle, so their header is no bound) once parsed,
    before cleaning.

    ``data``, when not empty, the bytes of the OBJ at ``path``, already read by the caller (which hashed
    them): the mesh is parsed from them, the file not read again, with the same checks and result. Other
    types are read by their loaders from the path (a glTF's buffers, a stage's layers beside it): ``data``
    for one is a ValueError.
    """
    check_budget(max_triangles)
    p = Path(path)
    suffix = p.suffix.lower()
    if p.is_dir():  # (a folder said "unsupported file type '(no suffix)'": it has none, being no file)
        raise MeshLoadError(p, _FOLDER_GIVEN, code="INPUT_UNREADABLE")
    if suffix not in SUPPORTED_SUFFIXES:
        # (an .swpm given to build or encode is this package's output: say what reads it)
        hint = f": it is already encoded, swpm-pipeline inspect {p} shows it" if suffix == ".swpm" else ""
        raise MeshLoadError(
            p,
            f"unsupported file type {suffix or '(no suffix)'!r}; supported: {' '.join(SUPPORTED_SUFFIXES)}"
            + hint,
            code="INPUT_UNSUPPORTED",
        )
    if not p.exists():
        from ..fileio import missing_file_problem

        raise MeshLoadError(p, missing_file_problem(p), code="INPUT_NOT_FOUND")
    if not p.is_file():
        raise MeshLoadError(p, "not a regular file", code="INPUT_UNREADABLE")
    if data and suffix != ".obj":
        raise ValueError(f"{p}: data is an OBJ's bytes; a {suffix} file is read from its path")
    try:
        if data:
            first = data[: len(SWPM_MAGIC)]
        else:
            with p.open("rb") as f:
                first = f.read(len(SWPM_MAGIC))
    except OSError as e:
        raise MeshLoadError(p, f"cannot read the file ({e.strerror or e})", code="INPUT_UNREADABLE") from e
    if not first:  # (each reader said it its own way, or not at all: "FileNotFoundError: model.gltf")
        raise MeshLoadError(p, "no triangles: the file is empty (0 bytes)", code="INPUT_EMPTY")
    if first == SWPM_MAGIC:  # (an .swpm renamed: an OBJ read "no triangle geometry", a stage "not valid")
        raise MeshLoadError(
            p,
            f"not a valid {suffix[1:].upper()} file: it is an SWPM file (byte offset 0: SWPM's magic), "
            f"already encoded; swpm-pipeline inspect reads it",
            offset=0,
        )
    if suffix in _USD_SUFFIXES:
        from .usd_loader import load_usd

        return load_usd(p, prim_path=prim_path, max_triangles=max_triangles)
    if prim_path is not None:
        raise MeshLoadError(p, "prim_path only applies to USD files", code="PARAMETER_INVALID")
    from .trimesh_loader import load_trimesh

    return load_trimesh(p, max_triangles=max_triangles, data=data)


def early_triangle_count(
    path: str | os.PathLike[str], *, prim_path: str | None = None
) -> tuple[int, bool] | None:
    """(count, exact) of the triangles the file at ``path`` tells before its geometry is read, where
    ``max_triangles`` checks it early (see :func:`load_mesh`): exact (the count before cleaning, each
    instance counted) from a glTF's JSON, a binary STL's header or a USD stage's ``faceVertexCounts``; a
    lower bound (``exact`` False) from an OBJ's face lines of 3 or more corners. None for a PLY, OFF or
    ASCII STL (known once parsed), or a file that does not read that far or is empty (its load says why)."""
    return early_triangle_count_and_data(path, prim_path=prim_path)[0]


def early_triangle_count_and_data(
    path: str | os.PathLike[str], *, prim_path: str | None = None
) -> tuple[tuple[int, bool] | None, bytes]:
    """:func:`early_triangle_count`, and the bytes of an OBJ it read to count its face lines (``b""`` for
    the other types): a caller that loads the file next (``load_trimesh(data=...)``) reads it once."""
    p = Path(path)
    suffix = p.suffix.lower()
    data = b""
    try:
        if suffix in _USD_SUFFIXES:
            from .usd_loader import declared_triangle_count as usd_count

            n = usd_count(p, prim_path)
            return (None if n is None else (n, True)), b""
        if suffix not in _TRIMESH_SUFFIXES or prim_path is not None:
            return None, b""
        from .gltf_checks import glb_chunk_problem
        from .trimesh_loader import declared_triangle_count

        if suffix == ".glb" and glb_chunk_problem(p) is not None:
            return None, b""  # (its JSON not read: a chunk length past the file's end)
        if suffix == ".obj":
            data = p.read_bytes()
            if not data:  # (no lower bound worth routing by: its load says "empty")
                return None, b""
        found = declared_triangle_count(p, suffix.lstrip("."), data)
    except (OSError, MemoryError):
        return None, b""
    return (None if found is None else (found[0], found[1])), data


def check_budget(max_triangles: object) -> None:
    """Raise a TypeError or ValueError unless ``max_triangles`` is None or a count (an int >= 0)."""
    if max_triangles is None:
        return
    if not isinstance(max_triangles, int) or isinstance(max_triangles, bool):
        raise TypeError(f"max_triangles must be an int or None, not {type(max_triangles).__name__}")
    if max_triangles < 0:
        raise ValueError(f"max_triangles must be >= 0, not {max_triangles}")


def triangles_read(mesh: Mesh) -> int:
    """The triangles the file of the loaded ``mesh`` holds as ``max_triangles`` counts them: before cleaning
    (its degenerate and duplicate triangles, which cleaning drops, counted; each instance counted)."""
    dropped = ("degenerate_dropped", "duplicate_dropped")
    return mesh.triangle_count + sum(mesh.stats.get(k, 0) for k in dropped)


def over_budget(path: Path, triangles: int, max_triangles: int | None, how: str = "") -> None:
    """Raise a :class:`MeshLoadError` when ``triangles`` (counted ``how``: " (at least: its header declares
    9 faces)") is over the budget ``max_triangles``."""
    if max_triangles is not None and triangles > max_triangles:
        raise MeshLoadError(
            path,
            f"over the triangle budget: {triangles} triangles{how}, more than max_triangles={max_triangles}",
            code="INPUT_TOO_LARGE",
        )
