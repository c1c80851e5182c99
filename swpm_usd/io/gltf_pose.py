"""glTF 2.0's skins and morph targets, which trimesh ignores: a mesh's posed copy, as a renderer draws it.

A morphed mesh is drawn at its weights (:func:`_morph_weights`, :func:`_morphed`); a skinned one posed by
its joints at the file's node transforms (:func:`_skinned`: positions by the blend of each joint's world
transform x inverse bind matrix, normals by its inverse transpose, :func:`_posed_normals`), each triangle
the skin mirrors wound the other way (:func:`_wind_as_posed`). Separate from :mod:`.gltf_prepare`'s
rewrite, which calls these for each node, because the posing is its own piece of geometry.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from ..errors import MeshLoadError
from .gltf_instancing import _instancing
from .gltf_read import (
    _FLOAT,
    _TRIANGLE_STRIP,
    _TRIANGLES,
    _accessor_type,
    _component,
    _index,
    _Rewrite,
    _Unread,
)


def _skinned_node(node: Any) -> bool:
    """Whether ``node`` draws its mesh with a skin (not an instanced node's: its instances are placed in
    the node's frame, which skinning leaves aside; :func:`.gltf_prepare.prepare_gltf` refuses such a node)."""
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
    for any primitive. Fans are triangle lists by now (:func:`.gltf_prepare._rewrite`)."""
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
