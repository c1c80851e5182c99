"""Validation and cleaning of raw triangle arrays into a :class:`~swpm_usd.mesh.Mesh` (numpy, vectorised).

Every loader (and ``Mesh.from_arrays``) ends in :func:`clean_mesh`, which

* rejects what cannot be a triangle mesh (no triangles, non-finite points or attributes, out-of-range indices,
  wrong shapes) with a :class:`~swpm_usd.errors.MeshLoadError` naming the source;
* welds vertices that are identical in position *and* every attribute (byte equality after the cast to the
  stored dtype), so duplicated positions at patch seams merge while UV / normal seams stay split;
* drops degenerate triangles (two corners at the same position), duplicate triangles (the same vertex set in
  any order, including the opposite winding; the first one is kept) and unreferenced vertices,

keeping the original relative order of vertices and triangles. What was dropped is counted in ``Mesh.stats``.

Helpers shared by the loaders live here too: :func:`split_corners` for per-corner (face-varying) attributes
turns each face corner into a (point, attribute values) pair and merges identical pairs, so only real seams
split a point; :func:`rgba_float`, :func:`transform_part` and :func:`concatenate_parts`.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..errors import MeshLoadError
from ..mesh import Mesh

_MAX_INDEX = np.iinfo(np.int32).max

Part = tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]
"""A loader's piece of mesh: (points (V, 3), triangles (T, 3), attributes name -> (V, k))."""


def _row_bytes(a: np.ndarray) -> np.ndarray:
    """View a 2-D array as (N, row_bytes) uint8 (copies only if it is not C-contiguous)."""
    a = np.ascontiguousarray(a)
    width = a.dtype.itemsize * int(np.prod(a.shape[1:], dtype=np.int64))
    return a.view(np.uint8).reshape(a.shape[0], width)


def group_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Group identical rows (byte equality) of a 2-D array, numbering groups by first occurrence.

    Returns ``(first, ids)``: ``first[g]`` is the row index where group ``g`` first occurs (increasing), and
    ``ids[i]`` the group of row ``i``; so ``rows[first][ids]`` equals ``rows`` and group order follows the
    original row order.
    """
    b = _row_bytes(rows)
    n, width = b.shape
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    if width == 0:
        return np.zeros(1, dtype=np.int64), np.zeros(n, dtype=np.int64)
    key = b.view(np.dtype((np.void, width))).reshape(n)
    _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.shape[0], dtype=order.dtype)
    return first[order].astype(np.int64, copy=False), rank[inverse.reshape(n)].astype(np.int64, copy=False)


def _positive_zero(a: np.ndarray) -> np.ndarray:
    """Turn -0.0 into +0.0 in a float array (so byte equality matches value equality for finite values)."""
    if a.dtype.kind == "f":
        a = a + a.dtype.type(0.0)
    return a


def split_corners(
    corner_point: np.ndarray, corner_attributes: Mapping[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Make one vertex per distinct (point index, per-corner attribute values) pair.

    ``corner_point``: (T, 3) point index of every triangle corner. ``corner_attributes``: name -> (3T, k)
    values per corner, in ``corner_point.reshape(-1)`` order. Returns ``(vertex_point, triangles, attrs)``:
    ``vertex_point`` (N,) is the point each new vertex comes from (gather per-point data with it),
    ``triangles`` (T, 3) the new vertex indices and ``attrs`` name -> (N, k) the per-corner values of each new
    vertex. Corners of one point with identical attribute bytes share a vertex, so only real seams split.
    """
    cp = np.asarray(corner_point, dtype=np.int64)
    t = cp.shape[0]
    flat = cp.reshape(-1)
    cols = [_row_bytes(flat[:, None])]
    vals: dict[str, np.ndarray] = {}
    for name, a in corner_attributes.items():
        a = _positive_zero(np.asarray(a))
        a = a.reshape(flat.shape[0], -1)
        vals[name] = a
        cols.append(_row_bytes(a))
    first, ids = group_rows(np.concatenate(cols, axis=1))
    return flat[first], ids.reshape(t, 3), {name: a[first] for name, a in vals.items()}


def _as_points(points: np.ndarray, source: str | None) -> np.ndarray:
    try:
        raw = np.asarray(points)
    except Exception as e:  # e.g. ragged nested sequences
        raise MeshLoadError(source, f"points are not an array: {e}") from e
    if raw.ndim != 2 or raw.shape[1] != 3:
        raise MeshLoadError(source, f"points must have shape (V, 3), got {raw.shape}")
    if raw.dtype.kind not in "iuf":
        raise MeshLoadError(source, f"points must be numbers, got dtype {raw.dtype}")
    if raw.shape[0] > _MAX_INDEX:
        raise MeshLoadError(
            source,
            f"{raw.shape[0]} points is more than int32 triangle indices can address",
            code="INPUT_TOO_LARGE",
        )
    with np.errstate(over="ignore", invalid="ignore"):
        pts = raw.astype(np.float32)
    bad = ~np.isfinite(pts).all(axis=1)
    nbad = int(np.count_nonzero(bad))
    if nbad:
        first = int(np.argmax(bad))
        raise MeshLoadError(
            source,
            f"{nbad} of {pts.shape[0]} points have NaN/inf (or float32-overflowing) coordinates "
            f"(first: point {first})",
        )
    return _positive_zero(pts)


def _as_triangles(triangles: np.ndarray, n_points: int, source: str | None) -> np.ndarray:
    try:
        tri = np.asarray(triangles)
    except Exception as e:
        raise MeshLoadError(source, f"triangles are not an array: {e}") from e
    if tri.size == 0:
        raise MeshLoadError(source, "mesh has no triangles", code="INPUT_EMPTY")
    if tri.ndim != 2 or tri.shape[1] != 3:
        raise MeshLoadError(source, f"triangles must have shape (T, 3), got {tri.shape}")
    if tri.dtype.kind not in "iu":
        raise MeshLoadError(source, f"triangle indices must be integers, got dtype {tri.dtype}")
    lo, hi = tri.min(), tri.max()
    if lo < 0 or hi >= n_points:
        bad = (tri < 0) | (tri >= n_points)
        flat = int(np.argmax(bad.reshape(-1)))
        value = int(tri.reshape(-1)[flat])
        raise MeshLoadError(
            source,
            f"triangle {flat // 3} has vertex index {value} out of range for {n_points} vertices "
            f"({int(np.count_nonzero(bad))} bad indices in all)",
        )
    return tri.astype(np.int32, copy=False)


def _as_attributes(
    attributes: Mapping[str, np.ndarray], n_points: int, source: str | None
) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for name, a in dict(attributes).items():
        try:
            a = np.asarray(a)
        except Exception as e:
            raise MeshLoadError(source, f"attribute {name!r} is not an array: {e}") from e
        if a.ndim == 1:
            a = a[:, None]
        if a.ndim != 2:
            raise MeshLoadError(source, f"attribute {name!r} must be (V,) or (V, k), got shape {a.shape}")
        if a.shape[0] != n_points:
            raise MeshLoadError(source, f"attribute {name!r} has {a.shape[0]} rows for {n_points} points")
        if a.dtype.kind not in "iuf":
            raise MeshLoadError(source, f"attribute {name!r} must be numbers, got dtype {a.dtype}")
        if a.dtype.kind == "f":
            with np.errstate(over="ignore", invalid="ignore"):
                a = a.astype(np.float32, copy=False)
            bad = ~np.isfinite(a).all(axis=1)
            nbad = int(np.count_nonzero(bad))
            if nbad:
                raise MeshLoadError(
                    source,
                    f"attribute {name!r} has NaN/inf values on {nbad} of {n_points} vertices "
                    f"(first: vertex {int(np.argmax(bad))})",
                )
            a = _positive_zero(a)
        out[name] = a
    return out


def clean_mesh(
    points: np.ndarray,
    triangles: np.ndarray,
    attributes: Mapping[str, np.ndarray] | None,
    source: str | Path | None,
) -> Mesh:
    """Validate raw arrays and return a cleaned :class:`Mesh`.

    ``points`` (V, 3) numbers (stored as float32), ``triangles`` (T, 3) integer indices, ``attributes``
    name -> (V,) or (V, k) numbers (floating ones stored as float32, others as given). Raises
    :class:`MeshLoadError` (naming ``source``) for an empty triangle list, wrong shapes or dtypes, NaN/inf in
    points or attributes, and indices outside ``[0, V)``.

    Cleaning: vertices equal in position and every attribute are merged (``vertices_merged``); triangles with
    two corners at one position (``degenerate_dropped``) and repeats of an earlier triangle's vertex set, in
    either winding (``duplicate_dropped``), are dropped; then vertices no triangle uses
    (``unreferenced_dropped``). Relative order of the surviving vertices and triangles is kept.
    """
    src = None if source is None else str(source)
    pts = _as_points(points, src)
    n = pts.shape[0]
    tri = _as_triangles(triangles, n, src)
    attrs = _as_attributes(attributes or {}, n, src)

    # 1. weld vertices identical in position and in every attribute
    pos_first, pos_id = group_rows(pts)
    if attrs:
        key = np.concatenate([_row_bytes(pos_id[:, None])] + [_row_bytes(a) for a in attrs.values()], axis=1)
        keep_v, remap = group_rows(key)
        del key
    else:
        keep_v, remap = pos_first, pos_id
    vertices_merged = n - keep_v.shape[0]

    # 2. degenerate triangles: two corners at the same position (covers equal indices after the weld)
    pid = pos_id[tri]
    degenerate = (pid[:, 0] == pid[:, 1]) | (pid[:, 1] == pid[:, 2]) | (pid[:, 0] == pid[:, 2])
    del pid
    merged_tri = remap[tri]
    good = np.flatnonzero(~degenerate)

    # 3. duplicates: same vertex set in any order (either winding); keep the first
    first_dup, _ = group_rows(np.sort(merged_tri[good], axis=1))
    kept_tri = good[first_dup]
    duplicate_dropped = good.shape[0] - kept_tri.shape[0]
    if kept_tri.shape[0] == 0:
        raise MeshLoadError(src, f"all {tri.shape[0]} triangles are degenerate (no area)", code="INPUT_EMPTY")
    new_tri = merged_tri[kept_tri]
    del merged_tri

    # 4. drop unreferenced (merged) vertices, keeping order
    used = np.zeros(keep_v.shape[0], dtype=bool)
    used[new_tri] = True
    compact = np.cumsum(used) - 1
    sel = keep_v[used]
    new_tri = compact[new_tri].astype(np.int32)

    stats = {
        "degenerate_dropped": int(np.count_nonzero(degenerate)),
        "duplicate_dropped": int(duplicate_dropped),
        "unreferenced_dropped": int(keep_v.shape[0] - sel.shape[0]),
        "vertices_merged": int(vertices_merged),
    }
    return Mesh(
        points=pts[sel],
        triangles=new_tri,
        attributes={name: a[sel] for name, a in attrs.items()},
        source=src,
        stats=stats,
    )


def rgba_float(colors: np.ndarray) -> np.ndarray:
    """Colors as (N, 4) float32 in [0, 1]: integers are scaled by their dtype's maximum, RGB gets alpha 1."""
    c = np.asarray(colors)
    if c.ndim == 1:
        c = c[:, None]
    if c.dtype.kind in "iu":
        c = c.astype(np.float32) / np.float32(np.iinfo(c.dtype).max)
    else:
        c = c.astype(np.float32)
    if c.shape[1] == 1:
        c = np.repeat(c, 3, axis=1)
    if c.shape[1] == 3:
        c = np.concatenate([c, np.ones((c.shape[0], 1), dtype=np.float32)], axis=1)
    if c.shape[1] != 4:
        raise ValueError(f"colors must have 1, 3 or 4 channels, got {c.shape[1]}")
    return np.clip(c, 0.0, 1.0)


def concatenate_parts(parts: list[Part], path: Path | str) -> Part:
    """Concatenate (points, triangles, attributes) parts, keeping only attributes every part has."""
    names = set(parts[0][2])
    for _, _, attrs in parts[1:]:
        names &= set(attrs)
    dropped = sorted({n for _, _, attrs in parts for n in attrs} - names)
    if dropped:
        warnings.warn(
            f"{path}: attributes {dropped} are missing on some of its {len(parts)} meshes; dropped",
            stacklevel=3,
        )
    offsets = np.cumsum([0] + [p.shape[0] for p, _, _ in parts[:-1]])
    points = np.concatenate([p for p, _, _ in parts], axis=0)
    triangles = np.concatenate([t.astype(np.int64) + o for (_, t, _), o in zip(parts, offsets, strict=True)])
    attrs = {n: np.concatenate([a[n] for _, _, a in parts], axis=0) for n in sorted(names)}
    return points, triangles, attrs


def transform_part(part: Part, matrix: np.ndarray) -> Part:
    """Apply a 4x4 column-vector transform (trimesh convention) to points and ``normal``; a mirroring
    transform also flips the winding so front faces stay front faces."""
    m = np.asarray(matrix, dtype=np.float64)
    if np.array_equal(m, np.eye(4)):
        return part
    points, triangles, attrs = part
    lin = m[:3, :3]
    points = points.astype(np.float64) @ lin.T + m[:3, 3]
    attrs = dict(attrs)
    if "normal" in attrs:
        # normals take the inverse transpose (row vectors: n @ inv(lin)); pinv keeps a collapsed axis finite
        inverse = np.linalg.inv(lin) if np.linalg.det(lin) != 0 else np.linalg.pinv(lin)
        n = attrs["normal"].astype(np.float64) @ inverse
        length = np.linalg.norm(n, axis=1, keepdims=True)
        attrs["normal"] = (n / np.where(length > 0, length, 1.0)).astype(np.float32)
    if np.linalg.det(lin) < 0:
        triangles = triangles[:, ::-1]
    return points, triangles, attrs


def transform_instances(part: Part, matrix: np.ndarray, instances: np.ndarray) -> Part:
    """The part placed at each of ``instances`` ((N, 4, 4) transforms, column vectors) and then by
    ``matrix`` (its node's transform: ``matrix @ instance``), the copies concatenated in the instances'
    order; each copy is :func:`transform_part`'s, computed for all of them at once (a mirroring instance's
    copy flips its winding)."""
    points, triangles, attrs = part
    m = np.asarray(matrix, dtype=np.float64) @ np.asarray(instances, dtype=np.float64)
    n, v = m.shape[0], points.shape[0]
    lin = m[:, :3, :3]
    placed = points.astype(np.float64)[None] @ lin.transpose(0, 2, 1) + m[:, None, :3, 3]
    out = {name: np.tile(a, (n,) + (1,) * (a.ndim - 1)) for name, a in attrs.items()}
    det = np.linalg.det(lin)
    if "normal" in attrs:
        # the inverse transpose of each (row vectors: n @ inv(lin)); pinv keeps a collapsed axis finite
        inverse = np.empty_like(lin)
        regular = det != 0
        inverse[regular] = np.linalg.inv(lin[regular])
        inverse[~regular] = np.linalg.pinv(lin[~regular]) if (~regular).any() else inverse[~regular]
        normals = attrs["normal"].astype(np.float64)[None] @ inverse
        length = np.linalg.norm(normals, axis=2, keepdims=True)
        out["normal"] = (normals / np.where(length > 0, length, 1.0)).astype(np.float32).reshape(n * v, 3)
    copies = np.broadcast_to(triangles, (n, *triangles.shape))
    copies = np.where((det < 0)[:, None, None], copies[:, :, ::-1], copies)
    copies = copies + (np.arange(n, dtype=triangles.dtype) * v)[:, None, None]
    return placed.reshape(n * v, 3), copies.reshape(-1, 3), out
