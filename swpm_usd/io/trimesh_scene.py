"""What the loader takes from the scene trimesh read: each triangle geometry's points, triangles and
per-vertex normals, uvs and colours (:func:`_geometry_part`, face colours split onto their corners), each
geometry node's transform from the scene's base frame computed in one pass down the tree
(:func:`_geometry_transforms`), and the ``EXT_mesh_gpu_instancing`` instances of the nodes the glTF rewrite
marked (:func:`_node_instances`). trimesh itself is imported here only inside the functions, which run once a
file has been read by it."""

from __future__ import annotations

from typing import Any

import numpy as np

from .clean import rgba_float, split_corners
from .gltf_prepare import INSTANCES_KEY, INSTANCING


def _geometry_part(
    geom: object, off_colours: tuple[np.ndarray | None, np.ndarray | None] | None = None
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]] | None:
    """One geometry's (points, triangles, attributes); ``off_colours``: the vertex and triangle colours of
    the OFF file it was read from, which trimesh's OFF reader drops (:func:`.off._off_colours`)."""
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
