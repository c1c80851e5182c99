"""What is wrong with a .gltf or .glb file, for the message once trimesh has failed on it (trimesh said
"AssertionError: ", "KeyError: 5", "FileNotFoundError: model.gltf"...): JSON that does not parse or is not
an object, a buffer's data URI or file, a bufferView, accessor or primitive that points past its data or to
nothing, a part of the document of the wrong type, a .glb's header, chunk lengths and JSON chunk. A .glb's
chunk lengths are also checked before trimesh reads the file (:func:`glb_chunk_problem`). The rewrite of
what trimesh reads wrongly is :mod:`.gltf_prepare`'s."""

from __future__ import annotations

import base64
import binascii
import itertools
import json
import os
import struct
from pathlib import Path
from typing import Any

import numpy as np

from .gltf_read import _COMPONENT, _GLB_BIN, _GLB_JSON, _WIDTH, _document, _index, _Unread, uri_names
from .text_rows import _undecoded


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
    as the loader's resolver does (:func:`.gltf_read.uri_names`), which refuses a file outside the .gltf's
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
    rewrite finds them (:func:`.gltf_read._document`: the first JSON and the first binary chunk, whatever
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
            # (trimesh's "cannot reshape array of size 5 into shape (3)")
            accessors = doc.get("accessors", [])
            corners = prim.get("indices", prim["attributes"]["POSITION"])
            count = accessors[corners].get("count") if _index(corners) and corners < len(accessors) else None
            if prim.get("mode", 4) == 4 and _index(count) and count % 3:
                what = "indices" if "indices" in prim else "POSITION values (no indices)"
                return (
                    f"meshes[{m}].primitives[{k}]: its {count} {what} (accessors[{corners}]) are not a whole "
                    "number of triangles (mode TRIANGLES: 3 a triangle)"
                )
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
