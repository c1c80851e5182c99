"""Non-destructive encoding of an existing stage: a layer that sublayers (or references) the source and
overrides each Mesh prim with SwpmMeshAPI, points in LOD order, LOD-0 topology and re-indexed primvars.

Per Mesh prim (in its local space, at its earliest time sample, the default where it has none: the time
the loader reads): faces are fan-triangulated (hole faces left out, so
the override authors no ``holeIndices``); vertices are the distinct (point, faceVarying values, uniform
normals/st/displayColor values) combinations, so seams split points only where needed; degenerate triangles
are dropped. Primvars are re-indexed consistently: ``vertex`` / ``varying`` ones follow the points;
``faceVarying`` ones (and uniform normals / st / displayColor) become ``vertex`` primvars on the split points;
other ``uniform`` ones follow the LOD-0 triangles; ``constant`` ones are untouched; indexed primvars are
written flattened (their indices blocked). A source encoded before keeps no ``swpm:`` value the new encoding
does not author (another encoding's buffers, ``swpm:discreteLods``): they are blocked. Face GeomSubsets get
the LOD-0 triangles of their faces, point GeomSubsets the new vertices of their points, edge GeomSubsets
(pairs of point indices) the LOD-0 triangle edges between the new vertices of their points (an edge no kept
face has is left out), at every time sample of their indices. Instanced meshes (inside prototypes) are
skipped (USD ignores overrides of them); a source with no Mesh prim to encode is an error that says why.
``velocities`` and ``accelerations`` follow the points as ``vertex`` primvars do. A mesh's ``normals``
attribute is re-indexed beside ``primvars:normals`` (which USD uses when both are authored; a uniform
``normals`` attribute then stays uniform). Time-sampled points, normals, primvars and subset indices (a
deforming mesh) are re-indexed at every sample of the source, the extent computed at each sample of the
points: an override's default alone would be stronger than the source's samples and stop the animation. A
blocked sample stays blocked. Topology that changes over time cannot be re-indexed: an error.
The source files are never written.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from pxr import Sdf, Tf, Usd, UsdGeom, Vt

from ..build import build
from ..encode.base import ProgressiveMesh, with_attributes
from ..errors import SwpmError, first_few, tf_message
from ..fileio import fill_layer_replacing
from ..io.usd_loader import _all_holes, _Invalid, _Topology
from ..mesh import Mesh
from .writer import LayerReloadError, author_swpm

_PROV = "_swpm_source_vertex"
#: the time the source is read at (a mesh's earliest time sample, else its default value: as the loader reads)
_TIME = Usd.TimeCode.EarliestTime()
_PM_NAMES = {"normals": "normal", "st": "uv", "displayColor": "color"}
#: the internal name of a mesh's ``normals`` attribute when ``primvars:normals`` (which USD uses) is beside it
_SHADOWED_NORMALS = "normals attribute"
#: the source stage's metadata the override layer (the stage's new root layer) takes, where the source
#: authors it: its units and its timing (the time samples re-authored are in its time codes)
_STAGE_METADATA = (
    "upAxis",
    "metersPerUnit",
    "timeCodesPerSecond",
    "framesPerSecond",
    "startTimeCode",
    "endTimeCode",
)


class UsdOverrideError(SwpmError):
    """A source stage or prim cannot be encoded in place."""

    code = "OUTPUT_UNSUPPORTED"


class _Primvar:
    def __init__(
        self, name: str, values: np.ndarray, interp: str, pv: UsdGeom.Primvar | None, attr: Usd.Attribute
    ):
        self.name, self.interp, self.pv, self.attr = name, interp, pv, attr
        self.values = values  # (n_elements, ...) flattened values, one row per element
        self.rows = values.reshape(values.shape[0], -1)

    def times(self) -> list[float]:
        """The source's time samples of the values (and of an indexed primvar's indices)."""
        return list(self.pv.GetTimeSamples() if self.pv is not None else self.attr.GetTimeSamples())

    def rows_at(self, time: float) -> np.ndarray | None:
        """The rows at time sample ``time`` (as :attr:`rows`), None where the sample is blocked (it stays
        blocked); an error unless there are as many."""
        value = self.attr.Get(time)
        if value is None:  # (a value block: "0 values at time t" before)
            return None
        flat = self.pv.ComputeFlattened(time) if self.pv is not None else value
        a = np.asarray(flat if flat is not None else [])
        es = max(self.pv.GetElementSize(), 1) if self.pv is not None else 1
        rows = a.reshape(a.shape[0] // es, -1) if a.size else a.reshape(0, self.rows.shape[1])
        if rows.shape != self.rows.shape:
            raise UsdOverrideError(
                f"{self.attr.GetPath()}: {rows.shape[0]} values at time {time}, {self.rows.shape[0]} at "
                "its first: values that change in number over time cannot be re-indexed"
            )
        return rows


def _first_value(get: Callable[[Any], Any], attr: Usd.Attribute) -> Any:
    """``get(time)`` at the time the loader reads (:data:`_TIME`), else at the first of ``attr``'s time
    samples that is not blocked; None when every one is (or there is no value)."""
    value = get(_TIME)
    for t in attr.GetTimeSamples() if value is None else ():
        value = get(t)
        if value is not None:
            break
    return value


def _primvars(prim: Usd.Prim, topo: _Topology) -> list[_Primvar]:
    mesh = UsdGeom.Mesh(prim)
    out = []
    api = UsdGeom.PrimvarsAPI(prim)
    for pv in api.GetPrimvarsWithValues():
        # (its first sample blocked: read at the first it has, every sample re-indexed, the blocked kept)
        flat = _first_value(pv.ComputeFlattened, pv.GetAttr())
        if flat is None:
            continue
        a = np.asarray(flat)
        es = max(pv.GetElementSize(), 1)
        a = a.reshape(a.shape[0] // es, es, *a.shape[1:]) if es > 1 else a
        out.append(_Primvar(str(pv.GetPrimvarName()), a, str(pv.GetInterpolation()), pv, pv.GetAttr()))
    normals = mesh.GetNormalsAttr()
    value = _first_value(normals.Get, normals) if normals.HasValue() else None
    if value is not None:
        # primvars:normals, when authored, is what USD draws (UsdGeomPointBased: it wins over normals); the
        # normals attribute beside it is re-indexed all the same (left in the source's order, of another
        # length than the new points, it was invalid), by its own interpolation: a faceVarying one splits
        # points as a primvar does, a uniform one stays uniform (it follows the LOD-0 triangles)
        name = _SHADOWED_NORMALS if any(p.name == "normals" for p in out) else "normals"
        out.append(_Primvar(name, np.asarray(value), str(mesh.GetNormalsInterpolation()), None, normals))
    # per-point motion (a deforming mesh's, for motion blur): re-indexed with the points, not left in the
    # source's order beside them (one of another length than the points is not per point: left alone)
    for attr in (mesh.GetVelocitiesAttr(), mesh.GetAccelerationsAttr()):
        value = _first_value(attr.Get, attr) if attr.HasValue() else None
        if value is not None and len(value) == topo.n_points:
            out.append(_Primvar(attr.GetName(), np.asarray(value), UsdGeom.Tokens.vertex, None, attr))
    return out


def _corner_rows(p: _Primvar, topo: _Topology, rows: np.ndarray | None = None) -> np.ndarray:
    """Values of ``p`` (its ``rows``, default those read) at each triangle corner (3T, k)."""
    rows = p.rows if rows is None else rows
    if p.interp == UsdGeom.Tokens.faceVarying:
        return rows[topo.corners.reshape(-1)]
    if p.interp == UsdGeom.Tokens.uniform:
        return rows[np.repeat(topo.face, 3)]
    return rows[topo.points.reshape(-1)]


def _splits(p: _Primvar) -> bool:
    return p.interp == UsdGeom.Tokens.faceVarying or (
        p.interp == UsdGeom.Tokens.uniform and p.name in _PM_NAMES
    )


def _extract(prim: Usd.Prim) -> tuple[Mesh, dict[str, Any]]:
    mesh = UsdGeom.Mesh(prim)
    _fixed_topology(prim)
    points = np.asarray(mesh.GetPointsAttr().Get(_TIME), np.float32).reshape(-1, 3)
    counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get(_TIME), np.int64)
    fvi = np.asarray(mesh.GetFaceVertexIndicesAttr().Get(_TIME), np.int64)
    holes = np.asarray(mesh.GetHoleIndicesAttr().Get(_TIME) or [], np.int64)
    try:
        topo = _Topology(counts, fvi, points.shape[0], False, str(prim.GetPath()), holes)
        pvs = [p for p in _primvars(prim, topo) if p.interp != UsdGeom.Tokens.constant]
    except _Invalid as e:  # (the loader's own, a ValueError: the message names the prim and the problem)
        raise UsdOverrideError(str(e)) from e
    n = topo.points.size
    cols = [np.ascontiguousarray(topo.points.reshape(-1, 1).astype("<i8")).view(np.uint8).reshape(n, -1)]
    for p in pvs:
        if _splits(p):
            r = np.ascontiguousarray(_corner_rows(p, topo))
            cols.append(r.view(np.uint8).reshape(n, -1))
    key = np.ascontiguousarray(np.concatenate(cols, axis=1))
    key = key.view(np.dtype((np.void, key.shape[1]))).reshape(-1)
    _, rep_corner, vertex_of_corner = np.unique(key, return_index=True, return_inverse=True)
    tris = vertex_of_corner.reshape(-1, 3)
    keep = (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])
    src_point = topo.points.reshape(-1)[rep_corner]
    attrs: dict[str, np.ndarray] = {}
    for p in pvs:
        if p.name in _PM_NAMES and p.rows.dtype.kind == "f":
            rows = _corner_rows(p, topo)[rep_corner].astype(np.float32)
            if p.name == "displayColor":
                opacity = next((q for q in pvs if q.name == "displayOpacity"), None)
                if opacity is not None and _splits(opacity) == _splits(p):
                    rows = np.concatenate([rows, _corner_rows(opacity, topo)[rep_corner][:, :1]], axis=1)
            attrs[_PM_NAMES[p.name]] = rows
    attrs[_PROV] = np.arange(rep_corner.shape[0], dtype=np.int64)[:, None]
    m = Mesh(points[src_point], tris[keep].astype(np.int32), attrs, source=str(prim.GetPath()))
    info = {
        "topo": topo,
        "primvars": pvs,
        "rep_corner": rep_corner,
        "src_point": src_point,
        "kept_tris": keep,
    }
    return m, info


def _fixed_topology(prim: Usd.Prim) -> None:
    """An error naming the attribute when ``prim``'s topology changes between its time samples."""
    for name in ("faceVertexCounts", "faceVertexIndices", "holeIndices"):
        attr = prim.GetAttribute(name)
        times = attr.GetTimeSamples() if attr else []
        if len(times) < 2:
            continue
        first = np.asarray(attr.Get(times[0]))
        for t in times[1:]:
            if not np.array_equal(np.asarray(attr.Get(t)), first):
                raise UsdOverrideError(
                    f"{attr.GetPath()}: the topology changes over time (at {t}, from its value at "
                    f"{times[0]}): a mesh of changing topology cannot be encoded"
                )


def _match_triangles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """For each row of ``b`` the row of ``a`` holding the same vertex set (a and b: same multiset)."""
    sa, sb = np.sort(a, axis=1), np.sort(b, axis=1)
    oa = np.lexsort(sa.T[::-1])
    ob = np.lexsort(sb.T[::-1])
    if a.shape != b.shape or not np.array_equal(sa[oa], sb[ob]):
        raise UsdOverrideError("the encoding's LOD-0 triangles are not the source triangles")
    out = np.empty(b.shape[0], np.int64)
    out[ob] = oa
    return out


def _set_values(p: _Primvar, remap: Callable[[np.ndarray], np.ndarray], interp: str) -> None:
    """Author ``remap(rows)`` of ``p`` (its default and, for each of the source's time samples, its rows at
    that time remapped), with interpolation ``interp``; an indexed primvar's indices blocked."""

    def values(rows: np.ndarray) -> np.ndarray:
        shape = p.values.shape[2:] if p.values.ndim > 2 else p.values.shape[1:]
        return np.ascontiguousarray(rows.reshape(-1, *shape))

    # (the source's samples read before any opinion is authored: the override's default hides them)
    samples = [(t, p.rows_at(t)) for t in p.times()]
    p.attr.Set(values(remap(p.rows)))
    for t, rows in samples:  # (a blocked sample stays blocked)
        p.attr.Set(Sdf.ValueBlock() if rows is None else values(remap(rows)), t)
    if p.pv is not None:
        if p.pv.IsIndexed():
            p.pv.BlockIndices()
        if interp != p.interp:
            p.pv.SetInterpolation(interp)
    elif interp != p.interp:
        UsdGeom.Mesh(p.attr.GetPrim()).SetNormalsInterpolation(interp)


def _animate_points(mesh: UsdGeom.Mesh, point_of: np.ndarray, n_points: int, extent: bool) -> None:
    """The source's time samples of points (``n_points`` each), re-indexed (new vertex i is source point
    ``point_of[i]``), each with its extent: the override's default alone would hide the source's samples.
    Called before the override's default points are authored (they would hide the samples from it)."""
    attr = mesh.GetPointsAttr()
    # (every sample read before one is authored: the override's samples hide the source's between them)
    samples = [(t, attr.Get(t)) for t in attr.GetTimeSamples()]
    for t, value in samples:
        if value is None:  # (a blocked sample stays blocked)
            attr.Set(Sdf.ValueBlock(), t)
            continue
        pts = np.asarray(value, np.float32).reshape(-1, 3)
        if pts.shape[0] != n_points:
            raise UsdOverrideError(
                f"{attr.GetPath()}: {pts.shape[0]} points at time {t}: points that change in number over "
                "time cannot be re-indexed"
            )
        moved = np.ascontiguousarray(pts[point_of])
        attr.Set(moved, t)
        if extent:
            mesh.GetExtentAttr().Set(np.stack([moved.min(axis=0), moved.max(axis=0)]), t)


def encode_prim(prim: Usd.Prim, encoding: str = "vanilla", **params: Any) -> ProgressiveMesh:
    """Encode one Mesh prim of an editable stage in place: apply SwpmMeshAPI and author everything on the
    stage's edit target (an ``over`` when the prim comes from a weaker layer)."""
    mesh_in, info = _extract(prim)
    pm = build(mesh_in, encoding, **params)
    prov = np.asarray(pm.attributes[_PROV]).reshape(-1).astype(np.int64)
    pm = with_attributes(pm, {k: v for k, v in pm.attributes.items() if k != _PROV})
    topo: _Topology = info["topo"]
    corner = info["rep_corner"][prov]  # source triangle corner of each new vertex
    kept_src = np.flatnonzero(info["kept_tris"])
    tri0 = np.asarray(pm.triangles_at(0), np.int64)
    mesh_tris = np.asarray(mesh_in.triangles, np.int64)
    src_tri = kept_src[_match_triangles(mesh_tris, prov[tri0])]  # source triangle of each LOD-0 triangle
    src_face = topo.face[src_tri]

    mesh = UsdGeom.Mesh(prim)
    point_of = info["src_point"][prov]  # source point of each new vertex
    _animate_points(mesh, point_of, topo.n_points, pm.vertex_count > 0)
    mesh.GetPointsAttr().Set(np.ascontiguousarray(pm.points))
    mesh.GetFaceVertexIndicesAttr().Set(np.ascontiguousarray(tri0.reshape(-1).astype(np.int32)))
    mesh.GetFaceVertexCountsAttr().Set(np.full(tri0.shape[0], 3, np.int32))
    if mesh.GetHoleIndicesAttr().HasValue():  # the source's hole faces were left out: no face is a hole
        mesh.GetHoleIndicesAttr().Set(Vt.IntArray())
    if pm.vertex_count:
        mesh.GetExtentAttr().Set(np.stack([pm.points.min(axis=0), pm.points.max(axis=0)]))
    for p in info["primvars"]:
        if p.interp in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying):
            _set_values(p, lambda rows: rows[point_of], p.interp)
        elif _splits(p):
            _set_values(p, lambda rows, p=p: _corner_rows(p, topo, rows)[corner], UsdGeom.Tokens.vertex)
        elif p.interp == UsdGeom.Tokens.uniform:
            _set_values(p, lambda rows: rows[src_face], p.interp)
    for subset in UsdGeom.Subset.GetAllGeomSubsets(mesh):
        _reindex_subset(subset, _subset_remap(subset, src_face, point_of, tri0, topo.n_points))
    ours = author_swpm(prim, pm)
    # a source encoded before (another encoding, discrete LODs) keeps its swpm: values in the weaker layer:
    # blocked, so the prim holds this encoding's buffers alone (swpm:discreteLods named the old LODs)
    for attr in prim.GetAttributes():
        if attr.GetName().startswith("swpm:") and attr.GetName() not in ours and attr.HasAuthoredValue():
            attr.Block()
    return pm


def _subset_remap(
    subset: UsdGeom.Subset, src_face: np.ndarray, point_of: np.ndarray, tri0: np.ndarray, n_points: int
) -> Callable[[np.ndarray], np.ndarray]:
    """The re-indexing of ``subset``'s indices: a face subset's become the LOD-0 triangles of its faces
    (``src_face``: each one's source face), a point subset's the new vertices of its points (``point_of``:
    each one's source point; a split point's each), an edge subset's (pairs of point indices) the edges of
    the LOD-0 triangles ``tri0`` between the new vertices of its points, each once, as (lower, higher)
    pairs in order (an edge that no kept face has, one of hole faces alone, is no edge of the new mesh: left
    out; a pair with an index outside the points names none). Any other element type (none a Mesh has) is an
    error naming the subset."""
    element = subset.GetElementTypeAttr().Get()
    where = subset.GetPath()
    if element == UsdGeom.Tokens.face:
        return lambda idx: np.flatnonzero(np.isin(src_face, idx))
    if element == UsdGeom.Tokens.point:
        return lambda idx: np.flatnonzero(np.isin(point_of, idx))
    if element != UsdGeom.Tokens.edge:
        raise UsdOverrideError(f"{where}: a GeomSubset of elementType {element!r} cannot be re-indexed")
    edges = np.sort(tri0[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges = np.unique(edges, axis=0)  # (each new edge once, in order)
    src = np.sort(point_of[edges], axis=1)
    src_key = src[:, 0] * n_points + src[:, 1]

    def remap(idx: np.ndarray) -> np.ndarray:
        if idx.shape[0] % 2:
            raise UsdOverrideError(
                f"{where}: an edge GeomSubset holds pairs of point indices, not {idx.shape[0]} indices"
            )
        pairs = np.sort(idx.reshape(-1, 2), axis=1)
        # (a pair with an index outside the points names no edge: keyed, it was another pair's, (0, n + 2)
        # that of (1, 2))
        pairs = pairs[(pairs[:, 0] >= 0) & (pairs[:, 1] < n_points)]
        return edges[np.isin(src_key, pairs[:, 0] * n_points + pairs[:, 1])].reshape(-1)

    return remap


def _reindex_subset(subset: UsdGeom.Subset, remap: Callable[[np.ndarray], np.ndarray]) -> None:
    """Author ``remap`` of ``subset``'s indices: its value at :data:`_TIME` (none: empty) and each of its
    time samples (the override's default alone would hide them; a blocked one stays blocked)."""
    attr = subset.GetIndicesAttr()
    # (every sample read before one is authored: the override's opinions hide the source's)
    samples = [(t, attr.Get(t)) for t in attr.GetTimeSamples()]
    first = attr.Get(_TIME)

    def new(value: Any) -> np.ndarray:
        return np.ascontiguousarray(remap(np.asarray(value if value is not None else [], np.int64)), np.int32)

    attr.Set(new(first))
    for t, value in samples:
        attr.Set(Sdf.ValueBlock() if value is None else new(value), t)


def _mesh_roots(stage: Usd.Stage, prims: Iterable[str] | None, src: Path) -> list[Usd.Prim]:
    """The prims to encode under: the pseudo-root, or each of ``prims`` (an error naming ``src`` and the
    path of one that is not on the stage)."""
    if prims is None:
        return [stage.GetPseudoRoot()]
    roots = []
    for path in prims:
        root = stage.GetPrimAtPath(path) if Sdf.Path.IsValidPathString(str(path)) else None
        if not root:
            raise UsdOverrideError(f"{src}: no prim at {path}")
        roots.append(root)
    return roots


def _mesh_prims(roots: list[Usd.Prim]) -> list[Usd.Prim]:
    """The Mesh prims at or under ``roots`` that can be overridden (not those in instances)."""
    out = []
    for root in roots:
        out.extend(p for p in Usd.PrimRange(root) if p.IsA(UsdGeom.Mesh) and not p.IsInstanceProxy())
    return out


def _instanced_meshes(roots: list[Usd.Prim]) -> list[str]:
    """The paths of the Mesh prims in instances at or under ``roots`` (instance proxies: an override of one
    is ignored by USD, so they are not encoded)."""
    proxies = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
    return [
        str(p.GetPath())
        for root in roots
        for p in Usd.PrimRange(root, proxies)
        if p.IsInstanceProxy() and p.IsA(UsdGeom.Mesh)
    ]


def write_overrides(
    source: str | os.PathLike[str],
    path: str | os.PathLike[str],
    encoding: str = "vanilla",
    *,
    mode: str = "sublayer",
    prims: Iterable[str] | None = None,
    **params: Any,
) -> dict[str, ProgressiveMesh]:
    """Write ``path``: a layer over ``source`` that encodes each Mesh prim (all, or those under ``prims``).

    ``mode="sublayer"``: the layer sublayers the source (all its prims, same paths). ``mode="reference"``:
    the layer's default prim references the source's default prim (only prims under it are encoded).
    Format from the suffix (``.usda`` text, else crate). Returns prim path -> progressive mesh.
    """
    src_path, out_path = Path(source).resolve(), Path(path).resolve()
    if src_path == out_path:
        raise UsdOverrideError("the override layer must not be the source file")
    if not src_path.is_file():
        raise UsdOverrideError(f"{source}: file not found")
    from .probe import checked

    with checked(src_path) as probed:  # (a corrupt crate file that would crash this process: not opened here)
        if probed is not None:
            raise UsdOverrideError(f"{source}: {probed.message.removeprefix(f'{src_path}: ')}")
        try:
            src_stage = Usd.Stage.Open(str(src_path))
        except Tf.ErrorException as e:
            raise UsdOverrideError(f"{source}: USD could not open it: {tf_message(e)}") from e
    if src_stage is None:
        raise UsdOverrideError(f"{source}: USD could not open it")
    suffix = out_path.suffix.lower()
    file_format = Sdf.FileFormat.FindByExtension(suffix[1:]) if suffix[1:] else None
    if file_format is None:
        raise UsdOverrideError(
            f"{path}: could not write: {suffix!r} is not a USD layer suffix (.usda, .usdc or .usd)"
        )
    if file_format.IsPackage():  # (the temporary layer's name would be in usd-core's message)
        raise UsdOverrideError(
            f"{path}: could not write: a {suffix} package cannot be written as a layer (.usda, .usdc or .usd)"
        )
    rel = os.path.relpath(src_path, out_path.parent).replace(os.sep, "/")
    # a new layer under a temporary name beside the output (relative paths resolve the same), renamed into
    # place once complete: a run that fails leaves the previous output as it was, on disk and in memory
    tmp_path = out_path.with_name(f".{out_path.stem}.{secrets.token_hex(4)}.tmp{out_path.suffix}")
    try:
        result = fill_layer_replacing(
            out_path,
            tmp_path,
            lambda layer: _author_overrides(layer, src_stage, src_path, rel, mode, encoding, prims, params),
            errors=lambda: _writing(path, tmp_path),
        )
    except LayerReloadError as e:  # (written: the layer open in this process was not reloaded)
        raise UsdOverrideError(str(e)) from e
    return result


def _author_overrides(
    layer: Sdf.Layer,
    src_stage: Usd.Stage,
    src_path: Path,
    rel: str,
    mode: str,
    encoding: str,
    prims: Iterable[str] | None,
    params: dict[str, Any],
) -> dict[str, ProgressiveMesh]:
    """Fill ``layer`` (new, empty): the sublayer or reference to the source, its metadata and the encoded
    Mesh prims; returns prim path -> progressive mesh."""
    if mode == "sublayer":
        layer.subLayerPaths.append(rel)
    elif mode == "reference":
        default = src_stage.GetDefaultPrim()
        if not default:
            raise UsdOverrideError(f"{src_path}: reference mode needs a defaultPrim")
        spec = Sdf.CreatePrimInLayer(layer, default.GetPath())
        spec.specifier = Sdf.SpecifierDef
        spec.typeName = default.GetTypeName()
        spec.referenceList.Prepend(Sdf.Reference(rel))
        layer.defaultPrim = default.GetName()
    else:
        raise UsdOverrideError(f"mode must be 'sublayer' or 'reference', not {mode!r}")
    # (before the stage is opened: a source of other timeCodesPerSecond than the new layer's 24 had its time
    # samples scaled into it, 1, 5, 10 at 48 read and re-authored as 0.5, 2.5, 5, with no time range left)
    for key in _STAGE_METADATA:
        if src_stage.HasAuthoredMetadata(key):
            layer.pseudoRoot.SetInfo(key, src_stage.GetMetadata(key))
    if mode == "sublayer" and src_stage.GetRootLayer().defaultPrim:
        layer.defaultPrim = src_stage.GetRootLayer().defaultPrim
    stage = Usd.Stage.Open(layer)
    result = {}
    skipped = []
    roots = _mesh_roots(stage, prims, src_path)
    for prim in _mesh_prims(roots):
        why = _nothing_to_encode(prim)
        if why is not None:  # (left as it is: the loader leaves such a mesh out too)
            skipped.append(f"{prim.GetPath()} ({why})")
            continue
        try:
            result[str(prim.GetPath())] = encode_prim(prim, encoding, **params)
        except UsdOverrideError as e:
            raise UsdOverrideError(f"{src_path}: {e}") from e
    if skipped and not result:
        listed = first_few(skipped)
        raise UsdOverrideError(f"{src_path}: no Mesh prim with faces to encode: {listed}")
    if not result:  # (an override layer that encodes nothing, returned as {}, told no one why)
        instanced = _instanced_meshes(roots)
        if instanced:
            listed = first_few(instanced)
            raise UsdOverrideError(
                f"{src_path}: no Mesh prim to encode: the {len(instanced)} Mesh prims are in instances "
                f"({listed}), which USD lets no layer override; encode the layers the instances reference"
            )
        under = "" if prims is None else f" under {', '.join(str(p) for p in prims)}"
        raise UsdOverrideError(f"{src_path}: no Mesh prim to encode{under}")
    return result


def _nothing_to_encode(prim: Usd.Prim) -> str | None:
    """Why the Mesh ``prim`` has no triangle to encode (no faces; every face a hole), or None."""
    mesh = UsdGeom.Mesh(prim)
    counts = mesh.GetFaceVertexCountsAttr().Get(_TIME)
    if counts is None or len(counts) == 0:
        return "no faces"
    if _all_holes(mesh, _TIME):
        return "every face is a hole"
    return None


@contextmanager
def _writing(path: str | os.PathLike[str], tmp: Path) -> Iterator[None]:
    """An OSError or usd-core error while creating or saving the override layer ``path`` (as ``tmp``): a
    :class:`UsdOverrideError` naming it (not the temporary file)."""
    try:
        yield
    except (OSError, Tf.ErrorException) as e:
        why = e.strerror or str(e) if isinstance(e, OSError) else tf_message(e)
        raise UsdOverrideError(f"{path}: could not write: {why.replace(str(tmp), os.fspath(path))}") from e
