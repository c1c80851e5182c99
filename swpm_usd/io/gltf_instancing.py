"""glTF 2.0's ``EXT_mesh_gpu_instancing``: which node places its mesh at instances, and their transforms.

trimesh reads an instanced node as one copy of its mesh; :mod:`.gltf_prepare`'s rewrite marks the node
(:data:`INSTANCES_KEY`) and returns its (instances, 4, 4) transforms (:func:`_instance_matrices`), which the
loader applies (:mod:`.trimesh_scene`). The extension's accessor types are read and no other: TRANSLATION
and SCALE VEC3 of FLOAT, ROTATION VEC4 of FLOAT or of normalized BYTE or SHORT. Separate from the rewrite:
one extension, its checks and its matrices.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import MeshLoadError
from .gltf_read import _COMPONENT, _FLOAT, _accessor_type, _component, _index, _Rewrite, _Unread

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


def _instancing(node: Any) -> dict | None:
    """The ``EXT_mesh_gpu_instancing`` object of ``node`` when it places the node's mesh at instances (a
    node with a mesh and an attribute; the extension defines nothing for a node without a mesh, and a node
    without attributes is drawn as a plain node, as three.js draws it), else None."""
    if not isinstance(node, dict) or node.get("mesh") is None:
        return None
    extensions = node.get("extensions")
    ext = extensions.get(INSTANCING) if isinstance(extensions, dict) else None
    return ext if isinstance(ext, dict) and "attributes" in ext and ext["attributes"] != {} else None


def _instanced_skin(node: Any) -> bool:
    """Whether ``node`` has both a ``skin`` and ``EXT_mesh_gpu_instancing`` instances (refused:
    :func:`.gltf_json._check_instanced_skins`)."""
    return _instancing(node) is not None and "skin" in node


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
