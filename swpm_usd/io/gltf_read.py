"""Read a glTF 2.0 file's JSON document and its accessors as arrays, and append new accessors to one buffer.

The reading beneath :mod:`.gltf_prepare`'s rewrite (and :mod:`.gltf_checks`'s problems): the .glb
container's chunks, a buffer's or image's ``uri`` (percent-decoded, kept inside the glTF's folder), and
:class:`_Rewrite`, which reads an accessor (strided, sparse, normalized) checked against the bytes it
names before anything is allocated for it. Kept apart from the rewrite so that each of the features it
rewrites (:mod:`.gltf_pose`, :mod:`.gltf_instancing`) reads on one page.
"""

from __future__ import annotations

import base64
import json
import os
import struct
import urllib.parse
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MeshLoadError

_COMPONENT = {5120: "i1", 5121: "u1", 5122: "i2", 5123: "u2", 5125: "u4", 5126: "f4"}


#: the component types' names in glTF 2.0, which messages give with the number the file holds
_COMPONENT_NAME = {
    5120: "BYTE",
    5121: "UNSIGNED_BYTE",
    5122: "SHORT",
    5123: "UNSIGNED_SHORT",
    5125: "UNSIGNED_INT",
    5126: "FLOAT",
}


_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


#: the widths of the matrix accessors read here (a skin's inverse bind matrices: floats, no padding)
_MATRIX_WIDTH = {"MAT4": 16}


_TRIANGLE_FAN = 6


_TRIANGLES = 4


_TRIANGLE_STRIP = 5


_FLOAT = 5126


_UINT = 5125


_GLB_HEADER = struct.Struct("<4sII")


_CHUNK = struct.Struct("<II")


_GLB_JSON, _GLB_BIN = 0x4E4F534A, 0x004E4942


#: the most elements of an accessor without a bufferView (zeros, sparse values applied) made dense
_ZEROS_MAX = 1 << 24


def uri_names(uri: str) -> list[str]:
    """The names, relative to a glTF's folder, under which the loader looks for the file of a buffer's or
    image's ``uri``, in order: the uri percent-decoded (RFC 3986, as glTF 2.0 asks: ``my%20mesh.bin`` is
    ``my mesh.bin``), then as written (a file named with a literal ``%``, which trimesh alone read); each as
    it is, without a leading ``/``, and by its last part (trimesh's tries: ``bin/data.bin`` is read from
    ``data.bin``). A name that leads out of the folder (``..``, an absolute path) is not read there
    (:class:`UriResolver`), so a file cannot make the loader read another file silently; a ``scheme:``
    uri (``file:``, ``http:``) is not fetched, only its names inside the folder are looked at."""
    names: list[str] = []
    for written in dict.fromkeys((urllib.parse.unquote(uri), uri)):
        for name in (written.strip(), written.strip().lstrip("/"), os.path.split(written)[-1]):
            if name not in names:
                names.append(name)
    return names


def uri_resolver(path: Path) -> Any:
    """A trimesh resolver of the files beside the glTF file ``path`` that finds a uri's file under
    :func:`uri_names` (trimesh's own looks under the uri as written alone)."""
    import trimesh

    class UriResolver(trimesh.resolvers.FilePathResolver):
        def get(self, name: str) -> bytes:
            for candidate in uri_names(name):
                try:
                    file = self.absolute(candidate)  # (a ValueError for a name out of the folder)
                except ValueError:
                    continue
                if file.is_file():  # (a folder of that name is passed over, as the pipeline does)
                    return file.read_bytes()
            self.absolute(name)  # (the name out of the folder raises, as trimesh's resolver does)
            raise FileNotFoundError(name)

    return UriResolver(str(path))


class _Unread(Exception):
    """The document's structure is not one this rewrite reads (trimesh reports the file)."""


def _document(path: Path, data: bytes) -> tuple[dict, bytes | None]:
    """(JSON document, a .glb's binary chunk or None) of the file's bytes ``data``."""
    if path.suffix.lower() != ".glb":
        return json.loads(data), None
    if len(data) < _GLB_HEADER.size + _CHUNK.size:
        raise _Unread
    magic, _, length = _GLB_HEADER.unpack_from(data)
    if magic != b"glTF" or length > len(data):
        raise _Unread
    at, doc, binary = _GLB_HEADER.size, None, None
    while at + _CHUNK.size <= length:
        size, kind = _CHUNK.unpack_from(data, at)
        body = data[at + _CHUNK.size : at + _CHUNK.size + size]
        if len(body) < size:
            raise _Unread
        if kind == _GLB_JSON and doc is None:
            doc = json.loads(body)
        elif kind == _GLB_BIN and binary is None:
            binary = body
        at += _CHUNK.size + size
    if doc is None:
        raise _Unread
    return doc, binary


def _json_document(path: Path, *, whole: bool = False) -> Any:
    """The JSON document of the .gltf or .glb file ``path`` (a .glb's JSON chunk alone is read; ``whole``:
    only when all the bytes that chunk declares follow its header); raises :class:`_Unread` (or what reading
    or parsing raises) when there is none."""
    if path.suffix.lower() != ".glb":
        return json.loads(path.read_bytes())
    with open(path, "rb") as f:
        head = f.read(_GLB_HEADER.size + _CHUNK.size)
        if len(head) < _GLB_HEADER.size + _CHUNK.size:
            raise _Unread
        size, kind = _CHUNK.unpack_from(head, _GLB_HEADER.size)
        room = os.fstat(f.fileno()).st_size - (len(head) if whole else 0)
        if kind != _GLB_JSON or size > room:  # (read(size) asks for size)
            raise _Unread
        return json.loads(f.read(size))


def _component(value: Any) -> str:
    """An accessor's ``componentType`` as glTF 2.0 names it, ``UNSIGNED_SHORT (5123)``; another value as
    the file holds it (shortened)."""
    known = isinstance(value, int) and not isinstance(value, bool) and value in _COMPONENT_NAME
    return f"{_COMPONENT_NAME[value]} ({value})" if known else f"{value!r:.40}"


def _accessor_type(value: Any) -> str:
    """An accessor's ``type`` as glTF 2.0 names it (``VEC3``); another value as the file holds it."""
    known = isinstance(value, str) and (value in _WIDTH or value in ("MAT2", "MAT3", "MAT4"))
    return value if known else f"{value!r:.40}"


def _index(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


#: what a rewrite of a document whose structure it does not read raises
_UNREAD = (_Unread, OSError, ValueError, KeyError, IndexError, TypeError, AttributeError, RecursionError)


class _Rewrite:
    """The document's accessors read as arrays; new arrays appended to one buffer."""

    def __init__(self, path: Path, doc: dict, binary: bytes | None):
        self.path, self.doc, self.binary = path, doc, binary
        self.resolver = uri_resolver(path)
        self.buffers: dict[int, bytes] = {}
        self.extra = bytearray()
        self.views = doc.setdefault("bufferViews", [])
        self.extra_buffer = len(doc.setdefault("buffers", []))

    def buffer(self, i: int) -> bytes:
        if i == self.extra_buffer:
            return bytes(self.extra)
        if i not in self.buffers:
            b = self.doc["buffers"][i]
            uri = b.get("uri")
            if uri is None:
                if self.binary is None or i != 0:
                    raise _Unread
                self.buffers[i] = self.binary
            elif "base64," in uri:
                self.buffers[i] = base64.b64decode(uri[uri.index("base64,") + 7 :])
            else:
                self.buffers[i] = self.resolver[uri]
        return self.buffers[i]

    def view(self, i: int) -> tuple[bytes, int | None]:
        if not isinstance(i, int) or not 0 <= i < len(self.views):  # (not views[-1])
            raise _Unread
        v = self.views[i]
        start = v.get("byteOffset", 0)
        if not isinstance(start, int) or start < 0:
            raise _Unread
        data = self.buffer(v["buffer"])[start : start + v["byteLength"]]
        if len(data) < v["byteLength"]:
            raise _Unread
        stride = v.get("byteStride")
        if stride is not None and (not isinstance(stride, int) or isinstance(stride, bool) or stride <= 0):
            raise MeshLoadError(self.path, f"bufferView {i} has byteStride {stride!r}, not a positive number")
        return data, stride

    def _strided(self, view: int, offset: int, count: int, dtype: np.dtype, width: int) -> np.ndarray:
        data, stride = self.view(view)
        stride = stride or dtype.itemsize * width
        end = offset + (count - 1) * stride + dtype.itemsize * width
        if offset < 0:
            raise MeshLoadError(self.path, f"an accessor of bufferView {view} has byteOffset {offset}")
        if count and end > len(data):
            raise MeshLoadError(
                self.path, f"bufferView {view} holds {len(data)} bytes, an accessor reads {end}"
            )
        arr = np.ndarray((count, width), dtype, buffer=data, offset=offset, strides=(stride, dtype.itemsize))
        return arr.copy()

    def count(self, i: int) -> int:
        """Accessor ``i``'s element count, checked against the bytes it reads before anything is allocated
        for it (a count of 10^10 in a small file is a MeshLoadError, not a 100 GiB array)."""
        a = self.doc["accessors"][i]
        count = a["count"]
        if not isinstance(count, int) or isinstance(count, bool) or count < 0:
            raise _Unread
        if "bufferView" in a:
            dtype = np.dtype(_COMPONENT[a["componentType"]])
            data, stride = self.view(a["bufferView"])
            size = dtype.itemsize * {**_WIDTH, **_MATRIX_WIDTH}[a["type"]]
            end = a.get("byteOffset", 0) + (count - 1) * (stride or size) + size
            if count and end > len(data):
                raise MeshLoadError(
                    self.path,
                    f"bufferView {a['bufferView']} holds {len(data)} bytes, accessor {i} reads {end}",
                )
        elif count > _ZEROS_MAX:
            raise MeshLoadError(
                self.path, f"accessor {i} has no bufferView and {count} elements (more than {_ZEROS_MAX})"
            )
        return count

    def read(self, i: int, rows: np.ndarray | None = None) -> np.ndarray:
        """Accessor ``i`` as a (count, width) array: its sparse values applied, normalized values as float.
        ``rows`` (sorted, holding every sparse index), for an accessor without a bufferView: those rows alone
        (its zeros are not allocated for every element)."""
        a = self.doc["accessors"][i]
        dtype = np.dtype("<" + _COMPONENT[a["componentType"]])
        width, count = {**_WIDTH, **_MATRIX_WIDTH}[a["type"]], self.count(i)
        if "bufferView" in a:
            values, rows = self._strided(a["bufferView"], a.get("byteOffset", 0), count, dtype, width), None
        else:
            values = np.zeros((count if rows is None else rows.shape[0], width), dtype)
        sparse = a.get("sparse")
        if sparse:
            n, si, sv = sparse["count"], sparse["indices"], sparse["values"]
            idt = np.dtype("<" + _COMPONENT[si["componentType"]])
            where = self._strided(si["bufferView"], si.get("byteOffset", 0), n, idt, 1)[:, 0].astype(np.int64)
            if n and (where.min() < 0 or where.max() >= count):
                raise MeshLoadError(
                    self.path,
                    f"accessor {i}: a sparse index ({int(where.max())}) is past its {count} elements",
                )
            at = where if rows is None else np.searchsorted(rows, where)
            values[at] = self._strided(sv["bufferView"], sv.get("byteOffset", 0), n, dtype, width)
        if a.get("normalized") is True and dtype.kind in "iu":
            top = np.float32(np.iinfo(dtype).max)
            values = values.astype(np.float32) / top
            if dtype.kind == "i":
                values = np.maximum(values, np.float32(-1.0))
        return values

    def add(self, values: np.ndarray, type_name: str) -> int:
        """A new accessor of ``values`` (float32 or uint32), its index."""
        values = np.ascontiguousarray(values, values.dtype.newbyteorder("<"))
        self.extra.extend(b"\0" * (-len(self.extra) % 4))
        self.views.append(
            {"buffer": self.extra_buffer, "byteOffset": len(self.extra), "byteLength": values.nbytes}
        )
        self.extra.extend(values.tobytes())
        accessor = {
            "bufferView": len(self.views) - 1,
            "componentType": _FLOAT if values.dtype.kind == "f" else _UINT,
            "count": values.shape[0],
            "type": type_name,
        }
        if type_name != "SCALAR" and values.shape[0]:
            accessor.update(min=values.min(axis=0).tolist(), max=values.max(axis=0).tolist())
        self.doc["accessors"].append(accessor)
        return len(self.doc["accessors"]) - 1
