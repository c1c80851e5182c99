"""Rewrite the glTF 2.0 features trimesh reads wrongly or drops, before it reads the file.

trimesh (the loader behind :mod:`.trimesh_loader`) silently

* ignores an accessor's ``sparse`` substitutions (a ``POSITION`` with sparse values loads its base values, or
  all zeros when it has no ``bufferView``);
* reads a ``normalized`` integer accessor as raw integers (a ``TEXCOORD_0`` of unsigned shorts, which glTF's
  core allows, came out as uv 0..65535, and flipped to ``1 - v`` in 16-bit arithmetic);
  a ``normalized`` that is not a JSON boolean, as glTF 2.0 says it is (the string ``"false"``, ``1``), is
  refused naming the accessor (:func:`.gltf_json._check_normalized`), where it was read as a truth value;
* drops a primitive of mode ``TRIANGLE_FAN`` (6);
* drops ``TEXCOORD_0`` of a primitive without a ``material``;
* leaves a node holding a camera out of the scene, with its mesh and children ("No path from world->3");
* loads nothing from a file without ``scenes`` (valid glTF: its nodes are then not in a scene), which the
  loader reported as "no triangles";
* loads a geometry compressed by an extension it cannot decode (meshopt; Draco without DracoPy) as zeros,
  which the loader reported as "all triangles are degenerate": :func:`prepared_gltf` names the extension;
* reads a node of ``EXT_mesh_gpu_instancing`` as one copy of its mesh: :func:`prepare_gltf` reads its
  instances' transforms (:func:`.gltf_instancing._instance_matrices`), which the loader applies to the node's
  mesh. The extension's accessor types are read and no other: TRANSLATION and SCALE VEC3 of FLOAT, ROTATION
  VEC4 of FLOAT or of normalized BYTE or SHORT (decoded as glTF 2.0's max(c / 127, -1), max(c / 32767, -1); no
  unsigned type, which the extension leaves out); another is a :class:`MeshLoadError` naming the node and the
  accessor. A node with both a ``skin`` and instances, which the extension does not define (its instances are
  placed by the node's transform, which skinning ignores), is refused naming the node
  (:func:`.gltf_json._check_instanced_skins`), where it was drawn instanced with its skin left aside;
* reads a file whatever extension its ``extensionsRequired`` lists: one this loader neither implements
  nor can leave aside (:data:`.gltf_json._KNOWN_REQUIRED`) is refused.
* fails on a primitive without ``POSITION`` (a KeyError), which glTF 2.0 says is not rendered: it is left
  out, with a warning naming it ("no triangles" when nothing else is drawn);
* ignores morph targets: a mesh is drawn at its weights (the node's ``weights``, else the mesh's, the
  default ones; zero when neither), its POSITION and NORMAL plus the weighted targets', a copy of the mesh
  for each distinct weights (:func:`.gltf_pose._morphed`);
* ignores skins, drawing the stored vertices placed by the skinned node: glTF 2.0 draws them posed by the
  joints (the blend of each joint's world transform x inverse bind matrix; a normal by its inverse transpose,
  where a joint scaled (1, 4, 1) had tilted a slanted triangle's by 60 degrees) and says the skinned node's
  own transform is ignored; the file's pose is drawn (its nodes' transforms, no animation), and a mesh at its
  bind pose is left as it is (:func:`.gltf_pose._skinned`). The winding follows the skin, not the ignored
  node: a triangle the skin mirrors (on mirroring joints alone; on mirroring and other joints, its blend's
  determinant negative at the triangle's centre) is reversed, as a mirroring node's is
  (:func:`.gltf_pose._wind_as_posed`), where the skinned node's mirror had flipped every triangle or none;
* reads a buffer's or image's ``uri`` as written: it is a URI, percent-decoded (``my%20mesh.bin``) by
  :func:`uri_names`, whose resolver (:func:`uri_resolver`) the loader gives trimesh for every glTF.

What glTF 2.0 says of the rest that changes the triangles, and what the loader does (each checked with a
file written in the tests): modes TRIANGLES, TRIANGLE_STRIP (its odd triangles' winding swapped, as the
spec lists them) and TRIANGLE_FAN are drawn, POINTS and LINE* primitives are not; without ``indices`` a
primitive's vertices are taken in order; ``byteStride`` interleaving, integer positions (normalized or
not, KHR_mesh_quantization) and sparse accessors (on POSITION and on indices) read as the spec defines;
a node's ``matrix`` or its T x R x S; a mesh of several nodes is drawn at each; a node whose world
transform mirrors (negative determinant) has its triangles' winding reversed, so the front faces stay
front faces; cameras and lights are not drawn. The scene drawn is ``scene``, else the first of ``scenes``
(the spec lets a loader draw nothing then: drawing the first is what viewers do), else every root node.
A skinned mesh's winding: glTF 2.0 says the determinant of the node's global transform decides it, and
that a skinned node's transform is ignored, the joints' transforms placing the mesh instead; the loader
decides it per triangle by its joints: none mirroring, not reversed (however they twist it); all, reversed;
a blend of mirrored and unmirrored joints by the sign of its mean's determinant at the centre (three.js's
renderer decides front faces by the drawn object's world matrix alone, for a skinned mesh the skinned
node's, so never reverses a triangle of no mirroring joint either). Left as trimesh does: the loader never
fetches a ``scheme:`` uri (``http:``, ``file:``) nor reads a file outside the glTF's folder.

:func:`prepared_gltf` returns, for a file that uses any of them, the document rewritten so trimesh reads what
the file means (dense float accessors in one added buffer, fans as triangle lists, a plain material added for
the uv to be read, a camera taken off a node with a mesh or children, a scene of every root node, a primitive
without POSITION left out, a morphed or skinned mesh's posed copy), as
``.gltf`` JSON with its buffers inline; None for a file that uses none of them (read as before)
or whose structure does not read (trimesh then says what is wrong). :func:`prepare_gltf` returns the
instances' transforms with it.

This module decides whether a file needs the rewrite (:func:`_needs`) and rewrites it (:func:`_rewrite`);
the pieces it stands on are beside it: :mod:`.gltf_read` (the file's document and accessors, read as
arrays), :mod:`.gltf_json` (the checks of the JSON alone, and the triangles it declares),
:mod:`.gltf_instancing` (``EXT_mesh_gpu_instancing``) and :mod:`.gltf_pose` (skins and morph targets).
"""

from __future__ import annotations

import base64
import json
import warnings
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ..errors import MeshLoadError
from .gltf_instancing import INSTANCES_KEY as INSTANCES_KEY  # (re-exported)
from .gltf_instancing import INSTANCING as INSTANCING  # (re-exported)
from .gltf_instancing import _instance_matrices, _instancing
from .gltf_json import _check_document
from .gltf_json import check_glb_json as check_glb_json  # (re-exported)
from .gltf_json import gltf_triangle_count as gltf_triangle_count  # (re-exported)
from .gltf_pose import _morph_weights, _morphed, _skinned, _skinned_node, _world_matrices
from .gltf_read import (
    _FLOAT,
    _TRIANGLE_FAN,
    _TRIANGLES,
    _UNREAD,
    _document,
    _json_document,
    _Rewrite,
)
from .gltf_read import uri_names as uri_names  # (re-exported)
from .gltf_read import uri_resolver as uri_resolver  # (re-exported)


def _odd(accessors: list, i: Any, name: str = "") -> bool:
    """Whether accessor ``i`` (of the attribute ``name``, or indices) is one trimesh reads wrongly: sparse, or
    normalized integers (but unsigned bytes of a colour, which it reads right, scaled by their maximum)."""
    a = accessors[i] if isinstance(i, int) and 0 <= i < len(accessors) else None
    if not isinstance(a, dict):
        return False
    if "sparse" in a:
        return True
    ubyte_colour = name.startswith("COLOR_") and a.get("componentType") == 5121
    return a.get("normalized") is True and a.get("componentType") != _FLOAT and not ubyte_colour


def _needs(doc: dict, skins: bool = True) -> bool:
    """Whether the document uses a feature the rewrite is for (``skins``: counting a skinned node, which
    needs one only when it is not at its bind pose: known once its buffers are read)."""
    accessors = doc.get("accessors") or []
    for mesh in doc.get("meshes") or []:
        for p in mesh.get("primitives") or []:
            attrs = p.get("attributes") or {}
            if p.get("mode") == _TRIANGLE_FAN or _odd(accessors, p.get("indices")):
                return True
            if isinstance(attrs, dict) and "POSITION" not in attrs:
                return True
            if any(_odd(accessors, i, name) for name, i in attrs.items()):
                return True
            if "TEXCOORD_0" in attrs and "material" not in p:
                return True
    if any(_camera_over_geometry(n) or _instancing(n) is not None for n in doc.get("nodes") or []):
        return True
    if any(
        _morph_weights(doc, n) is not None or (skins and _skinned_node(n)) for n in doc.get("nodes") or []
    ):
        return True
    if not doc.get("nodes") and any(
        _morph_weights(doc, {"mesh": m}) for m in range(len(doc.get("meshes") or []))
    ):
        return True  # (meshes and no node: each drawn once, with its own weights)
    return "scenes" not in doc and bool(doc.get("nodes") or doc.get("meshes"))


def _camera_over_geometry(node: Any) -> bool:
    """Whether ``node`` holds a camera and a mesh or children: trimesh takes a camera node for the camera
    alone and leaves it out of the scene graph, its mesh dropped and its children with no path to the root
    ("No path from world->3")."""
    return (
        isinstance(node, dict)
        and "camera" in node
        and bool(node.get("mesh") is not None or node.get("children"))
    )


def _rewrite(path: Path, doc: dict, binary: bytes | None) -> tuple[bytes, dict[int, np.ndarray]] | None:
    """The rewritten document and its instances; None when it needed the rewrite for skinned nodes alone
    and all are at their bind pose (read as they are: not inlined)."""
    skins_alone = not _needs(doc, skins=False)
    r = _Rewrite(path, doc, binary)
    accessors = doc.get("accessors") or []
    dense: dict[int, int] = {}  # an odd accessor -> its dense float (or index) copy

    def plain(i: int, name: str = "", as_indices: bool = False) -> int:
        a = accessors[i]
        if not _odd(accessors, i, name):
            return i
        if i not in dense:
            values = r.read(i)
            if as_indices:
                values = values.astype(np.uint32)
            elif values.dtype.kind != "f":
                values = values.astype(np.float32)
            dense[i] = r.add(values[:, 0] if a["type"] == "SCALAR" else values, a["type"])
        return dense[i]

    material = None
    unplaced = []  # (primitives without POSITION)
    for m, mesh in enumerate(doc.get("meshes") or []):
        primitives = mesh.get("primitives") or []
        drawn = ["POSITION" in (p.get("attributes") or {}) for p in primitives]
        unplaced += [f"meshes[{m}].primitives[{k}]" for k, d in enumerate(drawn) if not d]
        mesh["primitives"] = primitives = [p for p, d in zip(primitives, drawn, strict=True) if d]
        for p in primitives:
            attrs = p.get("attributes") or {}
            for name, i in list(attrs.items()):
                attrs[name] = plain(i, name)
            if "indices" in p:
                p["indices"] = plain(p["indices"], as_indices=True)
            if p.get("mode") == _TRIANGLE_FAN:
                if "indices" in p:
                    flat = r.read(p["indices"])[:, 0].astype(np.int64)
                else:
                    flat = np.arange(r.count(attrs["POSITION"]), dtype=np.int64)
                k = np.arange(1, max(flat.shape[0] - 1, 1))[: max(flat.shape[0] - 2, 0)]
                fan = np.stack([np.repeat(flat[:1], k.shape[0]), flat[k], flat[k + 1]], axis=1)
                p["indices"] = r.add(fan.reshape(-1).astype(np.uint32), "SCALAR")
                p["mode"] = _TRIANGLES
            if "TEXCOORD_0" in attrs and "material" not in p:
                if material is None:
                    doc.setdefault("materials", []).append({"name": "swpm-usd default (for the uv to load)"})
                    material = len(doc["materials"]) - 1
                p["material"] = material
    if unplaced:  # (glTF 2.0: a primitive without POSITION is not rendered; clients should skip it)
        shown = ", ".join(unplaced[:5]) + (f" and {len(unplaced) - 5} more" if len(unplaced) > 5 else "")
        warnings.warn(f"{path}: {shown} without a POSITION attribute, not drawn", stacklevel=4)
    instances: dict[int, np.ndarray] = {}
    for i, node in enumerate(doc.get("nodes") or []):
        if _camera_over_geometry(node):  # (the camera is not loaded: its node stays, as an empty node)
            del node["camera"]
        ext = _instancing(node)
        if ext is not None:
            instances[i] = _instance_matrices(r, i, ext)
            node["extensions"][INSTANCING] = {INSTANCES_KEY: i}
        elif isinstance(node, dict) and isinstance(node.get("extensions"), dict):
            node["extensions"].pop(INSTANCING, None)  # (a file's own key is not taken for the rewrite's)
    if "scenes" not in doc:
        nodes = doc.get("nodes") or []
        if not nodes:  # (meshes and no node: each mesh at the origin)
            nodes = doc["nodes"] = [{"mesh": i} for i in range(len(doc.get("meshes") or []))]
        children = {c for n in nodes if isinstance(n, dict) for c in n.get("children") or []}
        doc["scenes"] = [{"nodes": [i for i in range(len(nodes)) if i not in children]}]
        doc["scene"] = 0
    morphs: dict[tuple[int, tuple[float, ...]], int] = {}  # (mesh, weights) -> its morphed copy
    for node in doc.get("nodes") or []:
        weights = _morph_weights(doc, node)
        if weights is not None:
            key = (node["mesh"], weights)
            if key not in morphs:
                morphs[key] = _morphed(r, *key)
            node["mesh"] = morphs[key]
    nodes = doc.get("nodes") or []
    if any(_skinned_node(n) for n in nodes):
        world = _world_matrices(nodes)
        for i, node in enumerate(nodes):
            if _skinned_node(node):
                node["mesh"] = _skinned(r, i, world)
    if skins_alone and not r.extra:  # (no posed copy)
        return None
    for i, b in enumerate(doc["buffers"]):  # (inline, the .glb's binary chunk included: one JSON document)
        if b.get("uri") is None:
            b["uri"] = "data:application/octet-stream;base64," + base64.b64encode(r.buffer(i)).decode()
    if r.extra:
        doc["buffers"].append(
            {
                "byteLength": len(r.extra),
                "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(r.extra)).decode(),
            }
        )
    return json.dumps(doc).encode(), instances


class Prepared(NamedTuple):
    """A glTF rewritten for trimesh (:func:`prepare_gltf`)."""

    #: the document as ``.gltf`` JSON, buffers inline
    data: bytes
    #: {node index: its (instances, 4, 4) ``EXT_mesh_gpu_instancing`` transforms}; the node's extension in
    #: ``data`` holds its index under :data:`INSTANCES_KEY`
    instances: dict[int, np.ndarray]


class InstancingUnread(Exception):
    """A glTF with ``EXT_mesh_gpu_instancing`` nodes whose rewrite failed: trimesh alone would read each
    such node as one copy of its mesh."""


def prepared_gltf(path: Path) -> bytes | None:
    """The ``.gltf`` or ``.glb`` file ``path`` rewritten as ``.gltf`` JSON (buffers inline, images still by
    their uri) for trimesh to read what it means, or None when it needs no rewrite or does not read."""
    prepared = prepare_gltf(path)
    return None if prepared is None else prepared.data


def prepare_gltf(path: Path) -> Prepared | None:
    """:func:`prepared_gltf` with the instances of its ``EXT_mesh_gpu_instancing`` nodes. Raises
    :class:`InstancingUnread` when the file has such nodes and its rewrite fails (trimesh, left to read it,
    says what is wrong with it, or would read those nodes as one copy)."""
    doc: Any = None
    try:
        glb = path.suffix.lower() == ".glb"
        if glb:  # (its JSON chunk first: one that needs nothing is read no further)
            doc = _json_document(path)
            _check_document(path, doc)
            if not _needs(doc):
                return None
        data = path.read_bytes()
        doc, binary = _document(path, data)
        if not glb:  # (a .glb's JSON, the same chunk, was checked above)
            _check_document(path, doc)
        if not isinstance(doc, dict) or not _needs(doc):
            return None
        rewritten = _rewrite(path, doc, binary)
        return None if rewritten is None else Prepared(*rewritten)
    except MeshLoadError as e:
        if e.path is None:  # (found in the JSON alone: its file named here)
            raise MeshLoadError(path, e.problem) from e
        raise
    except _UNREAD as e:
        nodes = doc.get("nodes") if isinstance(doc, dict) else None
        if isinstance(nodes, list) and any(_instancing(n) is not None for n in nodes):
            raise InstancingUnread(f"{type(e).__name__}: {e}") from e
        return None
