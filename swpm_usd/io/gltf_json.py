"""What a glTF 2.0 file's JSON alone says, before any buffer is read: the checks that refuse a file, and the
triangles it declares.

:func:`_check_document` refuses an extension required that the loader neither reads nor may leave aside
(or a geometry compression it cannot decode), an accessor of zeros too large to allocate, a ``normalized``
that is not a boolean and an instanced skinned node; :func:`check_glb_json` runs them on a .glb's JSON
chunk alone. :func:`gltf_triangle_count` counts a dry run's triangles from the JSON. Separate from
:mod:`.gltf_prepare`'s rewrite: none of this reads a buffer.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import MeshLoadError
from .gltf_instancing import INSTANCING, _instanced_skin, _instancing, _node_name
from .gltf_read import _TRIANGLE_FAN, _TRIANGLES, _UNREAD, _ZEROS_MAX, _json_document, _Unread

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


def _check_document(path: Path, doc: Any) -> None:
    """The checks of the JSON alone, before any buffer is read: the extensions required, the counts, the
    ``normalized`` flags and the instanced skinned nodes."""
    _check_extensions(path, doc)
    _check_counts(path, doc)
    _check_normalized(path, doc)
    _check_instanced_skins(path, doc)


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
    (:meth:`.gltf_read._Rewrite.count`)."""
    accessors = doc.get("accessors") if isinstance(doc, dict) else None
    for i, a in enumerate(accessors if isinstance(accessors, list) else []):
        count = a.get("count") if isinstance(a, dict) and "bufferView" not in a else None
        if isinstance(count, int) and not isinstance(count, bool) and count > _ZEROS_MAX:
            raise MeshLoadError(
                path, f"accessor {i} has no bufferView and {count} elements (more than {_ZEROS_MAX})"
            )


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
