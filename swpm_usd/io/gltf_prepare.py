"""Rewrite the glTF 2.0 features trimesh reads wrongly or drops, before it reads the file.

trimesh (the loader behind :mod:`.trimesh_loader`) silently

* ignores an accessor's ``sparse`` substitutions (a ``POSITION`` with sparse values loads its base values, or
  all zeros when it has no ``bufferView``);
* reads a ``normalized`` integer accessor as raw integers (a ``TEXCOORD_0`` of unsigned shorts, which glTF's
  core allows, came out as uv 0..65535, and flipped to ``1 - v`` in 16-bit arithmetic);
  a ``normalized`` that is not a JSON boolean, as glTF 2.0 says it is (the string ``"false"``, ``1``), is
  refused naming the accessor (:func:`_check_normalized`), where it was read as a truth value;
* drops a primitive of mode ``TRIANGLE_FAN`` (6);
* drops ``TEXCOORD_0`` of a primitive without a ``material``;
* leaves a node holding a camera out of the scene, with its mesh and children ("No path from world->3");
* loads nothing from a file without ``scenes`` (valid glTF: its nodes are then not in a scene), which the
  loader reported as "no triangles";
* loads a geometry compressed by an extension it cannot decode (meshopt; Draco without DracoPy) as zeros,
  which the loader reported as "all triangles are degenerate": :func:`prepared_gltf` names the extension;
* reads a node of ``EXT_mesh_gpu_instancing`` as one copy of its mesh: :func:`prepare_gltf` reads its
  instances' transforms (:func:`_instance_matrices`), which the loader applies to the node's mesh. The
  extension's accessor types are read and no other: TRANSLATION and SCALE VEC3 of FLOAT, ROTATION VEC4 of
  FLOAT or of normalized BYTE or SHORT (decoded as glTF 2.0's max(c / 127, -1), max(c / 32767, -1); no
  unsigned type, which the extension leaves out); another is a :class:`MeshLoadError` naming the node and
  the accessor. A node with both a ``skin`` and instances, which the extension does not define (its
  instances are placed by the node's transform, which skinning ignores), is refused naming the node
  (:func:`_check_instanced_skins`), where it was drawn instanced with its skin left aside;
* reads a file whatever extension its ``extensionsRequired`` lists: one this loader neither implements
  nor can leave aside (:data:`_KNOWN_REQUIRED`) is refused.
* fails on a primitive without ``POSITION`` (a KeyError), which glTF 2.0 says is not rendered: it is left
  out, with a warning naming it ("no triangles" when nothing else is drawn);
* ignores morph targets: a mesh is drawn at its weights (the node's ``weights``, else the mesh's, the
  default ones; zero when neither), its POSITION and NORMAL plus the weighted targets', a copy of the mesh
  for each distinct weights (:func:`_morphed`);
* ignores skins, drawing the stored vertices placed by the skinned node: glTF 2.0 draws them posed by the
  joints (the blend of each joint's world transform x inverse bind matrix; a normal by its inverse
  transpose, where a joint scaled (1, 4, 1) had tilted a slanted triangle's by 60 degrees) and says the
  skinned node's own transform is ignored; the file's pose is drawn (its nodes' transforms, no
  animation), and a mesh at its bind pose is left as it is (:func:`_skinned`). The winding follows the
  skin, not the ignored node: a triangle the skin mirrors (on mirroring joints alone; on mirroring and
  other joints, its blend's determinant negative at the triangle's centre) is reversed, as a mirroring
  node's is (:func:`_wind_as_posed`), where the skinned node's mirror had flipped every triangle or none;
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
"""

from __future__ import annotations

import base64
import json
import math
import os
import struct
import urllib.parse
import warnings
from pathlib import Path
from typing import Any, NamedTuple

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


#: the glTF extension placing a node's mesh at each of its instances
INSTANCING = "EXT_mesh_gpu_instancing"
#: the key the rewrite puts in an instanced node's extension (its node index) for the loader to find its
#: instances in trimesh's scene graph, which keeps a node's extensions in its edge's metadata
INSTANCES_KEY = "swpm_usd_instances"
#: EXT_mesh_gpu_instancing's attributes read here: (accessor type, the component types allowed, of which
#: those that must be normalized)
_INSTANCE_ATTRIBUTES = {
    "TRANSLATION": ("VEC3", (_FLOAT,), ()),
    "ROTATION": ("VEC4", (_FLOAT, 5120, 5122), (5120, 5122)),
    "SCALE": ("VEC3", (_FLOAT,), ()),
}


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


def _component(value: Any) -> str:
    """An accessor's ``componentType`` as glTF 2.0 names it, ``UNSIGNED_SHORT (5123)``; another value as
    the file holds it (shortened)."""
    known = isinstance(value, int) and not isinstance(value, bool) and value in _COMPONENT_NAME
    return f"{_COMPONENT_NAME[value]} ({value})" if known else f"{value!r:.40}"


def _accessor_type(value: Any) -> str:
    """An accessor's ``type`` as glTF 2.0 names it (``VEC3``); another value as the file holds it."""
    known = isinstance(value, str) and (value in _WIDTH or value in ("MAT2", "MAT3", "MAT4"))
    return value if known else f"{value!r:.40}"


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


def _skinned_node(node: Any) -> bool:
    """Whether ``node`` draws its mesh with a skin (not an instanced node's: its instances are placed in
    the node's frame, which skinning leaves aside; :func:`prepare_gltf` refuses such a node)."""
    return (
        isinstance(node, dict)
        and node.get("mesh") is not None
        and "skin" in node
        and _instancing(node) is None
    )


def _morph_weights(doc: dict, node: Any) -> tuple[float, ...] | None:
    """The morph target weights the mesh of ``node`` is drawn with (glTF 2.0: the node's ``weights``, else
    its mesh's, the targets' default weights; zero when neither is given), or None when its mesh has no
    targets or they are all zero (the mesh is drawn as it is). A weight that is not a finite number is a
    :class:`MeshLoadError`."""
    meshes = doc.get("meshes") or []
    m = node.get("mesh") if isinstance(node, dict) else None
    if not _index(m) or m >= len(meshes) or not isinstance(meshes[m], dict):
        return None
    primitives = meshes[m].get("primitives") or []
    if not any(isinstance(p, dict) and p.get("targets") for p in primitives):
        return None
    weights = node["weights"] if "weights" in node else meshes[m].get("weights")
    if not isinstance(weights, list):
        return None
    if not all(isinstance(w, int | float) and not isinstance(w, bool) and math.isfinite(w) for w in weights):
        where = "its node's" if "weights" in node else f"meshes[{m}]'s"
        raise MeshLoadError(None, f"{where} morph weights {weights!r:.80} are not all finite numbers")
    return tuple(float(w) for w in weights) if any(weights) else None


def _local_matrix(node: dict) -> np.ndarray:
    """A node's transform as trimesh places the node (the loader draws the skinned node by trimesh's matrix,
    so the skin's taking it back must be the same one): its ``matrix`` (column-major), times translation x
    rotation x scale; the rotation's quaternion taken to length 1 (trimesh's ``quaternion_matrix``: glTF 2.0
    asks for unit quaternions, and a file's may be off; a zero one is no rotation)."""
    from trimesh import transformations

    m = np.array(node["matrix"], np.float64).reshape(4, 4).T if "matrix" in node else np.eye(4)
    if "translation" in node:
        m = m @ transformations.translation_matrix(node["translation"])
    if "rotation" in node:
        m = m @ transformations.quaternion_matrix(np.reshape(node["rotation"], 4)[[3, 0, 1, 2]])
    if "scale" in node:
        m = m @ np.diag(np.concatenate((np.asarray(node["scale"], np.float64), [1.0])))
    return m


def _world_matrices(nodes: list) -> list[np.ndarray]:
    """Each node's transform from the scene's root (its parents' times its own)."""
    parent = {c: i for i, n in enumerate(nodes) for c in n.get("children") or []}
    world: dict[int, np.ndarray] = {}
    for i in range(len(nodes)):
        chain, at = [], i
        while at not in world:
            chain.append(at)
            if at not in parent:
                break
            at = parent[at]
            if len(chain) > len(nodes):
                raise _Unread  # (a cycle)
        above = world.get(at, np.eye(4))  # (the root's frame, or the first parent placed before)
        for k in reversed(chain):
            above = world[k] = above @ _local_matrix(nodes[k])
    return [world[i] for i in range(len(nodes))]


def _skinned(r: _Rewrite, i: int, world: list[np.ndarray]) -> int:
    """A copy of the mesh of node ``i`` (which has a skin) posed as glTF 2.0 draws it at the nodes' own
    transforms: each POSITION moved by the blend of its joints' world transform x inverse bind matrix,
    weighted by WEIGHTS_n over JOINTS_n (its NORMAL by the inverse transpose: :func:`_posed_normals`, as
    Bevy's skinning shader does; the Khronos sample viewer blends each joint's inverse transpose instead,
    which differs where one vertex blends joints of different rotations or scales); the skinned node's own
    transform is not applied
    (the spec's "MUST be ignored"), so the copy's points are taken back by its inverse, which the loader
    then applies; the copy's index."""
    node, doc = r.doc["nodes"][i], r.doc
    skins = doc.get("skins")
    at = node["skin"]
    skin = skins[at] if isinstance(skins, list) and _index(at) and at < len(skins) else None
    joints = skin.get("joints") if isinstance(skin, dict) else None
    if not isinstance(joints, list) or not joints or not all(_index(j) and j < len(world) for j in joints):
        raise MeshLoadError(r.path, f"node {i}'s skin {at!r:.40} is not a skin of joints that are nodes")
    where = f"skins[{at}]"
    if "inverseBindMatrices" in skin:
        ibm, accessors = skin["inverseBindMatrices"], doc.get("accessors") or []
        if not _index(ibm) or ibm >= len(accessors) or not isinstance(accessors[ibm], dict):
            raise MeshLoadError(
                r.path,
                f"{where}: its inverseBindMatrices {ibm!r:.40} is not one of the {len(accessors)} accessors",
            )
        a = accessors[ibm]
        if a.get("type") != "MAT4" or a.get("componentType") != _FLOAT:
            raise MeshLoadError(
                r.path,
                f"{where}: its inverseBindMatrices (accessor {ibm}) are {_accessor_type(a.get('type'))} of "
                f"{_component(a.get('componentType'))}, not MAT4 of {_component(_FLOAT)}",
            )
        inverse_bind = r.read(skin["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
        if inverse_bind.shape[0] < len(joints):
            raise MeshLoadError(
                r.path, f"{where}: {inverse_bind.shape[0]} inverseBindMatrices for {len(joints)} joints"
            )
    else:
        inverse_bind = np.broadcast_to(np.eye(4), (len(joints), 4, 4))
    # (joint k's matrix, taken back to the skinned node's frame, which the loader applies after)
    node_world = world[i]
    if abs(np.linalg.det(node_world[:3, :3])) < 1e-12:
        raise MeshLoadError(r.path, f"node {i}: a skinned node whose transform is singular")
    joint_world = np.stack([world[j] for j in joints])
    pose = np.linalg.inv(node_world)[None] @ joint_world @ inverse_bind[: len(joints)]
    # (at its bind pose: drawn as it is, same bits. The pose's translations are off by the float32 rounding
    # of the inverse bind matrices' translations, which grows with the skeleton's distance from the origin:
    # their tolerance grows with it, or a skeleton bound 1000 units out was posed, to other bits)
    reach = max(1.0, np.abs(joint_world[:, :3, 3]).max(), np.abs(inverse_bind[: len(joints), :3, 3]).max())
    translation = pose[:, :3, 3].copy()
    pose_frame = pose.copy()
    pose_frame[:, :3, 3] = 0.0
    if np.allclose(pose_frame, np.eye(4), rtol=0, atol=1e-5) and np.allclose(
        translation, 0, atol=1e-5 * reach
    ):
        return node["mesh"]
    mesh = json.loads(json.dumps(doc["meshes"][node["mesh"]]))
    determinants = np.linalg.det(pose[:, :3, :3])
    mirrors, keeps = determinants < 0, determinants > 0  # (each joint's, in the skinned node's frame)
    for k, p in enumerate(mesh.get("primitives") or []):
        attrs = p["attributes"]
        sets = [n for n in range(len(attrs)) if f"JOINTS_{n}" in attrs and f"WEIGHTS_{n}" in attrs]
        if not sets:
            continue
        blend = np.zeros((r.count(attrs["POSITION"]), 4, 4))
        total = np.zeros(blend.shape[0])  # (each vertex's weights' sum, by which its blend is divided)
        # (whether each vertex is moved by a joint that mirrors it (in the skinned node's frame), by one that
        # does not: a triangle on no mirroring joint is not reversed however its joints twist it)
        on_mirror, on_plain = np.zeros(blend.shape[0], bool), np.zeros(blend.shape[0], bool)
        for n in sets:
            index = r.read(attrs[f"JOINTS_{n}"]).astype(np.int64)
            weight = r.read(attrs[f"WEIGHTS_{n}"]).astype(np.float64)
            if index.shape != weight.shape or index.shape[0] != blend.shape[0]:
                raise MeshLoadError(
                    r.path,
                    f"meshes[{node['mesh']}].primitives[{k}]: JOINTS_{n} and WEIGHTS_{n} differ in shape",
                )
            if index.size and (index.min() < 0 or index.max() >= len(joints)):
                raise MeshLoadError(
                    r.path,
                    f"meshes[{node['mesh']}].primitives[{k}]: JOINTS_{n} names joint {int(index.max())} of "
                    f"{where}'s {len(joints)}",
                )
            for c in range(index.shape[1]):  # (each influence at once: not a (V, 4, 4, 4) array)
                blend += weight[:, c, None, None] * pose[index[:, c]]
                if mirrors.any():
                    on_mirror |= mirrors[index[:, c]] & (weight[:, c] != 0)
                    on_plain |= keeps[index[:, c]] & (weight[:, c] != 0)
            total += np.abs(weight).sum(axis=1)
            if n == sets[0]:
                first = index[:, 0]
        # (weights that do not sum to 1 are scaled to, and a vertex of no weight follows its first joint at
        # weight 1, as three.js draws them (SkinnedMesh.normalizeSkinWeights; Blender's armature also
        # divides by the sum): unscaled, a vertex of weights summing to 0.5 was drawn halfway to the
        # skinned node's origin, one of no weight at it)
        unweighted = total <= 0
        if unweighted.any():
            blend[unweighted], total[unweighted] = pose[first[unweighted]], 1.0
            on_mirror[unweighted], on_plain[unweighted] = mirrors[first[unweighted]], keeps[first[unweighted]]
        blend /= total[:, None, None]
        if on_mirror.any():
            _wind_as_posed(r, p, blend, on_mirror, on_plain)
        for name in ("POSITION", "NORMAL"):
            if name not in attrs:
                continue
            values = r.read(attrs[name]).astype(np.float64)
            if name == "POSITION":
                values = np.einsum("vij,vj->vi", blend[:, :3, :3], values) + blend[:, :3, 3]
            else:
                values = _posed_normals(blend[:, :3, :3], values)
            attrs[name] = r.add(values.astype(np.float32), "VEC3")
    doc["meshes"].append(mesh)
    return len(doc["meshes"]) - 1


#: how far (relative to its scale squared) a vertex's blend may be from a similarity (M^T M = s^2 I) and its
#: normal be moved by the blend itself: a rigid joint's, off by the float32 rounding of the inverse bind
#: matrices (about 1e-7), which moved by the inverse transpose would change the normals' bits
_SIMILAR = 1e-6


def _posed_normals(linear: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """``normals`` (V, 3) moved by the inverse transpose of each vertex's blended (V, 3, 3) ``linear`` map and
    taken to length 1, as a surface's normals move: by the map itself a joint scaled (1, 4, 1) tilted a
    slanted triangle's normal off its perpendicular. A similarity's (a rotation, a uniform scale, a mirror:
    the inverse transpose is the map over its scale squared, the same direction) by the map itself, bit for
    bit as before. The others by the cofactor matrix (the determinant x the inverse transpose: finite where
    a blend of mirrored and unmirrored joints is singular), negated where the determinant is negative, so a
    mirrored normal points out of the mirrored surface, which :func:`_wind_as_posed` winds the other way."""
    moved = np.einsum("vij,vj->vi", linear, normals)
    # (the rows (a b c) (d e f) (g h k) as contiguous columns, each sum written out: np.einsum's M^T M and
    # np.cross took 220 ms of 200k vertices, these 30)
    a, b, c, d, e, f, g, h, k = np.ascontiguousarray(linear).reshape(-1, 9).T
    diagonal = a * a + d * d + g * g, b * b + e * e + h * h, c * c + f * f + k * k
    scale2 = (diagonal[0] + diagonal[1] + diagonal[2]) / 3
    apart = np.maximum.reduce(
        [np.abs(x - scale2) for x in diagonal]
        + [np.abs(a * b + d * e + g * h), np.abs(a * c + d * f + g * k), np.abs(b * c + e * f + h * k)]
    )
    off = apart > _SIMILAR * scale2
    if off.any():
        a, b, c, d, e, f, g, h, k = (x[off] for x in (a, b, c, d, e, f, g, h, k))
        cofactor = (
            (e * k - f * h, f * g - d * k, d * h - e * g),
            (h * c - k * b, k * a - g * c, g * b - h * a),
            (b * f - c * e, c * d - a * f, a * e - b * d),
        )
        x, y, z = normals[off].T
        sign = np.where(a * cofactor[0][0] + b * cofactor[0][1] + c * cofactor[0][2] < 0, -1.0, 1.0)
        moved[off] = np.stack([sign * (r[0] * x + r[1] * y + r[2] * z) for r in cofactor], axis=1)
    length = np.linalg.norm(moved, axis=1, keepdims=True)
    return moved / np.where(length > 0, length, 1.0)


def _triangles(r: _Rewrite, p: dict) -> np.ndarray | None:
    """The (T, 3) vertex indices of primitive ``p``'s triangles as glTF 2.0 lists them (TRIANGLES; a
    TRIANGLE_STRIP's triangle i is v_i, v_(i+1+i%2), v_(i+2-i%2)); None for points and lines (no winding),
    and for an index past the vertices: the loader refuses the file, naming the triangle and the index, as
    for any primitive. Fans are triangle lists by now (:func:`_rewrite`)."""
    mode = p.get("mode", _TRIANGLES)
    if mode not in (_TRIANGLES, _TRIANGLE_STRIP):
        return None
    count = r.count(p["attributes"]["POSITION"])
    flat = r.read(p["indices"])[:, 0].astype(np.int64) if "indices" in p else np.arange(count)
    if flat.size and (flat.min() < 0 or flat.max() >= count):
        return None
    if mode == _TRIANGLES:
        return flat[: flat.shape[0] // 3 * 3].reshape(-1, 3)
    i = np.arange(max(flat.shape[0] - 2, 0))
    return np.stack([flat[i], flat[i + 1 + i % 2], flat[i + 2 - i % 2]], axis=1)


def _wind_as_posed(
    r: _Rewrite, p: dict, blend: np.ndarray, on_mirror: np.ndarray, on_plain: np.ndarray
) -> None:
    """Reverse the winding of each triangle of the skinned primitive ``p`` (its posed copy) that its skin
    mirrors, as glTF 2.0 reverses a mirroring node's (front faces stay front), the joints standing for the
    skinned node's ignored transform. ``on_mirror`` and ``on_plain`` say of each vertex whether a joint of
    negative determinant moves it (at a weight not 0), and one of positive determinant. A triangle on
    mirroring joints alone is reversed, one on no mirroring joint is not (however far its joints twist it:
    the mean of three rotations may have a negative determinant, and no renderer reverses such a triangle);
    one on both is mirrored when the determinant of the skin's blend at its centre (the mean of its
    corners' blends: the transform skinning gives its centre) is negative, not by its corners' majority,
    and left as it is at det 0. ``blend`` is each vertex's (V, 4, 4) and the determinants are taken in the
    skinned node's frame (the skin's taken back by the node's transform, which the loader applies after,
    flipping the whole copy when it mirrors): flipped here where it is negative, a triangle is flipped once
    in all when the skin's own blend mirrors it, and not or twice when it does not. Changed: ``p``'s indices
    (then a triangle list)."""
    triangles = _triangles(r, p)
    if triangles is None or not triangles.size:
        return
    mirrored = on_mirror[triangles].any(axis=1)
    mixed = mirrored & on_plain[triangles].any(axis=1)
    if mixed.any():
        # (each vertex's 3x3 as one contiguous row, gathered whole, and the determinant written out: the
        # strided view's gathers and np.linalg.det took 76 ms of a 69k-triangle mesh's prepare_gltf)
        linear = np.ascontiguousarray(blend[:, :3, :3]).reshape(-1, 9)
        t = triangles[mixed]
        centre = linear[t[:, 0]] + linear[t[:, 1]] + linear[t[:, 2]]
        a, b, c, d, e, f, g, h, k = centre.T
        mirrored[mixed] = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g) < 0
    if mirrored.any():  # (none: the primitive's indices as they were, its bits too)
        triangles = np.where(mirrored[:, None], triangles[:, ::-1], triangles)
        p["indices"], p["mode"] = r.add(triangles.reshape(-1).astype(np.uint32), "SCALAR"), _TRIANGLES


def _morphed(r: _Rewrite, m: int, weights: tuple[float, ...]) -> int:
    """A copy of mesh ``m`` (its accessors already rewritten) with its morph targets applied at ``weights``:
    each primitive's POSITION and NORMAL plus the weighted sum of its targets' (normals then of length 1),
    as a renderer draws it; the copy's index."""
    mesh = json.loads(json.dumps(r.doc["meshes"][m]))
    for k, p in enumerate(mesh.get("primitives") or []):
        targets = p.pop("targets", None) or []
        attrs = p["attributes"]
        for name in ("POSITION", "NORMAL"):
            moves = [(w, t[name]) for w, t in zip(weights, targets, strict=False) if w and name in t]
            if name not in attrs or not moves:
                continue
            values = r.read(attrs[name]).astype(np.float64)
            for w, t in moves:
                delta = r.read(t)
                if delta.shape != values.shape:
                    raise MeshLoadError(
                        r.path,
                        f"meshes[{m}].primitives[{k}]: a morph target's {name} (accessor {t}) has "
                        f"{delta.shape[0]} elements of width {delta.shape[1]}, the attribute "
                        f"{values.shape[0]} of width {values.shape[1]}",
                    )
                values += w * delta.astype(np.float64)
            if name == "NORMAL":
                length = np.linalg.norm(values, axis=1, keepdims=True)
                values /= np.where(length > 0, length, 1.0)
            attrs[name] = r.add(values.astype(np.float32), "VEC3")
    mesh.pop("weights", None)
    r.doc["meshes"].append(mesh)
    return len(r.doc["meshes"]) - 1


def _camera_over_geometry(node: Any) -> bool:
    """Whether ``node`` holds a camera and a mesh or children: trimesh takes a camera node for the camera
    alone and leaves it out of the scene graph, its mesh dropped and its children with no path to the root
    ("No path from world->3")."""
    return (
        isinstance(node, dict)
        and "camera" in node
        and bool(node.get("mesh") is not None or node.get("children"))
    )


def _instancing(node: Any) -> dict | None:
    """The ``EXT_mesh_gpu_instancing`` object of ``node`` when it places the node's mesh at instances (a
    node with a mesh and an attribute; the extension defines nothing for a node without a mesh, and a node
    without attributes is drawn as a plain node, as three.js draws it), else None."""
    if not isinstance(node, dict) or node.get("mesh") is None:
        return None
    extensions = node.get("extensions")
    ext = extensions.get(INSTANCING) if isinstance(extensions, dict) else None
    return ext if isinstance(ext, dict) and "attributes" in ext and ext["attributes"] != {} else None


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


def _node_name(doc: dict, i: int) -> str:
    name = doc["nodes"][i].get("name")
    return f"node {i}" + (f" ({name[:60]!r})" if isinstance(name, str) else "")


def _instance_matrices(r: _Rewrite, i: int, ext: dict) -> np.ndarray:
    """The (instances, 4, 4) transforms (column vectors: translation x rotation x scale, each optional) of
    node ``i``'s ``EXT_mesh_gpu_instancing`` object ``ext``; a :class:`MeshLoadError` naming the node for an
    attribute that is not an accessor of the type the extension gives it, counts that differ, a value that is
    not finite or a rotation of length 0."""
    doc, where = r.doc, f"{_node_name(r.doc, i)}: its {INSTANCING}"
    attrs, accessors = ext.get("attributes"), doc.get("accessors")
    if not isinstance(attrs, dict):
        raise MeshLoadError(r.path, f"{where} attributes are not an object")
    accessors = accessors if isinstance(accessors, list) else []
    counts = {}
    for name, ref in attrs.items():
        a = accessors[ref] if _index(ref) and ref < len(accessors) else None
        if not isinstance(a, dict):
            raise MeshLoadError(r.path, f"{where} {name} is accessor {ref!r}, the file has {len(accessors)}")
        count = a.get("count")
        if not _index(count):
            raise MeshLoadError(r.path, f"{where} {name} (accessor {ref}) has count {count!r}, not a count")
        counts[name] = count
        if name not in _INSTANCE_ATTRIBUTES:  # (an application's own, "_ID": its count alone is checked)
            continue
        kind, components, normalized = _INSTANCE_ATTRIBUTES[name]
        component = a.get("componentType")
        if (
            a.get("type") != kind
            or component not in components
            or (component in normalized) != (a.get("normalized", False) is True)
        ):
            allowed = " or ".join(
                f"{'normalized ' if c in normalized else ''}{_component(c)}" for c in components
            )
            raise MeshLoadError(
                r.path,
                f"{where} {name} (accessor {ref}) is {_accessor_type(a.get('type'))} of "
                f"{'normalized ' if a.get('normalized') is True else ''}{_component(component)}, "
                f"not {kind} of {allowed}",
            )
    if len(set(counts.values())) > 1:
        shown = ", ".join(f"{name} {n}" for name, n in counts.items())
        raise MeshLoadError(r.path, f"{where} attributes differ in count ({shown}), the extension needs one")
    unread = (_Unread, KeyError, IndexError, TypeError, ValueError, OSError)
    for name in attrs:  # (each count checked against its bytes before anything is allocated for it)
        try:
            r.count(attrs[name])
        except MeshLoadError as e:
            raise MeshLoadError(r.path, f"{where} {name} (accessor {attrs[name]}): {e.problem}") from e
        except unread as e:
            raise MeshLoadError(r.path, f"{where} {name} (accessor {attrs[name]}) {_unread_why(e)}") from e
    n = next(iter(counts.values()), 0)
    try:
        keep = _distinct_instances(r, attrs, n)
    except MeshLoadError as e:
        raise MeshLoadError(r.path, f"{where} sparse indices: {e.problem}") from e
    except unread as e:
        raise MeshLoadError(r.path, f"{where} sparse indices do not read from their bufferView") from e
    values = {}
    for name in attrs:
        if name not in _INSTANCE_ATTRIBUTES:  # (an application's own: its count alone is checked)
            continue
        try:  # (the kept instances alone: an accessor of zeros is not written out for each node reading it)
            v = r.read(attrs[name], rows=keep if "bufferView" not in accessors[attrs[name]] else None)
        except MeshLoadError as e:
            raise MeshLoadError(r.path, f"{where} {name} (accessor {attrs[name]}): {e.problem}") from e
        except unread as e:
            raise MeshLoadError(r.path, f"{where} {name} (accessor {attrs[name]}) {_unread_why(e)}") from e
        if "bufferView" in accessors[attrs[name]]:
            v = v[keep]
        bad = ~np.isfinite(v).all(axis=1)
        if bad.any():
            k = int(np.argmax(bad))
            raise MeshLoadError(
                r.path, f"{where} {name} of instance {int(keep[k])} is {v[k].tolist()}, not finite"
            )
        values[name] = v.astype(np.float64)
    matrices = np.broadcast_to(np.eye(4), (keep.shape[0], 4, 4)).copy()
    if "ROTATION" in values:
        q = values["ROTATION"]
        length = np.linalg.norm(q, axis=1)
        if (length == 0).any():
            k = int(keep[np.argmax(length == 0)])
            raise MeshLoadError(r.path, f"{where} ROTATION of instance {k} is a quaternion of length 0")
        x, y, z, w = (q / length[:, None]).T  # (normalized ints are rounded; a float one may be off too)
        matrices[:, :3, :3] = np.stack(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
            ]
        ).transpose(2, 0, 1)
    if "SCALE" in values:  # (R x S: each column of the rotation scaled)
        matrices[:, :3, :3] *= values["SCALE"][:, None, :]
    if "TRANSLATION" in values:
        matrices[:, :3, 3] = values["TRANSLATION"]
    return matrices


def _unread_why(e: Exception) -> str:
    """Why an instance accessor did not read, as a message's end: its buffer's file (missing, say: named by
    the OSError) or its bufferView."""
    if isinstance(e, OSError):
        return f"does not read: its buffer's file does not read ({type(e).__name__}: {e})"
    return "does not read from its bufferView"


def _distinct_instances(r: _Rewrite, attrs: dict, n: int) -> np.ndarray:
    """The instances (of ``n``) to place: all of them, but when no TRANSLATION, ROTATION or SCALE has a
    bufferView (each one zeros but its sparse values), those at none of the sparse indices are one
    transform: the first of them stands for them all (their copies would be the same triangles, which
    cleaning drops). A 762-byte .gltf's TRANSLATION of 2^24 zeros asked for 5.7 GiB and 95 s before a
    MemoryError."""
    accessors = [r.doc["accessors"][attrs[name]] for name in _INSTANCE_ATTRIBUTES if name in attrs]
    if any("bufferView" in a for a in accessors):
        return np.arange(n)
    sparse = [np.zeros(0, np.int64)]
    for a in accessors:
        if a.get("sparse"):  # (its indices checked against the count by _Rewrite.read, next)
            si = a["sparse"]["indices"]
            idt = np.dtype("<" + _COMPONENT[si["componentType"]])
            where = r._strided(si["bufferView"], si.get("byteOffset", 0), a["sparse"]["count"], idt, 1)
            sparse.append(where[:, 0].astype(np.int64))
    placed = np.unique(np.concatenate(sparse))
    rest = np.setdiff1d(np.arange(min(n, placed.shape[0] + 1)), placed)[:1]  # (the first at no index)
    return np.union1d(placed, rest)


def _index(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


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


#: extensions that compress a glTF's geometry, which trimesh cannot decode (Draco: without DracoPy); their
#: accessors load as zeros ("all triangles are degenerate")
_UNDECODED = ("EXT_meshopt_compression", "KHR_meshopt_compression", "KHR_draco_mesh_compression")


#: the extensions a file may require that this loader reads (instancing: the rewrite; quantization: integer
#: accessors, normalized ones rewritten) or may leave aside, being about what it does not load (materials,
#: textures and their images, lights, animation, metadata and feature ids, outlines: the triangles are the
#: same without them, and main drew such files); glTF 2.0's loaders must refuse a file requiring any other
_KNOWN_REQUIRED = frozenset(
    (
        INSTANCING,
        "KHR_mesh_quantization",
        "KHR_lights_punctual",
        "EXT_lights_image_based",
        "KHR_xmp_json_ld",
        "KHR_animation_pointer",
        "EXT_structural_metadata",
        "EXT_mesh_features",
        "EXT_instance_features",
        "CESIUM_primitive_outline",
    )
)
#: families of the same kind: materials, texture formats and transforms, packed material textures
_KNOWN_PREFIXES = (
    "KHR_materials_",
    "KHR_texture_",
    "EXT_texture_",
    "MSFT_texture_",
    "MSFT_packing_",
    "ADOBE_materials_",
)


def _check_extensions(path: Path, doc: Any) -> None:
    """Raise a :class:`MeshLoadError` when the document requires a geometry compression trimesh cannot
    decode here, or an extension this loader neither reads nor may leave aside (trimesh read any, with
    what it changes ignored)."""
    import importlib.util

    required = doc.get("extensionsRequired") if isinstance(doc, dict) else None
    for name in required if isinstance(required, list) else []:
        if name not in _UNDECODED:
            if isinstance(name, str) and (name in _KNOWN_REQUIRED or name.startswith(_KNOWN_PREFIXES)):
                continue
            shown = repr(name[:80]) if isinstance(name, str) else f"{name!r:.80}"
            raise MeshLoadError(
                path,
                f"it requires the glTF extension {shown} (extensionsRequired), which this loader does not "
                "read: export it without that extension",
                code="INPUT_UNSUPPORTED",
            )
        if name == "KHR_draco_mesh_compression" and importlib.util.find_spec("DracoPy") is not None:
            continue
        hint = " (pip install DracoPy)" if name == "KHR_draco_mesh_compression" else ""
        raise MeshLoadError(
            path,
            f"its geometry is compressed with the glTF extension {name}, which this loader cannot decode"
            f"{hint}: export it without that compression",
            code="INPUT_UNSUPPORTED",
        )


def _check_counts(path: Path, doc: Any) -> None:
    """Raise a :class:`MeshLoadError` for an accessor without a ``bufferView`` of more than
    :data:`_ZEROS_MAX` elements: trimesh allocates its zeros from the count alone (an 871-byte file's count
    of 10^9 asked for 11.2 GiB, one of 2^53 for 96 PiB), as the rewrite here would
    (:meth:`_Rewrite.count`)."""
    accessors = doc.get("accessors") if isinstance(doc, dict) else None
    for i, a in enumerate(accessors if isinstance(accessors, list) else []):
        count = a.get("count") if isinstance(a, dict) and "bufferView" not in a else None
        if isinstance(count, int) and not isinstance(count, bool) and count > _ZEROS_MAX:
            raise MeshLoadError(
                path, f"accessor {i} has no bufferView and {count} elements (more than {_ZEROS_MAX})"
            )


def _check_document(path: Path, doc: Any) -> None:
    """The checks of the JSON alone, before any buffer is read: the extensions required, the counts, the
    ``normalized`` flags and the instanced skinned nodes."""
    _check_extensions(path, doc)
    _check_counts(path, doc)
    _check_normalized(path, doc)
    _check_instanced_skins(path, doc)


def _instanced_skin(node: Any) -> bool:
    """Whether ``node`` has both a ``skin`` and ``EXT_mesh_gpu_instancing`` instances (refused:
    :func:`_check_instanced_skins`)."""
    return _instancing(node) is not None and "skin" in node


def _check_normalized(path: Path, doc: Any) -> None:
    """Raise a :class:`MeshLoadError` naming the first accessor whose ``normalized`` is not a JSON boolean,
    which glTF 2.0 says it is: read as a truth value, the string ``"false"`` was normalized and ``0`` was
    not, each a guess at what the file means."""
    accessors = doc.get("accessors") if isinstance(doc, dict) else None
    for i, a in enumerate(accessors if isinstance(accessors, list) else []):
        value = a.get("normalized", False) if isinstance(a, dict) else False
        if not isinstance(value, bool):
            raise MeshLoadError(path, f"accessor {i} has normalized {value!r:.40}, not true or false")


def _check_instanced_skins(path: Path, doc: Any) -> None:
    """Raise a :class:`MeshLoadError` (``INPUT_UNSUPPORTED``) naming the first node that has both a ``skin``
    and ``EXT_mesh_gpu_instancing`` instances: the extension places the mesh by the node's world transform x
    each instance's, which skinning ignores (the joints place the mesh), and says nothing of the two
    together (KhronosGroup/glTF#2404 proposed that such a node should not be written; three.js draws no
    such node): drawn as an instanced node, its skin left aside, it was neither."""
    nodes = doc.get("nodes") if isinstance(doc, dict) else None
    for i, node in enumerate(nodes if isinstance(nodes, list) else []):
        if _instanced_skin(node):
            raise MeshLoadError(
                path,
                f"{_node_name(doc, i)} has both a skin and {INSTANCING} instances, which the extension does "
                "not define (skinning ignores the node's transform the instances are placed by): export the "
                "instances as nodes, or the mesh without its skin",
                code="INPUT_UNSUPPORTED",
            )


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


def check_glb_json(path: Path) -> None:
    """Run the checks of the JSON alone (:func:`_check_document`) on the .glb ``path``'s JSON chunk, read
    alone, when it is whole and parses (nothing otherwise): asked before the loader refuses a later chunk
    that declares more bytes than follow it, so a JSON that fails a check is refused for it, as it is when
    the file is whole (it was refused as a cut chunk, its JSON never looked at)."""
    try:
        doc = _json_document(path, whole=True)  # (a cut JSON chunk, even one that parses: the chunk's error)
    except _UNREAD:
        return
    _check_document(path, doc)  # (each check names the file)


def _count(value: Any) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) and value >= 0 else None


def gltf_triangle_count(path: Path) -> int | None:
    """The triangles the .gltf or .glb file ``path`` declares, read from its JSON alone (no buffer): each
    node of its scene (as trimesh loads it: the ``scene``, else the first; every root node when there is
    none) with a mesh counts that mesh's triangles (a primitive's ``indices`` count / 3, or its
    ``POSITION`` count / 3; strips and fans: count - 2; points and lines none), times its
    ``EXT_mesh_gpu_instancing`` instances. A node with instances and a skin counts none: the load refuses
    it (:func:`_check_instanced_skins`), which its instances, counted, pre-empted with a budget error. None
    when the document does not read (the load then says why)."""
    try:
        doc = _json_document(path)
    except (_Unread, OSError, ValueError, RecursionError):
        return None
    if not isinstance(doc, dict):
        return None
    lists = [doc.get(k) for k in ("accessors", "meshes", "nodes", "scenes")]
    accessors, meshes, nodes, scenes = (x if isinstance(x, list) else [] for x in lists)

    def accessor_count(ref: Any) -> int:
        a = accessors[ref] if _count(ref) is not None and ref < len(accessors) else None
        return (_count(a.get("count")) or 0) if isinstance(a, dict) else 0

    def instances(node: Any) -> int:
        """How many times the node's mesh is placed: its instances' count (the most its attributes give)."""
        ext = _instancing(node)
        attrs = ext.get("attributes") if ext is not None else None
        if not isinstance(attrs, dict):
            return 1
        return max((accessor_count(ref) for ref in attrs.values()), default=1)

    per_mesh = []
    for mesh in meshes:
        n = 0
        primitives = mesh.get("primitives") if isinstance(mesh, dict) else None
        for prim in primitives if isinstance(primitives, list) else []:
            if not isinstance(prim, dict):
                continue
            attrs = prim.get("attributes")
            position = attrs.get("POSITION") if isinstance(attrs, dict) else None
            if isinstance(attrs, dict) and position is None:  # (not drawn: the rewrite leaves it out)
                continue
            count = accessor_count(prim["indices"] if "indices" in prim else position)
            mode = prim.get("mode", _TRIANGLES)
            n += count // 3 if mode == _TRIANGLES else max(count - 2, 0) if mode in (5, _TRIANGLE_FAN) else 0
        per_mesh.append(n)

    def children(node: Any) -> list:
        c = node.get("children") if isinstance(node, dict) else None
        return [i for i in c if _count(i) is not None and i < len(nodes)] if isinstance(c, list) else []

    if scenes:
        at = doc.get("scene", 0)
        scene = scenes[at] if _count(at) is not None and at < len(scenes) else None
        roots = children({"children": scene.get("nodes")} if isinstance(scene, dict) else None)
    else:
        below = {c for n in nodes for c in children(n)}
        roots = [i for i in range(len(nodes)) if i not in below]
        if not nodes:  # (meshes and no node: each mesh once, as the rewrite places them)
            return sum(per_mesh)
    seen, stack, total = set(roots), list(roots), 0  # (a node once, however many parents: as trimesh)
    while stack:
        node = nodes[stack.pop()]
        m = node.get("mesh") if isinstance(node, dict) and not _instanced_skin(node) else None
        total += per_mesh[m] * instances(node) if _count(m) is not None and m < len(per_mesh) else 0
        for c in children(node):
            if c not in seen:
                seen.add(c)
                stack.append(c)
    return total


#: what a rewrite of a document whose structure it does not read raises
_UNREAD = (_Unread, OSError, ValueError, KeyError, IndexError, TypeError, AttributeError, RecursionError)


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
