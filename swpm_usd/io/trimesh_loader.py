"""Load OBJ / PLY / STL / OFF / glTF / GLB files through trimesh into a cleaned :class:`~swpm_usd.mesh.Mesh`.

trimesh is asked not to process anything (``process=False``): no vertex welding, so UV and normal seams stay
split. ``maintain_order`` is deliberately *not* used for OBJ: in trimesh it keeps one vertex per ``v`` line
and picks the median ``vt`` / ``vn`` index for it, which silently destroys UV and normal seams. Every
triangle geometry of the scene is taken with its scene-graph transform applied and the parts are
concatenated; per-vertex ``normal``, ``uv`` and ``color`` (RGBA float in [0, 1]) are kept when every part
has them. Any trimesh failure becomes a :class:`~swpm_usd.errors.MeshLoadError` naming the file.

STL files are checked before trimesh reads them (:func:`check_stl`): trimesh takes a binary STL whose length
disagrees with its header for ASCII, and drops an ASCII solid without its ``endsolid``, so a cut file would
load as "no triangles" (or as part of its triangles) instead of being reported as truncated. An ASCII PLY
is counted against its header likewise (:func:`ply_problem`), and a binary PLY, a .glb or a .gltf's buffers,
views, accessors and primitives are looked at once trimesh has refused them, so the error says what is cut
or wrong (a .glb's chunk lengths before: :func:`glb_chunk_problem`). A glTF's features trimesh
reads wrongly or drops (sparse and normalized accessors, triangle fans, a uv without a material, no scene)
are rewritten first (:mod:`.gltf_prepare`). An OFF file's vertex
and face colours, which trimesh's OFF reader drops, are read here (:func:`_off_colours`).
"""

from __future__ import annotations

import base64
import binascii
import contextlib
import contextvars
import functools
import io
import itertools
import json
import os
import re
import struct
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MeshLoadError
from ..mesh import Mesh
from . import over_budget
from .clean import (
    clean_mesh,
    concatenate_parts,
    rgba_float,
    split_corners,
    transform_instances,
    transform_part,
)
from .gltf_prepare import (
    _COMPONENT,
    _GLB_BIN,
    _GLB_JSON,
    _WIDTH,
    INSTANCES_KEY,
    INSTANCING,
    InstancingUnread,
    _document,
    _Unread,
    check_glb_json,
    gltf_triangle_count,
    prepare_gltf,
    uri_names,
    uri_resolver,
)
from .ply import _ply_ascii_problem, _ply_header_problem, ply_polygons_as_triangles, ply_problem
from .stl import _STL_HEADER_BYTES, _STL_TRIANGLE_BYTES, _stl_ascii_problem, check_stl
from .text_rows import _not_numbers, _numbered_rows, _shown, _undecoded

_TEXT_TYPES = ("obj", "off")


def _geometry_part(
    geom: object, off_colours: tuple[np.ndarray | None, np.ndarray | None] | None = None
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]] | None:
    """One geometry's (points, triangles, attributes); ``off_colours``: the vertex and triangle colours of
    the OFF file it was read from, which trimesh's OFF reader drops (:func:`_off_colours`)."""
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
    if off_colours is not None:
        vertex_colors, face_colors = off_colours
        if vertex_colors is not None and vertex_colors.shape[0] == v:
            attrs["color"] = vertex_colors
            face_colors = None  # (both: the vertices' are kept)
        visual = None
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


def _geometry_transforms(graph: Any) -> dict[Any, tuple[np.ndarray, Any]]:
    """{node: (its transform from the scene's base frame, its geometry's name)} of each node of the trimesh
    scene ``graph`` that has a geometry, in one pass down the tree: a transform is its parent's times its own
    edge's, each computed once. ``graph[node]`` looked up each node's path from the root, and multiplied it,
    anew: a .gltf of 3,000 nodes in a chain (98 KB) took 174 s. The result is trimesh's: an edge's matrix
    within 1e-8 of the identity is left out of a product as ``graph[node]`` leaves it out (a child of the base
    frame takes its edge's matrix as it is), and its rigid repair is applied to each product; the same bits
    as trimesh's up to two matrices on the path, within rounding below (trimesh multiplies the path from its
    end). A node whose parents do not lead to the base frame (a cycle, a broken chain) is left to
    ``graph[node]``."""
    from trimesh.transformations import fix_rigid

    forest = graph.transforms
    parents, edges, base = forest.parents, forest.edge_data, graph.base_frame
    # {node: the product of the matrices on its path not within 1e-8 of the identity, None for none}
    product: dict[Any, np.ndarray | None] = {base: None}
    identity = np.eye(4)
    out = {}
    for node in graph.nodes_geometry:
        chain = []
        at = node
        while at not in product and at in parents and len(chain) <= len(parents):
            chain.append(at)
            at = parents[at]
        if at not in product:  # (not under the base frame)
            out[node] = graph[node]
            continue
        for child in reversed(chain):
            before = product[parents[child]]
            matrix = edges.get((parents[child], child), {}).get("matrix")
            if matrix is None or np.abs(matrix - identity).max() <= 1e-8:
                product[child] = before
            else:
                product[child] = matrix if before is None else before @ matrix
        if node == base:
            matrix = identity
        elif parents.get(node) == base:  # (trimesh's edge as it is)
            matrix = edges.get((base, node), {}).get("matrix", identity)
        else:
            matrix = identity if product[node] is None else product[node]
        if graph.repair_rigid is not None:
            matrix = fix_rigid(matrix, max_deviance=graph.repair_rigid)
        out[node] = (matrix, forest.node_data[node].get("geometry"))
    return out


def _node_instances(
    graph: Any, placed: dict[Any, tuple[np.ndarray, Any]], instances: dict[int, np.ndarray]
) -> dict[Any, np.ndarray]:
    """{node of trimesh's scene ``graph``: its instances' transforms} of the nodes of ``placed`` that the
    glTF rewrite marked as the ``EXT_mesh_gpu_instancing`` node of ``instances`` (trimesh keeps a node's
    extensions in the metadata of the edge to it, and those of a mesh of several primitives on each
    primitive's edge)."""
    if not instances:
        return {}
    forest = graph.transforms
    out = {}
    for node in placed:
        edge = forest.edge_data.get((forest.parents.get(node), node), {})
        meta = edge.get("metadata") if isinstance(edge, dict) else None
        extensions = meta.get("gltf_extensions") if isinstance(meta, dict) else None
        ext = extensions.get(INSTANCING) if isinstance(extensions, dict) else None
        key = ext.get(INSTANCES_KEY) if isinstance(ext, dict) else None
        if isinstance(key, int) and key in instances:
            out[node] = instances[key]
    return out


def _gltf_json_problem(path: Path) -> str | None:
    """Why the .gltf file ``path`` is not a JSON object, or None if it is (asked once trimesh has failed on
    it: trimesh then reports a file it looked for instead, "FileNotFoundError: model.gltf")."""
    try:
        data = path.read_bytes()
        tree = json.loads(data.decode("utf-8-sig"))  # (UTF-8, as glTF says: not json's guess of UTF-16)
    except UnicodeDecodeError as e:
        return f"not UTF-8 JSON: {_undecoded(data, 0, e)}"
    except json.JSONDecodeError as e:
        return f"not JSON: {e}"
    except (OSError, ValueError, RecursionError) as e:
        return f"not JSON: {type(e).__name__}: {e}"
    if not isinstance(tree, dict):
        return f"the JSON is a {type(tree).__name__}, not an object"
    return None


def _buffer_uri_size(path: Path, uri: str) -> int | str:
    """The byte size of the buffer of ``uri`` (a base64 data URI, or a file beside the .gltf file ``path``),
    or why there is none (the end of a message: "its data URI is not valid base64 (...)"). A file is resolved
    as the loader's resolver does (:func:`.gltf_prepare.uri_names`), which refuses a file outside the .gltf's
    folder: such a file is not looked at, and its size not told."""
    if uri.startswith("data:"):
        meta, _, body = uri.partition(",")
        if not meta.endswith(";base64"):
            return f"its data URI is not base64 ({meta[:60]!r})"
        try:
            return len(base64.b64decode(body, validate=True))
        except (binascii.Error, ValueError) as e:
            return f"its data URI is not valid base64 ({e})"
    outside = None  # (whether the first name, the uri decoded, leads out of the folder)
    for name in uri_names(uri):  # (the loader's resolver's names, in its order)
        try:
            folder = path.parent.resolve()
            file = (folder / name).resolve()
            inside = file.is_relative_to(folder)
            outside = not inside if outside is None else outside
            if inside and file.is_file():
                return file.stat().st_size
        except (OSError, ValueError, RuntimeError):
            outside = False if outside is None else outside
    if outside:
        return f"its file {uri!r} is outside the .gltf's folder (not read)"
    return f"its file {uri!r} is not found beside the .gltf"


def _gltf_buffer_problem(path: Path) -> str | None:
    """What is wrong with a buffer of the .gltf file ``path`` (a JSON object), or None when nothing is found
    (asked once trimesh has failed on it: a bad data URI was a bare "AssertionError: ", a buffer file it
    could not find "FileNotFoundError: NAME")."""
    try:
        buffers = json.loads(path.read_bytes()).get("buffers")
    except (OSError, ValueError, RecursionError, AttributeError):
        return None
    if not isinstance(buffers, list):
        return None
    for i, buf in enumerate(buffers):
        if not isinstance(buf, dict):
            continue
        name = f"buffer {i}" + (f" ({buf['name']!r})" if isinstance(buf.get("name"), str) else "")
        if not isinstance(buf.get("uri"), str):  # (only a .glb's buffer 0 may have none: trimesh's KeyError)
            return f"{name} has no uri (a .gltf's buffer is a data URI or a file beside it)"
        uri, length = buf["uri"], buf.get("byteLength")
        size = _buffer_uri_size(path, uri)
        if isinstance(size, str):
            return f"{name}: {size}"
        what = "its data URI holds" if uri.startswith("data:") else f"its file {uri!r} holds"
        if isinstance(length, int) and not isinstance(length, bool) and size < length:
            return f"{name}: {what} {size} bytes, fewer than its byteLength {length}"
    return None


#: glTF's accessor component types (their sizes in bytes) and element types (their widths)
_GLTF_COMPONENT_BYTES = {k: np.dtype(v).itemsize for k, v in _COMPONENT.items()}
_GLTF_TYPE_WIDTH = {**_WIDTH, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def _gltf_document(path: Path) -> tuple[dict, int | None] | None:
    """(the JSON document, the byte length of a .glb's binary chunk or None) of the .gltf or .glb file
    ``path``, or None when it does not read (the checks before say why). The chunks are found as the glTF
    rewrite finds them (:func:`.gltf_prepare._document`: the first JSON and the first binary chunk, whatever
    comes between them)."""
    try:
        doc, binary = _document(path, path.read_bytes())
    except (_Unread, OSError, ValueError, RecursionError):
        return None
    return (doc, None if binary is None else len(binary)) if isinstance(doc, dict) else None


def _gltf_buffer_size(path: Path, buf: Any, i: int, binary: int | None) -> int | None:
    """The byte length of buffer ``i`` (``buf``) of the glTF file ``path``, or None when not known."""
    if not isinstance(buf, dict):
        return None
    uri = buf.get("uri")
    if uri is None:
        return binary if i == 0 else None
    size = _buffer_uri_size(path, uri) if isinstance(uri, str) else None
    return size if isinstance(size, int) else None


def _index(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _gltf_structure_problem(path: Path) -> str | None:
    """What is wrong with the bufferViews, accessors or primitives of the .gltf or .glb file ``path`` (a view
    past its buffer, an accessor past its view, an index to nothing, an unknown type), or None (asked once
    trimesh has failed on it: it said "AssertionError: ", "IndexError: list index out of range", "KeyError:
    5" or "cannot reshape array of size 0 into shape (206,3)")."""
    read = _gltf_document(path)
    if read is None:
        return None
    doc, binary = read
    buffers, views, accessors = (doc.get(k) for k in ("buffers", "bufferViews", "accessors"))
    buffers = buffers if isinstance(buffers, list) else []
    views = views if isinstance(views, list) else []
    accessors = accessors if isinstance(accessors, list) else []
    sizes = [_gltf_buffer_size(path, b, i, binary) for i, b in enumerate(buffers)]
    for i, v in enumerate(views):
        if not isinstance(v, dict):
            return f"bufferView {i} is not an object"
        b, offset, length = v.get("buffer"), v.get("byteOffset", 0), v.get("byteLength")
        if not _index(b) or b >= len(buffers):
            return f"bufferView {i} refers to buffer {b!r}, the file has {len(buffers)}"
        if not _index(offset) or not _index(length):
            return f"bufferView {i} has byteOffset {offset!r} and byteLength {length!r}, not both counts"
        if sizes[b] is not None and offset + length > sizes[b]:
            return f"bufferView {i} ends at byte {offset + length}, past buffer {b}'s {sizes[b]} bytes"
        stride = v.get("byteStride")
        if stride is not None and (not _index(stride) or not 4 <= stride <= 252):
            return f"bufferView {i} has byteStride {stride!r}, not 4 to 252"
    for i, a in enumerate(accessors):
        if not isinstance(a, dict):
            return f"accessor {i} is not an object"
        component, kind, count = a.get("componentType"), a.get("type"), a.get("count")
        if (
            not isinstance(component, int)
            or isinstance(component, bool)
            or component not in _GLTF_COMPONENT_BYTES
        ):
            return f"accessor {i} has componentType {component!r}, not a glTF component type"
        if not isinstance(kind, str) or kind not in _GLTF_TYPE_WIDTH:
            return f"accessor {i} has type {kind!r}, not a glTF accessor type"
        if not _index(count):
            return f"accessor {i} has count {count!r}, not a count"
        if "bufferView" not in a:
            continue
        view, offset = a["bufferView"], a.get("byteOffset", 0)
        if not _index(view) or view >= len(views):
            return f"accessor {i} refers to bufferView {view!r}, the file has {len(views)}"
        if not _index(offset):
            return f"accessor {i} has byteOffset {offset!r}, not a count"
        size = _GLTF_COMPONENT_BYTES[component] * _GLTF_TYPE_WIDTH[kind]
        end = offset + (count - 1) * (views[view].get("byteStride") or size) + size if count else offset
        if end > views[view]["byteLength"]:
            held = views[view]["byteLength"]
            return f"accessor {i} reads {end} bytes of bufferView {view}, which holds {held}"
        if offset % _GLTF_COMPONENT_BYTES[component]:
            return f"accessor {i} has byteOffset {offset}, not a multiple of its component's size"
    meshes = doc.get("meshes")
    for m, mesh in enumerate(meshes if isinstance(meshes, list) else []):
        primitives = mesh.get("primitives") if isinstance(mesh, dict) else None
        for k, prim in enumerate(primitives if isinstance(primitives, list) else []):
            if not isinstance(prim, dict):
                continue
            attrs = prim.get("attributes")
            refs = list(attrs.items()) if isinstance(attrs, dict) else []
            refs += [("indices", prim["indices"])] if "indices" in prim else []
            for name, ref in refs:
                if not _index(ref) or ref >= len(accessors):
                    n = len(accessors)
                    return f"mesh {m} primitive {k}: its {name} refers to accessor {ref!r}, the file has {n}"
    return None


#: the glTF document's arrays of objects
_GLTF_ARRAYS = ("accessors", "bufferViews", "buffers", "meshes", "nodes", "scenes", "materials", "cameras")
#: node fields: those that are an index, and those that are (so many) numbers
_NODE_INDICES = ("mesh", "camera", "skin")
_NODE_NUMBERS = {"matrix": 16, "translation": 3, "rotation": 4, "scale": 3}


def _kind(value: Any) -> str:
    return {dict: "an object", list: "an array", str: "a string", bool: "a boolean"}.get(
        type(value), "null" if value is None else "a number"
    )


def _gltf_shape_problem(doc: Any) -> str | None:
    """Which part of the glTF JSON document ``doc`` is not of the type glTF gives it (an array that is a
    number, a node that is a string, children that are not node indices, a primitive without attributes),
    or None (asked once trimesh has failed on it: "'int' object is not subscriptable", "KeyError: 0")."""
    if not isinstance(doc, dict):
        return f"the JSON is {_kind(doc)}, not an object"
    for name in _GLTF_ARRAYS:
        items = doc.get(name, [])
        if not isinstance(items, list):
            return f"its {name!r} is {_kind(items)}, not an array"
        for i, item in enumerate(items):
            if not isinstance(item, dict):
                return f"{name}[{i}] is {_kind(item)}, not an object"
            if "name" in item and not isinstance(item["name"], str):
                return f"{name}[{i}].name is {_kind(item['name'])}, not a string"
    n_nodes = len(doc.get("nodes", []))

    def node_list(value: Any) -> bool:
        return isinstance(value, list) and all(_index(c) and c < n_nodes for c in value)

    if "scene" in doc and not (_index(doc["scene"]) and doc["scene"] < len(doc.get("scenes", []))):
        n = len(doc.get("scenes", []))
        return f"its 'scene' is {doc['scene']!r}, not the index of one of its {n} scenes"
    for i, scene in enumerate(doc.get("scenes", [])):
        if "nodes" in scene and not node_list(scene["nodes"]):
            return f"scenes[{i}].nodes is not an array of indices of its {n_nodes} nodes"
    for i, node in enumerate(doc.get("nodes", [])):
        if "children" in node and not node_list(node["children"]):
            return f"nodes[{i}].children is not an array of indices of its {n_nodes} nodes"
        for key in _NODE_INDICES:
            if key in node and not _index(node[key]):
                return f"nodes[{i}].{key} is {node[key]!r}, not an index"
        if "mesh" in node and node["mesh"] >= len(doc.get("meshes", [])):
            return f"nodes[{i}].mesh is {node['mesh']}, the file has {len(doc.get('meshes', []))} meshes"
        for key, n in _NODE_NUMBERS.items():
            value = node.get(key, [0.0] * n)
            numbers = isinstance(value, list) and all(
                isinstance(v, int | float) and not isinstance(v, bool) for v in value
            )
            if not numbers or len(value) != n:
                return f"nodes[{i}].{key} is not {n} numbers"
    for m, mesh in enumerate(doc.get("meshes", [])):
        primitives = mesh.get("primitives")
        if not isinstance(primitives, list) or not all(isinstance(q, dict) for q in primitives):
            return f"meshes[{m}].primitives is not an array of objects"
        for k, prim in enumerate(primitives):
            if not isinstance(prim.get("attributes"), dict):
                return f"meshes[{m}].primitives[{k}].attributes is not an object"
            if "POSITION" not in prim["attributes"]:  # (trimesh's KeyError: 'POSITION')
                names = ", ".join(repr(str(a)[:30]) for a in list(prim["attributes"])[:4]) or "none"
                return f"meshes[{m}].primitives[{k}] has no POSITION attribute (its attributes: {names})"
            for key in ("indices", "material", "mode"):
                if key in prim and not _index(prim[key]):
                    return f"meshes[{m}].primitives[{k}].{key} is {prim[key]!r}, not an index"
    for i, buf in enumerate(doc.get("buffers", [])):
        if not _index(buf.get("byteLength")):
            return f"buffers[{i}].byteLength is {buf.get('byteLength')!r}, not a byte count"
    # (last: trimesh reads a file without an asset, so a problem above is the more likely cause)
    asset = doc.get("asset")
    version = asset.get("version") if isinstance(asset, dict) else None
    if not isinstance(version, str) or not version.startswith("2."):
        what = f"asset.version is {version!r}" if isinstance(asset, dict) else f"asset is {_kind(asset)}"
        return f"its {what}, not glTF 2's ('version': '2.0')"
    return None


def _glb_length_problem(path: Path) -> str | None:
    """Why the .glb file ``path`` is truncated (shorter than the length its header gives) or a chunk of it
    longer than the bytes after it, or None (asked once trimesh has failed on it: "chunk was not expected
    length!", or a JSON error for a cut JSON chunk)."""
    try:
        with open(path, "rb") as f:
            head = f.read(12)
            size = os.fstat(f.fileno()).st_size
    except OSError:
        return None
    if len(head) < 12 or head[:4] != b"glTF":
        return None
    length = int.from_bytes(head[8:12], "little")
    if size < length:
        return f"truncated GLB: its header says {length} bytes, the file has {size}"
    return glb_chunk_problem(path)


def glb_chunk_problem(path: Path) -> str | None:
    """Why a chunk of the .glb file ``path`` is longer than the bytes after it, or None. Asked before trimesh
    reads the file: trimesh reads each chunk with ``read(its length)``, which asks for that many bytes before
    it finds fewer (a 5.6 KB file whose chunk declared 4,294,967,295 bytes had 4.3 GB asked for, a
    MemoryError wherever the address space is limited). Every chunk is walked, as trimesh reads every one: a
    walk stopped after 4,096 let a lying chunk after 5,000 empty ones (40 KB) have 4.3 GB asked for."""
    try:
        with open(path, "rb") as f:
            head = f.read(12)
            size = os.fstat(f.fileno()).st_size
            if len(head) < 12 or head[:4] != b"glTF":
                return None
            at = 12
            for i in itertools.count():  # (every chunk: trimesh reads on while bytes follow)
                chunk = f.read(8)
                if len(chunk) < 8:
                    return None
                chunk_length, chunk_type = struct.unpack("<II", chunk)
                if at + 8 + chunk_length > size:
                    # (named by its type, not its place: a binary chunk first was called "chunk 0 (JSON)")
                    kind = {_GLB_JSON: " (JSON)", _GLB_BIN: " (binary)"}.get(chunk_type, "")
                    return (
                        f"not a valid GLB: chunk {i}{kind} declares {chunk_length} bytes, "
                        f"{size - at - 8} follow it"
                    )
                at += 8 + chunk_length
                f.seek(at)
    except OSError:
        return None
    return None


def _obj_problem(data: bytes) -> str | None:
    """What is wrong with a row of the OBJ file of bytes ``data`` (a ``v``/``vt``/``vn`` value that is not a
    number, or too few; a face corner whose index is not an integer, or refers to no vertex), or None (asked
    once trimesh has failed on it: "string or file could not be read to its end due to unmatched data",
    "invalid literal for int() with base 10", "index 3000 is out of bounds for axis 0")."""
    vertices = 0
    for number, words in _numbered_rows(data):
        key = words[0]
        if key in (b"v", b"vt", b"vn"):
            bad = _not_numbers(words[1:])
            if bad is not None:
                return f"line {number}: a '{key.decode()}' row holds {_shown(bad)}, not a number"
            need = 1 if key == b"vt" else 3
            if len(words) - 1 < need:
                return f"line {number}: a '{key.decode()}' row holds {len(words) - 1} values, not {need}"
            vertices += key == b"v"
    for number, words in _numbered_rows(data):
        if words[0].startswith(b"f") and words[0] != b"f":  # (trimesh reads a line of 'f' and more as one)
            return f"line {number}: {_shown(b' '.join(words[:6]))} starts with 'f', not a face ('f ...')"
        if words[0] != b"f":
            continue
        for corner in words[1:]:
            for kind, part in zip(("vertex", "uv", "normal"), corner.split(b"/"), strict=False):
                if part == b"" and kind != "vertex":
                    continue
                try:
                    index = int(part)
                except ValueError:
                    return (
                        f"line {number}: face corner {_shown(corner)}: its {kind} index is not a whole number"
                    )
                if kind == "vertex" and not (-vertices <= index <= vertices and index != 0):
                    where = f"line {number}: face corner {_shown(corner)}"
                    return f"{where} refers to vertex {index}, the file has {vertices}"
    return None


_OFF_HEADER = re.compile(rb"(ST)?C?N?4?n?OFF", re.IGNORECASE)


def _off_problem(data: bytes) -> str | None:
    """What is wrong with the header or a row of the OFF file of bytes ``data`` (counts that are not whole
    numbers; a vertex row of too few values, or one that is not a number; a face row whose corner count or
    index is not a whole number, with fewer corners than it declares, or an index to no vertex), or None
    (asked once trimesh has failed on it: "invalid literal for int() with base 10: '0.5'", "setting an array
    element with a sequence", "cannot reshape array of size 14 into shape (5,3)")."""
    rows = _numbered_rows(data)
    first = next(rows, None)
    if first is None:
        return None
    if _OFF_HEADER.fullmatch(first[1][0]) is None:
        return f"line {first[0]}: {_shown(first[1][0])} is not 'OFF' (nor a variant of it: COFF, NOFF...)"
    number, counts = (first[0], first[1][1:]) if len(first[1]) > 1 else next(rows, (first[0], []))
    try:
        n_vertices, n_faces = int(counts[0]), int(counts[1])
        if len(counts) > 2:
            int(counts[2])  # (the edge count: trimesh reads it as a whole number too)
    except (IndexError, ValueError):
        return f"line {number}: the counts line {_shown(b' '.join(counts))} is not vertices, faces, edges"
    for k in range(n_vertices):
        number, words = next(rows, (None, []))
        if number is None:
            return f"the header declares {n_vertices} vertices, the file has {k}"
        bad = _not_numbers(words[:3])
        if bad is not None:
            return f"line {number}: vertex {k} holds {_shown(bad)}, not a number"
        if len(words) < 3:
            return f"line {number}: vertex {k} holds {len(words)} values, not 3"
    for k in range(n_faces):
        number, words = next(rows, (None, []))
        if number is None:
            return f"the header declares {n_faces} faces, the file has {k}"
        try:
            corners = [int(w) for w in words[: 1 + max(int(words[0]), 0)]]
        except ValueError:
            return f"line {number}: face {k}: {_shown(b' '.join(words[:8]))} are not whole numbers"
        if len(corners) - 1 < corners[0] or corners[0] < 3:
            return f"line {number}: face {k} declares {corners[0]} corners and lists {len(words) - 1} values"
        out = [i for i in corners[1:] if not 0 <= i < n_vertices]
        if out:
            return f"line {number}: face {k} refers to vertex {out[0]}, the file has {n_vertices}"
    return None


def _glb_json_problem(data: bytes) -> str | None:
    """What is wrong with the header or the JSON chunk of the .glb file of bytes ``data`` (not 'glTF', not
    version 2, a first chunk that is not JSON, JSON that does not parse: where, as a byte offset of the
    file), or None (asked once trimesh has failed on it: "incorrect header on GLB file", a JSONDecodeError
    of the chunk without a word of where it is, "'utf-8' codec can't decode byte")."""
    if len(data) < 20:
        return f"not a valid GLB file: {len(data)} bytes, shorter than its 12-byte header and a chunk's 8"
    magic, version, _ = struct.unpack_from("<4sII", data)
    if magic != b"glTF":
        return f"not a GLB file: it starts with {magic!r}, not b'glTF'"
    if version != 2:
        return f"not a valid GLB file: its header says version {version}, not 2"
    size, kind = struct.unpack_from("<II", data, 12)
    if kind != 0x4E4F534A:
        return f"not a valid GLB file: its first chunk is of type 0x{kind:08x}, not JSON (0x4e4f534a)"
    chunk = data[20 : 20 + size]
    try:
        text = chunk.decode("utf-8")
    except UnicodeDecodeError as e:
        return f"not a valid GLB file: its JSON chunk: {_undecoded(chunk, 20, e)}"
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        where = f"byte offset {20 + len(text[: e.pos].encode())} (line {e.lineno} of the chunk)"
        return f"not a valid GLB file: its JSON chunk is not JSON: {e.msg} at {where}"
    except (ValueError, RecursionError) as e:
        return f"not a valid GLB file: its JSON chunk is not JSON ({type(e).__name__})"
    if not isinstance(doc, dict):
        return f"not a valid GLB file: its JSON chunk is {_kind(doc)}, not an object"
    return None


#: the check of a file's header (or a .glb's JSON chunk), by type, asked once trimesh has failed on it
_HEADER_PROBLEMS: dict[str, Callable[[bytes], str | None]] = {
    "glb": _glb_json_problem,
    "ply": _ply_header_problem,
}


#: the check of a text file's rows, by type, asked once trimesh has failed on it
_ROW_PROBLEMS: dict[str, Callable[[bytes], str | None]] = {
    "obj": _obj_problem,
    "off": _off_problem,
    "stl": _stl_ascii_problem,
    "ply": _ply_ascii_problem,
}


def _read_problem(path: Path, check: Callable[[bytes], str | None]) -> str | None:
    """``check`` of the bytes of ``path``, or None when it cannot be read again."""
    try:
        return check(path.read_bytes())
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
        n = len(_OBJ_FACE_LINE.findall(data or path.read_bytes()))
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


#: an OBJ face corner of each form (v, v/vt, v//vn, v/vt/vn) -> the columns of its texture and normal indices
_OBJ_CORNER_FORMS = {
    "{i}": (None, None),
    "{i}/{i}": (1, None),
    "{i}//{i}": (None, 1),
    "{i}/{i}/{i}": (1, 2),
}
#: an index as the vectorised reading below takes it (anything else: trimesh's own reading)
_OBJ_INDEX = "-?[0-9]{1,18}"


def _obj_faces_fallback(lines: list[str], original: Callable) -> tuple:
    """trimesh's ``_parse_faces_fallback`` (``original``: OBJ face lines of differing lengths, which it reads
    corner by corner in Python: a 200,000-corner polygon beside a triangle took 4.5 s) in numpy, with the
    same triangles in the same order (a quad as (0, 1, 2), (2, 3, 0), a polygon of more corners as the fan
    (0, k, k + 1), a line of fewer than 3 corners skipped) and the same indices. Only when every corner has
    the first's form and plain integer indices; any other lines are ``original``'s."""
    rows = [line.strip().split("\n")[0].split() for line in lines]
    counts = np.fromiter(map(len, rows), np.int64, len(rows))
    if counts.shape[0] == 0 or (counts < 3).all():
        return original(lines)
    first = rows[int(np.argmax(counts >= 3))][0]
    form = re.sub(r"[^/]+", "{i}", first)
    if form not in _OBJ_CORNER_FORMS:
        return original(lines)
    text = " ".join(itertools.chain.from_iterable(rows))
    token = form.replace("{i}", _OBJ_INDEX)
    if re.fullmatch(f"{token}(?: {token})*", text) is None:
        return original(lines)
    width = form.count("{i}")
    values = np.array(text.replace("/", " ").split(), np.int64).reshape(-1, width)
    n_tris = np.where(counts >= 3, counts - 2, 0)
    face = np.repeat(np.arange(counts.shape[0]), n_tris)
    k = np.arange(face.shape[0]) - (np.cumsum(n_tris) - n_tris)[face]  # (the triangle's place in its face)
    corners = np.stack([np.zeros_like(k), k + 1, k + 2], axis=1)
    corners[(counts[face] == 4) & (k == 1)] = (2, 3, 0)  # (trimesh's quad split)
    read = values[(np.cumsum(counts) - counts)[face][:, None] + corners]

    def column(c: int | None) -> np.ndarray | None:
        if c is None:
            return None
        out = np.ascontiguousarray(read[:, :, c])
        out[out > 0] -= 1  # (1-based; negative indices count from the end, as trimesh leaves them)
        return out

    tex, norm = _OBJ_CORNER_FORMS[form]
    return column(0), column(tex), column(norm)


#: set (in this thread or task only) while :func:`load_trimesh` has trimesh read an OBJ: only those reads
#: take :func:`_obj_faces_fallback`; any other code's trimesh calls in the process get trimesh's own function
_OBJ_FACES_IN_NUMPY: contextvars.ContextVar[bool] = contextvars.ContextVar("swpm_obj_faces", default=False)


def _install_obj_faces_fallback() -> None:
    """Put a wrapper in place of trimesh's ``_parse_faces_fallback`` (once; ``__wrapped__`` is trimesh's own):
    it calls trimesh's own function unless :data:`_OBJ_FACES_IN_NUMPY` is set, so a user's trimesh calls in
    the same process (other threads included) run trimesh's code unchanged; our OBJ reads, inside
    :func:`_obj_faces_in_numpy`, take :func:`_obj_faces_fallback` (the same result, fuzzed against it)."""
    import trimesh.exchange.obj as obj

    original = obj._parse_faces_fallback
    if getattr(original, "swpm_usd", False):
        return

    @functools.wraps(original)
    def fallback(lines: list[str]) -> tuple:
        if not _OBJ_FACES_IN_NUMPY.get():
            return original(lines)
        return _obj_faces_fallback(lines, original)

    fallback.swpm_usd = True  # type: ignore[attr-defined]
    obj._parse_faces_fallback = fallback


@contextlib.contextmanager
def _obj_faces_in_numpy() -> Iterator[None]:
    """Within it, trimesh's OBJ reads in this thread or task take :func:`_obj_faces_fallback`."""
    _install_obj_faces_fallback()
    token = _OBJ_FACES_IN_NUMPY.set(True)
    try:
        yield
    finally:
        _OBJ_FACES_IN_NUMPY.reset(token)


#: an OBJ face line of at least 3 corners, as trimesh reads them (from a line's start: an indented 'f' line
#: is not a face to it, nor one with a tab after the f; a line of fewer corners is skipped; '#' starts a
#: comment): each is at least a triangle
_OBJ_FACE_LINE = re.compile(rb"(?m)^f [ \t]*[^\s#]+(?:[ \t]+[^\s#]+){2}")


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
            scene = _trimesh().load_scene(str(path), file_type=file_type, process=False)
        elif file_type == "ply":
            data = path.read_bytes()
            problem = ply_problem(data, ascii_only=True)
            if problem is not None:
                raise MeshLoadError(path, problem)
            triangulated = ply_polygons_as_triangles(data)
            data = b""  # (released before trimesh reads the file: a large scan is not held twice)
            if triangulated is None:
                scene = _trimesh().load_scene(str(path), file_type=file_type, process=False)
            else:
                resolver = _trimesh().resolvers.FilePathResolver(str(path))
                scene = _trimesh().load_scene(
                    io.BytesIO(triangulated), file_type=file_type, resolver=resolver, process=False
                )
        elif file_type in _TEXT_TYPES:
            # trimesh needs the optional charset_normalizer to guess the encoding of non-UTF-8 text and fails
            # without it: hand it UTF-8 (non-UTF-8 bytes are read as Latin-1, which only occurs in comments
            # and names of a valid file)
            data = given or path.read_bytes()
            try:
                data.decode("utf-8")
            except UnicodeDecodeError:
                data = data.decode("latin-1").encode("utf-8")
            if max_triangles is not None and file_type == "obj":
                _budget_before_parsing(path, file_type, data, max_triangles)
            resolver = _trimesh().resolvers.FilePathResolver(str(path))
            with _obj_faces_in_numpy() if file_type == "obj" else contextlib.nullcontext():
                scene = _trimesh().load_scene(
                    io.BytesIO(data), file_type=file_type, resolver=resolver, process=False
                )
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
        problem = _read_problem(path, ply_problem) if file_type == "ply" else None
        problem = _glb_length_problem(path) if file_type == "glb" else problem
        if problem is None and file_type in _HEADER_PROBLEMS:
            try:
                problem = _read_problem(path, _HEADER_PROBLEMS[file_type])
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
                problem = _read_problem(path, _ROW_PROBLEMS[file_type])
            except Exception:  # noqa: BLE001 - (a look for the message: trimesh's is given without it)
                problem = None
            problem = None if problem is None else f"not a valid {file_type.upper()} file: {problem}"
        if problem is not None:
            raise MeshLoadError(path, problem) from e
        if isinstance(e, InstancingUnread):
            raise MeshLoadError(path, f"its {INSTANCING} nodes could not be read ({e})") from e
        raise MeshLoadError(path, f"trimesh could not read it ({type(e).__name__}: {e})") from e
    if not parts:
        raise MeshLoadError(path, "no triangles: the file holds no triangle geometry", code="INPUT_EMPTY")
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
        # (no '/' in the file, no corner that refers to either: the scan of every line start is skipped)
        if not any(name in attrs for _, _, attrs in parts) and b"/" in data and pattern.search(data)
    ]
    if dropped:
        warnings.warn(
            f"{path}: its faces refer to {', '.join(dropped)} values (vt/vn), but trimesh dropped them all "
            "(a face that refers to none, or to one out of range?): loaded without them",
            stacklevel=4,
        )


def _off_rows(data: bytes) -> Iterator[list[bytes]]:
    """The tokens of each non-empty line of an OFF file, comments left out, lazily."""
    for line in io.BytesIO(data):
        words = line.split(b"#", 1)[0].split()
        if words:
            yield words


def _off_colour_values(rows: list[list[bytes]]) -> np.ndarray | None:
    """The colours ``rows`` (each row's tokens) hold as (N, 4) float RGBA in [0, 1]: integers 0-255 (all of
    them integers) or floats in [0, 1], 3 or 4 per row; None when the rows differ in length, hold another
    count (a colour-map index) or a token that is not a number."""
    k = {len(r) for r in rows}
    if len(k) != 1 or k.pop() not in (3, 4):
        return None
    try:
        values = np.array([[float(t) for t in r] for r in rows], dtype=np.float64)
    except ValueError:
        return None
    if not np.isfinite(values).all():
        return None
    if all(t.lstrip(b"+-").isdigit() for r in rows for t in r):
        values = values / 255.0
    return rgba_float(values)


def _off_may_have_colours(data: bytes) -> bool:
    """Whether the OFF file's bytes ``data`` may hold colours (``COFF``, values after its first vertex's x y
    z or after its last face's indices: a writer colours every row or none), looked at without reading every
    row."""
    rows = _off_rows(data)
    first = next(rows, None)
    if first is None or first[0].upper() == b"COFF":
        return first is not None
    if len(first) == 1:
        next(rows, None)  # (the counts)
    vertex = next(rows, None)
    if vertex is not None and len(vertex) > 3:
        return True
    end = len(data)
    while end > 0:  # (its lines from the last, not every line split: a copy of the file in small objects)
        start = data.rfind(b"\n", 0, end) + 1
        words = data[start:end].split(b"#", 1)[0].split()
        end = start - 1
        if words:
            try:
                return len(words) > 1 + int(words[0])
            except ValueError:
                return True
    return False


def _off_colours(data: bytes, faces: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None, list[str]]:
    """(vertex colours (V, 4), colours of trimesh's triangles ``faces`` (T, 4), colours found but not
    kept) of an OFF file's bytes ``data``: a vertex's colour (``COFF``, ``CNOFF``, ``STCOFF``...) and the
    values after a face's vertex indices, which trimesh's OFF reader drops. A face's colour goes to each
    triangle of its fan
    (trimesh triangulates it so, in another order: triangles are matched by their vertices)."""
    if not _off_may_have_colours(data):
        return None, None, []
    rows = list(_off_rows(data))
    # the variants' vertex rows: x y z [nx ny nz (N)] [colour (C)] [s t (ST)] (4OFF, nOFF: other rows)
    variant = re.fullmatch(rb"(ST)?(C)?(N)?OFF", rows[0][0].upper()) if rows else None
    if variant is None:
        return None, None, []
    texture, colour, normal = (g is not None for g in variant.groups())
    at = 1 if len(rows[0]) > 1 else 2
    counts = rows[0][1:] if len(rows[0]) > 1 else (rows[1] if len(rows) > 1 else [])
    try:
        n_vertices, n_faces = int(counts[0]), int(counts[1])
    except (IndexError, ValueError):
        return None, None, []
    vertex_rows = rows[at : at + n_vertices]
    face_rows = rows[at + n_vertices : at + n_vertices + n_faces]
    if len(vertex_rows) != n_vertices or len(face_rows) != n_faces:
        return None, None, []
    lost: list[str] = []
    vertex_colours = None
    first, last = 3 + 3 * normal, 2 * texture
    if (colour or not (normal or texture)) and any(len(r) > first + last for r in vertex_rows):
        vertex_colours = _off_colour_values([r[first : len(r) - last] for r in vertex_rows])
        if vertex_colours is None:
            lost.append("vertex colours")
    try:
        sizes = np.array([int(r[0]) for r in face_rows], np.int64)
    except ValueError:
        return vertex_colours, None, lost
    extra = [r[1 + n :] for r, n in zip(face_rows, sizes.tolist(), strict=True)]
    if not any(extra):
        return vertex_colours, None, lost
    face_colours = _off_colour_values(extra)
    complete = all(3 <= n < len(r) for r, n in zip(face_rows, sizes.tolist(), strict=True))
    tris = np.asarray(faces, np.int64).reshape(-1, 3)
    if face_colours is not None and complete and int((sizes - 2).sum()) == tris.shape[0] > 0:
        # each face's fan (0, c, c + 1), vectorised over the faces' indices laid end to end
        try:
            flat = np.array(
                [int(t) for r, n in zip(face_rows, sizes.tolist(), strict=True) for t in r[1 : 1 + n]]
            )
        except ValueError:
            flat = None
        if flat is not None:
            n_tris = sizes - 2
            face = np.repeat(np.arange(n_faces), n_tris)
            corner = np.arange(face.shape[0]) - (np.cumsum(n_tris) - n_tris)[face] + 1
            start = (np.cumsum(sizes) - sizes)[face]
            fans = np.stack([flat[start], flat[start + corner], flat[start + corner + 1]], axis=1)
            if np.array_equal(fans, tris):  # (triangles only: trimesh's are the file's, in order)
                return vertex_colours, face_colours[face], lost
            # trimesh's triangles in its order (triangles, then quads' halves, then fans): matched by vertices
            _, key = np.unique(np.sort(np.concatenate([fans, tris]), axis=1), axis=0, return_inverse=True)
            key = key.reshape(-1)
            of_key = np.full(int(key.max()) + 1, -1, np.int64)
            of_key[key[: fans.shape[0]]] = face
            found = of_key[key[fans.shape[0] :]]
            if (found >= 0).all():
                return vertex_colours, face_colours[found], lost
    lost.append("face colours")
    return vertex_colours, None, lost
